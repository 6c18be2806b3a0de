//! A light-dial sweep written as PNG frames: per frame, mix the dial's lights at the frame's position,
//! build the model's 3×K matrix (exposure folded in), relight every pixel, sRGB-encode, write
//! `DIR/frame_0000.png …`. Frames are relit and encoded in parallel, and committed (synced, renamed into
//! place) on a thread of their own while the next ones are relit. Frame numbers and positions are
//! global (frame k of N sits at k/(N−1) whatever range is rendered), and the exposure depends only on
//! the scene and N, so runs over split frame ranges combine into one sweep.
//!
//! - Exposure: [`percentile_exposure`] (what `metamer render` uses) puts a high percentile (99.5 %) of
//!   the covered pixels of the brightest frame at 1, so a few bright specks do not darken the sweep;
//!   [`sweep_exposure`] is the conservative bound that never clips (used to compare colour models).
//! - Tone: an optional display gamma ([`SrgbLut::with_gamma`]): `gamma > 1` lifts dark tissue,
//!   applied to the linear value before sRGB encoding; 1 is plain sRGB. A pixel brighter than white is
//!   scaled down as a whole (hue kept) before encoding ([`SrgbLut::encode_rgb`]).
//! - Supersampling: [`downsample`] box-filters a raycast made `ss` times larger. Relighting is linear,
//!   so averaging the stored channels equals averaging the relit frames: frames stay exact and cost
//!   the same per frame.
//! - Contact sheet: every frame is shrunk to its tile as soon as it is encoded, so memory holds only
//!   thumbnails (never the full frames); tiles are labelled with the frame number, dial position and
//!   light mix, under an optional title. [`SweepOptions::overlay`] is the hook that draws the dial into
//!   every frame; each tile gets the same dial drawn at the tile's own size (in the frames' corner), so
//!   its names stay legible instead of being shrunk with the frame.

use super::RenderError;
use super::dial::Dial;
use super::raycast::ChannelImage;
use super::relight::{ColourModel, SrgbLut, relight_peaks, relight_srgb8};
use super::text;
use crate::colorimetry::Colorimetry;
use crate::spectrum::Spectrum;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, ImageEncoder, RgbImage};
use rayon::prelude::*;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The one exposure of a sweep: 1 over the largest linear-RGB channel of any material's exact colour
/// (full 31 samples) under any frame's light, times `scale`. Composited pixels are convex
/// combinations of material colours times shading ≤ 1, so at `scale = 1` nothing clips in the
/// reference, and every mode and every frame range of the same sweep gets the same exposure.
pub fn sweep_exposure(
    colorimetry: &Colorimetry,
    reflectances: &[Spectrum],
    dial: &Dial,
    frames: usize,
    scale: f64,
) -> f64 {
    let mut peak = 0.0f64;
    for k in 0..frames.max(1) {
        let e = dial.light_at(Dial::position(k, frames));
        for s in reflectances {
            peak = peak.max(colorimetry.rgb(&e, s).max());
        }
    }
    if peak > 1e-12 { scale / peak } else { scale }
}

/// File name of frame k.
pub fn frame_name(k: usize) -> String {
    format!("frame_{k:04}.png")
}

/// One frame as 8-bit sRGB.
pub fn frame_srgb8(
    image: &ChannelImage,
    model: &ColourModel,
    dial: &Dial,
    k: usize,
    frames: usize,
    exposure: f64,
    lut: &SrgbLut,
) -> Vec<u8> {
    let mut out = Vec::new();
    frame_srgb8_into(image, model, dial, (k, frames), exposure, lut, &mut out);
    out
}

/// [`frame_srgb8`] into `out` (resized to the frame), so that a sweep's thread reuses one buffer for all
/// its frames: a fresh 442 KB buffer per frame (384²) was faulted in page by page, ~0.2 ms a frame.
pub(crate) fn frame_srgb8_into(
    image: &ChannelImage,
    model: &ColourModel,
    dial: &Dial,
    (k, frames): (usize, usize),
    exposure: f64,
    lut: &SrgbLut,
    out: &mut Vec<u8>,
) {
    let e = dial.light_at(Dial::position(k, frames));
    let matrix = model.frame_matrix(&e, exposure);
    // Cleared so that no byte of the previous frame can survive, whatever the kernel writes.
    out.clear();
    out.resize(image.width * image.height * 3, 0);
    relight_srgb8(image, &matrix, lut, out);
}

/// How hard frames are compressed: the pixels are the same, only the time and the file size differ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PngCompression {
    /// The `png` crate's fast deflate with the Sub filter (the default: encoding costs about as much as
    /// relighting a frame).
    #[default]
    Fast,
    /// zlib's balanced level with adaptive filters: smaller files, several times the encoding time.
    Default,
    /// The highest level with adaptive filters: the smallest files, the slowest.
    Best,
}

/// Encode 8-bit RGB as PNG bytes.
pub fn encode_png(rgb: &[u8], width: usize, height: usize, compression: PngCompression) -> Result<Vec<u8>, String> {
    let mut buf = Vec::with_capacity(rgb.len() / 2);
    encode_png_into(rgb, width, height, compression, &mut buf)?;
    Ok(buf)
}

/// [`encode_png`] into `buf` (cleared first), so that a sweep's thread reuses one buffer for its frames.
pub(crate) fn encode_png_into(
    rgb: &[u8],
    width: usize,
    height: usize,
    compression: PngCompression,
    buf: &mut Vec<u8>,
) -> Result<(), String> {
    buf.clear();
    let (level, filter) = match compression {
        PngCompression::Fast => (CompressionType::Fast, FilterType::Sub),
        PngCompression::Default => (CompressionType::Default, FilterType::Adaptive),
        PngCompression::Best => (CompressionType::Best, FilterType::Adaptive),
    };
    PngEncoder::new_with_quality(&mut *buf, level, filter)
        .write_image(rgb, width as u32, height as u32, ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())
}

/// The fraction of covered pixels of the brightest frame that [`percentile_exposure`] keeps below 1.
pub(crate) const EXPOSURE_PERCENTILE: f64 = 0.995;

/// The exposure `metamer render` gives a sweep of `frames` frames of this picture — the one rule the
/// renderer and the designer's live preview share: the percentile exposure ([`percentile_exposure`] at
/// [`EXPOSURE_PERCENTILE`], times `scale`), or, with `conservative` or when no pixel is covered, the
/// never-clipping bound of the materials' colours ([`sweep_exposure`]).
#[allow(clippy::too_many_arguments)]
pub fn render_exposure(
    image: &ChannelImage,
    model: &ColourModel,
    dial: &Dial,
    colorimetry: &Colorimetry,
    reflectances: &[Spectrum],
    frames: usize,
    scale: f64,
    conservative: bool,
) -> f64 {
    let bound = || sweep_exposure(colorimetry, reflectances, dial, frames, scale);
    if conservative {
        return bound();
    }
    percentile_exposure(image, model, dial, frames, EXPOSURE_PERCENTILE, scale).unwrap_or_else(bound)
}

/// Frames [`percentile_exposure`] looks at: at most this many, spread evenly over the whole sweep.
const EXPOSURE_FRAMES: usize = 17;

/// The one exposure of a sweep, from the picture: for up to 17 frames spread evenly over all N frames
/// (the same frames whatever range is written), the `percentile` (e.g. 0.995) of the brightest linear
/// channel over the pixels the volume covers (sampled on a grid of at most about 256² pixels); the
/// brightest frame's value is put at 1, times `scale`. None when no pixel is covered or every covered
/// pixel is black.
pub(crate) fn percentile_exposure(
    image: &ChannelImage,
    model: &ColourModel,
    dial: &Dial,
    frames: usize,
    percentile: f64,
    scale: f64,
) -> Option<f64> {
    let k = image.channels;
    if k == 0 || image.width == 0 || image.height == 0 {
        return None;
    }
    let stride = (image.width.max(image.height) / 256).max(1);
    let mut data = Vec::new();
    for y in (0..image.height).step_by(stride) {
        for x in (0..image.width).step_by(stride) {
            let px = &image.data[(y * image.width + x) * k..(y * image.width + x + 1) * k];
            if px.iter().any(|v| *v != 0.0) {
                data.extend_from_slice(px);
            }
        }
    }
    let covered = data.len() / k;
    if covered == 0 {
        return None;
    }
    let sample = ChannelImage { width: covered, height: 1, channels: k, data };
    let n = frames.max(1);
    let looks = n.min(EXPOSURE_FRAMES);
    let p = percentile.clamp(0.0, 1.0);
    // One buffer of peaks for all the frames looked at (fresh ones cost page faults, see `relight_peaks`).
    let mut peak = Vec::with_capacity(covered);
    let brightest = (0..looks)
        .map(|i| if looks == 1 { 0 } else { (i * (n - 1) + (looks - 1) / 2) / (looks - 1) })
        .map(|f| {
            let e = dial.light_at(Dial::position(f, n));
            relight_peaks(&sample, &model.frame_matrix(&e, 1.0), &mut peak);
            if peak.is_empty() {
                return 0.0;
            }
            let idx = ((peak.len() - 1) as f64 * p).round() as usize;
            let (_, v, _) = peak.select_nth_unstable_by(idx, f32::total_cmp);
            f64::from(*v)
        })
        .fold(0.0f64, f64::max);
    (brightest > 1e-12).then(|| scale / brightest)
}

/// Box-filter a K-channel image by `factor` in each direction (supersampling: raycast at `factor`
/// times the size, then this). Relighting is linear, so frames of the result equal the averaged frames
/// of the large image exactly. A partial last block averages what it has.
pub fn downsample(image: &ChannelImage, factor: usize) -> ChannelImage {
    let f = factor.max(1);
    if f == 1 {
        return image.clone();
    }
    let (w, h, k) = (image.width.div_ceil(f), image.height.div_ceil(f), image.channels);
    let mut data = vec![0f32; w * h * k];
    data.par_chunks_mut((w * k).max(1)).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            let out = &mut row[x * k..(x + 1) * k];
            let mut count = 0u32;
            for sy in y * f..((y + 1) * f).min(image.height) {
                for sx in x * f..((x + 1) * f).min(image.width) {
                    let src = &image.data[(sy * image.width + sx) * k..(sy * image.width + sx + 1) * k];
                    for (o, s) in out.iter_mut().zip(src) {
                        *o += s;
                    }
                    count += 1;
                }
            }
            if count > 0 {
                let inv = 1.0 / count as f32;
                out.iter_mut().for_each(|o| *o *= inv);
            }
        }
    });
    ChannelImage { width: w, height: h, channels: k, data }
}

/// What to write.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// N, the frames of the whole sweep.
    pub frames: usize,
    /// The frames to write (global numbers, a sub-range of `0..frames`).
    pub range: Range<usize>,
    /// The linear factor every frame's colours are multiplied by before sRGB encoding (folded into the frame matrix).
    pub exposure: f64,
    /// Display gamma applied before sRGB encoding (1 = none).
    pub gamma: f64,
    /// The folder the frames are written to (`frame_0000.png`, …), made when missing.
    pub out_dir: PathBuf,
    /// Also write a contact sheet of the written frames here.
    pub contact_sheet: Option<PathBuf>,
    /// Title line of the contact sheet.
    pub title: Option<String>,
    /// Draw the light dial into every frame before it is written, and so into its tile (None: `--no-dial`).
    pub overlay: Option<super::overlay::DialOverlay>,
    /// PNG compression of the frames and the contact sheet.
    pub compression: PngCompression,
    /// What the writes may replace ([`crate::fsio::Replace`]): a frame, whose name the renderer chose, that
    /// is a symbolic link is written through only with `Force` (`render --force`).
    pub replace: crate::fsio::Replace,
}

impl SweepOptions {
    /// All frames of an N-frame sweep into `out_dir`, no gamma, no sheet, no overlay.
    pub fn new(frames: usize, exposure: f64, out_dir: PathBuf) -> SweepOptions {
        SweepOptions {
            frames,
            range: 0..frames,
            exposure,
            gamma: 1.0,
            out_dir,
            contact_sheet: None,
            title: None,
            overlay: None,
            compression: PngCompression::Fast,
            replace: crate::fsio::Replace::Writable,
        }
    }
}

/// What a sweep wrote and how long it took.
#[derive(Clone, Debug)]
pub struct SweepReport {
    pub written: Vec<PathBuf>,
    pub seconds: f64,
}

/// Relight, encode and write the frames of `options.range` in parallel; `progress` is called once per
/// frame written. With a contact sheet, each frame is shrunk to its tile right after encoding.
pub fn write_sweep(
    image: &ChannelImage,
    model: &ColourModel,
    dial: &Dial,
    options: &SweepOptions,
    progress: &(dyn Fn() + Sync),
) -> Result<SweepReport, RenderError> {
    let start = Instant::now();
    let range = options.range.start.min(options.frames)..options.range.end.min(options.frames);
    std::fs::create_dir_all(&options.out_dir).map_err(|e| RenderError::Output {
        path: options.out_dir.clone(),
        reason: format!("cannot create the folder: {e}"),
    })?;
    let lut = SrgbLut::with_gamma(options.gamma);
    let layout = options.contact_sheet.as_ref().map(|_| SheetLayout::new(range.len(), image.width, image.height));
    // The dial is drawn into each tile at the tile's size (legible names), in the frames' corner.
    let tile_overlay =
        options.overlay.as_ref().zip(layout.as_ref()).map(|(o, l)| o.for_size(l.tile_w as usize, l.tile_h as usize));
    // The frames are committed (synced, renamed into place) on a thread of their own, while the workers relight
    // and encode the next ones: a frame's sync is mostly a wait for the disk, about a third of a frame's time
    // when the workers made it themselves. The folder is synced once, after the last rename into it. At most
    // `COMMIT_QUEUE` frames wait for their commit: on a disk slower than the workers, a worker then waits for a
    // place in the queue instead of holding ever more staged frames (each an open file) — a long sweep would
    // otherwise run out of file descriptors.
    let (to_commit, staged) = std::sync::mpsc::sync_channel::<(usize, crate::fsio::Staged)>(COMMIT_QUEUE);
    let (results, committed) = std::thread::scope(|scope| {
        let committer = scope.spawn(move || {
            let mut folders = crate::fsio::FolderSync::default();
            let mut committed = Vec::new();
            for (k, frame) in staged {
                let path = frame.path().to_path_buf();
                let done = frame.commit_in(&mut folders).map_err(RenderError::File);
                // The replaced frame is freed here, not held to the folder sync.
                folders.close_replaced();
                if done.is_ok() {
                    progress();
                }
                committed.push((k, done.map(|()| path)));
            }
            folders.sync();
            committed
        });
        let results: Vec<Result<(usize, Option<RgbImage>), RenderError>> = range
            .clone()
            .into_par_iter()
            // Each worker keeps its frame and PNG buffers from frame to frame: allocated anew, they came from
            // the thread's arena as fresh pages (the arena gives them back when they are freed), ~120 page
            // faults a frame at 384² with two threads.
            .map_init(
                || (Vec::new(), Vec::new()),
                |(rgb, png), k| {
                    frame_srgb8_into(image, model, dial, (k, options.frames), options.exposure, &lut, rgb);
                    let path = options.out_dir.join(frame_name(k));
                    let bad = |reason: String| RenderError::Output { path: path.clone(), reason };
                    // The tile is shrunk from the frame without its dial; the tile gets its own.
                    let thumb = match &layout {
                        Some(l) => {
                            let mut t = l
                                .thumbnail(rgb, image.width, image.height)
                                .ok_or_else(|| bad("cannot shrink".into()))?;
                            if let Some(o) = &tile_overlay {
                                let (tw, th) = (t.width() as usize, t.height() as usize);
                                o.draw_frame(&mut t, tw, th, dial, k, options.frames);
                            }
                            Some(t)
                        }
                        None => None,
                    };
                    if let Some(o) = &options.overlay {
                        o.draw_frame(rgb, image.width, image.height, dial, k, options.frames);
                    }
                    encode_png_into(rgb, image.width, image.height, options.compression, png).map_err(bad)?;
                    let frame = crate::fsio::stage_unsynced(&path, png, crate::fsio::Name::Chosen, options.replace)?;
                    to_commit.send((k, frame)).map_err(|_| bad("the frames' writer stopped".into()))?;
                    Ok((k, thumb))
                },
            )
            .collect();
        // Every frame is sent: the writer's loop ends when the last sender is gone.
        drop(to_commit);
        let committed = committer.join().map_err(|_| RenderError::Invalid("the frames' writer failed".into()));
        (results, committed)
    });
    // The first error in frame order, whether the frame failed in its worker or in its commit: a frame its
    // worker staged was sent and so committed, so the committed frames in order are the workers' in order.
    let mut committed = committed?;
    committed.sort_unstable_by_key(|(k, _)| *k);
    let mut committed = committed.into_iter();
    let (mut written, mut thumbs) = (Vec::with_capacity(results.len()), Vec::new());
    for r in results {
        let (k, thumb) = r?;
        match committed.next() {
            Some((c, done)) if c == k => written.push(done?),
            _ => return Err(RenderError::Invalid(format!("frame {k} was staged and not committed"))),
        }
        thumbs.extend(thumb);
    }
    if let (Some(sheet), Some(layout)) = (&options.contact_sheet, &layout) {
        let labels: Vec<String> = range.clone().map(|k| frame_label(dial, k, options.frames)).collect();
        let img = layout.assemble(&thumbs, &labels, options.title.as_deref());
        write_contact_sheet_image(sheet, &img, options.compression, options.replace)?;
    }
    Ok(SweepReport { written, seconds: start.elapsed().as_secs_f64() })
}

/// How many staged frames may wait for the committer thread of [`write_sweep`] (each holds its temporary
/// file open).
const COMMIT_QUEUE: usize = 16;

/// The contact sheet of frames already written to `dir` (frames `range` of an N = `frames` sweep, e.g. by
/// `--frame-range` runs on several machines), read back through the one bounded reader, shrunk to tiles
/// and labelled as [`write_sweep`] does; returns how many frames it holds. A tile shrinks its frame as it
/// was written, so with the dial drawn into the frames the tiles show it shrunk (a one-run sheet draws it
/// anew at the tile's size); frames written without the dial give a sheet byte-identical to a one-run
/// sheet's. Every frame must be there and of one size. The sheet is written with the PNG compression and
/// the replace rule given last.
pub fn contact_sheet_from_frames(
    dir: &Path,
    range: Range<usize>,
    frames: usize,
    dial: &Dial,
    title: Option<&str>,
    sheet: &Path,
    (compression, replace): (PngCompression, crate::fsio::Replace),
) -> Result<usize, RenderError> {
    let bad = |path: &Path, reason: String| RenderError::Invalid(format!("{}: {reason}", crate::fsio::show(path)));
    let mut size = None;
    let mut layout = None;
    let mut tiles = Vec::with_capacity(range.len());
    for k in range.clone() {
        let path = dir.join(frame_name(k));
        let bytes = crate::fsio::read(&path, crate::fsio::Kind::Frame).map_err(|e| {
            RenderError::Invalid(format!(
                "{e} (frame {k} of the range {}..{}: is every shard's output here?)",
                range.start, range.end
            ))
        })?;
        // Frames are at most 4096² (`--size`): a PNG claiming more is refused before it is decoded.
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(4096);
        limits.max_image_height = Some(4096);
        let mut reader = image::ImageReader::with_format(std::io::Cursor::new(&bytes), image::ImageFormat::Png);
        reader.limits(limits);
        let rgb = reader.decode().map_err(|e| bad(&path, format!("not a PNG frame of at most 4096²: {e}")))?.to_rgb8();
        let (w, h) = (rgb.width() as usize, rgb.height() as usize);
        match size {
            None => size = Some((w, h)),
            Some((w0, h0)) if (w0, h0) != (w, h) => {
                return Err(bad(&path, format!("is {w}×{h}, the first frame of the range is {w0}×{h0}")));
            }
            Some(_) => {}
        }
        let l = *layout.get_or_insert_with(|| SheetLayout::new(range.len(), w, h));
        tiles.push(l.thumbnail(rgb.as_raw(), w, h).ok_or_else(|| bad(&path, "cannot shrink".into()))?);
    }
    let layout = layout.ok_or_else(|| RenderError::Invalid("the frame range is empty".into()))?;
    let labels: Vec<String> = range.clone().map(|k| frame_label(dial, k, frames)).collect();
    write_contact_sheet_image(sheet, &layout.assemble(&tiles, &labels, title), compression, replace)?;
    Ok(tiles.len())
}

/// The two-line label of frame k of N on a contact sheet: `frame 12 · t 0.26` and the light mix
/// `hide 48% split 52%` (the lights with a weight of at least 0.5 %), then the lights switched off
/// (`· purple off`). When the sheet has one frame per stage (N = the keyframes, at most 26), the first
/// line starts with the panel's letter, `(a) frame 0 · t 0.00`, as the seed's figures are labelled.
pub(crate) fn frame_label(dial: &Dial, k: usize, frames: usize) -> String {
    let t = Dial::position(k, frames);
    let state = dial.state_at(t);
    let mix: Vec<String> = state
        .lights
        .iter()
        .zip(state.weights())
        .filter(|(_, w)| *w >= 0.005)
        .map(|(l, w)| format!("{} {:.0}%", crate::fsio::escape(&l.name), w * 100.0))
        .collect();
    let off: Vec<String> =
        state.lights.iter().filter(|l| !l.on).map(|l| format!("{} off", crate::fsio::escape(&l.name))).collect();
    let mut second = mix.join(" ");
    if !off.is_empty() {
        second = format!("{second} · {}", off.join(" "));
    }
    // One frame per stage (a figure's panels, at most 26): lettered (a), (b), … like the paper's.
    let panel = if frames == dial.keyframe_count() && frames <= 26 {
        format!("({}) ", char::from(b'a' + k as u8))
    } else {
        String::new()
    };
    format!("{panel}frame {k} · t {t:.2}\n{second}")
}

/// Write a finished contact sheet as PNG (creating its folder).
pub(crate) fn write_contact_sheet_image(
    path: &Path,
    sheet: &RgbImage,
    compression: PngCompression,
    replace: crate::fsio::Replace,
) -> Result<(), RenderError> {
    let png = encode_png(sheet.as_raw(), sheet.width() as usize, sheet.height() as usize, compression)
        .map_err(|reason| RenderError::Output { path: path.to_path_buf(), reason })?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| RenderError::Output { path: dir.to_path_buf(), reason: e.to_string() })?;
    }
    // Through the one atomic writer, as the frames are (committed by [`write_sweep`]'s committer thread): a FIFO
    // or device there is refused, an interrupted sweep leaves whole files only. The user named the sheet
    // (`--contact-sheet PATH`): a link there is followed and kept.
    crate::fsio::stage_with(path, &png, replace).and_then(crate::fsio::Staged::commit).map_err(RenderError::File)
}

/// Geometry of a contact sheet: columns, tile size, label band, gaps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SheetLayout {
    pub(crate) count: usize,
    pub(crate) cols: usize,
    pub(crate) rows: usize,
    pub(crate) tile_w: u32,
    pub(crate) tile_h: u32,
    pub(crate) gap: u32,
    /// Height of the label band under every tile.
    pub(crate) label_h: u32,
    /// Height of the title band (used when a title is given).
    pub(crate) title_h: u32,
}

/// Label text size in pixels.
const LABEL_PX: f64 = 13.0;

impl SheetLayout {
    /// A near-square grid for `count` frames of `width × height`, about 1600 pixels wide.
    pub fn new(count: usize, width: usize, height: usize) -> SheetLayout {
        let count = count.max(1);
        let cols = (count as f64).sqrt().ceil() as usize;
        let rows = count.div_ceil(cols);
        let tile_w = (1600 / cols).clamp(16, width.max(16)) as u32;
        let tile_h = ((tile_w as usize * height) / width.max(1)).max(1) as u32;
        SheetLayout { count, cols, rows, tile_w, tile_h, gap: 6, label_h: 36, title_h: 30 }
    }

    /// Shrink one 8-bit RGB frame to a tile.
    pub(crate) fn thumbnail(&self, rgb: &[u8], width: usize, height: usize) -> Option<RgbImage> {
        let img = image::ImageBuffer::<image::Rgb<u8>, &[u8]>::from_raw(width as u32, height as u32, rgb)?;
        Some(image::imageops::resize(&img, self.tile_w, self.tile_h, image::imageops::FilterType::Triangle))
    }

    /// The sheet: tiles in rows (a short last row centred), each with its label below, and the title
    /// on top.
    pub(crate) fn assemble(&self, tiles: &[RgbImage], labels: &[String], title: Option<&str>) -> RgbImage {
        let label_h = if labels.is_empty() { 0 } else { self.label_h };
        let top = if title.is_some() { self.title_h } else { 0 };
        let cell_w = self.tile_w + self.gap;
        let cell_h = self.tile_h + label_h + self.gap;
        let width = self.cols as u32 * cell_w + self.gap;
        let height = top + self.rows as u32 * cell_h + self.gap;
        let mut sheet = RgbImage::from_pixel(width, height, image::Rgb([16, 16, 16]));
        let origin = |i: usize| {
            let (c, r) = (i % self.cols, i / self.cols);
            let in_row = (tiles.len() - r * self.cols).min(self.cols) as u32;
            let indent = (self.cols as u32 - in_row) * cell_w / 2;
            (indent + self.gap + c as u32 * cell_w, top + self.gap + r as u32 * cell_h)
        };
        for (i, t) in tiles.iter().enumerate() {
            let (x, y) = origin(i);
            image::imageops::replace(&mut sheet, t, i64::from(x), i64::from(y));
        }
        if let Some(font) = text::font() {
            let (w, h) = (sheet.width() as usize, sheet.height() as usize);
            let grey = [230, 230, 230];
            if let Some(t) = title {
                let l = text::rasterise(&font, &crate::fsio::escape(t), 20.0);
                text::blit(&mut sheet, 3, w, h, &l, (i64::from(self.gap), 6), grey, 1.0);
            }
            for (i, label) in labels.iter().enumerate().take(tiles.len()) {
                let (x, y) = origin(i);
                for (line, t) in label.lines().enumerate().take(2) {
                    let l = text::rasterise(&font, &fit_text(t, self.tile_w), LABEL_PX as f32);
                    let pos = (i64::from(x) + 2, i64::from(y + self.tile_h) + 3 + 16 * line as i64);
                    text::blit(&mut sheet, 3, w, h, &l, pos, grey, 1.0);
                }
            }
        }
        sheet
    }
}

/// Shorten a label to about the characters that fit in `width` pixels at the label size.
fn fit_text(label: &str, width: u32) -> String {
    let max = ((f64::from(width) / (LABEL_PX * 0.55)) as usize).max(4);
    if label.chars().count() <= max {
        label.to_string()
    } else {
        let mut s: String = label.chars().take(max - 1).collect();
        s.push('…');
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::dial::{DialLight, DialState};
    use crate::render::relight::relight_linear;

    fn dial() -> Dial {
        let lights = vec![
            DialLight::new("dim", Spectrum::flat(0.5), [0.0, 0.0]),
            DialLight::new("bright", Spectrum::flat(1.0), [1.0, 0.0]),
        ];
        Dial::path(DialState::new(lights).unwrap(), vec![0, 1]).unwrap()
    }

    fn rgb_model() -> ColourModel {
        ColourModel::rgb(Colorimetry::default())
    }

    #[test]
    fn exposure_follows_a_high_percentile_not_the_brightest_pixel() {
        // 1000 pixels of reflectance 0.2 and one of 1.0 (a speck); one black (uncovered) pixel.
        let mut data = vec![0.2f32; 3 * 1002];
        data[0..3].copy_from_slice(&[1.0, 1.0, 1.0]);
        data[3 * 1001..].copy_from_slice(&[0.0, 0.0, 0.0]);
        let img = ChannelImage { width: 1002, height: 1, channels: 3, data };
        let model = rgb_model();
        let e = percentile_exposure(&img, &model, &dial(), 5, EXPOSURE_PERCENTILE, 1.0).unwrap();
        // Under the bright light (the last frame), the 0.2 pixels' brightest channel lands at 1.
        let m = model.frame_matrix(&Spectrum::flat(1.0), e);
        let lin = relight_linear(&ChannelImage { width: 1, height: 1, channels: 3, data: vec![0.2; 3] }, &m);
        let peak = lin.iter().copied().fold(0.0f32, f32::max);
        assert!((peak - 1.0).abs() < 1e-3, "covered pixels peak at {peak}");
        // The conservative bound would expose 5× darker.
        let empty = ChannelImage { width: 2, height: 1, channels: 3, data: vec![0.0; 6] };
        assert!(percentile_exposure(&empty, &model, &dial(), 5, 0.99, 1.0).is_none());
    }

    #[test]
    fn supersampling_averages_channels_so_frames_stay_exact() {
        let data: Vec<f32> = (0..4 * 4 * 3).map(|i| (i % 7) as f32 * 0.1).collect();
        let big = ChannelImage { width: 4, height: 4, channels: 3, data };
        let small = downsample(&big, 2);
        assert_eq!((small.width, small.height), (2, 2));
        let m = rgb_model().frame_matrix(&Spectrum::flat(0.8), 1.3);
        let (lb, ls) = (relight_linear(&big, &m), relight_linear(&small, &m));
        // Relighting the averaged channels = averaging the relit pixels.
        for (y, x) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            for c in 0..3 {
                let avg: f32 = [(0, 0), (0, 1), (1, 0), (1, 1)]
                    .iter()
                    .map(|(dy, dx)| lb[((2 * y + dy) * 4 + 2 * x + dx) * 3 + c])
                    .sum::<f32>()
                    / 4.0;
                assert!((ls[(y * 2 + x) * 3 + c] - avg).abs() < 1e-5);
            }
        }
        assert_eq!(downsample(&big, 1), big);
    }

    /// The frames committed by the writer thread: each whole and in place, reported in frame order and
    /// counted once each; a rerun replaces them; a frame that cannot be written is named in the error, in
    /// frame order, while the others are written; no temporary file is left behind.
    #[test]
    fn frames_are_committed_whole_in_frame_order_and_a_failed_one_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let frames = dir.path().join("frames");
        let (w, h) = (24usize, 16usize);
        let data: Vec<f32> = (0..w * h * 3).map(|i| (i % 11) as f32 * 0.05).collect();
        let img = ChannelImage { width: w, height: h, channels: 3, data };
        let lut = SrgbLut::with_gamma(1.0);
        let expected = |k: usize, exposure: f64| {
            let rgb = frame_srgb8(&img, &rgb_model(), &dial(), k, 6, exposure, &lut);
            encode_png(&rgb, w, h, PngCompression::Fast).unwrap()
        };
        let temporaries = || {
            std::fs::read_dir(&frames)
                .unwrap()
                .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().ends_with(".tmp"))
                .count()
        };
        for exposure in [1.0, 0.5] {
            let count = std::sync::atomic::AtomicUsize::new(0);
            let opts = SweepOptions::new(6, exposure, frames.clone());
            let report = write_sweep(&img, &rgb_model(), &dial(), &opts, &|| {
                count.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            })
            .unwrap();
            let names: Vec<PathBuf> = (0..6).map(|k| frames.join(frame_name(k))).collect();
            assert_eq!(report.written, names, "in frame order");
            assert_eq!(count.into_inner(), 6, "each frame counted once");
            for (k, path) in names.iter().enumerate() {
                assert_eq!(std::fs::read(path).unwrap(), expected(k, exposure), "frame {k} at exposure {exposure}");
            }
            assert_eq!(temporaries(), 0);
        }
        assert_ne!(expected(1, 1.0), expected(1, 0.5), "the rerun replaced the frames with other content");
        // Frames 2 and 4 cannot be written (folders stand at their names): the first in frame order is named,
        // the others are written, and every temporary file is gone.
        for k in [2, 4] {
            let blocked = frames.join(frame_name(k));
            std::fs::remove_file(&blocked).unwrap();
            std::fs::create_dir(&blocked).unwrap();
        }
        let count = std::sync::atomic::AtomicUsize::new(0);
        let opts = SweepOptions::new(6, 0.8, frames.clone());
        let failed = write_sweep(&img, &rgb_model(), &dial(), &opts, &|| {
            count.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        });
        match failed {
            Err(RenderError::File(crate::fsio::FsError::NotRegularOutput { path, .. })) => {
                assert_eq!(path, frames.join(frame_name(2)))
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(count.into_inner(), 4);
        for k in [0, 1, 3, 5] {
            assert_eq!(std::fs::read(frames.join(frame_name(k))).unwrap(), expected(k, 0.8), "frame {k}");
        }
        assert_eq!(temporaries(), 0);
    }

    #[test]
    fn contact_sheet_is_built_from_thumbnails_with_labels_and_a_centred_last_row() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (64usize, 48usize);
        let img = ChannelImage { width: w, height: h, channels: 3, data: vec![0.5; w * h * 3] };
        let sheet_path = dir.path().join("sheet.png");
        let opts = SweepOptions {
            contact_sheet: Some(sheet_path.clone()),
            title: Some("a title".into()),
            ..SweepOptions::new(5, 1.0, dir.path().join("frames"))
        };
        let report = write_sweep(&img, &rgb_model(), &dial(), &opts, &|| {}).unwrap();
        assert_eq!(report.written.len(), 5);
        let sheet = image::open(&sheet_path).unwrap().to_rgb8();
        let layout = SheetLayout::new(5, w, h);
        assert_eq!((layout.cols, layout.rows), (3, 2));
        let cell_w = layout.tile_w + layout.gap;
        assert_eq!(sheet.width(), 3 * cell_w + layout.gap);
        assert_eq!(sheet.height(), layout.title_h + 2 * (layout.tile_h + layout.label_h + layout.gap) + layout.gap);
        // Labels: light text pixels in the label band under the first tile.
        let band_y = layout.title_h + layout.gap + layout.tile_h;
        let text = (band_y..band_y + layout.label_h)
            .flat_map(|y| (layout.gap..layout.gap + layout.tile_w).map(move |x| (x, y)))
            .filter(|(x, y)| sheet.get_pixel(*x, *y).0[0] > 120)
            .count();
        assert!(text > 30, "label band has {text} text pixels");
        // The last row holds two tiles, indented by half a cell: its first tile starts at gap + cell/2.
        let row2_y = layout.title_h + layout.gap + layout.tile_h + layout.label_h + layout.gap + layout.tile_h / 2;
        let lit = |x: u32| sheet.get_pixel(x, row2_y).0[0] > 60;
        assert!(!lit(layout.gap + 2) && lit(layout.gap + cell_w / 2 + 2), "last row not centred");
        assert!(frame_label(&dial(), 2, 5).contains("dim 50% bright 50%"));
        // A sweep of many frames is not lettered; one frame per stage is, (a) … like the seed's figures.
        assert!(frame_label(&dial(), 2, 5).starts_with("frame 2"));
        let stages = dial().keyframe_count();
        assert!(frame_label(&dial(), 0, stages).starts_with("(a) frame 0"), "{}", frame_label(&dial(), 0, stages));
        assert!(frame_label(&dial(), 1, stages).starts_with("(b) frame 1"));
    }

    #[test]
    fn contact_sheet_tiles_get_the_dial_drawn_at_their_size() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (240usize, 240usize);
        let img = ChannelImage { width: w, height: h, channels: 3, data: vec![0.5; w * h * 3] };
        let sheet_path = dir.path().join("sheet.png");
        let overlay = super::super::overlay::DialOverlay::new(&dial(), &Colorimetry::default(), w, h);
        let opts = SweepOptions {
            contact_sheet: Some(sheet_path.clone()),
            overlay: Some(overlay.clone()),
            ..SweepOptions::new(2, 1.0, dir.path().join("frames"))
        };
        write_sweep(&img, &rgb_model(), &dial(), &opts, &|| {}).unwrap();
        let sheet = image::open(&sheet_path).unwrap().to_rgb8();
        let layout = SheetLayout::new(2, w, h);
        let tile = overlay.for_size(layout.tile_w as usize, layout.tile_h as usize);
        let [x, y, pw, ph] = tile.panel_rect().unwrap();
        // The tile's panel: opaque dark over most of its area, on a mid-grey frame. (Not one row: this
        // dial's two vertices, its outline, slider and names lie on one line, which runs along the
        // panel's middle row or a pixel beside it as the panel's height rounds.)
        let tile_px =
            |dx: usize, dy: usize| sheet.get_pixel(layout.gap + (x + dx) as u32, layout.gap + (y + dy) as u32);
        let dark = (0..ph).flat_map(|dy| (0..pw).map(move |dx| (dx, dy))).filter(|&(dx, dy)| tile_px(dx, dy).0[0] < 40);
        let dark = dark.count();
        assert!(dark > pw * ph * 2 / 3, "{dark} of {} panel pixels dark", pw * ph);
        // Around the panel, the tile is the frame's grey: the panel is where panel_rect says.
        assert!(sheet.get_pixel(layout.gap + (x - 2) as u32, layout.gap + (y + ph / 2) as u32).0[0] > 120);
        assert!(sheet.get_pixel(layout.gap + (x + pw / 2) as u32, layout.gap + (y - 2) as u32).0[0] > 120);
        // The frame itself carries the dial too.
        let frame = image::open(dir.path().join("frames").join(frame_name(0))).unwrap().to_rgb8();
        let [fx, fy, _, _] = overlay.panel_rect().unwrap();
        assert!(frame.get_pixel(fx as u32 + 3, fy as u32 + 3 + 10).0[0] < 40);
    }

    #[test]
    fn gamma_lifts_dark_values_only() {
        let (plain, lifted) = (SrgbLut::new(), SrgbLut::with_gamma(2.0));
        assert!(lifted.encode(0.05) > plain.encode(0.05));
        assert_eq!(lifted.encode(1.0), plain.encode(1.0));
        assert_eq!(lifted.encode(0.0), 0);
    }
}
