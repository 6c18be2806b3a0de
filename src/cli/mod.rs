//! The command line (DESIGN_SPEC §5): argument parsing with clap derive and error reporting.
//! Each subcommand lives in its own module with an `Args` struct and a `run` function.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

pub mod basis;
pub mod bench;
pub mod check;
pub mod design;
mod heap;
pub mod out;
pub mod render;
pub mod solve;

/// Where the file formats are documented, for `--help`.
pub(crate) const FORMATS_HELP: &str = "\
File formats (reference pages in the source repository):
  docs/formats/palette.md   palettes: lights, reflectances, colours, free groups, settings; the .basis.json sidecar
  docs/formats/scene.md     scenes for `render` and `design --scene`: palette, volume, materials, camera, dial
  docs/formats/dial.md      the light dial's keyframes
  docs/formats/report.md    the table and the JSON report of `solve`
  docs/formats/keys.md      key scripts for `design --replay` and the screens it writes
  docs/DESIGN_SPEC.md       the pinned colour pipeline, objective, formats and command line
Data: scenes find their volume from `render --volume PATH`, the scene's `volume` key, or the folder named by
METAMER_DATA (README, section Data, says where each public dataset comes from).";

/// Design spectra (metamers, colour constancy, metameric blacks) and render spectral volumes
/// relit in real time.
#[derive(Debug, Parser)]
#[command(name = "metamer", version, about, long_about = None, propagate_version = true, after_help = FORMATS_HELP)]
pub struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Debug, Subcommand)]
pub(crate) enum Command {
    /// Validate a palette and print its design matrix with truecolor swatches.
    Check(check::Args),
    /// Solve a palette's design headless: write the solved palette and a JSON report.
    Solve(solve::Args),
    /// Train the sharpened spectral factor basis of a palette and report its accuracy.
    Basis(basis::Args),
    /// Raycast a spectral volume scene and write a PNG sequence sweeping the light dial.
    Render(render::Args),
    /// The terminal palette designer.
    Design(design::Args),
    /// Run the benchmark suite: run time against error, as a Markdown report and PNG plots.
    Bench(bench::Args),
}

/// Parse the process arguments, run, and report any error on stderr with a non-zero exit.
pub fn main() -> ExitCode {
    tune_allocator();
    let cli = Cli::parse();
    // The designer in its terminal answers SIGTERM, SIGHUP and SIGINT itself (the terminal restored, unsaved
    // work kept: tui::terminal); a headless replay (`--replay`, which writes `--screen`) is like any command.
    if !matches!(&cli.command, Command::Design(a) if a.replay.is_none()) {
        remove_staged_on_signals();
    }
    heap::build_pool(pool_size());
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        // A closed pipe (`metamer check p.toml | head -1`): the reader has what it wanted.
        Err(e) if out::is_closed(&e) => ExitCode::SUCCESS,
        Err(e) => {
            // Every message may quote user text (names, paths, file contents): control characters are
            // shown escaped, never sent to the terminal.
            eprintln!("error: {}", crate::fsio::escape_lines(&message(&e)));
            ExitCode::FAILURE
        }
    }
}

/// From now on SIGINT, SIGTERM and SIGHUP first remove the temporary files of the outputs being written
/// ([`crate::fsio::remove_staged`]: an interrupted `render` leaves no hidden `.frame_NNNN.png.XXXXXX.tmp` in
/// its folder, an interrupted `solve` none beside its outputs), then end the process as they would have
/// (killed by the signal: a shell shows 130 for Ctrl-C). The signals are taken on a thread of their own, which
/// registers them itself: if it cannot be started, they keep their default action. Until it has registered
/// them (the first tenth of a millisecond or so) a signal acts as it always did.
fn remove_staged_on_signals() {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let _ = std::thread::Builder::new().name("metamer-signals".into()).spawn(|| {
            // A signal the process was started ignoring (`nohup` ignores SIGHUP, a non-interactive shell
            // SIGINT for a command run with `&`) stays ignored.
            let taken: Vec<i32> = [SIGINT, SIGTERM, SIGHUP].into_iter().filter(|&s| !ignored(s)).collect();
            let Ok(mut signals) = signal_hook::iterator::Signals::new(&taken) else {
                return;
            };
            if let Some(signal) = signals.forever().next() {
                crate::fsio::remove_staged();
                // The default action of these three ends the process; the exit below is only a fallback.
                let _ = signal_hook::low_level::emulate_default_handler(signal);
                std::process::exit(128 + signal);
            }
        });
    }
}

/// Whether `signal`'s action is to be ignored (SIG_IGN), as the process was started with it.
#[cfg(unix)]
fn ignored(signal: i32) -> bool {
    let mut old = std::mem::MaybeUninit::<libc::sigaction>::zeroed();
    // SAFETY: with a null new action `sigaction` only writes the current one into `old`, which is valid for
    // writes of a `sigaction`.
    let got = unsafe { libc::sigaction(signal, std::ptr::null(), old.as_mut_ptr()) };
    // SAFETY: zero-initialised and filled by the call when it succeeded; an all-zero `sigaction` is valid.
    got == 0 && unsafe { old.assume_init() }.sa_sigaction == libc::SIG_IGN
}

/// An error and its causes, `a: b: c` as anyhow's `{:#}` writes them, except a cause whose text the message
/// already ends with: an error that quotes its source in its own message (the atomic writer's "cannot write:
/// {source}") would otherwise print it twice.
fn message(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let cause = cause.to_string();
        if !text.ends_with(&cause) {
            text.push_str(": ");
            text.push_str(&cause);
        }
    }
    text
}

/// The allocator's top pad: what glibc maps beyond a request when it makes a thread's heap or grows the main
/// one, and keeps when it trims either.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub(crate) const TOP_PAD: usize = 8 << 20;

/// glibc's allocator grows each pool thread's heap by the pages a request needs, one `mprotect` a growth, and
/// each `mprotect` holds the process's memory map while the other threads' page faults wait for it: a
/// 1200-design `metamer solve` made about 1200 of them, and its pool threads stalled on each other's. A top
/// pad, set before any other thread exists, makes each thread's heap with [`TOP_PAD`] mapped from the start
/// (and the main arena grow by as much); past that a thread's heap still grows by what each request needs
/// (glibc's `sysmalloc` pads only a new heap), but the solve's workers stay inside their first 8 MiB. Pages
/// are still taken only when first written, so what is resident does not grow with the pad
/// (docs/solve_performance.md, "The allocator's top pad").
pub(crate) fn tune_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` sets one parameter of the allocator under the allocator's own lock; it moves and
    // frees nothing.
    unsafe {
        libc::mallopt(libc::M_TOP_PAD, TOP_PAD as libc::c_int);
    }
}

/// The size of rayon's global pool ([`heap::build_pool`]): one worker more than the machine's available
/// parallelism, unless `RAYON_NUM_THREADS` says otherwise (then `None`: rayon's builder reads it). Measured on
/// 2 cores, 1200 reachable designs, `metamer solve r.toml -o OUT --report R.json` (docs/solve_performance.md,
/// "The pool's size"): three workers against two, whole process 0.87-0.90 of the time and the solve's own
/// 0.64; with a busy loop on one core 0.91-0.96; a raycast unchanged (1.01).
fn pool_size() -> Option<usize> {
    if std::env::var_os("RAYON_NUM_THREADS").is_some() {
        return None;
    }
    std::thread::available_parallelism().ok().map(|n| n.get() + 1)
}

/// Run a parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Check(a) => check::run(a),
        Command::Solve(a) => solve::run(a),
        Command::Basis(a) => basis::run(a),
        Command::Render(a) => render::run(a),
        Command::Design(a) => design::run(a),
        Command::Bench(a) => bench::run(a),
    }
}

#[cfg(test)]
mod message_tests {
    use super::message;

    /// A cause the message already quotes at its end is not repeated; a cause it does not quote is added,
    /// as anyhow's `{:#}` adds it.
    #[test]
    fn a_cause_the_message_quotes_is_printed_once() {
        let quoted = crate::fsio::FsError::Write {
            path: "out/frame_0001.png".into(),
            source: std::io::Error::other("Too many open files (os error 24)"),
        };
        let text = message(&anyhow::Error::new(quoted));
        assert_eq!(text.matches("Too many open files").count(), 1, "{text}");
        assert!(text.starts_with("out/frame_0001.png: cannot write: "), "{text}");
        let added = anyhow::Error::new(std::io::Error::other("disk full")).context("writing the report");
        assert_eq!(message(&added), "writing the report: disk full");
        assert_eq!(message(&added), format!("{added:#}"), "anyhow's own form where nothing is quoted");
    }
}
