//! `metamer bench [solve|basis|render|all] [-o DIR] [--quick]`: run the benchmark suites and write a
//! Markdown report (`DIR/README.md`, plus one file per suite) and PNG plots.

use crate::bench::report::{self, ReportOptions, Suite};
use anyhow::Context;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Which {
    /// The design engine: batches, blocks vs dense, joint n×n palettes, condition numbers.
    Solve,
    /// The spectral factor model: dimension against error and relighting cost.
    Basis,
    /// The renderer: raycast, relight, sweep cost, accuracy of the factor and RGB models.
    Render,
    /// Every suite, one report.
    All,
}

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which benchmark to run.
    #[arg(value_enum, default_value_t = Which::All)]
    pub which: Which,
    /// Output folder for the report (README.md) and plots (`bench/` is ignored by git in a checkout;
    /// `-o docs/bench` replaces the tracked report, and the run then lists the tracked files it rewrote).
    #[arg(short, long, default_value = "bench")]
    pub output: PathBuf,
    /// A small, fast version of every suite (smoke test; figures are not meaningful).
    #[arg(long)]
    pub(crate) quick: bool,
    /// Timed repetitions per measurement (default: each suite's own).
    #[arg(long)]
    pub(crate) runs: Option<usize>,
    /// Also replace the generated block of this README's "Performance and accuracy" section with the
    /// headline table and the Pareto plots.
    #[arg(long)]
    pub(crate) readme: Option<PathBuf>,
    /// Renderer benchmark: volume to use instead of engine.nhdr from METAMER_DATA or ../shared/volumes.
    #[arg(long)]
    pub(crate) volume: Option<PathBuf>,
    /// Replace files in -o DIR that the benchmark did not write (a file of one of its names without its
    /// mark, e.g. a project's own README.md in `-o .`) and write through symbolic links there.
    #[arg(long)]
    pub(crate) force: bool,
}

/// The most timed repetitions `--runs` asks for (a huge count would run for ever).
pub(crate) const MAX_RUNS: usize = 1000;

pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(r) = args.runs
        && !(1..=MAX_RUNS).contains(&r)
    {
        anyhow::bail!("--runs {r} is outside 1..={MAX_RUNS}");
    }
    let suites: Vec<Suite> = match args.which {
        Which::Solve => vec![Suite::Solve],
        Which::Basis => vec![Suite::Basis],
        Which::Render => vec![Suite::Render],
        Which::All => Suite::ALL.to_vec(),
    };
    check_outputs(&args, &suites)?;
    crate::bench::set_force(args.force);
    let options =
        ReportOptions { out_dir: args.output.clone(), quick: args.quick, runs: args.runs, volume: args.volume };
    let report = report::run(&suites, &options)
        .with_context(|| format!("benchmark report into {}", crate::fsio::show(&args.output)))?;
    if let Some(readme) = &args.readme {
        report::splice_readme(readme, &report, &args.output)?;
        super::out::println(&format!("updated {}", crate::fsio::show(readme)))?;
    }
    // Paths from the command line reach the terminal with their control characters escaped.
    let mut text = format!("{}\n", crate::fsio::escape_lines(&report.markdown));
    for f in &report.files {
        text.push_str(&format!("wrote {}\n", crate::fsio::show(f)));
    }
    super::out::print(&text)?;
    // Say plainly when the run replaced files that git tracks (e.g. `-o docs/bench --readme README.md` in a
    // checkout), so a user does not commit regenerated figures by accident.
    let written: Vec<&PathBuf> = report.files.iter().chain(args.readme.as_ref()).collect();
    let tracked: Vec<String> = written.iter().filter(|f| tracked_by_git(f)).map(|f| crate::fsio::show(f)).collect();
    if !tracked.is_empty() {
        super::out::println(&format!(
            "rewrote {} file(s) tracked by git (review with `git diff --stat`, undo with `git checkout -- FILE`): {}",
            tracked.len(),
            tracked.join(", ")
        ))?;
    }
    Ok(())
}

/// Refuse, before anything runs or is written, a run whose outputs (the report files in `-o DIR`, the
/// `--readme` to update) are one another or an input: the renderer suite's volume (header and detached
/// data file, found by reading it) or the README itself as a report file.
fn check_outputs(args: &Args, suites: &[Suite]) -> anyhow::Result<()> {
    let mut files = crate::fsio::Outputs::new();
    if suites.contains(&Suite::Render) {
        let volume = args.volume.clone().or_else(crate::bench::render::find_shared_engine);
        if let Some(v) = &volume {
            let (opened, read) = crate::fsio::record_reads(|| crate::volume::Volume::open(v));
            opened.with_context(|| format!("renderer benchmark volume {}", crate::fsio::show(v)))?;
            files.inputs_read(&read);
        }
    }
    let own = std::iter::once(crate::bench::REPORT_FILE)
        .chain(suites.iter().flat_map(|s| crate::bench::output_files(*s).iter().copied()));
    let own: Vec<PathBuf> = own.map(|name| args.output.join(name)).collect();
    for path in &own {
        files.output("benchmark report", path)?;
    }
    if let Some(readme) = &args.readme {
        files.output("README to update", readme)?;
    }
    for path in &own {
        if !args.force {
            // The benchmark chose these names: a link there, or a file it did not write (`-o .` in a
            // project: its README.md), is not replaced unasked.
            crate::fsio::check_chosen(path, crate::fsio::Replace::Writable)?;
            if path.exists() && !crate::bench::is_own(path) {
                anyhow::bail!(
                    "{}: refusing to replace a file `metamer bench` did not write (it has no mark of the \
                     benchmark's): choose another -o folder, or ask for it explicitly (--force)",
                    crate::fsio::show(path)
                );
            }
        }
    }
    Ok(())
}

/// True when `git ls-files --error-unmatch` knows `path` (false without git or outside a repository).
fn tracked_by_git(path: &Path) -> bool {
    std::process::Command::new("git")
        .args(["ls-files", "--error-unmatch", "--"])
        .arg(path)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}
