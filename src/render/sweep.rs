//! A light-dial sweep written as PNG frames: per frame, mix the dial's lights at the frame's position,
//! build the model's 3×K matrix (exposure folded in), relight every pixel, sRGB-encode, write
//! `DIR/frame_0000.png …`. Frames are relit and encoded in parallel. Frame numbers and positions are
//! global (frame k of N sits at k/(N−1) whatever range is rendered), and the exposure depends only on
//! the scene and N, so runs over split frame ranges combine into one sweep.

use super::RenderError;
use super::dial::Dial;
use super::raycast::ChannelImage;
use super::relight::{ColourModel, SrgbLut, relight_srgb8};
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
    let e = dial.light_at(Dial::position(k, frames));
    let matrix = model.frame_matrix(&e, exposure);
    let mut out = vec![0u8; image.width * image.height * 3];
    relight_srgb8(image, &matrix, lut, &mut out);
    out
}

/// Encode 8-bit RGB as PNG bytes (fast deflate).
pub fn encode_png(rgb: &[u8], width: usize, height: usize) -> Result<Vec<u8>, String> {
    let mut buf = Vec::with_capacity(rgb.len() / 2);
    PngEncoder::new_with_quality(&mut buf, CompressionType::Fast, FilterType::Sub)
        .write_image(rgb, width as u32, height as u32, ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())?;
    Ok(buf)
}

/// What to write.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// N, the frames of the whole sweep.
    pub frames: usize,
    /// The frames to write (global numbers, a sub-range of `0..frames`).
    pub range: Range<usize>,
    pub exposure: f64,
    pub out_dir: PathBuf,
    /// Also write a contact sheet of the written frames here.
    pub contact_sheet: Option<PathBuf>,
    /// Draw the light dial into every frame (None: `--no-dial`).
    pub overlay: Option<super::overlay::DialOverlay>,
}

/// What a sweep wrote and how long it took.
#[derive(Clone, Debug)]
pub struct SweepReport {
    pub written: Vec<PathBuf>,
    pub seconds: f64,
}

/// Relight, encode and write the frames of `options.range` in parallel; `progress` is called once per
/// frame written.
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
    let lut = SrgbLut::new();
    let want_sheet = options.contact_sheet.is_some();
    type Written = (PathBuf, Option<Vec<u8>>);
    let results: Vec<Result<Written, RenderError>> = range
        .clone()
        .into_par_iter()
        .map(|k| {
            let mut rgb = frame_srgb8(image, model, dial, k, options.frames, options.exposure, &lut);
            if let Some(o) = &options.overlay {
                o.draw_frame(&mut rgb, image.width, image.height, dial, k, options.frames);
            }
            let path = options.out_dir.join(frame_name(k));
            let png = encode_png(&rgb, image.width, image.height)
                .map_err(|reason| RenderError::Output { path: path.clone(), reason })?;
            write_file(&path, &png)?;
            progress();
            Ok((path, want_sheet.then_some(rgb)))
        })
        .collect();
    let mut written = Vec::with_capacity(results.len());
    let mut frames_rgb = Vec::new();
    for r in results {
        let (p, rgb) = r?;
        written.push(p);
        if let Some(rgb) = rgb {
            frames_rgb.push(rgb);
        }
    }
    if let Some(sheet) = &options.contact_sheet {
        write_contact_sheet(sheet, &frames_rgb, image.width, image.height)?;
    }
    Ok(SweepReport { written, seconds: start.elapsed().as_secs_f64() })
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), RenderError> {
    std::fs::write(path, bytes)
        .map_err(|e| RenderError::Output { path: path.to_path_buf(), reason: format!("cannot write: {e}") })
}

/// A grid of thumbnails (about 1600 pixels wide at most) of the given frames, in order.
pub fn write_contact_sheet(path: &Path, frames: &[Vec<u8>], width: usize, height: usize) -> Result<(), RenderError> {
    let sheet = contact_sheet(frames, width, height).ok_or_else(|| RenderError::Output {
        path: path.to_path_buf(),
        reason: "no frames for the contact sheet".into(),
    })?;
    let png = encode_png(sheet.as_raw(), sheet.width() as usize, sheet.height() as usize)
        .map_err(|reason| RenderError::Output { path: path.to_path_buf(), reason })?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| RenderError::Output { path: dir.to_path_buf(), reason: e.to_string() })?;
    }
    write_file(path, &png)
}

/// Build the contact sheet image.
pub fn contact_sheet(frames: &[Vec<u8>], width: usize, height: usize) -> Option<RgbImage> {
    if frames.is_empty() || width == 0 || height == 0 {
        return None;
    }
    let cols = (frames.len() as f64).sqrt().ceil() as usize;
    let rows = frames.len().div_ceil(cols);
    let tw = (1600 / cols).clamp(16, width.max(16)) as u32;
    let th = ((tw as usize * height) / width).max(1) as u32;
    let gap = 4u32;
    let mut sheet = RgbImage::new(cols as u32 * (tw + gap) + gap, rows as u32 * (th + gap) + gap);
    for (i, f) in frames.iter().enumerate() {
        let img = RgbImage::from_raw(width as u32, height as u32, f.clone())?;
        let thumb = image::imageops::resize(&img, tw, th, image::imageops::FilterType::Triangle);
        let (c, r) = ((i % cols) as u32, (i / cols) as u32);
        image::imageops::replace(&mut sheet, &thumb, i64::from(gap + c * (tw + gap)), i64::from(gap + r * (th + gap)));
    }
    Some(sheet)
}
