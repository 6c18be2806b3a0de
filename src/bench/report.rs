//! The whole `metamer bench` report: runs the chosen suites (solver, basis, renderer), adds the cross-suite
//! views of [`super::summary`] (Pareto fronts, ratios against in-process baselines, condition numbers), and
//! writes `DIR/README.md` with every table and links to the PNG plots beside it.

use super::render::{RenderBenchOptions, RenderBenchReport};
use super::{basis, fixed, format_seconds, markdown_table, render, solve, summary};
use crate::basis::TrainOptions;
use crate::render::Mode;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// One benchmark suite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Suite {
    Solve,
    Basis,
    Render,
}

impl Suite {
    pub const ALL: [Suite; 3] = [Suite::Solve, Suite::Basis, Suite::Render];

    pub(crate) fn name(self) -> &'static str {
        match self {
            Suite::Solve => "solve",
            Suite::Basis => "basis",
            Suite::Render => "render",
        }
    }
}

/// What to run and where to write it.
#[derive(Clone, Debug)]
pub struct ReportOptions {
    pub out_dir: PathBuf,
    /// A small, fast version of every suite (CI smoke tests); its figures are not meaningful.
    pub quick: bool,
    /// Timed repetitions per measurement (medians are reported); `None`: the suites' defaults.
    pub runs: Option<usize>,
    /// Renderer: use this volume instead of `../shared/volumes/engine.nhdr` (or the generated engine).
    pub volume: Option<PathBuf>,
}

/// Why the report could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("cannot write {}: {source}", crate::fsio::show(path))]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{0}")]
    File(crate::fsio::FsError),
    #[error("basis benchmark: {0}")]
    Basis(#[from] basis::BenchError),
    #[error("render benchmark: {0}")]
    Render(#[from] crate::render::RenderError),
    #[error("plot: {0}")]
    Plot(#[from] super::plot::PlotError),
    #[error("{}: no `{README_BEGIN}` … `{README_END}` block to replace", crate::fsio::show(path))]
    Readme { path: PathBuf },
}

/// One aim of a headline: a measured figure that must stay below a limit.
#[derive(Clone, Debug)]
pub struct Check {
    /// The figure as named in the aim ("mean ΔE*ab", "worst palette", "median time").
    pub(crate) what: String,
    pub(crate) value: f64,
    pub(crate) limit: f64,
    /// `value < limit` (true) or `value ≤ limit` (false).
    pub(crate) strict: bool,
    /// The limit as written (with its unit), e.g. "3 s".
    pub(crate) limit_text: String,
}

impl Check {
    /// `what < limit`.
    pub(crate) fn below(what: &str, value: f64, limit: f64, limit_text: &str) -> Check {
        Check { what: what.into(), value, limit, strict: true, limit_text: limit_text.into() }
    }

    /// `what ≤ limit`.
    pub(crate) fn at_most(what: &str, value: f64, limit: f64, limit_text: &str) -> Check {
        Check { what: what.into(), value, limit, strict: false, limit_text: limit_text.into() }
    }

    /// Whether the figure meets the aim; a figure that is not finite never does.
    pub(crate) fn passed(&self) -> bool {
        self.value.is_finite() && if self.strict { self.value < self.limit } else { self.value <= self.limit }
    }

    fn text(&self) -> String {
        let op = if self.strict { "<" } else { "≤" };
        let mark = if self.passed() { "" } else { " ✗" };
        format!("{} {op} {}{mark}", self.what, self.limit_text)
    }
}

/// A headline figure for the summary table.
#[derive(Clone, Debug)]
pub struct Headline {
    pub what: String,
    pub(crate) figure: String,
    /// What the figure is compared with, besides its aims (may be empty).
    pub(crate) against: String,
    /// The aims the figure must meet, every one of them (empty: no aim, a comparison only).
    pub(crate) checks: Vec<Check>,
}

impl Headline {
    /// Whether every aim is met (None: no aim). The one rule for every row: one missed aim is a miss.
    pub fn met(&self) -> Option<bool> {
        (!self.checks.is_empty()).then(|| self.checks.iter().all(Check::passed))
    }

    /// The table row: what, measured (prefixed ✓ when every aim is met, ✗ when one is not), against
    /// (the comparison, then every aim, a missed one marked ✗).
    pub(crate) fn row(&self) -> Vec<String> {
        let mark = match self.met() {
            Some(true) => "✓ ",
            Some(false) => "✗ ",
            None => "",
        };
        let aims = self.checks.iter().map(Check::text).collect::<Vec<_>>().join(", ");
        let against = match (self.against.is_empty(), aims.is_empty()) {
            (_, true) => self.against.clone(),
            (true, false) => format!("aim: {aims}"),
            (false, false) => format!("{}; aim: {aims}", self.against),
        };
        vec![self.what.clone(), format!("{mark}{}", self.figure), against]
    }
}

/// The report as written.
#[derive(Clone, Debug, Default)]
pub struct BenchReport {
    pub markdown: String,
    pub headlines: Vec<Headline>,
    /// Files written into the output folder.
    pub files: Vec<PathBuf>,
}

fn write(path: &Path, text: &str) -> Result<(), ReportError> {
    crate::bench::write_own(path, text.as_bytes()).map_err(ReportError::File)
}

fn image(md: &mut String, files: &mut Vec<PathBuf>, dir: &Path, name: &str, alt: &str) {
    let path = dir.join(name);
    if path.is_file() {
        md.push_str(&format!("\n![{alt}]({name})\n"));
        files.push(path);
    }
}

/// Run `suites` and write `README.md` plus plots into `options.out_dir`.
pub fn run(suites: &[Suite], options: &ReportOptions) -> Result<BenchReport, ReportError> {
    let dir = &options.out_dir;
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io { path: dir.clone(), source })?;
    let started = Instant::now();
    let mut report = BenchReport::default();
    let mut sections = String::new();
    for suite in suites {
        let t = Instant::now();
        let section = match suite {
            Suite::Solve => solve_section(options, &mut report)?,
            Suite::Basis => basis_section(options, &mut report)?,
            Suite::Render => render_section(options, &mut report)?,
        };
        sections.push_str(&section);
        sections.push_str(&format!("\n_{} suite took {}._\n", suite.name(), format_seconds(t.elapsed().as_secs_f64())));
    }
    let names: Vec<&str> = suites.iter().map(|s| s.name()).collect();
    let which = if suites.len() == Suite::ALL.len() { "all".to_string() } else { names.join(" ") };
    let load =
        std::fs::read_to_string("/proc/loadavg").ok().and_then(|s| s.split_whitespace().next().map(String::from));
    let mut md = String::from("# metamer benchmarks: run time against error\n\n");
    md.push_str(&format!(
        "Regenerate with `cargo run --release -- bench {which} -o {}`{}. {} rayon threads{}; \
         figures are medians of repeated runs with the interquartile range in brackets; ratios compare \
         measurements made in the same process. Whole run: {}.\n\n",
        dir.display(),
        if options.quick { " --quick (a smoke test: small sizes, figures not meaningful)" } else { "" },
        rayon::current_num_threads(),
        load.map_or(String::new(), |l| format!(", 1-minute load average {l} at the end")),
        format_seconds(started.elapsed().as_secs_f64()),
    ));
    if !report.headlines.is_empty() {
        md.push_str("## Headline figures\n\n");
        let rows: Vec<Vec<String>> = report.headlines.iter().map(Headline::row).collect();
        md.push_str(&markdown_table(&["what", "measured", "against"], &rows));
        md.push('\n');
    }
    md.push_str(&sections);
    // The mark that lets the next run replace this file (`crate::bench::is_own`).
    md.push_str(&format!("\n{}\n", crate::bench::MD_MARK));
    let path = dir.join("README.md");
    write(&path, &md)?;
    report.files.insert(0, path);
    report.markdown = md;
    Ok(report)
}

/// Markers around the generated part of a README's "Performance and accuracy" section.
pub const README_BEGIN: &str =
    "<!-- metamer bench: begin (generated by `metamer bench all -o docs/bench --readme README.md`) -->";
pub const README_END: &str = "<!-- metamer bench: end -->";

/// Replace the text between [`README_BEGIN`] and [`README_END`] in `readme` with the report's headline
/// table and its Pareto plots (image paths relative to the README's folder); atomic (temp file + rename).
pub(crate) fn splice_readme(readme: &Path, report: &BenchReport, out_dir: &Path) -> Result<(), ReportError> {
    let text = crate::fsio::read_to_string(readme, crate::fsio::Kind::Text).map_err(ReportError::File)?;
    let missing = || ReportError::Readme { path: readme.to_path_buf() };
    let begin = text.find(README_BEGIN).ok_or_else(missing)?;
    let end = text[begin..].find(README_END).map(|i| begin + i).ok_or_else(missing)?;
    let base = readme.parent().unwrap_or(Path::new("."));
    let rel = out_dir.strip_prefix(base).unwrap_or(out_dir);
    let mut block = format!(
        "{README_BEGIN}

"
    );
    let rows: Vec<Vec<String>> = report.headlines.iter().map(Headline::row).collect();
    block.push_str(&markdown_table(&["what", "measured", "against"], &rows));
    for f in &report.files {
        let name = f.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if name.ends_with("_pareto.png") {
            block.push_str(&format!("\n![{name}]({})\n", rel.join(name).display()));
        }
    }
    block.push_str(&format!("\nFull report: [{0}/README.md]({0}/README.md).\n\n", rel.display()));
    let new = format!("{}{block}{}", &text[..begin], &text[end..]);
    crate::fsio::write_atomic(readme, new.as_bytes()).map_err(ReportError::File)
}

fn solve_section(options: &ReportOptions, report: &mut BenchReport) -> Result<String, ReportError> {
    let dir = &options.out_dir;
    let mut cfg = if options.quick { solve::Config::quick() } else { solve::Config::default() };
    if let Some(r) = options.runs {
        cfg.runs = r.max(1);
    }
    if options.quick {
        cfg.time_limit = Duration::from_secs(2);
    }
    let seeds = cfg.joint_seeds;
    let results = solve::run(&cfg, Some(&dir.join("solve_scaling.png")));
    summary::solve_tradeoff_plot(&results, &dir.join("solve_pareto.png"))?;
    let ratios = summary::solve_ratios(&results);
    let conditions = summary::condition_survey(options.quick);
    let mut md = String::from("## Design engine (`metamer bench solve`)\n\n");
    md.push_str(
        "Batches of independent bounded single-reflectance designs under D65, A and F11 (targets ±25 % off \
         a smooth reflectance's colours, so most designs press on the bounds), the same unbounded, blocks \
         against one dense system, and the TOG 2009 Fig. 3 capacity protocol (n×n, everything designed, \
         positivity, smoothness 0.001). Error: mean CIELAB ΔE*ab / CIEDE2000 of target against achieved \
         full colour.\n\n",
    );
    md.push_str(&results.markdown());
    image(&mut md, &mut report.files, dir, "solve_pareto.png", "solver run time against error, Pareto front");
    image(&mut md, &mut report.files, dir, "solve_scaling.png", "solver run time against designs solved, per path");
    let front = summary::solve_pareto_cases(&results);
    md.push_str(&format!(
        "\nPareto front (time, mean ΔE*ab) per workload, among the solver paths that measured it (n/a errors left \
         out; a workload one path alone measured has no front): {}.\n\n",
        if front.is_empty() { "none".to_string() } else { front.join("; ") }
    ));
    md.push_str("### Against in-process baselines\n\n");
    md.push_str(&summary::ratios_markdown(&ratios));
    md.push_str("\n### Condition numbers of the design systems met\n\n");
    md.push_str(
        "σ_max/σ_min of each block's stacked matrix A (singular values below σ_max·n·ε count as null \
         directions, which the minimum-norm SVD solve leaves at zero).\n\n",
    );
    md.push_str(&summary::conditions_markdown(&conditions));
    write(&dir.join("solve.md"), &md)?;

    let bounded = results.rows.iter().filter(|r| r.group.starts_with("bounded [0,1]")).max_by_key(|r| r.designs);
    if let Some(b) = bounded {
        report.headlines.push(Headline {
            what: format!("bounded single-reflectance design (batch of {})", b.designs),
            figure: format!("{} per design, mean ΔE*ab {:.3}", format_seconds(b.per_design), b.mean_delta_e_ab),
            against: "scipy BVLS ≈ 1 ms each".into(),
            checks: vec![Check::at_most("per design", b.per_design, 50e-6, "50 µs")],
        });
    }
    for r in &ratios {
        if r.what.starts_with("blocks vs one dense") {
            report.headlines.push(Headline {
                what: r.what.clone(),
                figure: format!("{:.1}× faster, objective gap {:.1e}", r.speedup, r.objective_gap.unwrap_or(f64::NAN)),
                against: "one dense stacked system, same process".into(),
                checks: Vec::new(),
            });
        }
    }
    for n in [10, 15] {
        for r in results.rows.iter().filter(|r| r.group.starts_with("joint") && r.case == format!("{n}×{n}")) {
            let aim = if n == 10 { 0.5 } else { 8.5 };
            let white = [solve::CAPACITY_LIGHT_WHITE, solve::CAPACITY_DISPLAY_WHITE]
                .into_iter()
                .find(|w| r.group.contains(w))
                .unwrap_or("?");
            let worst = r.worst_delta_e_ab.unwrap_or(f64::NAN);
            report.headlines.push(Headline {
                what: format!("joint {n}×{n} capacity palette, ΔE*ab vs {white}"),
                figure: format!(
                    "mean ΔE*ab {} (worst palette {}, {}) in {} (median, IQR)",
                    fixed(r.mean_delta_e_ab, 3),
                    fixed(worst, 3),
                    solve::seeds_text(r.timing.runs, seeds),
                    r.timing.display()
                ),
                against: String::new(),
                // The aim holds for every palette: the mean over seeds and the worst one.
                checks: vec![
                    Check::below("mean", r.mean_delta_e_ab, aim, &aim.to_string()),
                    Check::below("worst palette", worst, aim, &aim.to_string()),
                    Check::below("median time", r.timing.median, 3.0, "3 s"),
                ],
            });
        }
    }
    if let Some(worst) = conditions.iter().max_by(|a, b| a.condition.total_cmp(&b.condition)) {
        report.headlines.push(Headline {
            what: "worst condition number met".into(),
            figure: format!("{:.1e} ({})", worst.condition, worst.palette),
            against: "1/ε ≈ 4.5e15".into(),
            checks: Vec::new(),
        });
    }
    Ok(md)
}

fn basis_section(options: &ReportOptions, report: &mut BenchReport) -> Result<String, ReportError> {
    let dir = &options.out_dir;
    let mut bench = basis::BenchOptions::default();
    if options.quick {
        bench.dimensions = 3..=4;
        bench.pixels = 4096;
        bench.runs = 3;
        bench.training = TrainOptions { transform_iterations: 30, full_iterations: 30, ..TrainOptions::default() };
    }
    if let Some(r) = options.runs {
        bench.runs = r.max(3);
    }
    let results = basis::run(&bench)?;
    basis::plots(&results, dir)?;
    summary::basis_tradeoff_plot(&results, &dir.join("basis_pareto.png"))?;
    let mut md = String::from("## Spectral factor model (`metamer bench basis`)\n\n");
    md.push_str(&basis::markdown(&results));
    image(&mut md, &mut report.files, dir, "basis_pareto.png", "relighting cost against factor-model error");
    image(&mut md, &mut report.files, dir, "basis_error.png", "factor-model error against dimension");
    image(&mut md, &mut report.files, dir, "basis_cost.png", "relighting cost against dimension");
    md.push_str(&format!(
        "\nPareto front (relight cost, mean ΔE00): {}.\n",
        summary::basis_pareto_dimensions(&results).join(", ")
    ));
    write(&dir.join("basis.md"), &md)?;
    let row = results.rows.iter().find(|r| r.dimension == 7).or(results.rows.last());
    if let Some(r) = row {
        report.headlines.push(Headline {
            what: format!("factor model m = {} on ColorChecker × 7 lights", r.dimension),
            figure: format!("mean / p95 ΔE00 {:.2} / {:.2}", r.full.mean, r.full.p95),
            against: format!("RGB factor model {:.2} / {:.2}", results.rgb.mean, results.rgb.p95),
            checks: vec![
                Check::at_most("mean", r.full.mean, 1.0, "1.0"),
                Check::at_most("p95", r.full.p95, 2.5, "2.5"),
            ],
        });
    }
    Ok(md)
}

fn render_section(options: &ReportOptions, report: &mut BenchReport) -> Result<String, ReportError> {
    let dir = &options.out_dir;
    let mut bench = RenderBenchOptions { out_dir: dir.clone(), volume: options.volume.clone(), ..Default::default() };
    if options.quick {
        bench.runs = 1;
        bench.raycast_size = 96;
        bench.sweep_size = 64;
        bench.sweep_frames = 4;
        bench.accuracy_size = 48;
        bench.accuracy_frames = 3;
        bench.large_dims = [128, 128, 96];
        bench.quality_frames = 2;
    }
    if let Some(r) = options.runs {
        bench.runs = r.max(1);
    }
    let r: RenderBenchReport = render::run(&bench)?;
    summary::render_tradeoff_plot(&r, &dir.join("render_pareto.png"))?;
    let mut md = String::from("## Renderer (`metamer bench render`)\n\n");
    // The renderer's own report starts with a level-1 title: demote it into this section.
    let own = r.markdown.replacen("# Renderer benchmark\n\n", "", 1).replace("\n## ", "\n### ");
    md.push_str(&own);
    image(&mut md, &mut report.files, dir, "render_pareto.png", "render modes: relight time against error");
    image(&mut md, &mut report.files, dir, "render_raycast.png", "raycast time against samples");
    image(&mut md, &mut report.files, dir, "render_relight.png", "relight time against channels");
    md.push_str("\n### Against in-process baselines\n\n");
    md.push_str(&summary::ratios_markdown(&summary::render_ratios(&r)));
    let (f, fu) = (&r.accuracy.factor, &r.accuracy.factor_unquantised);
    report.headlines.push(Headline {
        what: format!("render: factor model (m = {}) vs full 31-sample frames", r.accuracy.dimension),
        figure: format!(
            "mean ΔE00 {:.4}, p95 {:.3}, max {:.3} on the 8-bit frames{}; before 8-bit rounding mean {:.4}, max {:.3}",
            f.mean,
            f.p95,
            f.max,
            if f.p95 < f.mean {
                " (p95 below the mean: at least 95 % of pixels are identical after rounding, the mean comes from \
                 the few that are not)"
            } else {
                ""
            },
            fu.mean,
            fu.max
        ),
        against: format!(
            "RGB model mean {:.3}, p95 {:.3}, max {:.3}",
            r.accuracy.rgb.mean, r.accuracy.rgb.p95, r.accuracy.rgb.max
        ),
        checks: vec![Check::at_most("mean", f.mean, 1.5, "1.5")],
    });
    if let Some(both) = r.raycast.iter().find(|x| x.accel.early_termination && x.accel.empty_space_skipping) {
        let off = r.raycast.iter().find(|x| !x.accel.early_termination && !x.accel.empty_space_skipping);
        report.headlines.push(Headline {
            what: format!("raycast {0}×{0} (early termination + empty-space skipping)", bench.raycast_size),
            figure: format!(
                "{}{}",
                format_seconds(both.median_s),
                off.map_or(String::new(), |o| format!(", {:.1}× faster than both off", o.median_s / both.median_s))
            ),
            against: if bench.raycast_size == 512 { String::new() } else { "aim is for 512²".into() },
            checks: if bench.raycast_size == 512 {
                vec![Check::below("median", both.median_s, 0.3, "0.3 s")]
            } else {
                Vec::new()
            },
        });
    }
    let at = |m: Mode| r.relight.iter().find(|x| x.mode == m && x.size == r.sweep_size);
    if let (Some(f), Some(full)) = (at(Mode::Factor), at(Mode::Full)) {
        report.headlines.push(Headline {
            what: format!("relight one {0}×{0} frame, factor model", f.size),
            figure: format!(
                "{} ({:.1}× faster than full 31-sample)",
                format_seconds(f.median_s),
                full.median_s / f.median_s
            ),
            against: if f.size == 384 { String::new() } else { "aim is for 384²".into() },
            checks: if f.size == 384 { vec![Check::below("median", f.median_s, 2e-3, "2 ms")] } else { Vec::new() },
        });
    }
    let extra = r.sweep_frames.saturating_sub(1).max(1) as f64;
    let budget = r.one_frame_s + 0.02 * extra;
    report.headlines.push(Headline {
        what: format!("sweep of {} frames at {}² (raycast once)", r.sweep_frames, r.sweep_size),
        figure: format!("{} in all, {}", format_seconds(r.sweep_s), r.per_frame_text()),
        against: String::new(),
        checks: vec![Check::at_most(
            "whole sweep",
            r.sweep_s,
            budget,
            &format!("one frame + 20 ms per extra = {}", format_seconds(budget)),
        )],
    });
    Ok(md)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headline(checks: Vec<Check>) -> Headline {
        Headline { what: "w".into(), figure: "f".into(), against: "c".into(), checks }
    }

    #[test]
    fn one_missed_aim_is_a_miss_and_is_named() {
        // The 15×15 case: mean below the aim, worst palette above it.
        let h = headline(vec![
            Check::below("mean", 7.588, 8.5, "8.5"),
            Check::below("worst palette", 8.583, 8.5, "8.5"),
            Check::below("median time", 0.8, 3.0, "3 s"),
        ]);
        assert_eq!(h.met(), Some(false));
        let row = h.row();
        assert!(row[1].starts_with("✗ "), "{row:?}");
        assert_eq!(row[2], "c; aim: mean < 8.5, worst palette < 8.5 ✗, median time < 3 s");
        let ok = headline(vec![Check::below("mean", 7.5, 8.5, "8.5"), Check::below("worst palette", 8.4, 8.5, "8.5")]);
        assert_eq!(ok.met(), Some(true));
        assert!(ok.row()[1].starts_with("✓ ") && !ok.row()[2].contains('✗'), "{:?}", ok.row());
    }

    #[test]
    fn aims_at_the_limit_and_not_finite_figures() {
        assert!(Check::at_most("x", 1.0, 1.0, "1").passed());
        assert!(!Check::below("x", 1.0, 1.0, "1").passed());
        // n/a never meets an aim.
        assert!(!Check::at_most("x", f64::NAN, 1.0, "1").passed());
        assert!(!Check::below("x", f64::INFINITY, 1.0, "1").passed());
        // No aim: no mark.
        let h = headline(vec![]);
        assert_eq!(h.met(), None);
        assert_eq!(h.row(), vec!["w".to_string(), "f".to_string(), "c".to_string()]);
    }
}
