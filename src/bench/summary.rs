//! Cross-suite views of the benchmark results that `metamer bench` adds on top of the per-area suites
//! ([`super::solve`], [`super::basis`], [`super::render`]): run time against error with the Pareto front
//! marked and the timing spread drawn, ratios against in-process baselines (blocks vs one dense system,
//! bounded vs unbounded, factor model vs full 31-sample vs RGB), and the condition numbers of the design
//! systems the solver meets.
//!
//! Ratios are taken between measurements made in the same process a moment apart, so they hold on a noisy
//! shared machine better than the absolute times do.

use super::plot::{self, PlotError, Scale, Series, XyPlot};
use super::render::RenderBenchReport;
use super::{basis, format_seconds, markdown_table, pareto_front, solve};
use crate::colorimetry::Colorimetry;
use crate::design::{Design, Layout};
use crate::palette::{Bounds, Palette};
use crate::render::Mode;
use metamer_core::palette::random;
use std::path::Path;

/// The workload of a solver row: its case (the same case, e.g. "20 designs", is the same work for every
/// solver path) and the error measure (the capacity rows' sRGB-white ΔE*ab is another measure of the same
/// solves, so it is never compared with the light-white one).
fn solve_workload(r: &solve::Row) -> String {
    let white = if r.group.contains(solve::CAPACITY_DISPLAY_WHITE) {
        solve::CAPACITY_DISPLAY_WHITE
    } else {
        solve::CAPACITY_LIGHT_WHITE
    };
    format!("{}, ΔE*ab vs {white}", r.case)
}

/// Run time against mean ΔE*ab for every solver path: one series per path (points not joined: a path's
/// points are different workloads), the interquartile range of the time as bars, and the Pareto front of
/// each workload.
pub(crate) fn solve_tradeoff(report: &solve::Report) -> XyPlot {
    let mut groups: Vec<&str> = Vec::new();
    for r in &report.rows {
        if !groups.contains(&r.group.as_str()) {
            groups.push(&r.group);
        }
    }
    let series = groups
        .iter()
        .map(|g| {
            let rows: Vec<&solve::Row> = report.rows.iter().filter(|r| r.group == *g).collect();
            Series {
                label: (*g).to_string(),
                points: rows.iter().map(|r| (r.timing.median, r.mean_delta_e_ab)).collect(),
                spread: Some(rows.iter().map(|r| (r.timing.q1, r.timing.q3)).collect()),
                point_workloads: rows.iter().map(|r| solve_workload(r)).collect(),
                ..Series::default()
            }
        })
        .collect();
    XyPlot {
        title: "metamer solve: run time against colour error (bars: IQR)".into(),
        x_label: "run time per solve, median (s)".into(),
        y_label: "mean CIELAB ΔE*ab".into(),
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series,
        pareto: true,
        notes: vec![
            "A workload is one case (batch size or n×n) with one error measure; the points of a path are \
             not joined, as they are different work."
                .into(),
        ],
        ..XyPlot::default()
    }
}

/// Draw [`solve_tradeoff`].
pub(crate) fn solve_tradeoff_plot(report: &solve::Report, path: &Path) -> Result<(), PlotError> {
    plot::draw(&solve_tradeoff(report), path, 1000, 700)
}

/// The Pareto front of each workload that two or more solver paths measured with a finite error, as
/// "workload: path, path" (sorted by time), from the same fronts the plot marks.
pub(crate) fn solve_pareto_cases(report: &solve::Report) -> Vec<String> {
    let plot = solve_tradeoff(report);
    plot::workload_fronts(&plot)
        .into_iter()
        .map(|(w, front)| {
            let paths: Vec<&str> = front.iter().map(|(i, _)| plot.series[*i].label.as_str()).collect();
            format!("{w}: {}", paths.join(", "))
        })
        .collect()
}

/// One ratio against an in-process baseline.
#[derive(Clone, Debug)]
pub(crate) struct Ratio {
    pub(crate) what: String,
    pub(crate) measured: String,
    pub(crate) baseline: String,
    /// baseline time ÷ measured time (> 1: faster than the baseline).
    pub(crate) speedup: f64,
    /// Relative objective gap `(f − f_baseline) / max(|f_baseline|, tiny)`, when objectives are comparable.
    pub(crate) objective_gap: Option<f64>,
}

/// Ratios from the solver suite: blocks against one dense system (same palette), bounded against unbounded
/// (same batch).
pub(crate) fn solve_ratios(report: &solve::Report) -> Vec<Ratio> {
    let find = |group: &str, case: &str| report.rows.iter().find(|r| r.group == group && r.case == case);
    let mut out = Vec::new();
    // (baseline group, measured group, label, whether the objectives are comparable)
    let pairs = [
        ("bounded, one dense system", "bounded, blocks", "blocks vs one dense system", true),
        ("unbounded, blocks", "bounded [0,1], blocks", "bounded [0,1] vs unbounded", false),
    ];
    for (baseline, measured, label, comparable) in pairs {
        for r in report.rows.iter().filter(|r| r.group == baseline) {
            if let Some(b) = find(measured, &r.case) {
                out.push(Ratio {
                    what: format!("{label}, {}", r.case),
                    measured: b.timing.display(),
                    baseline: r.timing.display(),
                    speedup: r.timing.median / b.timing.median.max(1e-12),
                    objective_gap: comparable.then(|| (b.objective - r.objective) / r.objective.abs().max(1e-300)),
                });
            }
        }
    }
    out
}

/// Ratios from the renderer suite at the sweep size: relighting time of the factor and RGB models against
/// the full 31-sample model (with their ΔE00 against the full frames).
pub(crate) fn render_ratios(report: &RenderBenchReport) -> Vec<Ratio> {
    let at = |mode: Mode| report.relight.iter().find(|r| r.mode == mode && r.size == report.sweep_size);
    let Some(full) = at(Mode::Full) else { return Vec::new() };
    let mut out = Vec::new();
    for (mode, err) in [(Mode::Factor, report.accuracy.factor.mean), (Mode::Rgb, report.accuracy.rgb.mean)] {
        if let Some(r) = at(mode) {
            out.push(Ratio {
                what: format!(
                    "relight {0}×{0}: {1} model (K = {2}, mean ΔE00 {err:.3}) vs full 31-sample",
                    r.size,
                    mode.as_str(),
                    r.channels
                ),
                measured: format_seconds(r.median_s),
                baseline: format_seconds(full.median_s),
                speedup: full.median_s / r.median_s.max(1e-12),
                objective_gap: None,
            });
        }
    }
    out
}

/// Markdown table of ratios.
pub(crate) fn ratios_markdown(ratios: &[Ratio]) -> String {
    let rows: Vec<Vec<String>> = ratios
        .iter()
        .map(|r| {
            vec![
                r.what.clone(),
                r.measured.clone(),
                r.baseline.clone(),
                format!("{:.2}×", r.speedup),
                r.objective_gap.map_or("–".into(), |g| format!("{g:.1e}")),
            ]
        })
        .collect();
    markdown_table(&["comparison", "measured (median, IQR)", "baseline", "speed-up", "objective gap"], &rows)
}

/// The one workload of the basis plot.
const BASIS_WORKLOAD: &str = "ColorChecker × 7 lights";

/// Relighting cost against factor-model error for each basis dimension and the RGB model, Pareto front
/// marked (what a renderer pays per pixel-frame for each ΔE00): one series per model, each its own colour
/// and marker.
pub(crate) fn basis_tradeoff_plot(results: &basis::Results, path: &Path) -> Result<(), PlotError> {
    let mut series: Vec<Series> = results
        .rows
        .iter()
        .map(|r| Series {
            label: format!("m = {}", r.dimension),
            points: vec![(r.relight_ns_per_pixel, r.full.mean)],
            workload: Some(BASIS_WORKLOAD.into()),
            ..Series::default()
        })
        .collect();
    series.push(Series {
        label: "RGB factor model".into(),
        points: vec![(results.rgb_relight_ns_per_pixel, results.rgb.mean)],
        workload: Some(BASIS_WORKLOAD.into()),
        ..Series::default()
    });
    plot::draw(
        &XyPlot {
            title: "factor model: relighting cost against error".into(),
            x_label: "relight ns per pixel-frame (fastest frame)".into(),
            y_label: "mean ΔE00 vs full 31-sample (ColorChecker × 7 lights)".into(),
            x_scale: Scale::Linear,
            y_scale: Scale::Log,
            series,
            pareto: true,
            ..XyPlot::default()
        },
        path,
        900,
        600,
    )
}

/// The basis dimensions on the Pareto front of (relight cost, mean ΔE00), "RGB" for the RGB model.
pub(crate) fn basis_pareto_dimensions(results: &basis::Results) -> Vec<String> {
    let mut pts: Vec<(f64, f64)> = results.rows.iter().map(|r| (r.relight_ns_per_pixel, r.full.mean)).collect();
    pts.push((results.rgb_relight_ns_per_pixel, results.rgb.mean));
    pareto_front(&pts)
        .into_iter()
        .map(|i| results.rows.get(i).map_or("RGB".to_string(), |r| format!("m = {}", r.dimension)))
        .collect()
}

/// Relighting time per frame against mean ΔE00 of the factor and RGB models, one workload per image
/// size, Pareto front marked. The full 31-sample model is the reference (ΔE00 = 0 by definition, no
/// point on a log axis): its time is a dashed line, never a point at a made-up error.
pub(crate) fn render_tradeoff_plot(report: &RenderBenchReport, path: &Path) -> Result<(), PlotError> {
    let err = |mode: Mode| match mode {
        Mode::Factor => Some(report.accuracy.factor.mean),
        Mode::Rgb => Some(report.accuracy.rgb.mean),
        Mode::Full => None,
    };
    let mut sizes: Vec<usize> = report.relight.iter().map(|r| r.size).collect();
    sizes.dedup();
    let mut series = Vec::new();
    let mut x_refs = Vec::new();
    for size in &sizes {
        for r in report.relight.iter().filter(|r| r.size == *size) {
            match err(r.mode) {
                Some(e) => series.push(Series {
                    label: format!("{} (K = {}), {}²", r.mode.as_str(), r.channels, r.size),
                    points: vec![(r.median_s * 1e3, e)],
                    workload: Some(format!("{size}²")),
                    ..Series::default()
                }),
                None => {
                    x_refs.push((r.median_s * 1e3, format!("full (K = {}), {}²: the reference", r.channels, r.size)))
                }
            }
        }
    }
    plot::draw(
        &XyPlot {
            title: "render modes: relight time against ΔE00".into(),
            x_label: "relight time per frame, one thread (ms)".into(),
            y_label: "mean ΔE00 vs full 31-sample frames".into(),
            x_scale: Scale::Log,
            y_scale: Scale::Log,
            series,
            pareto: true,
            x_refs,
            notes: vec![
                "The full 31-sample model is the reference (ΔE00 = 0 by definition): dashed at its time, \
                 no point."
                    .into(),
                "One workload per frame size.".into(),
            ],
            y_from_zero: false,
        },
        path,
        900,
        600,
    )
}

/// Condition numbers of the linear design systems of one palette.
#[derive(Clone, Debug)]
pub(crate) struct ConditionRow {
    pub(crate) palette: String,
    /// Linear blocks measured (bilinear blocks are measured with their lights held at the start values).
    pub(crate) blocks: usize,
    /// Largest `σ_max / σ_min` over the blocks (σ_min: the smallest singular value above
    /// `σ_max · n · ε`; rank-deficient directions are what the minimum-norm SVD solve drops).
    pub(crate) condition: f64,
    /// Largest number of numerically zero singular values in a block.
    pub(crate) rank_deficiency: usize,
    /// Smallest and largest row weight (ω/√3) seen.
    pub(crate) weight_range: (f64, f64),
}

/// `σ_max / σ_min` (above the relative cut-off `n · ε`) and the count of singular values below it.
pub fn condition_number(a: &nalgebra::DMatrix<f64>) -> (f64, usize) {
    if a.nrows() == 0 || a.ncols() == 0 {
        return (1.0, 0);
    }
    let sv = a.clone().svd(false, false).singular_values;
    let max = sv.iter().copied().fold(0.0, f64::max);
    if max <= 0.0 || !max.is_finite() {
        return (f64::INFINITY, a.ncols());
    }
    let cut = max * a.nrows().max(a.ncols()) as f64 * f64::EPSILON;
    let kept: Vec<f64> = sv.iter().copied().filter(|s| *s > cut).collect();
    let min = kept.iter().copied().fold(f64::INFINITY, f64::min);
    // Under-determined blocks (fewer rows than unknowns) have ncols − rank null directions too.
    (max / min, a.ncols() - kept.len())
}

/// Condition numbers of every block of a palette's design (bilinear blocks: the reflectance subproblem with
/// the lights at their start values, which is what the alternating start solves).
pub(crate) fn palette_conditions(name: &str, palette: &Palette) -> Option<ConditionRow> {
    let col = Colorimetry::default();
    let design = Design::new(palette, None, &col).ok()?;
    let v = design.start_values();
    let mut row = ConditionRow {
        palette: name.into(),
        blocks: 0,
        condition: 1.0,
        rank_deficiency: 0,
        weight_range: (f64::INFINITY, 0.0),
    };
    for t in &design.terms {
        row.weight_range = (row.weight_range.0.min(t.scale), row.weight_range.1.max(t.scale));
    }
    for block in design.blocks() {
        let units: Vec<_> = if block.bilinear {
            block.units.iter().copied().filter(|u| !matches!(u, crate::design::Unit::Light(_))).collect()
        } else {
            block.units.clone()
        };
        let layout = Layout::new(&units);
        let sys = design.linear_system(&layout, &block.terms, &v);
        let (c, d) = condition_number(&sys.a);
        row.blocks += 1;
        row.condition = row.condition.max(c);
        row.rank_deficiency = row.rank_deficiency.max(d);
    }
    Some(row)
}

/// The palettes whose conditioning the report shows: the benchmark's batch design, random convex palettes,
/// weights across 16 decades, near-identical lights, a spiky light, and the joint capacity palettes
/// (5×5, 10×10, 15×15; only 5×5 when `quick`).
pub(crate) fn condition_survey(quick: bool) -> Vec<ConditionRow> {
    let col = Colorimetry::default();
    let mut out = Vec::new();
    out.extend(palette_conditions("batch: 1 design, 3 lights, [0,1]", &random::batch_palette(1, 0, &col)));
    let worst_convex = (0..20)
        .filter_map(|s| palette_conditions("", &random::convex_palette(s, &col)))
        .max_by(|a, b| a.condition.total_cmp(&b.condition));
    if let Some(mut r) = worst_convex {
        r.palette = "random convex palettes (worst of 20)".into();
        out.push(r);
    }
    let mut wide = random::batch_palette(1, 1, &col);
    for (c, w) in wide.colours.iter_mut().zip([1e-8, 1.0, 1e8]) {
        c.weight = w;
    }
    out.extend(palette_conditions("weights 1e-8, 1, 1e8", &wide));
    let mut near = random::batch_palette(1, 2, &col);
    let d65 = near.lights[0].spectrum;
    for (k, l) in near.lights.iter_mut().enumerate() {
        l.spectrum = d65.scaled(1.0 + 1e-9 * k as f64);
    }
    out.extend(palette_conditions("near-identical lights (D65 × (1 + 1e-9 k))", &near));
    let mut spiky = random::batch_palette(1, 3, &col);
    spiky.settings.reflectance_bounds = Bounds::UNBOUNDED;
    spiky.settings.smoothness = 0.0;
    let mut spike = [0.0; crate::spectrum::SAMPLES];
    spike[15] = 1.0;
    for l in spiky.lights.iter_mut() {
        l.spectrum = crate::spectrum::Spectrum::from_array(spike);
    }
    out.extend(palette_conditions("one-sample spike lights, no smoothness", &spiky));
    let sizes: &[usize] = if quick { &[5] } else { &[5, 10, 15] };
    for &n in sizes {
        out.extend(palette_conditions(
            &format!("joint {n}×{n} (reflectance step)"),
            &random::capacity_palette(n, 0, &col),
        ));
    }
    out
}

/// Markdown table of condition numbers.
pub(crate) fn conditions_markdown(rows: &[ConditionRow]) -> String {
    let body: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.palette.clone(),
                r.blocks.to_string(),
                format!("{:.2e}", r.condition),
                r.rank_deficiency.to_string(),
                format!("{:.1e} … {:.1e}", r.weight_range.0, r.weight_range.1),
            ]
        })
        .collect();
    markdown_table(&["palette", "blocks", "max cond(A)", "null directions", "row weights ω/√3"], &body)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(group: &str, case: &str, time: f64, error: f64) -> solve::Row {
        let timing = crate::bench::Timing::from_samples(&[time]).unwrap();
        solve::Row {
            group: group.into(),
            case: case.into(),
            designs: 1,
            timing,
            per_design: time,
            mean_delta_e_ab: error,
            worst_delta_e_ab: None,
            mean_delta_e00: error,
            objective: 1.0,
        }
    }

    #[test]
    fn solver_fronts_never_mix_workloads_or_use_na_errors() {
        let report = solve::Report {
            rows: vec![
                row("fast", "10 designs", 1e-4, 0.001),
                row("slow", "10 designs", 1e-3, 3.0),
                row("dense", "5 designs", 1e-5, f64::NAN),
                row("slow", "5 designs", 2e-3, 2.0),
                row("slower", "5 designs", 3e-3, 1.0),
                row("joint", "3×3", 1e-6, 1e-6),
            ],
            versus_scipy: Vec::new(),
        };
        let fronts = solve_pareto_cases(&report);
        // Over all points "joint 3×3" would dominate everything; per workload it has no rival, and the
        // n/a dense row takes no part.
        assert_eq!(
            fronts,
            vec![
                "10 designs, ΔE*ab vs each light's white: fast".to_string(),
                "5 designs, ΔE*ab vs each light's white: slow, slower".to_string(),
            ]
        );
    }

    #[test]
    fn condition_number_of_known_matrices() {
        let a = nalgebra::DMatrix::from_row_slice(2, 2, &[2.0, 0.0, 0.0, 0.5]);
        let (c, d) = condition_number(&a);
        assert!((c - 4.0).abs() < 1e-12 && d == 0);
        let singular = nalgebra::DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert_eq!(condition_number(&singular).1, 1);
        // 3 rows, 31 unknowns: 28 null directions.
        let wide = nalgebra::DMatrix::from_fn(3, 31, |i, j| 1.0 / (i + j + 1) as f64);
        assert_eq!(condition_number(&wide).1, 28);
    }

    #[test]
    fn survey_sees_wide_weights_as_worse_conditioned() {
        let col = Colorimetry::default();
        let plain = palette_conditions("plain", &random::batch_palette(1, 1, &col)).unwrap();
        let mut wide = random::batch_palette(1, 1, &col);
        for (c, w) in wide.colours.iter_mut().zip([1e-8, 1.0, 1e8]) {
            c.weight = w;
        }
        let wide = palette_conditions("wide", &wide).unwrap();
        assert!(wide.condition > 1e6 * plain.condition, "{} vs {}", wide.condition, plain.condition);
        assert!(plain.condition.is_finite() && plain.condition >= 1.0);
    }
}
