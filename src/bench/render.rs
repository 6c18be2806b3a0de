//! `metamer bench render`: the renderer's costs and accuracy on the engine (the GE CT from
//! `../shared/volumes/engine.nhdr` when present, else the generated engine-like volume) with four
//! ColorChecker materials swept D65 → A → F11:
//!
//! - raycast time at 512² with early ray termination and empty-space skipping on/off (speed-ups);
//! - relight time per frame (one thread, 3×K matrix + sRGB table) for the factor (K = m), full (31) and
//!   RGB (3) models, against the memory-bandwidth bound (bytes a frame must touch ÷ measured bandwidth);
//! - a 48-frame sweep at 384² (raycast once, relight + PNG per frame) against a single frame: the
//!   budget is one frame + 20 ms per extra frame;
//! - mean / p95 / max CIEDE2000 of the factor and RGB models against the full-spectrum frames.
//!
//! Writes `render.md` and `render_raycast.png`, `render_relight.png` into the output folder.

use super::plot::{Scale, Series, XyPlot, draw};
use super::{format_seconds, markdown_table, time_runs};
use crate::colorimetry::Colorimetry;
use crate::render::accuracy::{AccuracyReport, ModelError, compare_models};
use crate::render::overlay::DialOverlay;
use crate::render::raycast::{BrickMap, ChannelImage};
use crate::render::relight::{ColourModel, Mode, SrgbLut, relight_srgb8};
use crate::render::scene::{Scene, engine_check_scene, generated_check_scene};
use crate::render::sweep::{SweepOptions, sweep_exposure, write_sweep};
use crate::render::{Acceleration, RenderError, colour_model, render_views};
use crate::volume::Volume;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to run.
#[derive(Clone, Debug)]
pub struct RenderBenchOptions {
    pub out_dir: PathBuf,
    /// Timed repetitions of each raycast (relighting repeats 20× as many).
    pub runs: usize,
    /// Raycast image size (the figure is 512).
    pub raycast_size: usize,
    /// Sweep image size and frame count (the figures are 384 and 48).
    pub sweep_size: usize,
    pub sweep_frames: usize,
    /// Image size and frames of the accuracy comparison.
    pub accuracy_size: usize,
    pub accuracy_frames: usize,
    /// Use this volume instead of looking for the shared engine.
    pub volume: Option<PathBuf>,
}

impl Default for RenderBenchOptions {
    fn default() -> Self {
        RenderBenchOptions {
            out_dir: PathBuf::from("bench"),
            runs: 5,
            raycast_size: 512,
            sweep_size: 384,
            sweep_frames: 48,
            accuracy_size: 256,
            accuracy_frames: 24,
            volume: None,
        }
    }
}

/// One raycast configuration's timing.
#[derive(Clone, Debug)]
pub struct RaycastRow {
    pub accel: Acceleration,
    pub median_s: f64,
    /// Process CPU time per raycast (all threads; Linux only, from /proc/self/stat), when known.
    pub cpu_s: Option<f64>,
    pub samples: u64,
    pub skipped: u64,
}

/// One relight model's timing.
#[derive(Clone, Debug)]
pub struct RelightRow {
    pub mode: Mode,
    pub channels: usize,
    pub size: usize,
    pub median_s: f64,
    /// Process CPU time per frame (one thread working; Linux only), when known.
    pub cpu_s: Option<f64>,
    /// Bytes read and written per frame ÷ measured bandwidth.
    pub bound_s: f64,
}

/// Everything measured.
#[derive(Clone, Debug)]
pub struct RenderBenchReport {
    pub volume: String,
    pub threads: usize,
    /// 1-minute load average when the benchmark started (other processes compete for the cores).
    pub load_average: Option<f64>,
    pub brick_build_s: f64,
    pub raycast: Vec<RaycastRow>,
    pub bandwidth_bytes_per_s: f64,
    pub relight: Vec<RelightRow>,
    pub one_frame_s: f64,
    pub sweep_s: f64,
    pub sweep_frames: usize,
    pub sweep_size: usize,
    pub accuracy: AccuracyReport,
    pub markdown: String,
}

/// `$CARGO_MANIFEST_DIR/../shared/volumes/engine.nhdr`, `../shared/…` from the working folder, or
/// `/work/shared/…`.
pub fn find_shared_engine() -> Option<PathBuf> {
    let candidates = [
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/volumes/engine.nhdr"),
        PathBuf::from("../shared/volumes/engine.nhdr"),
        PathBuf::from("/work/shared/volumes/engine.nhdr"),
    ];
    candidates.into_iter().find(|p| p.is_file())
}

/// User + system CPU seconds of this process so far (Linux `/proc/self/stat`, 100 ticks per second).
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// The 1-minute load average (Linux), to judge how contended the timings were.
pub fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg").ok()?.split_whitespace().next()?.parse().ok()
}

/// Streaming bandwidth of this machine (one thread, read + write of a 64 MiB buffer, best of 3), bytes/s.
pub fn measure_bandwidth() -> f64 {
    let n = 16 << 20;
    let src: Vec<f32> = (0..n).map(|i| i as f32).collect();
    let mut dst = vec![0f32; n];
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        for (d, s) in dst.iter_mut().zip(&src) {
            *d = s * 1.0001;
        }
        best = best.min(t.elapsed().as_secs_f64());
        std::hint::black_box(&dst);
    }
    (2 * n * 4) as f64 / best
}

/// Run the renderer benchmark and write its report and plots.
pub fn run(options: &RenderBenchOptions) -> Result<RenderBenchReport, RenderError> {
    let col = Colorimetry::default();
    let volume_path = options.volume.clone().or_else(find_shared_engine);
    let (scene, volume_name): (Scene, String) = match &volume_path {
        Some(p) => (engine_check_scene(Volume::open(p)?), p.display().to_string()),
        None => (generated_check_scene(256), "generated engine-like 256×256×128 (../shared not found)".into()),
    };
    std::fs::create_dir_all(&options.out_dir)
        .map_err(|e| RenderError::Output { path: options.out_dir.clone(), reason: e.to_string() })?;
    let runs = options.runs.max(1);
    let load = load_average();

    // Raycast with the four switch combinations.
    let t = Instant::now();
    let bricks = BrickMap::new(&scene.volume, 8);
    let brick_build_s = t.elapsed().as_secs_f64();
    let factor = colour_model(&scene, Mode::Factor, &col)?;
    let mut raycast = Vec::new();
    for (et, ess) in [(true, true), (true, false), (false, true), (false, false)] {
        let accel = Acceleration { early_termination: et, empty_space_skipping: ess };
        let size = options.raycast_size;
        let cpu0 = process_cpu_seconds();
        let (timing, views) =
            time_runs(runs, || render_views(&scene, vec![factor.clone()], size, size, accel, Some(&bricks)));
        // time_runs makes one warm-up call besides the timed runs.
        let cpu_s = cpu0.zip(process_cpu_seconds()).map(|(a, b)| (b - a) / (runs + 1) as f64);
        let stats = views.first().map(|v| v.stats).unwrap_or_default();
        raycast.push(RaycastRow {
            accel,
            median_s: timing.median,
            cpu_s,
            samples: stats.samples,
            skipped: stats.skipped,
        });
    }

    // Relight kernels against the bandwidth bound.
    let bandwidth = measure_bandwidth();
    let lut = SrgbLut::new();
    let mut relight = Vec::new();
    for size in [options.sweep_size, options.raycast_size] {
        let models = vec![factor.clone(), ColourModel::full(col.clone()), ColourModel::rgb(col.clone())];
        let views = render_views(&scene, models, size, size, Acceleration::default(), Some(&bricks));
        for v in &views {
            let e = scene.dial.light_at(0.5);
            let m = v.model.frame_matrix(&e, 1.0);
            let mut out = vec![0u8; size * size * 3];
            let reps = runs * 20;
            let cpu0 = process_cpu_seconds();
            let (timing, _) = time_runs(reps, || relight_srgb8(&v.image, &m, &lut, &mut out));
            let cpu_s = cpu0.zip(process_cpu_seconds()).map(|(a, b)| (b - a) / (reps + 1) as f64);
            let bytes = (size * size * (4 * v.image.channels + 3)) as f64;
            relight.push(RelightRow {
                mode: v.model.mode,
                channels: v.image.channels,
                size,
                median_s: timing.median,
                cpu_s,
                bound_s: bytes / bandwidth,
            });
        }
    }

    // Sweep cost: 48 frames vs one, both from scratch (raycast included), PNGs into a temporary folder.
    let tmp =
        tempfile::tempdir().map_err(|e| RenderError::Output { path: std::env::temp_dir(), reason: e.to_string() })?;
    let reflectances: Vec<_> = scene.materials.iter().map(|m| m.spectrum).collect();
    let sweep_once = |frames: usize| -> Result<f64, RenderError> {
        let start = Instant::now();
        let size = options.sweep_size;
        let view = render_views(&scene, vec![factor.clone()], size, size, Acceleration::default(), Some(&bricks))
            .pop()
            .ok_or_else(|| RenderError::Invalid("no view".into()))?;
        let exposure = sweep_exposure(&col, &reflectances, &scene.dial, frames, 1.0);
        let opts = SweepOptions {
            frames,
            range: 0..frames,
            exposure,
            out_dir: tmp.path().join(format!("sweep{frames}")),
            contact_sheet: None,
            overlay: Some(DialOverlay::new(&scene.dial, &col, size, size)),
        };
        write_sweep(&view.image, &view.model, &scene.dial, &opts, &|| {})?;
        Ok(start.elapsed().as_secs_f64())
    };
    let mut one = Vec::new();
    let mut many = Vec::new();
    for _ in 0..runs.min(3) {
        one.push(sweep_once(1)?);
        many.push(sweep_once(options.sweep_frames)?);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (one_frame_s, sweep_s) = (median(&mut one), median(&mut many));

    let accuracy = compare_models(&scene, &col, options.accuracy_size, options.accuracy_frames)?;

    let mut report = RenderBenchReport {
        volume: volume_name,
        threads: rayon::current_num_threads(),
        load_average: load,
        brick_build_s,
        raycast,
        bandwidth_bytes_per_s: bandwidth,
        relight,
        one_frame_s,
        sweep_s,
        sweep_frames: options.sweep_frames,
        sweep_size: options.sweep_size,
        accuracy,
        markdown: String::new(),
    };
    report.markdown = markdown(&report, options);
    let md = options.out_dir.join("render.md");
    std::fs::write(&md, &report.markdown)
        .map_err(|e| RenderError::Output { path: md.clone(), reason: e.to_string() })?;
    plots(&report, &options.out_dir)?;
    Ok(report)
}

fn onoff(b: bool) -> &'static str {
    if b { "on" } else { "off" }
}

fn markdown(r: &RenderBenchReport, o: &RenderBenchOptions) -> String {
    let base = r
        .raycast
        .iter()
        .find(|x| !x.accel.early_termination && !x.accel.empty_space_skipping)
        .map_or(1.0, |x| x.median_s);
    let rows: Vec<Vec<String>> = r
        .raycast
        .iter()
        .map(|x| {
            vec![
                onoff(x.accel.early_termination).into(),
                onoff(x.accel.empty_space_skipping).into(),
                format_seconds(x.median_s),
                x.cpu_s.map_or("–".into(), format_seconds),
                format!("{:.1}", x.samples as f64 / 1e6),
                format!("{:.1}", x.skipped as f64 / 1e6),
                format!("{:.2}×", base / x.median_s.max(1e-12)),
            ]
        })
        .collect();
    let mut s = format!(
        "# Renderer benchmark\n\nVolume: {}; {} rayon threads; 1-minute load average at the start: {}; four ColorChecker materials, dial D65 → A → F11.\n\n",
        r.volume,
        r.threads,
        r.load_average.map_or("unknown".into(), |l| format!("{l:.2}"))
    );
    s += &format!(
        "## Raycast at {0}×{0} (min/max bricks built once in {1})\n\n",
        o.raycast_size,
        format_seconds(r.brick_build_s)
    );
    s += &markdown_table(
        &[
            "early termination",
            "empty-space skipping",
            "median wall time",
            "CPU time (all threads)",
            "samples (M)",
            "skipped steps (M)",
            "speed-up vs both off",
        ],
        &rows,
    );
    let rows: Vec<Vec<String>> = r
        .relight
        .iter()
        .map(|x| {
            vec![
                x.mode.as_str().into(),
                x.channels.to_string(),
                format!("{0}×{0}", x.size),
                format_seconds(x.median_s),
                x.cpu_s.map_or("–".into(), format_seconds),
                format_seconds(x.bound_s),
                format!("{:.1}×", x.median_s / x.bound_s.max(1e-12)),
            ]
        })
        .collect();
    s += &format!(
        "\n## Relight per frame (one thread: 3×K matrix per pixel + sRGB table)\n\nMeasured streaming bandwidth: {:.1} GB/s (read + write, one thread). Bound = (4·K + 3) bytes per pixel ÷ bandwidth.\n\n",
        r.bandwidth_bytes_per_s / 1e9
    );
    s += &markdown_table(
        &["mode", "K", "size", "median wall time", "CPU time", "bandwidth bound", "wall time / bound"],
        &rows,
    );
    let extra = r.sweep_frames.saturating_sub(1) as f64;
    let budget = r.one_frame_s + 0.020 * extra;
    s += &format!(
        "\n## Sweep cost ({0} frames at {1}×{1}, factor model, raycast once, frames relit and PNG-encoded in parallel)\n\n",
        r.sweep_frames, r.sweep_size
    );
    s += &markdown_table(
        &["one frame", "whole sweep", "per extra frame", "budget (one frame + 20 ms per extra frame)", "within budget"],
        &[vec![
            format_seconds(r.one_frame_s),
            format_seconds(r.sweep_s),
            format_seconds((r.sweep_s - r.one_frame_s) / extra.max(1.0)),
            format_seconds(budget),
            (if r.sweep_s <= budget { "yes" } else { "no" }).into(),
        ]],
    );
    let a = &r.accuracy;
    s += &format!(
        "\n## Accuracy against the full 31-sample frames ({0}×{0}, {1} frames, {2} non-black pixels, 8-bit frames as written)\n\n",
        o.accuracy_size, a.frames, a.pixels
    );
    let row = |name: String, e: &ModelError, u: &ModelError| {
        vec![
            name,
            format!("{:.3}", e.mean),
            format!("{:.3}", e.p95),
            format!("{:.3}", e.max),
            format!("{:.4}", u.mean),
            format!("{:.3}", u.max),
        ]
    };
    s += &markdown_table(
        &["model", "mean ΔE00", "p95 ΔE00", "max ΔE00", "mean ΔE00 before 8-bit", "max ΔE00 before 8-bit"],
        &[
            row(format!("spectral factor (m = {}, trained basis)", a.dimension), &a.factor, &a.factor_unquantised),
            row("RGB factor".into(), &a.rgb, &a.rgb_unquantised),
        ],
    );
    s += "\nRerun: `cargo run --release -- bench render` (options: see `metamer bench --help`).\n";
    s
}

fn plots(r: &RenderBenchReport, dir: &Path) -> Result<(), RenderError> {
    let plot_err =
        |p: &Path, e: super::plot::PlotError| RenderError::Output { path: p.to_path_buf(), reason: e.to_string() };
    let series = r
        .raycast
        .iter()
        .map(|x| Series {
            label: format!(
                "termination {}, skipping {}",
                onoff(x.accel.early_termination),
                onoff(x.accel.empty_space_skipping)
            ),
            points: vec![(x.samples as f64 / 1e6, x.median_s * 1e3)],
            spread: None,
            line: false,
        })
        .collect();
    let p = dir.join("render_raycast.png");
    draw(
        &XyPlot {
            title: "Raycast: time against samples taken".into(),
            x_label: "samples (millions)".into(),
            y_label: "time (ms)".into(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            series,
            pareto: false,
        },
        &p,
        900,
        600,
    )
    .map_err(|e| plot_err(&p, e))?;
    let mut series = Vec::new();
    for size in [r.sweep_size, r.relight.last().map_or(r.sweep_size, |x| x.size)] {
        let rows: Vec<&RelightRow> = r.relight.iter().filter(|x| x.size == size).collect();
        if rows.is_empty() || series.iter().any(|s: &Series| s.label.contains(&format!("{size}²"))) {
            continue;
        }
        let mut pts: Vec<(f64, f64)> = rows.iter().map(|x| (x.channels as f64, x.median_s * 1e3)).collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut bound: Vec<(f64, f64)> = rows.iter().map(|x| (x.channels as f64, x.bound_s * 1e3)).collect();
        bound.sort_by(|a, b| a.0.total_cmp(&b.0));
        series.push(Series { label: format!("measured, {size}²"), points: pts, spread: None, line: true });
        series.push(Series { label: format!("bandwidth bound, {size}²"), points: bound, spread: None, line: true });
    }
    let p = dir.join("render_relight.png");
    draw(
        &XyPlot {
            title: "Relight per frame against channels K (rgb 3, factor m, full 31)".into(),
            x_label: "channels per pixel K".into(),
            y_label: "time per frame (ms)".into(),
            x_scale: Scale::Linear,
            y_scale: Scale::Log,
            series,
            pareto: false,
        },
        &p,
        900,
        600,
    )
    .map_err(|e| plot_err(&p, e))?;
    Ok(())
}

/// Relight-kernel input for criterion: a factor-model image of the generated engine.
pub fn sample_image(size: usize) -> (ChannelImage, ColourModel, Scene) {
    let scene = generated_check_scene(128);
    let col = Colorimetry::default();
    let model = colour_model(&scene, Mode::Factor, &col).unwrap_or_else(|_| ColourModel::full(col.clone()));
    let view = render_views(&scene, vec![model], size, size, Acceleration::default(), None).pop();
    let (image, model) = match view {
        Some(v) => (v.image, v.model),
        None => (ChannelImage { width: 0, height: 0, channels: 31, data: vec![] }, ColourModel::full(col)),
    };
    (image, model, scene)
}
