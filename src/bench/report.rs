//! The whole `metamer bench` report: runs the chosen suites (solver, basis, renderer), adds the cross-suite
//! views of [`super::summary`] (Pareto fronts, ratios against in-process baselines, condition numbers), and
//! writes `DIR/README.md` with every table and links to the PNG plots beside it.

use super::render::{RenderBenchOptions, RenderBenchReport};
use super::{basis, fixed, format_seconds, markdown_table, render, solve, summary};
use crate::basis::train::TrainOptions;
use crate::render::relight::Mode;
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

/// A headline figure for the summary table.
#[derive(Clone, Debug)]
pub struct Headline {
    pub what: String,
    pub(crate) figure: String,
    pub(crate) against: String,
    /// Whether the measured figure meets the aim in `against` (None: no aim, a comparison only).
    pub(crate) met: Option<bool>,
}

impl Headline {
    /// The table row: what, measured (prefixed ✓ or ✗ when there is an aim), against.
    pub(crate) fn row(&self) -> Vec<String> {
        let mark = match self.met {
            Some(true) => "✓ ",
            Some(false) => "✗ ",
            None => "",
        };
        vec![self.what.clone(), format!("{mark}{}", self.figure), self.against.clone()]
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
    crate::fsio::write_atomic(path, text.as_bytes()).map_err(ReportError::File)
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
    let results = solve::run(&cfg, Some(&dir.join("solve_time_error.png")));
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
    image(&mut md, &mut report.files, dir, "solve_time_error.png", "solver run time against error per path");
    let front = summary::solve_pareto_cases(&results);
    md.push_str(&format!("\nPareto front (time, mean ΔE*ab): {}.\n\n", front.join("; ")));
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
            against: "aim ≤ 50 µs; scipy BVLS ≈ 1 ms each".into(),
            met: Some(b.per_design <= 50e-6),
        });
    }
    for r in &ratios {
        if r.what.starts_with("blocks vs one dense") {
            report.headlines.push(Headline {
                what: r.what.clone(),
                figure: format!("{:.1}× faster, objective gap {:.1e}", r.speedup, r.objective_gap.unwrap_or(f64::NAN)),
                against: "one dense stacked system, same process".into(),
                met: None,
            });
        }
    }
    for n in [10, 15] {
        for r in results.rows.iter().filter(|r| r.group.starts_with("joint") && r.case == format!("{n}×{n}")) {
            let (aim, aim_v) = if n == 10 { ("< 0.5", 0.5) } else { ("< 8.5", 8.5) };
            let white = [solve::CAPACITY_LIGHT_WHITE, solve::CAPACITY_DISPLAY_WHITE]
                .into_iter()
                .find(|w| r.group.contains(w))
                .unwrap_or("?");
            report.headlines.push(Headline {
                what: format!("joint {n}×{n} capacity palette, ΔE*ab vs {white}"),
                figure: format!(
                    "mean ΔE*ab {} (worst palette {}, {}) in {} (median, IQR)",
                    fixed(r.mean_delta_e_ab, 3),
                    fixed(r.worst_delta_e_ab.unwrap_or(f64::NAN), 3),
                    solve::seeds_text(r.timing.runs, seeds),
                    r.timing.display()
                ),
                against: format!("aim {aim}, < 3 s"),
                met: Some(r.mean_delta_e_ab < aim_v && r.timing.median < 3.0),
            });
        }
    }
    if let Some(worst) = conditions.iter().max_by(|a, b| a.condition.total_cmp(&b.condition)) {
        report.headlines.push(Headline {
            what: "worst condition number met".into(),
            figure: format!("{:.1e} ({})", worst.condition, worst.palette),
            against: "1/ε ≈ 4.5e15".into(),
            met: None,
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
            against: format!("RGB factor model {:.2} / {:.2}; aim 1.0 / 2.5", results.rgb.mean, results.rgb.p95),
            met: Some(r.full.mean <= 1.0 && r.full.p95 <= 2.5),
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
    report.headlines.push(Headline {
        what: format!("render: factor model (m = {}) vs full 31-sample frames", r.accuracy.dimension),
        figure: format!("mean / p95 ΔE00 {:.3} / {:.3}", r.accuracy.factor.mean, r.accuracy.factor.p95),
        against: format!("RGB model {:.3} / {:.3}; aim ≤ 1.5 (0.5)", r.accuracy.rgb.mean, r.accuracy.rgb.p95),
        met: Some(r.accuracy.factor.mean <= 1.5),
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
            against: "aim < 0.3 s at 512²".into(),
            met: (bench.raycast_size == 512).then_some(both.median_s < 0.3),
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
            against: "aim < 2 ms".into(),
            met: (f.size == 384).then_some(f.median_s < 2e-3),
        });
    }
    let extra = r.sweep_frames.saturating_sub(1).max(1) as f64;
    let budget = r.one_frame_s + 0.02 * extra;
    report.headlines.push(Headline {
        what: format!("sweep of {} frames at {}² (raycast once)", r.sweep_frames, r.sweep_size),
        figure: format!("{} in all, {}", format_seconds(r.sweep_s), r.per_frame_text()),
        against: format!("budget one frame + 20 ms per extra = {}", format_seconds(budget)),
        met: Some(r.sweep_s <= budget),
    });
    Ok(md)
}
