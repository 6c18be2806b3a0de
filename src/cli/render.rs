//! `metamer render`: raycast a scene once and write a PNG sequence sweeping its light dial.

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use crate::colorimetry::Colorimetry;
use crate::render::raycast::{Gradient, Shading};
use crate::render::relight::Mode;
use crate::render::scene::Scene;
use crate::render::sweep::{
    EXPOSURE_PERCENTILE, SweepOptions, downsample, percentile_exposure, sweep_exposure, write_sweep,
};
use crate::render::{Acceleration, colour_model, render_views};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene file (DESIGN_SPEC §4). Without it (or with --builtin) the embedded default renders: a
    /// generated engine-like volume with a built-in palette, no data files needed.
    pub scene: Option<PathBuf>,
    /// Render the embedded default scene.
    #[arg(long)]
    pub builtin: bool,
    /// Frames in the whole sweep (N): frame k sits at t = k/(N−1) along the dial path.
    #[arg(long, default_value_t = 48)]
    pub frames: usize,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 384)]
    pub size: usize,
    /// Output folder for frame_0000.png …
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
    /// Supersampling: raycast SS× larger in each direction and average down (1 = off; 2 for
    /// publication frames, about 4× the raycast time, same per-frame cost).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=4))]
    pub ss: u32,
    /// Display gamma before sRGB encoding (1 = plain sRGB; 1.5–2.2 lifts dark, thin tissue).
    #[arg(long, default_value_t = 1.0)]
    pub gamma: f64,
    /// Title line on the contact sheet.
    #[arg(long)]
    pub title: Option<String>,
    /// Shading: key (a key light above left of the eye, the default), headlight, or unshaded (the
    /// seed's look). Overrides the scene's `render.shading`.
    #[arg(long, value_parser = ["key", "headlight", "unshaded"])]
    pub shading: Option<String>,
    /// Turn off the per-pixel ray-start jitter (fixed-phase sampling, shows banding).
    #[arg(long)]
    pub no_jitter: bool,
    /// Shade with the faceted gradient of each trilinear cell instead of the smooth central differences.
    #[arg(long)]
    pub cell_gradient: bool,
    /// Every material emits without absorbing (nothing hides what is behind it, so a material that is
    /// black under the current light vanishes instead of darkening). Still one raycast per view.
    #[arg(long)]
    pub emissive_only: bool,
    /// Expose for the brightest possible material colour (never clips, darker) instead of the 99.5th
    /// percentile of the brightest frame.
    #[arg(long)]
    pub conservative_exposure: bool,
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
    if !(args.gamma.is_finite() && (0.2..=5.0).contains(&args.gamma)) {
        bail!("--gamma {} is outside 0.2..=5", args.gamma);
    }
    let mut scene = match (&args.scene, args.builtin) {
        (Some(p), false) => Scene::load(p)?,
        (Some(_), true) => bail!("give either a scene file or --builtin, not both"),
        (None, _) => crate::render::scene::builtin_scene(args.builtin_volume_size)?,
    };
    if let Some(sh) = &args.shading {
        scene.settings.shading = match sh.as_str() {
            "headlight" => Shading::Headlight,
            "unshaded" => Shading::Unshaded,
            _ => Shading::Key,
        };
    }
    scene.settings.jitter &= !args.no_jitter;
    if args.cell_gradient {
        scene.settings.gradient = Gradient::Cell;
    }
    if args.emissive_only {
        scene.materials.iter_mut().for_each(|m| m.class.absorbs = false);
    }
    let model = colour_model(&scene, mode, &colorimetry)?;
    let accel = Acceleration {
        early_termination: !args.no_early_termination,
        empty_space_skipping: !args.no_empty_space_skipping,
    };
    let start = Instant::now();
    let ss = args.ss as usize;
    let mut view = render_views(&scene, vec![model], args.size * ss, args.size * ss, accel, None)
        .pop()
        .context("the raycast produced no image")?;
    view.image = downsample(&view.image, ss);
    let reflectances: Vec<_> = scene.materials.iter().map(|m| m.spectrum).collect();
    let bound = || sweep_exposure(&colorimetry, &reflectances, &scene.dial, args.frames, scene.settings.exposure);
    let exposure = if args.conservative_exposure {
        bound()
    } else {
        let e = &scene.settings.exposure;
        percentile_exposure(&view.image, &view.model, &scene.dial, args.frames, EXPOSURE_PERCENTILE, *e)
            .unwrap_or_else(bound)
    };
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
        title: args.title.clone(),
        ..SweepOptions::new(args.frames, exposure, args.output.clone())
    };
    let report = write_sweep(&view.image, &view.model, &scene.dial, &options, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let path: Vec<&str> = scene.dial.stops.iter().map(|s| s.name.as_str()).collect();
    println!(
        "{} frames {}..{} of {} ({} mode, {} channels, dial {}) in {}",
        report.written.len(),
        range.start,
        range.end,
        args.frames,
        mode.as_str(),
        view.image.channels,
        path.join(" → "),
        args.output.display()
    );
    println!(
        "raycast {:.1} ms at {}² ({} samples, {} skipped), exposure {exposure:.3}, relight + PNG {:.1} ms ({:.2} ms/frame), total {:.1} ms",
        view.seconds * 1e3,
        args.size * ss,
        view.stats.samples,
        view.stats.skipped,
        report.seconds * 1e3,
        report.seconds * 1e3 / report.written.len().max(1) as f64,
        start.elapsed().as_secs_f64() * 1e3
    );
    if let Some(sheet) = &args.contact_sheet {
        println!("contact sheet {}", sheet.display());
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
