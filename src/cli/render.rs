//! `metamer render`: raycast a scene once and write a PNG sequence sweeping its light dial.

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use crate::colorimetry::Colorimetry;
use crate::render::Mode;
use crate::render::Scene;
use crate::render::Sweep;
use crate::render::Timing;
use crate::render::{Acceleration, colour_model, render_views};
use crate::render::{Corner, DialOverlay};
use crate::render::{Gradient, Shading};
use crate::render::{PngCompression, SweepOptions, downsample, render_exposure, write_sweep};

/// The dial's formula and scene format, shown by `metamer render --help` (docs/formats/dial.md has more).
const DIAL_HELP: &str = "\
The light dial (seed §5.1): every palette light is a vertex v_i at its `dial = [x, y]` (or the scene's
[dial] vertices), on or off, with an intensity a_i. The light at the slider point p mixes the lights
that are on with Shepard inverse-distance weights, exponent 2:
    u_i = 1/|p - v_i|^2,   w_i = u_i / sum_j u_j,   E(p) = sum_i w_i a_i E_i
(exactly light i at its own vertex; a far light still contributes a little; lights off weigh 0).
Scene [dial] keys:
    path = [\"a\", \"b\"]                    frames mix two neighbouring lights linearly (as before)
    vertices = { a = [0.0, 1.0] }        move vertices for the whole scene
    [[dial.keyframes]]                   or keyframes, the slider moving at constant speed:
    at = \"a\"  or  at = [0.3, 0.2]        slider at a light's vertex or a point
    off = [\"b\"]  on = [\"b\"]              lights switched off / on from this keyframe on
    move = { c = [0.5, 0.9] }            vertices moved from this keyframe on
    intensity = { a = 0.5 }              intensities from this keyframe on
The dial is drawn into every frame, on an opaque panel in the corner where it hides least of the
volume, one corner per sweep (--dial-corner fixes it, --no-dial turns it off); --keyframes renders
exactly one frame per keyframe.

The scene format is docs/formats/scene.md (dial keyframes: docs/formats/dial.md). A scene's volume is
--volume PATH, else its `volume` key beside the scene file, else that file name in the folder named by
METAMER_DATA (or its volumes/).";

#[derive(Debug, clap::Args)]
#[command(after_help = DIAL_HELP)]
pub struct Args {
    /// Scene file (docs/formats/scene.md). Without it (or with --builtin) the embedded default renders: a
    /// generated engine-like volume with a built-in palette, no data files needed.
    pub scene: Option<PathBuf>,
    /// Render the embedded default scene.
    #[arg(long)]
    pub(crate) builtin: bool,
    /// The volume file to render, instead of the scene's `volume` key (which is otherwise looked for beside
    /// the scene file, then by file name in the folder named by METAMER_DATA or its volumes/).
    #[arg(long, value_name = "PATH")]
    pub(crate) volume: Option<PathBuf>,
    /// Frames in the whole sweep (N): frame k sits at t = k/(N−1) along the dial's path or keyframes
    /// (keyframes: the slider moves at constant speed).
    #[arg(long, default_value_t = 48)]
    pub(crate) frames: usize,
    /// Render exactly one frame per dial keyframe (or path light), ignoring --frames.
    #[arg(long)]
    pub(crate) keyframes: bool,
    /// Do not draw the light dial into the frames.
    #[arg(long)]
    pub(crate) no_dial: bool,
    /// Corner of the light dial: auto (the corner where it hides least of the volume, one per sweep),
    /// lower-right, lower-left, upper-right or upper-left.
    #[arg(long, default_value = "auto", value_parser = ["auto", "lower-right", "lower-left", "upper-right", "upper-left"])]
    pub(crate) dial_corner: String,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 384)]
    pub(crate) size: usize,
    /// Output folder for frame_0000.png … (created; `frames/` is ignored by git in a checkout).
    #[arg(short, long, default_value = "frames")]
    pub(crate) output: PathBuf,
    /// Colour model: factor (m-D spectral factor model), full (31 samples, reference) or rgb (RGB factor model).
    #[arg(long, value_enum, default_value_t = ModeArg::Factor)]
    pub(crate) mode: ModeArg,
    /// Also write a contact sheet of the written frames.
    #[arg(long)]
    pub(crate) contact_sheet: Option<PathBuf>,
    /// Render only frames A..B (end exclusive) of the N; numbering and exposure stay those of the whole
    /// sweep, so split runs combine.
    #[arg(long, value_name = "A..B")]
    pub(crate) frame_range: Option<String>,
    /// Size of the generated volume of the built-in scene (voxels along x and y).
    #[arg(long, default_value_t = 160)]
    pub(crate) builtin_volume_size: usize,
    /// Supersampling: raycast SS× larger in each direction and average down (1 = off; 2 for
    /// publication frames, about 4× the raycast time, same per-frame cost).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=4))]
    pub(crate) ss: u32,
    /// Display gamma before sRGB encoding (1 = plain sRGB; 1.5–2.2 lifts dark, thin tissue).
    #[arg(long, default_value_t = 1.0)]
    pub(crate) gamma: f64,
    /// Title line on the contact sheet.
    #[arg(long)]
    pub(crate) title: Option<String>,
    /// Do not render: assemble the --contact-sheet from the frames already in -o DIR (frames A..B of
    /// --frame-range, else all of --frames), e.g. after --frame-range runs on several machines.
    #[arg(long, requires = "contact_sheet")]
    pub(crate) sheet_from_frames: bool,
    /// Shading: key (a key light above left of the eye, the default), headlight, or unshaded (the
    /// seed's look). Overrides the scene's `render.shading`.
    #[arg(long, value_parser = ["key", "headlight", "unshaded"])]
    pub(crate) shading: Option<String>,
    /// Turn off the per-pixel ray-start jitter (fixed-phase sampling, shows banding).
    #[arg(long)]
    pub(crate) no_jitter: bool,
    /// Sample every step once, even where it crosses a material boundary (no substeps there; faster,
    /// with a fine dither on thin plates).
    #[arg(long)]
    pub(crate) no_refine: bool,
    /// Shade with the faceted gradient of each trilinear cell instead of the smooth central differences.
    #[arg(long)]
    pub(crate) cell_gradient: bool,
    /// Every material emits without absorbing (nothing hides what is behind it, so a material that is
    /// black under the current light vanishes instead of darkening). Still one raycast per view.
    #[arg(long)]
    pub(crate) emissive_only: bool,
    /// Expose for the brightest possible material colour (never clips, darker) instead of the 99.5th
    /// percentile of the brightest frame.
    #[arg(long)]
    pub(crate) conservative_exposure: bool,
    /// Turn off early ray termination (for benchmarking).
    #[arg(long)]
    pub(crate) no_early_termination: bool,
    /// Turn off empty-space skipping (for benchmarking).
    #[arg(long)]
    pub(crate) no_empty_space_skipping: bool,
    /// PNG compression of the frames and the contact sheet: fast (the png crate's fast deflate, the
    /// default), default (zlib's balanced level, adaptive filters: smaller files, slower) or best (the
    /// smallest files, slowest). The pixels are the same.
    #[arg(long, value_enum, default_value_t = CompressionArg::Fast)]
    pub(crate) png_compression: CompressionArg,
    /// Replace what the writer otherwise refuses: a frame in -o DIR that is a symbolic link (the renderer
    /// chose that name, so a link there is not followed unasked), a read-only frame or contact sheet.
    #[arg(long)]
    pub(crate) force: bool,
}

impl Args {
    fn replace(&self) -> crate::fsio::Replace {
        if self.force { crate::fsio::Replace::Force } else { crate::fsio::Replace::Writable }
    }
}

const MIB: f64 = 1024.0 * 1024.0;

/// Parse `A..B` (end exclusive); either end may be omitted.
fn parse_range(s: &str, frames: usize) -> anyhow::Result<std::ops::Range<usize>> {
    let (a, b) = s.split_once("..").with_context(|| format!("--frame-range `{s}`: expected A..B"))?;
    let num = |t: &str, default: usize| -> anyhow::Result<usize> {
        if t.trim().is_empty() {
            Ok(default)
        } else {
            t.trim().parse().with_context(|| format!("--frame-range `{s}`: `{t}` is not a frame number"))
        }
    };
    let (a, b) = (num(a, 0)?, num(b, frames)?);
    if a >= b || b > frames {
        bail!("--frame-range `{s}`: must satisfy A < B ≤ {frames} (the --frames count)");
    }
    Ok(a..b)
}

/// `--mode`: the renderer's colour models ([`Mode`]) as command-line values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum ModeArg {
    // (no doc comments: clap would list them in --help instead of `[possible values: …]`)
    Factor,
    Full,
    Rgb,
}

/// `--png-compression`: [`PngCompression`] as command-line values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum CompressionArg {
    Fast,
    Default,
    Best,
}

impl From<CompressionArg> for PngCompression {
    fn from(c: CompressionArg) -> PngCompression {
        match c {
            CompressionArg::Fast => PngCompression::Fast,
            CompressionArg::Default => PngCompression::Default,
            CompressionArg::Best => PngCompression::Best,
        }
    }
}

impl From<ModeArg> for Mode {
    fn from(m: ModeArg) -> Mode {
        match m {
            ModeArg::Factor => Mode::Factor,
            ModeArg::Full => Mode::Full,
            ModeArg::Rgb => Mode::Rgb,
        }
    }
}

pub fn run(mut args: Args) -> anyhow::Result<()> {
    if !(1..=100_000).contains(&args.frames) {
        bail!("--frames {} is outside 1..=100000", args.frames);
    }
    if !(8..=4096).contains(&args.size) {
        bail!("--size {} is outside 8..=4096", args.size);
    }
    let mode = Mode::from(args.mode);
    let range = match &args.frame_range {
        Some(s) => parse_range(s, args.frames)?,
        None => 0..args.frames,
    };
    let colorimetry = Colorimetry::default();
    if !(args.gamma.is_finite() && (0.2..=5.0).contains(&args.gamma)) {
        bail!("--gamma {} is outside 0.2..=5", args.gamma);
    }
    // Every file the scene reads (scene, palette, CSV sources, volume header and its detached data file)
    // is recorded, so no output can be one of them.
    let mut read = Vec::new();
    let mut scene = match (&args.scene, args.builtin) {
        (Some(p), false) => {
            let (scene, files) = crate::fsio::record_reads(|| Scene::load_with_volume(p, args.volume.as_deref()));
            read = files;
            scene?
        }
        (Some(_), true) => bail!("give either a scene file or --builtin, not both"),
        (None, _) if args.volume.is_some() => bail!("--volume needs a scene file (it replaces the scene's `volume`)"),
        (None, _) => crate::render::builtin_scene(args.builtin_volume_size)?,
    };
    if let Some(sh) = &args.shading {
        scene.settings.shading = match sh.as_str() {
            "headlight" => Shading::Headlight,
            "unshaded" => Shading::Unshaded,
            _ => Shading::Key,
        };
    }
    scene.settings.jitter &= !args.no_jitter;
    scene.settings.refine &= !args.no_refine;
    if args.cell_gradient {
        scene.settings.gradient = Gradient::Cell;
    }
    if args.emissive_only {
        scene.materials.iter_mut().for_each(|m| m.class.absorbs = false);
    }
    let range = if args.keyframes {
        if args.frame_range.is_some() {
            bail!("give either --keyframes or --frame-range, not both");
        }
        scene.dial.timing = Timing::PerKeyframe;
        args.frames = scene.dial.keyframe_count().max(1);
        0..args.frames
    } else {
        range
    };
    if args.sheet_from_frames {
        return assemble_sheet(&args, &scene, range, &read);
    }
    if mode == Mode::Factor {
        let resolved = crate::render::scene_basis_report(&scene)?;
        if let Some(w) = resolved.1.poor_model() {
            eprintln!("warning: palette `{}`: {w}", crate::fsio::escape(&scene.palette.name));
        }
    }
    // No output may be the scene, its volume (header or data file), its palette, the palette's CSV sources
    // or its basis sidecar, nor one another.
    let mut files = crate::fsio::Outputs::new();
    if let Some(p) = &scene.path {
        files.input("scene", p);
    }
    if let Some(p) = &scene.palette_path {
        files.input("palette", p);
        files.input("basis sidecar", &crate::basis::sidecar_path(p));
    }
    if let Some(p) = &scene.volume_path {
        files.input("volume", p);
    }
    files.inputs_read(&read);
    for k in range.clone() {
        let frame = args.output.join(crate::render::frame_name(k));
        files.check("frame", &frame)?;
        // Before anything is rendered: a frame that is a link the renderer did not make is refused.
        crate::fsio::check_chosen(&frame, args.replace())?;
    }
    if let Some(sheet) = &args.contact_sheet {
        files.output("contact sheet", sheet)?;
        let frames = range.clone().map(|k| args.output.join(crate::render::frame_name(k)));
        let mut frames_only = crate::fsio::Outputs::new();
        for f in frames {
            frames_only.input("frame", &f);
        }
        frames_only.check("contact sheet", sheet)?;
    }
    let model = colour_model(&scene, mode, &colorimetry)?;
    // The large allocations estimated before they are made: the raycast's image of K f32 channels per
    // pixel (and its shrunk copy with --ss), on top of what the volume's rendering takes.
    let side = (args.size as u64) * u64::from(args.ss);
    let per_pixel = model.channels() as u64 * 4;
    let image = side * side * per_pixel;
    let shrunk = if args.ss > 1 { (args.size as u64).pow(2) * per_pixel } else { 0 };
    let voxels = scene.volume.voxels.bytes() as u64;
    crate::memory::ensure(
        || {
            format!(
                "a {side}×{side} {} render ({} channels of f32: {} MiB) of a {} MiB volume",
                mode.as_str(),
                model.channels(),
                crate::memory::show_mib(image + shrunk),
                crate::memory::show_mib(voxels)
            )
        },
        crate::memory::render_estimate(voxels).saturating_add(image).saturating_add(shrunk),
    )?;
    let accel = Acceleration {
        early_termination: !args.no_early_termination,
        empty_space_skipping: !args.no_empty_space_skipping,
        ..Acceleration::default()
    };
    let start = Instant::now();
    let ss = args.ss as usize;
    let mut view = render_views(&scene, vec![model], args.size * ss, args.size * ss, accel, None)
        .pop()
        .context("the raycast produced no image")?;
    // Shrunk only when supersampled: at one sample a pixel the copy was the same image, and 4 MiB of
    // fresh pages (at 384², seven channels) to fault in.
    if ss > 1 {
        view.image = downsample(&view.image, ss);
    }
    let reflectances: Vec<_> = scene.materials.iter().map(|m| m.spectrum).collect();
    let exposure = render_exposure(
        &view.image,
        &view.model,
        &scene.dial,
        &colorimetry,
        &reflectances,
        args.frames,
        scene.settings.exposure,
        args.conservative_exposure,
    );
    let bar = if std::io::stderr().is_terminal() {
        let b = ProgressBar::new(range.len() as u64);
        b.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b
    } else {
        ProgressBar::hidden()
    };
    let options = SweepOptions {
        range: range.clone(),
        gamma: args.gamma,
        contact_sheet: args.contact_sheet.clone(),
        overlay: (!args.no_dial).then(|| {
            let mut o = DialOverlay::new(&scene.dial, &colorimetry, args.size, args.size);
            match Corner::parse(&args.dial_corner) {
                Some(c) => o.set_corner(c),
                None => {
                    o.choose_corner(&view.image);
                }
            }
            o
        }),
        title: args.title.clone(),
        compression: args.png_compression.into(),
        replace: args.replace(),
        ..SweepOptions::new(args.frames, exposure, args.output.clone())
    };
    let report = write_sweep(&view.image, &view.model, &scene.dial, &options, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let path: Vec<String> = scene.dial.stages().iter().map(|l| crate::fsio::escape(l).into_owned()).collect();
    // What the slider sweeps: the scene's keyframes (each named by its light, or its point and the
    // lights off) or its path of lights.
    let sweep = match scene.dial.sweep {
        Sweep::Keyframes(_) => "keyframes",
        Sweep::Path(_) => "dial path",
    };
    let mut summary = format!(
        "{} frames {}..{} of {} ({} mode, {} channels, {sweep}: {}) in {}\n",
        report.written.len(),
        range.start,
        range.end,
        args.frames,
        mode.as_str(),
        view.image.channels,
        path.join(" → "),
        crate::fsio::show(&args.output)
    );
    let st = &view.stats;
    summary.push_str(&format!(
        "raycast {:.1} ms at {}² ({} samples, {} skipped), exposure {exposure:.3}, relight + PNG {:.1} ms ({:.2} ms/frame), total {:.1} ms, peak memory {}\n",
        view.seconds * 1e3,
        args.size * ss,
        st.samples,
        st.skipped,
        report.seconds * 1e3,
        report.seconds * 1e3 / report.written.len().max(1) as f64,
        start.elapsed().as_secs_f64() * 1e3,
        crate::bench::render::peak_memory_bytes().map_or("unknown".into(), |b| format!("{:.0} MiB", b as f64 / MIB))
    ));
    summary.push_str(&format!(
        "skipped: {} steps in {} jumps over empty bricks or groups of them ({} of {} bricks empty for this transfer function); {} samples in \
         {} single-material bricks taken without reconstruction; {} rays stopped at transmittance < {}; derived fields {} \
         blocks built, {:.1} MiB, at most {:.1} MiB resident of a {:.0} MiB cap ({} evicted), {}\n",
        st.skipped,
        st.skipped_bricks,
        st.empty_bricks,
        st.bricks,
        st.uniform,
        st.uniform_bricks,
        st.terminated,
        accel.termination_transmittance,
        st.field_blocks,
        st.field_bytes as f64 / MIB,
        st.field_peak as f64 / MIB,
        st.field_cap as f64 / MIB,
        st.field_evicted,
        st.field_store,
    ));
    if let Some(sheet) = &args.contact_sheet {
        summary.push_str(&format!("contact sheet {}\n", crate::fsio::show(sheet)));
    }
    super::out::print(&summary)?;
    Ok(())
}

/// `--sheet-from-frames`: the contact sheet of frames `range` already in the output folder, no raycast.
fn assemble_sheet(
    args: &Args,
    scene: &Scene,
    range: std::ops::Range<usize>,
    read: &[(PathBuf, crate::fsio::Kind)],
) -> anyhow::Result<()> {
    let sheet = args.contact_sheet.as_ref().context("--sheet-from-frames needs --contact-sheet PATH")?;
    // The sheet may be none of the scene's files nor one of the frames it is made of.
    let mut files = crate::fsio::Outputs::new();
    for p in [&scene.path, &scene.palette_path, &scene.volume_path].into_iter().flatten() {
        files.input("scene input", p);
    }
    files.inputs_read(read);
    for k in range.clone() {
        files.input("frame", &args.output.join(crate::render::frame_name(k)));
    }
    files.output("contact sheet", sheet)?;
    let n = crate::render::contact_sheet_from_frames(
        &args.output,
        range.clone(),
        args.frames,
        &scene.dial,
        args.title.as_deref(),
        sheet,
        (args.png_compression.into(), args.replace()),
    )?;
    println!(
        "contact sheet {} of {n} frames {}..{} of {} from {}",
        crate::fsio::show(sheet),
        range.start,
        range.end,
        args.frames,
        crate::fsio::show(&args.output)
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_ranges_parse() {
        assert_eq!(parse_range("2..5", 10).unwrap(), 2..5);
        assert_eq!(parse_range("..5", 10).unwrap(), 0..5);
        assert_eq!(parse_range("7..", 10).unwrap(), 7..10);
        assert!(parse_range("5..2", 10).is_err());
        assert!(parse_range("0..11", 10).is_err());
        assert!(parse_range("x..2", 10).is_err());
        assert!(parse_range("3", 10).is_err());
    }
}
