//! `metamer bench render`: the renderer's costs and accuracy on the engine (the GE CT from
//! `engine.nhdr` in `$METAMER_DATA` or `../shared/volumes/` when present, else the generated engine-like volume) with four
//! ColorChecker materials swept D65 → A → F11:
//!
//! - raycast time at 512² with early ray termination and empty-space skipping on/off (speed-ups);
//! - relight time per frame (one thread, 3×K matrix + sRGB table) for the factor (K = m), full (31) and
//!   RGB (3) models, against the memory-bandwidth bound (bytes a frame must touch ÷ measured bandwidth);
//! - a 48-frame sweep at 384² (raycast once, relight + PNG per frame) against a single frame: the
//!   budget is one frame + 20 ms per extra frame;
//! - mean / p95 / max CIEDE2000 of the factor and RGB models against the full-spectrum frames;
//! - throughput: ns per sample and samples per second per core (process CPU time), what was skipped;
//! - a large generated u16 volume (512×512×384 in the full run, [`generate::engine_like_u16`]): raycast
//!   time, throughput, the derived-field cache and the process's peak memory against the budget
//!   ([`crate::memory::render_estimate`]);
//! - time against error: each quality setting's raycast time and p99 ΔE00 to a high-quality reference
//!   (step 0.25, `--ss 2`), with the Pareto front;
//! - the VTK ratio: `benches/vtk_compare.py` run on the engine CT when it and VTK are there (else the
//!   reason it was not measured).
//!
//! Writes `render.md` and `render_raycast.png`, `render_relight.png`, `render_pareto_quality.png` into the
//! output folder.
//!
//! [`generate::engine_like_u16`]: crate::volume::engine_like_u16

use super::plot::{Scale, Series, XyPlot, draw};
use super::{format_seconds, markdown_table, time_runs};
use crate::colorimetry::Colorimetry;
use crate::render::BrickMap;
use crate::render::DialOverlay;
use crate::render::{Acceleration, RenderError, colour_model, render_views};
use crate::render::{AccuracyReport, ModelError, compare_models};
use crate::render::{ColourModel, Mode, SrgbLut, relight_srgb8};
use crate::render::{Scene, engine_check_scene, generated_check_scene};
use crate::render::{SweepOptions, sweep_exposure, write_sweep};
use crate::volume::Volume;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to run.
#[derive(Clone, Debug)]
pub struct RenderBenchOptions {
    pub out_dir: PathBuf,
    /// Timed repetitions of each raycast (relighting repeats 20× as many).
    pub(crate) runs: usize,
    /// Raycast image size (the figure is 512).
    pub(crate) raycast_size: usize,
    /// Sweep image size and frame count (the figures are 384 and 48).
    pub(crate) sweep_size: usize,
    pub(crate) sweep_frames: usize,
    /// Image size and frames of the accuracy comparison.
    pub(crate) accuracy_size: usize,
    pub(crate) accuracy_frames: usize,
    /// Use this volume instead of looking for the shared engine.
    pub(crate) volume: Option<PathBuf>,
    /// The large generated u16 volume's grid.
    pub(crate) large_dims: [usize; 3],
    /// Frames of the time-against-error comparison.
    pub(crate) quality_frames: usize,
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
            large_dims: [512, 512, 384],
            quality_frames: 5,
        }
    }
}

/// One raycast configuration's timing.
#[derive(Clone, Debug)]
pub(crate) struct RaycastRow {
    pub(crate) accel: Acceleration,
    pub(crate) median_s: f64,
    /// Process CPU time per raycast (all threads; Linux only, from /proc/self/stat), when known.
    pub(crate) cpu_s: Option<f64>,
    pub(crate) samples: u64,
    pub(crate) skipped: u64,
    pub(crate) skipped_bricks: u64,
}

/// One relight model's timing.
#[derive(Clone, Debug)]
pub(crate) struct RelightRow {
    pub(crate) mode: Mode,
    pub(crate) channels: usize,
    pub(crate) size: usize,
    pub(crate) median_s: f64,
    /// Process CPU time per frame (one thread working; Linux only), when known.
    pub(crate) cpu_s: Option<f64>,
    /// Bytes read and written per frame ÷ measured bandwidth.
    pub(crate) bound_s: f64,
}

/// One sampling-quality configuration's raycast time and its error against the high-quality reference.
#[derive(Clone, Debug)]
pub(crate) struct QualityRow {
    pub(crate) what: String,
    pub(crate) median_s: f64,
    pub(crate) error: crate::render::FrameError,
}

/// The large generated volume's raycast.
#[derive(Clone, Debug)]
pub(crate) struct LargeRow {
    pub(crate) dims: [usize; 3],
    pub(crate) voxel_bytes: u64,
    pub(crate) generate_s: f64,
    pub(crate) size: usize,
    pub(crate) median_s: f64,
    pub(crate) cpu_s: Option<f64>,
    pub(crate) stats: crate::render::RaycastStats,
    /// Relight + PNG of a few frames after the raycast, per frame.
    pub(crate) per_frame_s: f64,
    /// The process's peak resident memory during the raycasts and frames (VmHWM reset before them), and
    /// what it was measured as.
    pub(crate) peak_bytes: Option<u64>,
    pub(crate) peak_note: &'static str,
}

/// VTK's CPU raycaster on the engine CT against metamer's raycast of the same view, at the same step.
#[derive(Clone, Debug)]
pub(crate) enum VtkRatio {
    /// One row per image size (the sweep's, 384² by default as in issue 24, and the raycast table's) and step (voxels: the
    /// scene's own step, then the script's step 0.5).
    Measured {
        rows: Vec<VtkRow>,
        version: String,
    },
    NotMeasured(String),
}

/// VTK's frame and metamer's raycast at one sample distance, both renderers at the same step, timed in
/// alternated rounds by the script.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct VtkRow {
    pub(crate) size: usize,
    pub(crate) step: f64,
    /// VTK's frames, median.
    pub(crate) vtk_s: f64,
    /// metamer's raycasts (each a whole `metamer render` process's summary), median.
    pub(crate) metamer_s: f64,
    /// Each round's metamer raycast over VTK's frame: median, least, greatest.
    pub(crate) paired: [f64; 3],
}

impl RenderBenchReport {
    /// The per-frame cost as text (the fit's slope, or why there is none).
    pub(crate) fn per_frame_text(&self) -> String {
        match self.per_frame_s {
            Some(s) => {
                format!("{} per extra frame (fit over {} frame counts)", format_seconds(s), self.sweep_points.len())
            }
            None => "per extra frame below timing noise (fit slope ≤ 0)".into(),
        }
    }
}

/// Least-squares slope of y over x (None with fewer than two distinct x).
pub(crate) fn slope(points: &[(f64, f64)]) -> Option<f64> {
    let n = points.len() as f64;
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (points.len() >= 2 && sxx > 0.0).then(|| sxy / sxx)
}

/// Everything measured.
#[derive(Clone, Debug)]
pub struct RenderBenchReport {
    pub volume: String,
    pub(crate) threads: usize,
    /// 1-minute load average when the benchmark started (other processes compete for the cores).
    pub(crate) load_average: Option<f64>,
    pub(crate) brick_build_s: f64,
    pub(crate) raycast: Vec<RaycastRow>,
    pub(crate) bandwidth_bytes_per_s: f64,
    pub(crate) relight: Vec<RelightRow>,
    pub(crate) one_frame_s: f64,
    pub(crate) sweep_s: f64,
    /// Median wall time of drawing the light dial into one frame at the sweep size (single thread).
    pub(crate) overlay_s: f64,
    /// Median sweep time (raycast included) at each frame count measured.
    pub(crate) sweep_points: Vec<(usize, f64)>,
    /// The marginal cost of a frame: the least-squares slope of sweep time over the frame counts,
    /// None when timing noise makes it come out ≤ 0.
    pub(crate) per_frame_s: Option<f64>,
    /// Raycasts made per sweep (one per view: frames only relight).
    pub(crate) raycasts_per_sweep: usize,
    /// The cost of each sampling-quality step.
    pub(crate) quality: Vec<QualityRow>,
    pub(crate) sweep_frames: usize,
    pub(crate) sweep_size: usize,
    /// The image size (pixels per side) of the raycast timings.
    pub(crate) raycast_size: usize,
    pub(crate) accuracy: AccuracyReport,
    pub(crate) large: LargeRow,
    pub(crate) vtk: VtkRatio,
    pub(crate) markdown: String,
}

/// The engine CT: `engine.nhdr` in the folder named by `METAMER_DATA` (or its `volumes/`), else
/// `../shared/volumes/engine.nhdr` from the working folder (a checkout with the data folder beside it).
pub(crate) fn find_shared_engine() -> Option<PathBuf> {
    let name = std::ffi::OsStr::new("engine.nhdr");
    crate::volume::find_in_data_dir(name).or_else(|| crate::volume::find_in(Path::new("../shared"), name))
}

/// User + system CPU seconds of this process so far (Linux `/proc/self/stat`, 100 ticks per second).
pub(crate) fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// The peak resident memory of this process so far (`VmHWM` in Linux `/proc/self/status`), bytes.
pub(crate) fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// The 1-minute load average (Linux), to judge how contended the timings were.
pub(crate) fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg").ok()?.split_whitespace().next()?.parse().ok()
}

/// Streaming bandwidth of this machine (one thread, read + write of a 64 MiB buffer, best of 3), bytes/s.
pub(crate) fn measure_bandwidth() -> f64 {
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
        // The file name only: the report must not record where the data folder sits on this machine.
        Some(p) => (
            engine_check_scene(Volume::open(p)?),
            p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned()),
        ),
        None => (
            generated_check_scene(256),
            "generated engine-like 256×256×128 (engine.nhdr not found: set METAMER_DATA or pass --volume)".into(),
        ),
    };
    // The data set named with its size (the plots and the report say what was measured).
    let volume_name = if volume_path.is_some() {
        let [x, y, z] = scene.volume.dims;
        format!("{volume_name} ({x}×{y}×{z})")
    } else {
        volume_name
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
        let accel = Acceleration { early_termination: et, empty_space_skipping: ess, ..Acceleration::default() };
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
            skipped_bricks: stats.skipped_bricks,
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
        let mut opts = SweepOptions::new(frames, exposure, tmp.path().join(format!("sweep{frames}")));
        opts.overlay = Some(DialOverlay::new(&scene.dial, &col, size, size));
        write_sweep(&view.image, &view.model, &scene.dial, &opts, &|| {})?;
        Ok(start.elapsed().as_secs_f64())
    };
    // Sweep time at several frame counts; the marginal cost per frame is the fitted slope.
    let n = options.sweep_frames.max(1);
    let mut counts = vec![1, n.div_ceil(4), n.div_ceil(2), n];
    counts.dedup();
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let mut sweep_points = Vec::new();
    for &c in &counts {
        let times: Result<Vec<f64>, RenderError> = (0..runs.clamp(1, 3)).map(|_| sweep_once(c)).collect();
        sweep_points.push((c, median(times?)));
    }
    let at = |c: usize| sweep_points.iter().find(|p| p.0 == c).map_or(f64::NAN, |p| p.1);
    let (one_frame_s, sweep_s) = (at(1), at(n));
    let fit: Vec<(f64, f64)> = sweep_points.iter().map(|(c, t)| (*c as f64, *t)).collect();
    let per_frame_s = slope(&fit).filter(|s| *s > 0.0);

    // The cost of each sampling-quality step, one raycast at the raycast size.
    let size = options.raycast_size;
    let with = |f: &dyn Fn(&mut Scene)| {
        let mut sc = scene.clone();
        f(&mut sc);
        sc
    };
    use crate::render::{Gradient, Interpolation, Shading};
    let configs: Vec<(String, Scene, usize)> = vec![
        (
            "fixed-phase sampling, cell gradient (no quality steps)".into(),
            with(&|s| {
                s.settings.jitter = false;
                s.settings.refine = false;
                s.settings.gradient = Gradient::Cell;
            }),
            1,
        ),
        (
            "+ jitter".into(),
            with(&|s| {
                s.settings.refine = false;
                s.settings.gradient = Gradient::Cell;
            }),
            1,
        ),
        ("+ jitter + smooth gradient".into(), with(&|s| s.settings.refine = false), 1),
        ("+ jitter + smooth gradient + boundary refinement (the default)".into(), scene.clone(), 1),
        ("unshaded (no gradient at all)".into(), with(&|s| s.settings.shading = Shading::Unshaded), 1),
        (
            "shape-based labels (interpolation = labels)".into(),
            with(&|s| s.settings.interpolation = Interpolation::Labels),
            1,
        ),
        ("default at --ss 2 (raycast 2× per side, averaged)".into(), scene.clone(), 2),
        ("default at step 2".into(), with(&|s| s.settings.step = 2.0), 1),
        ("default at step 0.5".into(), with(&|s| s.settings.step = 0.5), 1),
    ];
    // The reference: every quality step on, step 0.25, --ss 2.
    let reference = {
        let sc = with(&|s| s.settings.step = 0.25);
        let mut v = render_views(&sc, vec![factor.clone()], size * 2, size * 2, Acceleration::default(), None)
            .pop()
            .ok_or_else(|| RenderError::Invalid("no view".into()))?;
        v.image = crate::render::downsample(&v.image, 2);
        v
    };
    let mut quality = Vec::new();
    for (what, sc, ss) in configs {
        let (timing, view) = time_runs(runs.min(3), || {
            render_views(&sc, vec![factor.clone()], size * ss, size * ss, Acceleration::default(), None).pop()
        });
        let view = view.ok_or_else(|| RenderError::Invalid("no view".into()))?;
        // compare_views box-filters a supersampled view down to the reference's size.
        let error = crate::render::compare_views(&scene, &col, &reference, &view, options.quality_frames);
        quality.push(QualityRow { what, median_s: timing.median, error });
    }

    // The dial overlay alone, per frame (state, trail, panel drawing, labels), on a mid-grey frame.
    let overlay_s = {
        let size = options.sweep_size;
        let overlay = DialOverlay::new(&scene.dial, &col, size, size);
        let mut rgb = vec![128u8; size * size * 3];
        let n = options.sweep_frames.max(2);
        let mut k = 0usize;
        let (timing, _) = time_runs(runs * 20, || {
            overlay.draw_frame(&mut rgb, size, size, &scene.dial, k % n, n);
            k += 1;
        });
        timing.median
    };

    let accuracy = compare_models(&scene, &col, options.accuracy_size, options.accuracy_frames)?;
    let large = large_volume(options, &col, &tmp)?;
    let vtk = vtk_ratio(options, volume_path.as_deref(), runs, &tmp);

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
        overlay_s,
        sweep_points,
        per_frame_s,
        raycasts_per_sweep: 1,
        quality,
        sweep_frames: options.sweep_frames,
        sweep_size: options.sweep_size,
        raycast_size: options.raycast_size,
        accuracy,
        large,
        vtk,
        markdown: String::new(),
    };
    report.markdown = markdown(&report, options);
    let md = options.out_dir.join("render.md");
    crate::bench::write_own(&md, report.markdown.as_bytes())
        .map_err(|e| RenderError::Output { path: md.clone(), reason: e.to_string() })?;
    plots(&report, &options.out_dir)?;
    Ok(report)
}

/// Reset this process's peak resident memory to what it holds now (Linux: `5` into
/// `/proc/self/clear_refs`); false when it cannot be. With glibc, the heap that earlier suites freed and
/// the allocator kept is first returned to the system (`malloc_trim`), so the peak measured after the reset
/// is what the workload needs on top of what the benchmark holds live, not whatever freed memory glibc
/// happened to keep (which varied by ~30 MiB from run to run of the same binary).
fn reset_peak_memory() -> bool {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `malloc_trim` only releases free heap memory back to the system; it is thread-safe and
    // leaves every live allocation where it is.
    unsafe {
        libc::malloc_trim(0);
    }
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The large generated u16 volume: generated, raycast at the raycast size, a few frames relit and written.
fn large_volume(
    options: &RenderBenchOptions,
    col: &Colorimetry,
    tmp: &tempfile::TempDir,
) -> Result<LargeRow, RenderError> {
    let t = Instant::now();
    let scene = crate::render::generated_u16_check_scene(options.large_dims);
    let generate_s = t.elapsed().as_secs_f64();
    let dims = scene.volume.dims;
    let voxel_bytes = scene.volume.voxels.bytes() as u64;
    let factor = colour_model(&scene, Mode::Factor, col)?;
    let reset = reset_peak_memory();
    let size = options.raycast_size;
    let runs = options.runs.clamp(1, 3);
    let cpu0 = process_cpu_seconds();
    let (timing, view) =
        time_runs(runs, || render_views(&scene, vec![factor.clone()], size, size, Acceleration::default(), None).pop());
    let cpu_s = cpu0.zip(process_cpu_seconds()).map(|(a, b)| (b - a) / (runs + 1) as f64);
    let view = view.ok_or_else(|| RenderError::Invalid("no view".into()))?;
    let frames = 8;
    let reflectances: Vec<_> = scene.materials.iter().map(|m| m.spectrum).collect();
    let exposure = sweep_exposure(col, &reflectances, &scene.dial, frames, 1.0);
    let mut opts = SweepOptions::new(frames, exposure, tmp.path().join("large"));
    opts.overlay = Some(DialOverlay::new(&scene.dial, col, size, size));
    let sweep = write_sweep(&view.image, &view.model, &scene.dial, &opts, &|| {})?;
    Ok(LargeRow {
        dims,
        voxel_bytes,
        generate_s,
        size,
        median_s: timing.median,
        cpu_s,
        stats: view.stats,
        per_frame_s: sweep.seconds / frames as f64,
        peak_bytes: peak_memory_bytes(),
        peak_note: if reset {
            "VmHWM reset after generating the volume (with glibc, after returning freed heap to the system): the raycasts and frames, with all the benchmark holds"
        } else {
            "VmHWM of the whole benchmark (it could not be reset here)"
        },
    })
}

/// VTK's raycast of the engine CT (`benches/vtk_compare.py`, from the working folder) against metamer's
/// raycast of the same view (`volumes/engine.toml`, headlight shading, as the script's docstring says),
/// at the sweep's size (384² by default, the size issue 24 names) and the raycast table's, each at the same
/// sample distance: the scene's own step (what `metamer render volumes/engine.toml` uses) and the script's
/// default, 0.5 voxels. The script renders both (`--run-metamer`, this binary, at VTK's step, of the volume
/// VTK reads) in alternated rounds, so that a machine whose speed drifts weighs on both alike: each round a
/// whole `metamer render` process and a VTK frame, each after an untimed run of its own kind.
fn vtk_ratio(options: &RenderBenchOptions, engine: Option<&Path>, runs: usize, tmp: &tempfile::TempDir) -> VtkRatio {
    let script = Path::new("benches/vtk_compare.py");
    let scene_file = Path::new("volumes/engine.toml");
    let Some(engine) = engine.filter(|p| p.extension().is_some_and(|e| e == "nhdr")) else {
        return VtkRatio::NotMeasured("no engine CT (engine.nhdr) found: the script renders that volume".into());
    };
    if !script.is_file() || !scene_file.is_file() {
        return VtkRatio::NotMeasured("benches/vtk_compare.py or volumes/engine.toml not in the working folder".into());
    }
    let Some(metamer) = super::metamer_binary() else {
        return VtkRatio::NotMeasured("the metamer binary was not found".into());
    };
    let scene_step = match Scene::load_with_volume(scene_file, Some(engine)) {
        Ok(s) => s.settings.step,
        Err(e) => return VtkRatio::NotMeasured(format!("volumes/engine.toml: {e}")),
    };
    let mut sizes = vec![options.sweep_size];
    if options.raycast_size != options.sweep_size {
        sizes.push(options.raycast_size);
    }
    let mut steps = vec![scene_step];
    if (scene_step - 0.5).abs() > 1e-9 {
        steps.push(0.5);
    }
    let mut rows = Vec::new();
    let mut version = String::new();
    for (size, step) in sizes.iter().flat_map(|&size| steps.iter().map(move |&step| (size, step))) {
        let out = std::process::Command::new("python3")
            .arg(script)
            .arg(engine)
            // The CPU raycaster the page names (the script's default is the GPU mapper, which on a machine
            // without a GPU runs on software GL and is no fair yardstick).
            .args(["--mapper", "fixed", "--size", &size.to_string(), "--step", &step.to_string()])
            .args(["--repeat", &runs.max(3).to_string(), "--run-metamer"])
            .arg(&metamer)
            .arg("-o")
            .arg(tmp.path().join("vtk.png"))
            .output();
        let out = match out {
            Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).into_owned(),
            Ok(o) => {
                let err = String::from_utf8_lossy(&o.stderr);
                let last = err.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no message");
                return VtkRatio::NotMeasured(format!(
                    "the script failed (is vtk importable?): {}",
                    crate::fsio::escape(last)
                ));
            }
            Err(e) => return VtkRatio::NotMeasured(format!("python3 did not run: {e}")),
        };
        let Some(((v, vtk_s), (metamer_s, paired))) = parse_vtk_line(&out).zip(parse_paired_lines(&out)) else {
            return VtkRatio::NotMeasured(
                "the script's output lacks its `VTK … fixed-point … median … ms`, `metamer's raycast: median … ms` \
                 or `paired: … median …×, …–…×` line"
                    .into(),
            );
        };
        version = v;
        rows.push(VtkRow { size, step, vtk_s, metamer_s, paired });
    }
    VtkRatio::Measured { rows, version }
}

/// The script's summary line, "VTK 9.7.2 fixed-point CPU raycast 512², step 0.5: median 123.4 ms of 3 …":
/// VTK's version and its median frame time in seconds.
fn parse_vtk_line(out: &str) -> Option<(String, f64)> {
    let l = out.lines().find(|l| l.starts_with("VTK ") && l.contains("fixed-point"))?;
    let version = l.split_whitespace().nth(1)?.to_string();
    let ms: f64 = l.split("median ").nth(1)?.split_whitespace().next()?.parse().ok()?;
    Some((version, ms / 1e3))
}

/// The script's lines for metamer's side, "metamer's raycast: median 119.1 ms of 9 processes …" and "paired:
/// metamer's raycast / VTK's frame in each of 9 alternated rounds: median 0.94×, 0.62–1.19×; …": metamer's
/// median raycast in seconds and the rounds' ratios (median, least, greatest).
fn parse_paired_lines(out: &str) -> Option<(f64, [f64; 3])> {
    let raycast = out.lines().find_map(|l| l.strip_prefix("metamer's raycast: median "))?;
    let ms: f64 = raycast.split_whitespace().next()?.parse().ok()?;
    let paired = out.lines().find_map(|l| l.strip_prefix("paired: "))?;
    let rest = paired.split(": median ").nth(1)?;
    let (median, rest) = rest.split_once("×, ")?;
    let (least, rest) = rest.split_once('–')?;
    let greatest = rest.split('×').next()?;
    let number = |t: &str| t.trim().parse::<f64>().ok();
    Some((ms / 1e3, [number(median)?, number(least)?, number(greatest)?]))
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
                format!("{:.2}", x.skipped_bricks as f64 / 1e6),
                per_sample(x.cpu_s, x.samples),
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
            "jumps over empty space (M)",
            "ns per sample per core (M samples/s per core)",
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
        "\n## Sweep cost ({0} frames at {1}×{1}, factor model, {2} raycast per sweep, frames relit and PNG-encoded in parallel)\n\n",
        r.sweep_frames, r.sweep_size, r.raycasts_per_sweep
    );
    s += &format!(
        "Whole sweeps (raycast included) at {} frames: {}. The per-frame cost is the least-squares slope over \
         these counts (a difference of two noisy timings can come out negative).\n\n",
        r.sweep_points.iter().map(|(c, _)| c.to_string()).collect::<Vec<_>>().join(", "),
        r.sweep_points.iter().map(|(_, t)| format_seconds(*t)).collect::<Vec<_>>().join(", "),
    );
    s += &markdown_table(
        &["one frame", "whole sweep", "per extra frame", "budget (one frame + 20 ms per extra frame)", "within budget"],
        &[vec![
            format_seconds(r.one_frame_s),
            format_seconds(r.sweep_s),
            r.per_frame_s.map_or("below noise".into(), format_seconds),
            format_seconds(budget),
            (if r.sweep_s <= budget { "✓ yes" } else { "✗ no" }).into(),
        ]],
    );
    s += &format!(
        "\nThe light dial drawn into one frame (lower right, {0}×{0}, one thread): {1} per frame (aim ≤ 1 ms); it is \
         included in every sweep frame above.\n",
        r.sweep_size,
        format_seconds(r.overlay_s)
    );
    s += "\nCPU time per sample is the process's user + system time of a raycast (all threads) over its samples; \
          the machine's other load inflates wall time, not CPU time.\n";
    let l = &r.large;
    let budget = crate::memory::render_estimate(l.voxel_bytes);
    s += &format!(
        "\n## A large generated volume: u16 {}×{}×{} ({} MiB of voxels, generated in {})\n\n",
        l.dims[0],
        l.dims[1],
        l.dims[2],
        crate::memory::show_mib(l.voxel_bytes),
        format_seconds(l.generate_s)
    );
    s += &markdown_table(
        &[
            "image",
            "median raycast",
            "samples (M)",
            "ns per sample per core (M samples/s per core)",
            "jumps over empty space (M)",
            "field blocks built / evicted, most resident of the cap",
            "relight + PNG per frame",
            "peak memory",
            "budget 1.5 × voxels + 160 MiB",
        ],
        &[vec![
            format!("{0}×{0}", l.size),
            format_seconds(l.median_s),
            format!("{:.1}", l.stats.samples as f64 / 1e6),
            per_sample(l.cpu_s, l.stats.samples),
            format!("{:.2}", l.stats.skipped_bricks as f64 / 1e6),
            format!(
                "{} / {}, {} of {} MiB",
                l.stats.field_blocks,
                l.stats.field_evicted,
                crate::memory::show_mib(l.stats.field_peak),
                crate::memory::show_mib(l.stats.field_cap)
            ),
            format_seconds(l.per_frame_s),
            l.peak_bytes.map_or("unknown".into(), |b| format!("{} MiB", crate::memory::show_mib(b))),
            format!(
                "{} MiB{}",
                crate::memory::show_mib(budget),
                match l.peak_bytes {
                    Some(b) if b <= budget => " ✓ within",
                    Some(_) => " ✗ over",
                    None => "",
                }
            ),
        ]],
    );
    s += &format!("\nPeak memory: {}.\n", l.peak_note);
    s += "\n## VTK\n\n";
    s += &match &r.vtk {
        VtkRatio::Measured { rows, version } => {
            let mut t = format!(
                "VTK {version}'s CPU raycaster (`vtkFixedPointVolumeRayCastMapper`, `benches/vtk_compare.py --mapper fixed \
                 --step S --run-metamer BIN`) renders one RGB frame of the engine CT; metamer renders the same view \
                 (`volumes/engine.toml`, headlight, every quality step on, m channels per pixel) at the same size and \
                 step S, each run a whole `metamer render` process whose summary gives the raycast. The two take turns \
                 (a metamer process, then a VTK frame, each after an untimed run of its own kind), so that a machine \
                 whose speed drifts weighs on both alike: medians, and each round's own ratio. \
                 Every further frame of a sweep is a relight, where VTK renders again.\n\n"
            );
            t += &markdown_table(
                &[
                    "image",
                    "step (voxels)",
                    "VTK frame",
                    "metamer raycast",
                    "metamer / VTK",
                    "per round: median (range)",
                ],
                &rows
                    .iter()
                    .map(|r| {
                        let [median, least, greatest] = r.paired;
                        vec![
                            format!("{0}×{0}", r.size),
                            format!("{}", r.step),
                            format_seconds(r.vtk_s),
                            format_seconds(r.metamer_s),
                            format!("{:.2}×", r.metamer_s / r.vtk_s.max(1e-12)),
                            format!("{median:.2}× ({least:.2}–{greatest:.2}×)"),
                        ]
                    })
                    .collect::<Vec<_>>(),
            );
            t
        }
        VtkRatio::NotMeasured(why) => format!("Not measured: {why}.\n"),
    };
    s += &format!(
        "\n## Sampling quality: cost of each step and its error (one raycast at {0}×{0})\n\n\
         Error: CIEDE2000 per pixel against a high-quality reference (every step on, step 0.25, --ss 2) over a \
         {1}-frame sweep of 8-bit frames; the Pareto plot `render_pareto_quality.png` sets them against time.\n\n",
        o.raycast_size, o.quality_frames
    );
    let base_q = r.quality.first().map_or(1.0, |q| q.median_s);
    let qrows: Vec<Vec<String>> = r
        .quality
        .iter()
        .map(|q| {
            vec![
                q.what.clone(),
                format_seconds(q.median_s),
                format!("{:.2}×", q.median_s / base_q.max(1e-12)),
                format!("{:.3}", q.error.mean),
                format!("{:.2}", q.error.p99),
            ]
        })
        .collect();
    s += &markdown_table(
        &["configuration", "median raycast", "against no quality steps", "mean ΔE00", "p99 ΔE00"],
        &qrows,
    );
    // Jitter's cost in words that agree with the table: it adds no samples, but what it costs is measured.
    let jitter = r.quality.iter().find(|q| q.what == "+ jitter").map(|q| q.median_s / base_q.max(1e-12));
    s += &match jitter {
        Some(j) if j < 1.05 => format!(
            "\nJitter moves each ray's sample positions by a per-pixel offset below one step: the same number of \
             samples, and it measured {j:.2}× the fixed-phase raycast here, no cost above timing noise. "
        ),
        Some(j) => format!(
            "\nJitter moves each ray's sample positions by a per-pixel offset below one step: the same number of \
             samples, yet it measured {j:.2}× the fixed-phase raycast here (the extra time is most likely cache \
             locality, as neighbouring rays no longer sample the same planes of the volume, and on a busy machine \
             partly noise; it is not measured apart). "
        ),
        None => "\nJitter moves each ray's sample positions by a per-pixel offset below one step (the same number \
                 of samples). "
            .into(),
    };
    s += "The smooth gradient interpolates per-voxel central differences \
          (i16, 6 bytes an entry) at shaded samples only, built per 8³ brick the first time a ray reaches it (capped at half the voxels' bytes, the block whose rays end soonest evicted); shape-based \
          labels build, per brick reached, each nearby material's in-slice signed distance (a 2D distance transform per \
          slice, smoothed; u16 per material present) and sample it trilinearly, with one distance gradient per material \
          (here on the CT's value classes; on a label volume such as the frog it replaces voxel terraces by smooth \
          surfaces); supersampling multiplies the rays by ss². None of them changes the per-frame cost.\n";
    let a = &r.accuracy;
    s += &format!(
        "\n## Accuracy against the full 31-sample frames ({0}×{0}, {1} frames, {2} non-black pixels, 8-bit frames as written)\n\n",
        o.accuracy_size, a.frames, a.pixels
    );
    let row = |name: String, e: &ModelError, u: &ModelError| {
        vec![
            name,
            format!("{:.4}", e.mean),
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
    if a.factor.p95 < a.factor.mean || a.rgb.p95 < a.rgb.mean {
        s += "\nA p95 below the mean is not an error: at least 95 % of the pixels are identical after 8-bit rounding \
              (ΔE00 0), and the mean comes from the few that are not (their worst is the max column).\n";
    }
    s += "\nRerun: `cargo run --release -- bench render` (options: see `metamer bench --help`).\n";
    s
}

/// "ns (M samples/s)" per core from a CPU time and a sample count.
fn per_sample(cpu_s: Option<f64>, samples: u64) -> String {
    match cpu_s {
        Some(c) if c > 0.0 && samples > 0 => {
            format!("{:.0} ({:.2})", c * 1e9 / samples as f64, samples as f64 / c / 1e6)
        }
        _ => "–".into(),
    }
}

fn plots(r: &RenderBenchReport, dir: &Path) -> Result<(), RenderError> {
    let plot_err =
        |p: &Path, e: super::plot::PlotError| RenderError::Output { path: p.to_path_buf(), reason: e.to_string() };
    let series = r
        .quality
        .iter()
        .map(|q| Series {
            label: q.what.clone(),
            points: vec![(q.median_s * 1e3, q.error.p99.max(1e-3))],
            workload: Some("engine".into()),
            ..Series::default()
        })
        .collect();
    let p = dir.join("render_pareto_quality.png");
    draw(
        &XyPlot {
            title: "Raycast time against p99 ΔE00 to the reference (step 0.25, --ss 2)".into(),
            x_label: "raycast time (ms)".into(),
            y_label: "p99 ΔE00".into(),
            x_scale: Scale::Log,
            y_scale: Scale::Log,
            series,
            pareto: true,
            ..XyPlot::default()
        },
        &p,
        900,
        600,
    )
    .map_err(|e| plot_err(&p, e))?;
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
            ..Series::default()
        })
        .collect();
    let p = dir.join("render_raycast.png");
    draw(
        &XyPlot {
            title: format!("Raycast of {} at {}²: time against samples taken", r.volume, r.raycast_size),
            x_label: "samples (millions)".into(),
            y_label: "time (ms)".into(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            y_from_zero: true,
            series,
            ..XyPlot::default()
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
        series.push(Series { label: format!("measured, {size}²"), points: pts, line: true, ..Series::default() });
        series.push(Series {
            label: format!("bandwidth bound, {size}²"),
            points: bound,
            line: true,
            ..Series::default()
        });
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
            ..XyPlot::default()
        },
        &p,
        900,
        600,
    )
    .map_err(|e| plot_err(&p, e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lines `benches/vtk_compare.py --run-metamer` prints (copied from a run), read into the page's row:
    /// VTK's median frame, metamer's median raycast and the rounds' ratios; a line missing or cut short
    /// reads as nothing.
    #[test]
    fn the_vtk_scripts_alternated_figures_are_read() {
        let out = "material bounds [57, 21, 0]..[212, 222, 107]; focal point [132.23, 120.74, 55.05]\n\
                   raycast 118.1 ms at 384² (5735216 samples, 2481194 skipped), exposure 1.597\n\
                   metamer's raycast: median 119.1 ms of 9 processes, each after an untimed one (117.4, 124.0); whole \
                   process (volume read, raycast, one frame): median 0.27 s CPU\n\
                   paired: metamer's raycast / VTK's frame in each of 9 alternated rounds: median 0.94×, \
                   0.62–1.19×; medians' ratio 0.94×\n\
                   VTK 9.7.2 fixed-point CPU raycast 384², step 1.0: median 127.2 ms of 9 (min 122.8), 245 ms CPU \
                   per render (mean), load 0.8 -> /tmp/vtk_engine.png\n";
        assert_eq!(parse_vtk_line(out), Some(("9.7.2".to_string(), 0.1272)));
        let (ms, paired) = parse_paired_lines(out).expect("both lines read");
        assert!((ms - 0.1191).abs() < 1e-12, "{ms}");
        assert_eq!(paired, [0.94, 0.62, 1.19]);
        let without_pairs: String = out.lines().filter(|l| !l.starts_with("paired:")).collect::<Vec<_>>().join("\n");
        assert_eq!(parse_paired_lines(&without_pairs), None);
        assert_eq!(parse_paired_lines(&out.replace("0.62–1.19×", "0.62")), None);
    }
}
