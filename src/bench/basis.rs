//! `metamer bench basis`: the spectral factor model's dimension m against its colour error and its
//! relighting cost.
//!
//! For each m the basis is trained on the reference set (24 ColorChecker reflectances × D65, A, F2, F7,
//! F11, LED_B3, D50, luminance-normalised, [`TrainingSet::colorchecker_seven_lights`]) with the default
//! training, and measured there (mean / p95 / max ΔE00 against full 31-sample colour) after the T refinement
//! alone and after refining all of B. The relighting cost is the post-illumination kernel the renderer
//! runs per pixel and frame: `rgb = Q_rgb,m (e ∘ s)` with f32 coefficients (m multiplies for `e ∘ s`, then
//! a 3×m matrix), timed over a frame of [`BenchOptions::pixels`] pixels and reported in ns per
//! pixel-frame for the fastest timed frame (the least disturbed by other work on a shared machine; median
//! and quartiles are kept in [`Row::relight`]). The RGB factor model is the m = 3 kernel with its own error.

use super::plot::{self, PlotError, Scale, Series, XyPlot};
use super::{Timing, markdown_table, time_runs};
use crate::basis::accuracy::{self, ErrorStats, Model};
use crate::basis::{self, TrainError, TrainOptions, TrainingSet};
use crate::basis::{Basis, BasisError};
use crate::colorimetry::Colorimetry;
use std::hint::black_box;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub dimensions: RangeInclusive<usize>,
    /// Pixels per timed relighting frame.
    pub(crate) pixels: usize,
    /// Timed frames per dimension (after one warm-up).
    pub(crate) runs: usize,
    pub(crate) training: TrainOptions,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions { dimensions: 3..=12, pixels: 512 * 512, runs: 30, training: TrainOptions::default() }
    }
}

/// One dimension's results.
#[derive(Clone, Debug)]
pub struct Row {
    pub(crate) dimension: usize,
    /// The basis after refining T only (B in the PCA span).
    pub(crate) transform_only: ErrorStats,
    /// The basis after refining all of B (what `metamer basis` returns).
    pub(crate) full: ErrorStats,
    pub(crate) training_seconds: f64,
    /// Relighting time per frame.
    pub relight: Timing,
    /// Relighting cost in nanoseconds per pixel-frame: the fastest timed frame (the least disturbed by other
    /// work on the machine; the spread is in `relight`).
    pub(crate) relight_ns_per_pixel: f64,
}

/// The whole benchmark.
#[derive(Clone, Debug)]
pub struct Results {
    pub rows: Vec<Row>,
    /// The RGB factor model's error on the same set and its (m = 3) relighting cost.
    pub rgb: ErrorStats,
    pub rgb_relight_ns_per_pixel: f64,
    pub(crate) pixels: usize,
}

/// Why the benchmark failed.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Train(#[from] TrainError),
    #[error(transparent)]
    Basis(#[from] BasisError),
    #[error(transparent)]
    Plot(#[from] PlotError),
    #[error("{0}")]
    File(crate::fsio::FsError),
}

/// The post-illumination kernel: for every pixel's m coefficients `s`, `rgb = Q (e ∘ s)` with `q` the 3×m
/// matrix `Q_rgb,m` in row-major order. `coefficients.len()` must be `pixels · m` and `out.len()` `pixels · 3`.
pub(crate) fn relight(coefficients: &[f32], light: &[f32], q: &[f32], out: &mut [f32]) {
    let m = light.len();
    if m == 0 {
        return;
    }
    let (q0, rest) = q.split_at(m);
    let (q1, q2) = rest.split_at(m);
    for (s, o) in coefficients.chunks_exact(m).zip(out.chunks_exact_mut(3)) {
        let (mut r, mut g, mut b) = (0.0f32, 0.0f32, 0.0f32);
        for k in 0..m {
            let c = s[k] * light[k];
            r += q0[k] * c;
            g += q1[k] * c;
            b += q2[k] * c;
        }
        o[0] = r;
        o[1] = g;
        o[2] = b;
    }
}

/// Time [`relight`] for an m-dimensional model on a frame of `pixels` pixels.
fn time_relight(q: &[f32], light: &[f32], pixels: usize, runs: usize) -> Timing {
    let m = light.len();
    // Deterministic, varied coefficients (a cheap LCG), so the kernel cannot be specialised away.
    let mut state = 0x2545_f491_u32;
    let coefficients: Vec<f32> = (0..pixels * m)
        .map(|_| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        })
        .collect();
    let mut out = vec![0.0f32; pixels * 3];
    let (timing, _) = time_runs(runs, || {
        relight(black_box(&coefficients), black_box(light), black_box(q), &mut out);
        black_box(out[0])
    });
    timing
}

fn q_of(basis: &Basis) -> Vec<f32> {
    let q = &basis.q_rgb_m;
    (0..3).flat_map(|r| (0..q.ncols()).map(move |c| q[(r, c)] as f32)).collect()
}

/// Run the benchmark.
pub fn run(options: &BenchOptions) -> Result<Results, BenchError> {
    let colorimetry = Colorimetry::default();
    let set = TrainingSet::colorchecker_seven_lights(&colorimetry);
    let mut rows = Vec::new();
    for m in options.dimensions.clone() {
        let start = Instant::now();
        let trained = basis::train(&set, m, &colorimetry, &options.training)?;
        let training_seconds = start.elapsed().as_secs_f64();
        let t_basis = Basis::from_matrix(trained.transform_only.clone(), &colorimetry)?;
        let light: Vec<f32> = trained.basis.coefficients(&set.lights[0]).iter().map(|v| *v as f32).collect();
        let relight = time_relight(&q_of(&trained.basis), &light, options.pixels, options.runs);
        rows.push(Row {
            dimension: m,
            transform_only: accuracy::stats(&set, Model::Factor(&t_basis), &colorimetry),
            full: accuracy::stats(&set, Model::Factor(&trained.basis), &colorimetry),
            training_seconds,
            relight_ns_per_pixel: relight.min * 1e9 / options.pixels.max(1) as f64,
            relight,
        });
    }
    let rgb = accuracy::stats(&set, Model::Rgb, &colorimetry);
    let q3: Vec<f32> = (0..3).flat_map(|r| (0..3).map(move |c| if r == c { 1.0 } else { 0.0 })).collect();
    let rgb_relight = time_relight(&q3, &[1.0, 0.9, 0.8], options.pixels, options.runs);
    Ok(Results {
        rows,
        rgb,
        rgb_relight_ns_per_pixel: rgb_relight.min * 1e9 / options.pixels.max(1) as f64,
        pixels: options.pixels,
    })
}

/// The results as a Markdown table.
pub(crate) fn markdown(results: &Results) -> String {
    let f = |v: f64| format!("{v:.2}");
    let mut rows: Vec<Vec<String>> = results
        .rows
        .iter()
        .map(|r| {
            vec![
                r.dimension.to_string(),
                format!("{} / {} / {}", f(r.full.mean), f(r.full.p95), f(r.full.max)),
                format!("{} / {} / {}", f(r.transform_only.mean), f(r.transform_only.p95), f(r.transform_only.max)),
                format!("{:.2}", r.relight_ns_per_pixel),
                super::format_seconds(r.training_seconds),
            ]
        })
        .collect();
    rows.push(vec![
        "RGB factor model".into(),
        format!("{} / {} / {}", f(results.rgb.mean), f(results.rgb.p95), f(results.rgb.max)),
        "–".into(),
        format!("{:.2}", results.rgb_relight_ns_per_pixel),
        "–".into(),
    ]);
    let mut out = format!(
        "Spectral factor model on 24 ColorChecker × {{D65, A, F2, F7, F11, LED_B3, D50}} (168 pairs); \
         ΔE00 against full 31-sample colour; relighting timed on {} pixels per frame (fastest frame).\n\n",
        results.pixels
    );
    out.push_str(&markdown_table(
        &["m", "ΔE00 refined B (mean / p95 / max)", "ΔE00 refined T only", "relight ns/pixel-frame", "training"],
        &rows,
    ));
    out
}

/// Draw the error plot (ΔE00 against m) and the cost plot (ns per pixel-frame against m).
pub(crate) fn plots(results: &Results, dir: &Path) -> Result<Vec<PathBuf>, BenchError> {
    let dims = |f: &dyn Fn(&Row) -> f64| -> Vec<(f64, f64)> {
        results.rows.iter().map(|r| (r.dimension as f64, f(r))).collect()
    };
    let series =
        |label: &str, points: Vec<(f64, f64)>| Series { label: label.into(), points, line: true, ..Series::default() };
    let first = results.rows.first().map_or(3.0, |r| r.dimension as f64);
    let last = results.rows.last().map_or(12.0, |r| r.dimension as f64);
    let error = XyPlot {
        title: "factor-model error against dimension".into(),
        x_label: "basis dimension m".into(),
        y_label: "ΔE00 (ColorChecker × 7 lights)".into(),
        x_scale: Scale::Linear,
        y_scale: Scale::Log,
        series: vec![
            series("refined B, mean", dims(&|r| r.full.mean)),
            series("refined B, p95", dims(&|r| r.full.p95)),
            series("refined T only, mean", dims(&|r| r.transform_only.mean)),
            series("refined T only, p95", dims(&|r| r.transform_only.p95)),
            series(
                "RGB factor model, mean (one value; no m, drawn across)",
                vec![(first, results.rgb.mean), (last, results.rgb.mean)],
            ),
        ],
        ..XyPlot::default()
    };
    // Nanoseconds per pixel of one timed frame.
    let per_pixel = 1e9 / results.pixels.max(1) as f64;
    let frames = results.rows.first().map_or(0, |r| r.relight.runs);
    let cost = XyPlot {
        title: "relighting cost against dimension".into(),
        x_label: "basis dimension m".into(),
        y_label: "ns per pixel-frame".into(),
        x_scale: Scale::Linear,
        y_scale: Scale::Linear,
        series: vec![
            Series {
                label: format!("median of {frames} frames (bars: interquartile range)"),
                points: dims(&|r| r.relight.median * per_pixel),
                y_spread: Some(
                    results.rows.iter().map(|r| (r.relight.q1 * per_pixel, r.relight.q3 * per_pixel)).collect(),
                ),
                line: true,
                ..Series::default()
            },
            series("fastest frame (the table's figure)", dims(&|r| r.relight_ns_per_pixel)),
        ],
        notes: vec![format!(
            "Timed: relighting one frame of {} pixels on one thread, each pixel's colour from its m \
             coefficients under the light (m products, then the 3×m matrix Q_rgb,m), f32.",
            results.pixels
        )],
        ..XyPlot::default()
    };
    let mut written = Vec::new();
    for (plot, name) in [(error, "basis_error.png"), (cost, "basis_cost.png")] {
        let path = dir.join(name);
        plot::draw(&plot, &path, 900, 520)?;
        written.push(path);
    }
    Ok(written)
}

/// Run, write `basis.md` and the two plots into `dir`, and return the Markdown.
#[cfg(test)]
pub(crate) fn run_and_write(options: &BenchOptions, dir: &Path) -> Result<String, BenchError> {
    let results = run(options)?;
    let md = markdown(&results);
    let path = dir.join("basis.md");
    crate::bench::write_own(&path, md.as_bytes()).map_err(BenchError::File)?;
    plots(&results, dir)?;
    Ok(md)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relight_kernel_matches_the_factor_model() {
        let c = Colorimetry::default();
        let set = TrainingSet::colorchecker_seven_lights(&c);
        let opts =
            TrainOptions { sharpen: true, transform_iterations: 30, full_iterations: 0, ..TrainOptions::default() };
        let basis = basis::train(&set, 5, &c, &opts).unwrap().basis;
        let e = &set.lights[2];
        let coefficients: Vec<f32> = set
            .reflectances
            .iter()
            .flat_map(|s| basis.coefficients(s).iter().map(|v| *v as f32).collect::<Vec<_>>())
            .collect();
        let light: Vec<f32> = basis.coefficients(e).iter().map(|v| *v as f32).collect();
        let mut out = vec![0.0f32; set.reflectances.len() * 3];
        relight(&coefficients, &light, &q_of(&basis), &mut out);
        for (s, o) in set.reflectances.iter().zip(out.chunks_exact(3)) {
            let want = basis.rgb_factor(e, s);
            for k in 0..3 {
                // f32 arithmetic on values of order 1: 1e-5 absolute.
                assert!((f64::from(o[k]) - want[k]).abs() < 1e-5, "{} vs {}", o[k], want[k]);
            }
        }
    }

    #[test]
    fn a_small_run_writes_table_and_plots() {
        let dir = tempfile::tempdir().unwrap();
        let options = BenchOptions {
            dimensions: 3..=4,
            pixels: 1000,
            runs: 2,
            training: TrainOptions {
                sharpen: true,
                transform_iterations: 20,
                full_iterations: 20,
                ..TrainOptions::default()
            },
        };
        let md = run_and_write(&options, dir.path()).unwrap();
        assert!(md.contains("| 3 |") && md.contains("| 4 |") && md.contains("RGB factor model"), "{md}");
        for f in ["basis.md", "basis_error.png", "basis_cost.png"] {
            assert!(dir.path().join(f).metadata().unwrap().len() > 100, "{f}");
        }
    }
}
