//! Solver benchmarks: run time against error for single bounded designs, batches of independent
//! designs, n×n joint palettes (TOG 2009 Fig. 3 capacity protocol), bounded vs unbounded, and blocks vs
//! one dense system. Printed as a Markdown table and drawn as a PNG plot (time vs error). Full runs also
//! time the whole `metamer solve` process on a 1200-design batch file against scipy's BVLS solving the
//! same designs one by one (benches/scipy_bvls.py), when python3 with scipy is there, on two workloads: random
//! targets (most designs press on the bounds, many cannot be met) and reachable targets.
//!
//! The error of a palette is the mean over its cells of the CIELAB ΔE*ab (and CIEDE2000) between the
//! target and the achieved full colour, against the white of the cell's light (DESIGN_SPEC §1); the
//! capacity rows give ΔE*ab both that way and against the fixed white of linear sRGB
//! ([`capacity_errors`]), as mean and worst over seeds.

use super::plot::{self, Scale, Series, XyPlot};
use super::{Timing, fixed, format_seconds, markdown_table, time_runs};
use crate::colorimetry::{Colorimetry, xyz_to_lab};
use crate::design::{self, Solution, SolveOptions};
use crate::palette::{Bounds, Palette};
use metamer_core::palette::random;
use std::path::Path;
use std::time::Duration;

/// What to run.
#[derive(Clone, Debug)]
pub struct Config {
    /// Repetitions per timed case (medians are reported).
    pub runs: usize,
    /// Batch sizes (independent bounded single-reflectance designs under 3 lights).
    pub(crate) batches: Vec<usize>,
    /// Joint palette sizes n (n lights × n reflectances, all designed).
    pub(crate) joint_sizes: Vec<usize>,
    /// Seeds per joint size (errors and times are averaged over them).
    pub(crate) joint_seeds: u64,
    /// Time cap per joint solve.
    pub(crate) time_limit: Duration,
    /// Designs in the batch file the whole process is timed on against scipy (`None`: not measured).
    pub(crate) versus_scipy: Option<usize>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            runs: 5,
            batches: vec![1, 10, 100, 1200],
            joint_sizes: (3..=15).collect(),
            joint_seeds: 8,
            time_limit: Duration::from_secs(10),
            versus_scipy: Some(1200),
        }
    }
}

impl Config {
    /// A quick configuration (for smoke tests of the benchmark code itself).
    pub(crate) fn quick() -> Config {
        Config {
            runs: 1,
            batches: vec![1, 10],
            joint_sizes: vec![3, 4],
            joint_seeds: 1,
            time_limit: Duration::from_secs(5),
            versus_scipy: None,
        }
    }
}

/// One measured case.
#[derive(Clone, Debug)]
pub struct Row {
    pub group: String,
    pub(crate) case: String,
    /// Designs (spectra solved) in the case.
    pub(crate) designs: usize,
    pub(crate) timing: Timing,
    /// Median time per designed spectrum.
    pub(crate) per_design: f64,
    pub(crate) mean_delta_e_ab: f64,
    /// Capacity rows: the worst over seeds of the per-palette mean ΔE*ab (`mean_delta_e_ab` is then the
    /// mean over seeds).
    pub(crate) worst_delta_e_ab: Option<f64>,
    pub(crate) mean_delta_e00: f64,
    pub(crate) objective: f64,
}

/// The whole `metamer solve` process against scipy's BVLS, or why it was not measured.
#[derive(Clone, Debug, PartialEq)]
pub enum VersusScipy {
    Measured {
        /// Which targets: "random targets" ([`random::batch_palette`]) or "reachable targets"
        /// ([`random::reachable_batch_palette`]).
        workload: &'static str,
        designs: usize,
        /// Alternated rounds timed (each one scipy pass, then metamer's processes); the figures below are
        /// their medians.
        rounds: usize,
        /// scipy's BVLS over all designs, one by one.
        scipy_seconds: f64,
        /// `metamer solve IN -o OUT --report R.json` as one process (the table to /dev/null).
        process_seconds: f64,
        /// The same with `--quiet --no-subspace`.
        process_quiet_seconds: f64,
        /// The solve alone (inside the process).
        solve_seconds: f64,
        /// The rounds' own ratios (scipy's pass over metamer's process): median, least, greatest.
        round_ratios: [f64; 3],
        /// (metamer − scipy) / scipy of the summed objective.
        relative_difference: f64,
    },
    Skipped(String),
}

/// The whole `metamer solve` process should take at most 1/20 of scipy's time on the batch (issue 27).
const PROCESS_AIM: f64 = 20.0;
/// The solve alone (the report's `solve_seconds`) per design, seconds (issue 27).
const PER_DESIGN_AIM: f64 = 5e-6;

/// `met` or `not met` (a figure that is not a number meets no aim).
fn met(ok: bool) -> &'static str {
    if ok { "met" } else { "not met" }
}

impl VersusScipy {
    /// One Markdown paragraph.
    pub(crate) fn markdown(&self) -> String {
        match self {
            VersusScipy::Measured {
                workload,
                designs,
                rounds,
                scipy_seconds,
                process_seconds,
                process_quiet_seconds,
                solve_seconds,
                round_ratios: [ratio_median, ratio_min, ratio_max],
                relative_difference,
            } => format!(
                "Whole process against scipy, {workload} ({designs} bounded single-reflectance designs, 3 lights \
                 each, one file; medians of {rounds} alternated rounds): `metamer solve IN -o OUT --report R.json` {} \
                 ({} with `--quiet --no-subspace`; solve alone {}), scipy BVLS one by one {} ({} per design): \
                 **{:.1}× faster** as a process (the rounds' own ratios: median {:.1}×, {:.1}–{:.1}×). Objective \
                 (metamer − scipy) / scipy = {:.1e}. Aims (issue 27): the process ≥ {PROCESS_AIM}× faster than scipy, {}; \
                 the solve alone ≤ {} per design, {} ({} per design). Where the process's time goes: \
                 [docs/solve_performance.md](../solve_performance.md). Rerun: `python3 benches/scipy_bvls.py FILE`.\n",
                format_seconds(*process_seconds),
                format_seconds(*process_quiet_seconds),
                format_seconds(*solve_seconds),
                format_seconds(*scipy_seconds),
                format_seconds(scipy_seconds / *designs as f64),
                scipy_seconds / process_seconds,
                ratio_median,
                ratio_min,
                ratio_max,
                relative_difference,
                met(scipy_seconds / process_seconds >= PROCESS_AIM),
                format_seconds(PER_DESIGN_AIM),
                met(solve_seconds / *designs as f64 <= PER_DESIGN_AIM),
                format_seconds(solve_seconds / *designs as f64),
            ),
            VersusScipy::Skipped(why) => format!("Whole process against scipy: skipped ({why}).\n"),
        }
    }
}

/// All results.
#[derive(Clone, Debug, Default)]
pub struct Report {
    pub rows: Vec<Row>,
    /// The whole-process comparisons, one per workload (none when the configuration does not ask for them).
    pub versus_scipy: Vec<VersusScipy>,
}

impl Report {
    /// The Markdown table, then the whole-process comparison when there is one.
    pub fn markdown(&self) -> String {
        let mut text = self.table();
        for v in &self.versus_scipy {
            text.push('\n');
            text.push_str(&v.markdown());
        }
        text
    }

    /// The Markdown table.
    pub(crate) fn table(&self) -> String {
        let rows: Vec<Vec<String>> = self
            .rows
            .iter()
            .map(|r| {
                vec![
                    r.group.clone(),
                    r.case.clone(),
                    r.designs.to_string(),
                    r.timing.display(),
                    format_seconds(r.per_design),
                    match r.worst_delta_e_ab {
                        Some(w) => format!("{} (worst {})", fixed(r.mean_delta_e_ab, 3), fixed(w, 3)),
                        None => fixed(r.mean_delta_e_ab, 3),
                    },
                    fixed(r.mean_delta_e00, 3),
                    if r.objective.is_finite() { format!("{:.4e}", r.objective) } else { "n/a".into() },
                ]
            })
            .collect();
        markdown_table(
            &["group", "case", "designs", "time (median, IQR)", "per design", "mean ΔE*ab", "mean ΔE00", "objective"],
            &rows,
        )
    }

    /// Draw run time against the number of designs solved, one series per solver path (group), its
    /// points joined in order of size: how each path scales. Bars: interquartile range of the run time.
    /// The error of each case is in [`super::summary::solve_tradeoff_plot`].
    pub(crate) fn plot(&self, path: &Path) -> Result<(), plot::PlotError> {
        let mut groups: Vec<String> = Vec::new();
        for r in &self.rows {
            if !groups.contains(&r.group) {
                groups.push(r.group.clone());
            }
        }
        // The two capacity groups are the same solves (one timing, two error measures): drawn once.
        groups.retain(|g| !g.contains(CAPACITY_DISPLAY_WHITE));
        let series = groups
            .iter()
            .map(|g| {
                let mut rows: Vec<&Row> = self.rows.iter().filter(|r| &r.group == g).collect();
                rows.sort_by_key(|r| r.designs);
                let label = if g.contains(CAPACITY_LIGHT_WHITE) {
                    g.replace(&format!(", ΔE*ab vs {CAPACITY_LIGHT_WHITE}"), "")
                } else {
                    g.clone()
                };
                Series {
                    label,
                    points: rows.iter().map(|r| (r.designs as f64, r.timing.median)).collect(),
                    y_spread: Some(rows.iter().map(|r| (r.timing.q1, r.timing.q3)).collect()),
                    line: true,
                    ..Series::default()
                }
            })
            .collect();
        let p = XyPlot {
            title: "metamer solve: run time against designs solved (bars: IQR)".into(),
            x_label: "designed spectra in the solve".into(),
            y_label: "run time per solve, median (s)".into(),
            x_scale: Scale::Log,
            y_scale: Scale::Log,
            series,
            notes: vec!["Joint n×n: 2n spectra designed together (n lights, n reflectances).".into()],
            ..XyPlot::default()
        };
        plot::draw(&p, path, 1000, 700)
    }
}

/// Mean ΔE*ab and ΔE00 over the active cells of a solution.
pub(crate) fn mean_errors(palette: &Palette, sol: &Solution, colorimetry: &Colorimetry) -> (f64, f64) {
    let (mut ab, mut e00, mut n) = (0.0, 0.0, 0usize);
    for c in &sol.cells {
        let cell = &palette.colours[c.cell];
        if !cell.is_active() {
            continue;
        }
        let light = &sol.palette.lights[cell.light].spectrum;
        let a = colorimetry.lab_under(&c.target, light);
        let b = colorimetry.lab_under(&c.rgb_full, light);
        ab += ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        e00 += c.delta_e_full;
        n += 1;
    }
    let n = n.max(1) as f64;
    (ab / n, e00 / n)
}

/// The capacity error of a solution: the mean over its active cells of CIELAB ΔE*ab between target and
/// achieved full colour, (1) against the fixed white of linear sRGB (D65, `rgb = (1, 1, 1)`, Y = 1: linear
/// sRGB → XYZ → CIELAB, independent of the solution) and (2) against the white of the cell's solved light
/// (DESIGN_SPEC §1). Both are reported: the second is the contract's CIELAB, but it moves with the scale
/// the solve gives the lights (the gauge `E·α, S/α` leaves every colour unchanged but makes every colour
/// darker relative to the light's white; smoothness fixes that scale), the first does not.
pub fn capacity_errors(palette: &Palette, sol: &Solution, colorimetry: &Colorimetry) -> (f64, f64) {
    let white = colorimetry.rgb_to_xyz(&nalgebra::Vector3::new(1.0, 1.0, 1.0));
    let dist =
        |a: [f64; 3], b: [f64; 3]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    let (mut fixed, mut under, mut n) = (0.0, 0.0, 0usize);
    for c in &sol.cells {
        let cell = &palette.colours[c.cell];
        if !cell.is_active() {
            continue;
        }
        let lab = |rgb| xyz_to_lab(&colorimetry.rgb_to_xyz(rgb), &white);
        fixed += dist(lab(&c.target), lab(&c.rgb_full));
        let light = &sol.palette.lights[cell.light].spectrum;
        under += dist(colorimetry.lab_under(&c.target, light), colorimetry.lab_under(&c.rgb_full, light));
        n += 1;
    }
    let n = n.max(1) as f64;
    (fixed / n, under / n)
}

fn unbounded(mut p: Palette) -> Palette {
    p.settings.reflectance_bounds = Bounds::UNBOUNDED;
    p.settings.light_bounds = Bounds::UNBOUNDED;
    p
}

fn measure(
    group: &str,
    case: String,
    palette: &Palette,
    designs: usize,
    runs: usize,
    options: &SolveOptions,
    parallel: bool,
) -> Option<Row> {
    let col = Colorimetry::default();
    let (timing, sol) = time_runs(runs, || design::solve_with(palette, None, &col, options, parallel));
    let sol = sol.ok()?;
    let (ab, e00) = mean_errors(palette, &sol, &col);
    Some(Row {
        group: group.into(),
        case,
        designs,
        timing,
        per_design: timing.median / designs.max(1) as f64,
        mean_delta_e_ab: ab,
        worst_delta_e_ab: None,
        mean_delta_e00: e00,
        objective: sol.objective,
    })
}

/// Batches of independent bounded designs (and the same unbounded).
pub(crate) fn batches(cfg: &Config) -> Vec<Row> {
    let col = Colorimetry::default();
    let options = SolveOptions::default();
    let mut rows = Vec::new();
    for &n in &cfg.batches {
        let p = random::batch_palette(n, 1, &col);
        let runs = if n >= 1000 { cfg.runs.max(3) } else { cfg.runs * 4 };
        rows.extend(measure("bounded [0,1], blocks", format!("{n} designs"), &p, n, runs, &options, true));
        rows.extend(measure("unbounded, blocks", format!("{n} designs"), &unbounded(p), n, runs, &options, true));
    }
    rows
}

/// Blocks (parallel, shared factorisations) against one dense stacked system, for modest batches.
pub(crate) fn blocks_vs_dense(cfg: &Config) -> Vec<Row> {
    let col = Colorimetry::default();
    let mut rows = Vec::new();
    for n in [5usize, 20] {
        let p = random::batch_palette(n, 2, &col);
        rows.extend(measure(
            "bounded, blocks",
            format!("{n} designs"),
            &p,
            n,
            cfg.runs,
            &SolveOptions::default(),
            true,
        ));
        let design = match design::Design::new(&p, None, &col) {
            Ok(d) => d,
            Err(_) => continue,
        };
        let start = design.start_values();
        let (timing, out) = time_runs(cfg.runs, || design::solve_dense(&design, &start));
        if let Some((v, _)) = out {
            rows.push(Row {
                group: "bounded, one dense system".into(),
                case: format!("{n} designs"),
                designs: n,
                timing,
                per_design: timing.median / n as f64,
                mean_delta_e_ab: f64::NAN,
                worst_delta_e_ab: None,
                mean_delta_e00: f64::NAN,
                objective: design.objective(&v),
            });
        }
    }
    rows
}

/// Capacity row labels: which CIELAB white the ΔE*ab column uses.
pub(crate) const CAPACITY_LIGHT_WHITE: &str = "each light's white";
pub(crate) const CAPACITY_DISPLAY_WHITE: &str = "sRGB white";

/// The capacity protocol: n×n palettes, everything designed, over `joint_seeds` seeds. Two rows per size
/// from the same solves: ΔE*ab against each solved light's white (DESIGN_SPEC §1, the contract's CIELAB)
/// and against the fixed sRGB white ([`capacity_errors`]; mean over seeds of the per-palette mean, and the
/// worst palette); ΔE00 is the cell reports' (light white); the time is the median over seeds of one solve
/// each.
pub(crate) fn joint(cfg: &Config) -> Vec<Row> {
    let col = Colorimetry::default();
    let options = SolveOptions { time_limit: cfg.time_limit, cancel: None };
    let mut rows = Vec::new();
    for &n in &cfg.joint_sizes {
        let mut times = Vec::new();
        let (mut under, mut fixed, mut e00, mut obj) = (Vec::new(), Vec::new(), 0.0, 0.0);
        for seed in 0..cfg.joint_seeds {
            let p = random::capacity_palette(n, seed, &col);
            let t = std::time::Instant::now();
            let Ok(sol) = design::solve(&p, None, &col, &options) else { continue };
            times.push(t.elapsed().as_secs_f64());
            let (f, u) = capacity_errors(&p, &sol, &col);
            fixed.push(f);
            under.push(u);
            e00 += mean_errors(&p, &sol, &col).1;
            obj += sol.objective;
        }
        let k = times.len().max(1) as f64;
        if let Some(timing) = Timing::from_samples(&times) {
            // The same solves, their ΔE*ab against each light's white (DESIGN_SPEC §1) and against the
            // fixed sRGB display white.
            // ΔE00 is measured against each light's white only, so the display-white row has none (n/a)
            // rather than a copy of the other row's.
            let e00_light = e00 / k;
            for (white, ab, e00) in
                [(CAPACITY_LIGHT_WHITE, &under, e00_light), (CAPACITY_DISPLAY_WHITE, &fixed, f64::NAN)]
            {
                rows.push(Row {
                    group: format!(
                        "joint n×n, positivity ({}, ΔE*ab vs {white})",
                        seeds_text(times.len(), cfg.joint_seeds)
                    ),
                    case: format!("{n}×{n}"),
                    designs: 2 * n,
                    timing,
                    per_design: timing.median / (2 * n) as f64,
                    mean_delta_e_ab: ab.iter().sum::<f64>() / k,
                    worst_delta_e_ab: Some(ab.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
                    mean_delta_e00: e00,
                    objective: obj / k,
                });
            }
        }
    }
    rows
}

/// `8 seeds`, `1 seed`, or `7 of 8 seeds` when some solves failed.
pub(crate) fn seeds_text(solved: usize, asked: u64) -> String {
    let plural = |n: u64| if n == 1 { "seed" } else { "seeds" };
    if solved as u64 == asked {
        format!("{solved} {}", plural(asked))
    } else {
        format!("{solved} of {asked} {}", plural(asked))
    }
}

/// Time the whole `metamer solve` process on a file of `designs` bounded single-reflectance designs against
/// scipy's BVLS solving them one by one (benches/scipy_bvls.py, which also checks the objectives agree).
pub(crate) fn versus_scipy(designs: usize, reachable: bool) -> VersusScipy {
    let skip = |why: String| VersusScipy::Skipped(why);
    // Relative to the working folder (the bench runs from a checkout): no build machine's path is compiled in.
    let script = Path::new("benches").join("scipy_bvls.py");
    if !script.is_file() {
        return skip(format!("{} not found (run the bench from the repository's folder)", script.display()));
    }
    let Some(metamer) = super::metamer_binary() else { return skip("the metamer binary was not found".into()) };
    let Ok(dir) = tempfile::tempdir() else { return skip("no temporary folder".into()) };
    let path = dir.path().join("batch.toml");
    let col = Colorimetry::default();
    let (workload, palette) = if reachable {
        ("reachable targets", random::reachable_batch_palette(designs, 1, &col))
    } else {
        ("random targets", random::batch_palette(designs, 1, &col))
    };
    let mut file = crate::palette::PaletteFile::from_palette(&palette);
    if let Err(e) = file.save_as(&palette, &path) {
        return skip(format!("cannot write the batch file: {e}"));
    }
    let out = std::process::Command::new("python3")
        .arg(&script)
        .arg(&path)
        .arg("--metamer")
        .arg(&metamer)
        .arg("--json")
        .output();
    let out = match out {
        Ok(o) => o,
        Err(e) => return skip(format!("python3 cannot be run: {e}")),
    };
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        let last = stderr.lines().last().unwrap_or("no message");
        return skip(format!("benches/scipy_bvls.py failed (python3 with numpy and scipy needed): {last}"));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let Ok(v) = serde_json::from_str::<serde_json::Value>(text.trim()) else {
        return skip("benches/scipy_bvls.py printed no JSON".into());
    };
    let num = |k: &str| v.get(k).and_then(serde_json::Value::as_f64);
    let ratios = [num("ratio_median"), num("ratio_min"), num("ratio_max")];
    match (
        v.get("rounds").and_then(serde_json::Value::as_u64),
        num("scipy_seconds"),
        num("process_seconds"),
        num("process_quiet_seconds"),
        num("solve_seconds"),
        num("relative_difference"),
        ratios,
    ) {
        (
            Some(rounds),
            Some(scipy_seconds),
            Some(process_seconds),
            Some(process_quiet_seconds),
            Some(solve_seconds),
            Some(rel),
            [Some(median), Some(least), Some(greatest)],
        ) => VersusScipy::Measured {
            workload,
            designs,
            rounds: usize::try_from(rounds).unwrap_or(usize::MAX),
            scipy_seconds,
            process_seconds,
            process_quiet_seconds,
            solve_seconds,
            round_ratios: [median, least, greatest],
            relative_difference: rel,
        },
        _ => skip("benches/scipy_bvls.py printed incomplete figures".into()),
    }
}

/// Run everything and draw the plot to `plot_path` when given (the caller prints the report: `metamer bench`
/// through the one stdout writer, `cli/out.rs`).
pub fn run(cfg: &Config, plot_path: Option<&Path>) -> Report {
    let mut report = Report::default();
    report.rows.extend(batches(cfg));
    report.rows.extend(blocks_vs_dense(cfg));
    report.rows.extend(joint(cfg));
    report.versus_scipy =
        cfg.versus_scipy.map(|n| vec![versus_scipy(n, false), versus_scipy(n, true)]).unwrap_or_default();
    if let Some(path) = plot_path
        && let Err(e) = report.plot(path)
    {
        eprintln!("could not draw the plot: {e}");
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measured(scipy_seconds: f64, process_seconds: f64, solve_seconds: f64) -> VersusScipy {
        VersusScipy::Measured {
            workload: "reachable targets",
            designs: 1200,
            rounds: 10,
            scipy_seconds,
            process_seconds,
            process_quiet_seconds: process_seconds,
            solve_seconds,
            round_ratios: [scipy_seconds / process_seconds, 0.9 * scipy_seconds / process_seconds, 21.0],
            relative_difference: 0.0,
        }
    }

    #[test]
    fn the_whole_process_paragraph_says_which_aims_are_met() {
        let both = measured(0.40, 0.018, 0.0048).markdown();
        assert!(both.contains("22.2× faster"), "{both}");
        assert!(both.contains("medians of 10 alternated rounds"), "{both}");
        assert!(both.contains("the rounds' own ratios: median 22.2×, 20.0–21.0×"), "{both}");
        assert!(both.contains("≥ 20× faster than scipy, met;"), "{both}");
        assert!(both.contains("per design, met (4.00 µs per design)"), "{both}");
        let neither = measured(0.40, 0.056, 0.012).markdown();
        assert!(neither.contains("≥ 20× faster than scipy, not met;"), "{neither}");
        assert!(neither.contains("per design, not met (10.00 µs per design)"), "{neither}");
        let nan = measured(0.40, f64::NAN, f64::NAN).markdown();
        assert_eq!(nan.matches("not met").count(), 2, "{nan}");
    }
}
