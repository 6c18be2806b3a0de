//! `metamer render`: raycast a scene once and write a PNG sequence sweeping its light dial.

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use crate::colorimetry::Colorimetry;
use crate::render::relight::Mode;
use crate::render::scene::Scene;
use crate::render::sweep::{SweepOptions, sweep_exposure, write_sweep};
use crate::render::{Acceleration, colour_model, render_views};

#[derive(Debug, clap::Args)]
#[command(after_help = "The scene format is docs/formats/scene.md (dial keyframes: docs/formats/dial.md). A scene's \
                        volume is --volume PATH, else its `volume` key beside the scene file, else that file name \
                        in the folder named by METAMER_DATA (or its volumes/).")]
pub struct Args {
    /// Scene file (docs/formats/scene.md). Without it (or with --builtin) the embedded default renders: a
    /// generated engine-like volume with a built-in palette, no data files needed.
    pub scene: Option<PathBuf>,
    /// Render the embedded default scene.
    #[arg(long)]
    pub builtin: bool,
    /// The volume file to render, instead of the scene's `volume` key (which is otherwise looked for beside
    /// the scene file, then by file name in the folder named by METAMER_DATA or its volumes/).
    #[arg(long, value_name = "PATH")]
    pub volume: Option<PathBuf>,
    /// Frames in the whole sweep (N): frame k sits at t = k/(N−1) along the dial path.
    #[arg(long, default_value_t = 48)]
    pub frames: usize,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 384)]
    pub size: usize,
    /// Output folder for frame_0000.png … (created; `frames/` is ignored by git in a checkout).
    #[arg(short, long, default_value = "frames")]
    pub output: PathBuf,
    /// Colour model: factor (m-D spectral factor model), full (31 samples, reference) or rgb (RGB factor model).
    #[arg(long, default_value = "factor", value_parser = ["factor", "full", "rgb"])]
    pub mode: String,
    /// Also write a contact sheet of the written frames.
    #[arg(long)]
    pub contact_sheet: Option<PathBuf>,
    /// Render only frames A..B (end exclusive) of the N; numbering and exposure stay those of the whole
    /// sweep, so split runs combine.
    #[arg(long, value_name = "A..B")]
    pub frame_range: Option<String>,
    /// Size of the generated volume of the built-in scene (voxels along x and y).
    #[arg(long, default_value_t = 160)]
    pub builtin_volume_size: usize,
    /// Turn off early ray termination (for benchmarking).
    #[arg(long)]
    pub no_early_termination: bool,
    /// Turn off empty-space skipping (for benchmarking).
    #[arg(long)]
    pub no_empty_space_skipping: bool,
}

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

pub fn run(args: Args) -> anyhow::Result<()> {
    if !(1..=100_000).contains(&args.frames) {
        bail!("--frames {} is outside 1..=100000", args.frames);
    }
    if !(8..=4096).contains(&args.size) {
        bail!("--size {} is outside 8..=4096", args.size);
    }
    let mode = Mode::parse(&args.mode).with_context(|| format!("--mode `{}` is unknown", args.mode))?;
    let range = match &args.frame_range {
        Some(s) => parse_range(s, args.frames)?,
        None => 0..args.frames,
    };
    let colorimetry = Colorimetry::default();
    let scene = match (&args.scene, args.builtin) {
        (Some(p), false) => Scene::load_with_volume(p, args.volume.as_deref())?,
        (Some(_), true) => bail!("give either a scene file or --builtin, not both"),
        (None, _) if args.volume.is_some() => bail!("--volume needs a scene file (it replaces the scene's `volume`)"),
        (None, _) => crate::render::scene::builtin_scene(args.builtin_volume_size)?,
    };
    if mode == Mode::Factor {
        let resolved = crate::render::scene_basis_report(&scene)?;
        if let Some(w) = resolved.1.poor_model() {
            eprintln!("warning: palette `{}`: {w}", scene.palette.name.escape_debug());
        }
    }
    // No output may be the scene, its volume, its palette or the palette's basis sidecar, nor one another.
    let mut files = crate::fsio::Outputs::new();
    if let Some(p) = &scene.path {
        files.input("scene", p);
    }
    if let Some(p) = &scene.palette_path {
        files.input("palette", p);
        files.input("basis sidecar", &crate::basis::store::sidecar_path(p));
    }
    if let Some(p) = &scene.volume_path {
        files.input("volume", p);
    }
    for k in range.clone() {
        files.check("frame", &args.output.join(crate::render::sweep::frame_name(k)))?;
    }
    if let Some(sheet) = &args.contact_sheet {
        files.output("contact sheet", sheet)?;
        let frames = range.clone().map(|k| args.output.join(crate::render::sweep::frame_name(k)));
        let mut frames_only = crate::fsio::Outputs::new();
        for f in frames {
            frames_only.input("frame", &f);
        }
        frames_only.check("contact sheet", sheet)?;
    }
    let model = colour_model(&scene, mode, &colorimetry)?;
    let accel = Acceleration {
        early_termination: !args.no_early_termination,
        empty_space_skipping: !args.no_empty_space_skipping,
    };
    let start = Instant::now();
    let view = render_views(&scene, vec![model], args.size, args.size, accel, None)
        .pop()
        .context("the raycast produced no image")?;
    let reflectances: Vec<_> = scene.materials.iter().map(|m| m.spectrum).collect();
    let exposure = sweep_exposure(&colorimetry, &reflectances, &scene.dial, args.frames, scene.settings.exposure);
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
        frames: args.frames,
        range: range.clone(),
        exposure,
        out_dir: args.output.clone(),
        contact_sheet: args.contact_sheet.clone(),
    };
    let report = write_sweep(&view.image, &view.model, &scene.dial, &options, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let path: Vec<String> = scene.dial.stops.iter().map(|s| crate::fsio::escape(&s.name).into_owned()).collect();
    println!(
        "{} frames {}..{} of {} ({} mode, {} channels, dial {}) in {}",
        report.written.len(),
        range.start,
        range.end,
        args.frames,
        mode.as_str(),
        view.image.channels,
        path.join(" → "),
        crate::fsio::show(&args.output)
    );
    println!(
        "raycast {:.1} ms ({} samples, {} skipped), relight + PNG {:.1} ms ({:.2} ms/frame), total {:.1} ms",
        view.seconds * 1e3,
        view.stats.samples,
        view.stats.skipped,
        report.seconds * 1e3,
        report.seconds * 1e3 / report.written.len().max(1) as f64,
        start.elapsed().as_secs_f64() * 1e3
    );
    if let Some(sheet) = &args.contact_sheet {
        println!("contact sheet {}", crate::fsio::show(sheet));
    }
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
