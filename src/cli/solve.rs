//! `metamer solve IN.toml [-o OUT.toml] [--report R.json]` (DESIGN_SPEC §5): solve a palette's design,
//! print a per-cell table (target, achieved full and subspace colour, ΔE00) with a line for every cell
//! that cannot be met and why, write the solved palette (atomically; never after a failed solve) and a
//! JSON report.

use crate::basis::Basis;
use crate::basis::basis_for_palette;
use crate::basis::{self, palette_uses_basis};
use crate::colorimetry::{Colorimetry, linear_to_hex};
use crate::design::Fixed;
use crate::design::{self, Criterion, Solution, SolveOptions};
use crate::palette::PaletteFile;
use crate::palette::mixing;
use crate::palette::{MixSpec, Palette, PaletteError, PreparedEnd, SpectrumEntry};
use anyhow::Context;
use nalgebra::Vector3;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Palettes with at most this many spectra get subspace colours in the report by default (training a basis
/// for thousands of spectra would dominate a batch solve).
pub(crate) const AUTO_SUBSPACE_SPECTRA: usize = 100;

#[derive(Debug, clap::Args)]
#[command(
    about = "Solve a palette's design headless: write the solved palette and a JSON report",
    long_about = "Solve the design of a palette (docs/formats/palette.md): every designed light and reflectance and every \
                  free colour is chosen to minimise the weighted colour errors plus smoothness under the bounds. \
                  Prints one row per colour cell (target, achieved colour in full 31-sample and in the spectral \
                  factor model, CIEDE2000) and says for every cell that cannot be met why. The solved palette is \
                  written to OUT only when the solve succeeds, atomically (OUT may be IN).",
    after_help = "Subspace colours need the palette's trained basis (cached in IN's .basis.json sidecar). It is \
                  always used when the palette sets fit_in_subspace or subspace_error; otherwise it is trained for \
                  palettes of up to 100 spectra, or when --subspace is given, and skipped with --no-subspace. The palette \
                  format is docs/formats/palette.md, the table and the report docs/formats/report.md."
)]
pub struct Args {
    /// The palette to solve.
    #[arg(value_name = "IN.toml")]
    pub input: PathBuf,
    /// Where to write the solved palette (may be IN). Without it nothing is written but the report.
    #[arg(short = 'o', long = "output", value_name = "OUT.toml")]
    pub(crate) output: Option<PathBuf>,
    /// Write a JSON report here.
    #[arg(long, value_name = "REPORT.json")]
    pub(crate) report: Option<PathBuf>,
    /// Always report subspace colours (trains the basis if needed).
    #[arg(long, conflicts_with = "no_subspace")]
    pub(crate) subspace: bool,
    /// Never train a basis just for reporting subspace colours.
    #[arg(long)]
    pub(crate) no_subspace: bool,
    /// Wall-clock cap in seconds, counted from the start: the iterative parts (joint design) stop at it,
    /// and --feasibility analyses no unmet cell after it (those are reported as not analysed).
    #[arg(long, default_value_t = 60.0, value_name = "SECONDS")]
    pub(crate) time_limit: f64,
    /// Print only the summary and the unmet cells, not the per-cell table.
    #[arg(short, long)]
    pub(crate) quiet: bool,
    /// For every unmet cell, say whether its target is reachable at all while the other cells of its
    /// designed spectrum keep their colours (the cell's metamer mismatch region), how far it is, and the
    /// closest reachable colour.
    #[arg(long)]
    pub(crate) feasibility: bool,
    /// Replace OUT and the report even when they are read-only files (their mode is kept) or when OUT is
    /// the palette and another program changed it while the solve ran.
    #[arg(long)]
    pub(crate) force: bool,
    /// How far (ΔE) the other cells may move for --feasibility.
    #[arg(long, default_value_t = design::feasibility::DEFAULT_TOLERANCE, value_name = "DELTA_E", requires = "feasibility")]
    pub(crate) tolerance: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let started = Instant::now();
    let file = PaletteFile::load(&args.input)?;
    let palette = &file.palette;
    let colorimetry = Colorimetry::default();
    let sidecar = basis::sidecar_path(&args.input);
    // No output may be an input or another output (compared as files, not as strings). The solved palette
    // may be IN itself (an in-place solve), but nothing else may.
    let mut files = crate::fsio::Outputs::new();
    file.record_inputs("palette", &mut files);
    files.input("basis sidecar", &sidecar);
    if let Some(out) = &args.output {
        files.output_except("solved palette", out, &args.input)?;
    }
    if let Some(report) = &args.report {
        files.output("report", report)?;
    }
    let uses = palette_uses_basis(palette);
    // The solve's own subspace criteria need the basis of the spectra it starts from.
    let basis = if uses {
        Some(
            basis_for_palette(palette, Some(&sidecar))
                .with_context(|| format!("{}: settings need the trained basis", args.input.display()))?,
        )
    } else {
        None
    };
    if !(args.time_limit.is_finite() && args.time_limit > 0.0) {
        anyhow::bail!("--time-limit must be a positive number of seconds, got {}", args.time_limit);
    }
    let options = SolveOptions {
        time_limit: Duration::try_from_secs_f64(args.time_limit).unwrap_or(Duration::MAX),
        cancel: None,
    };
    let replace = if args.force { crate::fsio::Replace::Force } else { crate::fsio::Replace::Writable };
    // With -o, the solved palette's text is formatted on the pool as soon as the spectra are solved, beside
    // the solve's last part (cells, diagnostics); it is written and synced below. The report's spectra rows
    // need only the solved spectra: with -o they are rendered beside the text (a run with the report alone
    // formats nothing inside the solve's time).
    let before_solve = started.elapsed();
    let (mut solution, early) =
        design::solve_with_then(palette, basis.as_ref().map(|b| &b.0), &colorimetry, &options, true, |solved| {
            let Some(out) = args.output.as_ref() else {
                return Early::default();
            };
            let (prepared, spectra) = rayon::join(
                || file.prepare_save_to_end(solved, out),
                || {
                    args.report.is_some().then(|| {
                        let bad = Unphysical::of(solved);
                        let pieces = spectra_pieces(&spectrum_rows(solved, &bad));
                        (bad, pieces)
                    })
                },
            );
            Early { prepared: Some(prepared), spectra }
        })
        .with_context(|| format!("{}: the design cannot be solved", args.input.display()))?;
    let after_solve = Instant::now();
    let Early { prepared, spectra: early_spectra } = early;
    // Subspace colours for the report: always the basis of the *solved* spectra (the one basis policy,
    // the basis that rendering the solved palette and the designer use).
    let spectra = palette.lights.len() + palette.reflectances.len();
    let want_subspace = uses || (!args.no_subspace && (args.subspace || spectra <= AUTO_SUBSPACE_SPECTRA));
    let mut notes = Vec::new();
    let mut basis_warning = None;
    if want_subspace {
        match basis_for_palette(&solution.palette, Some(&sidecar)) {
            Ok(resolved) => {
                let (b, report) = &*resolved;
                solution.set_subspace(b, &colorimetry);
                basis_warning = report.poor_model();
            }
            Err(e) => notes.push(format!("no subspace colours: {e}")),
        }
    }
    if !(args.tolerance.is_finite() && args.tolerance >= 0.0) {
        anyhow::bail!("--tolerance must be a finite ΔE ≥ 0, got {}", args.tolerance);
    }
    // `seconds` is the time to read and solve. The solved palette and the report are written and synced
    // (mostly waiting for the disk) in parallel with each other and with the table's formatting, then put in
    // place together: when either cannot be written, neither replaces anything and nothing is printed.
    // The solve's own time, not the wait for the solved palette's text when that took longer.
    let solve_seconds = Duration::try_from_secs_f64(solution.seconds).unwrap_or_default();
    let seconds = (before_solve + solve_seconds + after_solve.elapsed()).as_secs_f64();
    let feasibility = args.feasibility.then(|| {
        let deadline = started.checked_add(options.time_limit);
        let basis = basis.as_ref().map(|b| &b.0);
        feasibility_of(&solution, basis, &colorimetry, args.tolerance, deadline, args.time_limit)
    });
    let saved_context = |out: &Path| format!("{}: cannot write the solved palette", out.display());
    // The solved palette is staged on a thread of its own: its text was formatted on the pool's threads, and
    // its write and fsync (mostly waiting for the disk) then block that thread, not a pool thread. The report
    // is staged on this thread meanwhile, the table formatted on a third. (Staging it from a thread started
    // inside the solve was measured slower: 0.984 and 1.008 of the previous binary's wall in two runs, against
    // 0.927 and 1.000 without; docs/solve_performance.md.)
    let (unphysical, spectra_pieces) = match early_spectra {
        Some((bad, pieces)) => (bad, Some(pieces)),
        None => (Unphysical::of(&solution.palette), None),
    };
    // Taken by the thread that finishes it (a closure of `beside` must be `Copy`).
    let prepared = std::sync::Mutex::new(prepared);
    let spectra_pieces = std::sync::Mutex::new(spectra_pieces);
    // Both renames first, then each distinct folder synced once (one sync when both outputs share a
    // folder, as they usually do); a failed second commit still syncs the first's folder (on drop).
    let commit = |saved: anyhow::Result<Option<crate::palette::StagedEnd>>,
                  report: anyhow::Result<Option<crate::fsio::Staged>>|
     -> anyhow::Result<()> {
        let (saved, report) = (saved?, report?);
        let mut folders = crate::fsio::FolderSync::default();
        if let (Some(staged), Some(out)) = (saved, &args.output) {
            // The command ends here: the file need not become what was written (its new text joined, its new
            // palette built).
            staged.commit_only_in(&mut folders).with_context(|| saved_context(out))?;
        }
        if let Some(staged) = report {
            staged.commit_in(&mut folders).context("cannot write the report")?;
        }
        folders.sync();
        Ok(())
    };
    // The table is formatted on a thread of its own, but only once the report's text is written (or at once
    // without a report): formatting it (12 M instructions for 3600 cells) while the report's cells rows render
    // and both outputs are copied into the page cache took a core from the outputs' path, and the report's
    // fsync, the renames and the folder's fsync leave both cores idle. Its cells' rows are formatted in pieces
    // on the pool ([`cell_rows`]): on one thread they often took longer than those syncs (2.4 ms against
    // 0.6–2 ms on the 1200-design batch), and the command waited for the table at its end.
    let report_written = Gate::default();
    let (committed, table) = std::thread::scope(|scope| {
        // Opens the gate however the report's staging ends (written, failed, or a panic unwinding).
        let opens = report_written.opener();
        if args.report.is_none() {
            opens.open();
        }
        let saved = beside(scope, |_| {
            let prepared = prepared.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
            match (prepared, &args.output) {
                (Some(prepared), Some(out)) => {
                    prepared.and_then(|p| p.stage_to_end(replace)).map(Some).with_context(|| saved_context(out))
                }
                _ => Ok(None),
            }
        });
        let table = beside(scope, |own_thread| {
            // Run here and now (no thread could be started), it must not wait for what follows it.
            if own_thread {
                report_written.wait();
            }
            let mut t = table_text(&solution, &unphysical, &notes, basis_warning.as_deref(), args.quiet);
            for f in feasibility.iter().flatten() {
                let _ = writeln!(t, "feasibility: {}", f.line);
            }
            // Names in the table are the user's: control characters are shown escaped. Here rather than
            // when it is printed, after the outputs are in place.
            match crate::fsio::escape_lines(&t) {
                std::borrow::Cow::Borrowed(_) => t,
                std::borrow::Cow::Owned(escaped) => escaped,
            }
        });
        let report = match &args.report {
            Some(path) => {
                let mut report = Report::new(&solution, &unphysical, seconds);
                report.basis_warning = basis_warning.as_deref();
                report.feasibility = feasibility.as_deref();
                if let Some(pieces) = spectra_pieces.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take() {
                    report.spectra.rendered(pieces);
                }
                // Serialised straight into the staged file (its long arrays in pieces, in parallel); the
                // table starts once the text is written, while the file syncs.
                stage_report(path, replace, &report, || opens.open()).map(Some)
            }
            None => Ok(None),
        };
        drop(opens);
        // The outputs are put in place while the table may still be rendered (it is printed after them).
        let committed = commit(saved.join(), report);
        (committed, table.join())
    });
    committed?;
    let printed = print_table(&table, &solution, args.output.as_deref(), seconds);
    // The process ends here: the model, the solution and the table are left to the exit rather than freed
    // one allocation at a time (a 1200-design batch's are about 1 M instructions of `free`, after every
    // output is in place and printed).
    std::mem::forget((file, solution, table));
    printed
}

/// What `metamer solve` renders inside the solve ([`design::solve_with_then`]) with -o: the solved palette's
/// text, and with --report too the report's spectra rows with the flags they were rendered with.
#[derive(Default)]
struct Early {
    prepared: Option<Result<PreparedEnd, PaletteError>>,
    spectra: Option<(Unphysical, Vec<std::io::Result<Vec<u8>>>)>,
}

/// Work started on a thread of its own ([`beside`]), or already done.
enum Beside<'scope, T> {
    Thread(std::thread::ScopedJoinHandle<'scope, T>),
    Done(T),
}

impl<T> Beside<'_, T> {
    /// The work's result (a panic in it goes on here).
    fn join(self) -> T {
        match self {
            Beside::Thread(handle) => handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
            Beside::Done(result) => result,
        }
    }
}

/// `work` on a thread of its own in `scope`, or here and now when no thread can be started; `work` is told
/// which (`true`: its own thread).
fn beside<'scope, T: Send + 'scope>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    work: impl FnOnce(bool) -> T + Send + Copy + 'scope,
) -> Beside<'scope, T> {
    match std::thread::Builder::new().spawn_scoped(scope, move || work(true)) {
        Ok(handle) => Beside::Thread(handle),
        Err(_) => Beside::Done(work(false)),
    }
}

/// A one-way gate: [`Gate::wait`] returns once [`Gate::open`] was called (at once after).
#[derive(Default)]
struct Gate {
    open: std::sync::Mutex<bool>,
    opened: std::sync::Condvar,
}

impl Gate {
    fn open(&self) {
        *self.open.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = true;
        self.opened.notify_all();
    }

    fn wait(&self) {
        let mut open = self.open.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        while !*open {
            open = self.opened.wait(open).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
    }

    /// Opens the gate when told to or, at the latest, when dropped (an error or a panic on the way), so
    /// that a thread waiting for it is never left waiting.
    fn opener(&self) -> GateOpener<'_> {
        GateOpener(self)
    }
}

/// See [`Gate::opener`].
struct GateOpener<'a>(&'a Gate);

impl GateOpener<'_> {
    fn open(&self) {
        self.0.open();
    }
}

impl Drop for GateOpener<'_> {
    fn drop(&mut self) {
        self.0.open();
    }
}

/// A row's columns from the target on (as `#rrggbb`, then linear), the full model's colour and ΔE00, the
/// subspace's or `-`: written straight into the table's text ([`push_fixed`], [`crate::colorimetry::push_hex`]) rather than
/// through the standard formatter, which took 25 M of the 37.5 M instructions a 3600-cell table took to
/// format (callgrind, `RAYON_NUM_THREADS=1`).
fn colour_columns(w: &mut String, r: &design::CellResult) {
    crate::colorimetry::push_hex(w, &r.target);
    w.push_str("  ");
    for v in [&r.target, &r.rgb_full] {
        push_rgb(w, v);
        w.push(' ');
    }
    push_fixed_right(w, r.delta_e_full, 2, 7);
    w.push(' ');
    match (r.rgb_subspace, r.delta_e_subspace) {
        (Some(c), Some(d)) => {
            push_rgb(w, &c);
            w.push(' ');
            push_fixed_right(w, d, 2, 7);
        }
        _ => w.push_str("-                            -"),
    }
}

/// `r g b` with four decimals, padded to 22 characters (the numbers are ASCII: a byte is a character).
fn push_rgb(w: &mut String, c: &Vector3<f64>) {
    let at = w.len();
    push_fixed(w, c[0], 4);
    w.push(' ');
    push_fixed(w, c[1], 4);
    w.push(' ');
    push_fixed(w, c[2], 4);
    push_blanks(w, 22usize.saturating_sub(w.len() - at));
}

/// `x` with `decimals` decimals, as `Fixed(x, decimals)` displays it (and so as `format!("{x:.decimals$}")`).
fn push_fixed(w: &mut String, x: f64, decimals: usize) {
    match Fixed(x, decimals).fast_digits() {
        Some((bytes, at)) => push_ascii(w, &bytes[at..]),
        None => {
            let _ = write!(w, "{}", Fixed(x, decimals));
        }
    }
}

/// As [`push_fixed`], right-aligned in `width` characters (`{:>width$}` of `Fixed`).
fn push_fixed_right(w: &mut String, x: f64, decimals: usize, width: usize) {
    match Fixed(x, decimals).fast_digits() {
        Some((bytes, at)) => {
            push_blanks(w, width.saturating_sub(bytes.len() - at));
            push_ascii(w, &bytes[at..]);
        }
        None => {
            let _ = write!(w, "{:>width$}", Fixed(x, decimals));
        }
    }
}

/// Digits, points and signs written by [`Fixed::fast_digits`] (ASCII), a character a byte (`str::from_utf8` of
/// a number's few bytes took more instructions than pushing them one by one).
fn push_ascii(w: &mut String, bytes: &[u8]) {
    w.extend(bytes.iter().map(|&b| char::from(b)));
}

/// Blanks to pad the table's columns with.
const BLANKS: &str = "                                ";

/// `n` blanks.
fn push_blanks(w: &mut String, mut n: usize) {
    while n > 0 {
        let k = n.min(BLANKS.len());
        w.push_str(&BLANKS[..k]);
        n -= k;
    }
}

/// Pad `w` with spaces from `from` to `width` characters.
fn pad(w: &mut String, from: usize, width: usize) {
    let used = w[from..].chars().count();
    push_blanks(w, width.saturating_sub(used));
}

/// What the table's columns and remarks mean, printed above it.
pub(crate) const TABLE_LEGEND: &str = "\
columns: light, reflectance = the cell; target = its target as #rrggbb (display sRGB) and as linear sRGB;
  full = the achieved linear sRGB of the full 31-sample model, then its CIEDE2000 (ΔE00) from the target;
  subspace = the same in the m-D spectral factor model the renderer uses (- without a basis).
remarks: (not used) = weight 0 or use = false, left out of the design; unphysical = a designed spectrum of the
  cell leaves [0, 1] (reflectance) or goes below 0 (light), which no surface or lamp can do (turn bounds on).
summary: objective = the weighted sum of squares minimised; KKT residual = distance from the optimality
  conditions (0 at the exact optimum); remarks = remark lines naming a cell. Formats: docs/formats/report.md";

/// Samples of a physical spectrum may miss [0, 1] (reflectance) or 0 (light) by this much (rounding at a bound).
const PHYSICAL_SLACK: f64 = 1e-6;

/// The (lowest, highest) sample of a designed spectrum that is not physical: a reflectance outside [0, 1] or
/// a light below 0. `None` for fixed spectra (the user's own data) and for physical designs.
pub(crate) fn unphysical_range(e: &SpectrumEntry) -> Option<(f64, f64)> {
    if !e.design {
        return None;
    }
    let x = e.spectrum.as_slice();
    let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let bad = match e.kind {
        crate::palette::Kind::Reflectance => lo < -PHYSICAL_SLACK || hi > 1.0 + PHYSICAL_SLACK || !hi.is_finite(),
        crate::palette::Kind::Light => lo < -PHYSICAL_SLACK || !hi.is_finite(),
    };
    bad.then_some((lo, hi))
}

/// Which designed spectra are not physical ([`unphysical_range`]), found once per spectrum for the table
/// and the report alike (a batch's 3600 cells would otherwise scan their two spectra's samples each).
pub(crate) struct Unphysical {
    lights: Vec<bool>,
    reflectances: Vec<bool>,
}

impl Unphysical {
    pub(crate) fn of(p: &Palette) -> Self {
        let bad = |list: &[SpectrumEntry]| list.iter().map(|e| unphysical_range(e).is_some()).collect();
        Unphysical { lights: bad(&p.lights), reflectances: bad(&p.reflectances) }
    }

    /// A cell whose light or reflectance is an unphysical design.
    fn cell(&self, c: &crate::palette::ColourCell) -> bool {
        self.lights[c.light] || self.reflectances[c.reflectance]
    }

    /// A mixture cell one of whose lights, or whose reflectance, is an unphysical design.
    fn mixture(&self, m: &crate::palette::MixtureCell) -> bool {
        m.mix.iter().any(|&(i, _)| self.lights[i]) || self.reflectances[m.reflectance]
    }
}

/// A line per designed spectrum that is not physical.
fn unphysical_lines(w: &mut String, p: &crate::palette::Palette) {
    for e in p.lights.iter().chain(&p.reflectances) {
        if let Some((lo, hi)) = unphysical_range(e) {
            let (kind, range, fix) = match e.kind {
                crate::palette::Kind::Reflectance => {
                    ("reflectance", "outside [0, 1]", "reflectance_bounds = [0.0, 1.0]")
                }
                crate::palette::Kind::Light => ("light", "below 0", "light_bounds = [0.0, inf]"),
            };
            let _ = writeln!(
                w,
                "unphysical: designed {kind} {:?} ranges {} … {}, {range}: no real {} does that (set {fix} in \
                 [settings], or bounds on the spectrum)",
                e.name,
                Fixed(lo, 3),
                Fixed(hi, 3),
                if kind == "light" { "lamp" } else { "surface" }
            );
        }
    }
}

/// Cells' rows a piece of the table: a few hundred microseconds of formatting each.
const TABLE_PIECE: usize = 600;

/// The per-cell table (unless `quiet`) and the remark lines: everything printed but the summary.
fn table_text(s: &Solution, bad: &Unphysical, notes: &[String], basis_warning: Option<&str>, quiet: bool) -> String {
    let palette = &s.palette;
    let mut w = String::with_capacity(if quiet { 0 } else { 130 * (s.cells.len() + 1) } + 200 * s.diagnostics.len());
    if !quiet {
        w.push_str(TABLE_LEGEND);
        w.push('\n');
        let _ = writeln!(
            w,
            "{:<14} {:<14} {:<8} {:<22} {:<22} {:>7} {:<22} {:>7}",
            "light", "reflectance", "target", "target (linear)", "full", "ΔE00", "subspace", "ΔE00"
        );
        w.push_str(&cell_rows(palette, &s.cells, bad, TABLE_PIECE));
        mixture_rows(&mut w, s, bad);
        path_lines(&mut w, s);
    }
    unphysical_lines(&mut w, palette);
    for d in &s.diagnostics {
        let tag = if d.is_unmet() { "UNMET" } else { "note" };
        let _ = writeln!(w, "{tag}: {}", d.message);
    }
    for n in notes {
        let _ = writeln!(w, "note: {n}");
    }
    if let Some(b) = basis_warning {
        let _ = writeln!(w, "WARNING: {b}");
    }
    w
}

/// The table's rows of `cells`, formatted in pieces of `piece` cells on the pool (the table is formatted
/// while the outputs sync, both cores otherwise mostly idle) and joined in order: the same text as one pass.
fn cell_rows(palette: &Palette, cells: &[design::CellResult], bad: &Unphysical, piece: usize) -> String {
    let rows = |cells: &[design::CellResult]| {
        let mut w = String::with_capacity(130 * cells.len());
        for c in cells {
            let cell = &palette.colours[c.cell];
            let at = w.len();
            w.push_str(&palette.lights[cell.light].name);
            pad(&mut w, at, 14);
            w.push(' ');
            let at = w.len();
            w.push_str(&palette.reflectances[cell.reflectance].name);
            pad(&mut w, at, 14);
            w.push(' ');
            colour_columns(&mut w, c);
            if !cell.is_active() {
                w.push_str("  (not used)");
            }
            if bad.cell(cell) {
                w.push_str("  unphysical");
            }
            w.push('\n');
        }
        w
    };
    if cells.len() <= piece {
        return rows(cells);
    }
    use rayon::prelude::*;
    let pieces: Vec<String> = cells.par_chunks(piece.max(1)).map(rows).collect();
    pieces.concat()
}

/// One row per mixture cell, as the cells' rows: the mixture's name in the light column.
fn mixture_rows(w: &mut String, s: &Solution, bad: &Unphysical) {
    let p = &s.palette;
    for r in &s.mixtures {
        let m = &p.mixtures[r.cell];
        let at = w.len();
        w.push_str(&mixing::mix_label(p, &m.spec, &m.mix));
        pad(w, at, 14);
        w.push(' ');
        let at = w.len();
        w.push_str(&p.reflectances[m.reflectance].name);
        pad(w, at, 14);
        w.push(' ');
        colour_columns(w, r);
        if !m.is_active() {
            w.push_str("  (not used)");
        }
        if bad.mixture(m) {
            w.push_str("  unphysical");
        }
        w.push('\n');
    }
}

/// One line per constancy path: the worst ΔE00 found by the dense check after the solve.
fn path_lines(w: &mut String, s: &Solution) {
    let p = &s.palette;
    for r in &s.paths {
        let q = &p.paths[r.path];
        let _ = write!(
            w,
            "path {}: target {} — worst ΔE00 {} over {} positions ({} design samples, {} at them; tolerance {}) at t = {}",
            mixing::path_label(p, q),
            linear_to_hex(&r.target),
            Fixed(r.worst_delta_e, 2),
            r.checked,
            r.samples,
            Fixed(r.worst_at_samples, 2),
            r.tolerance,
            Fixed(r.worst_t, 3),
        );
        if let Some(d) = r.worst_delta_e_subspace {
            let _ = write!(w, "; factor model worst {}", Fixed(d, 2));
        }
        if !q.is_active() {
            w.push_str("  (not used)");
        }
        w.push('\n');
    }
}

/// Print the table (escaped already: [`crate::fsio::escape_lines`] of [`table_text`]) and the summary line.
fn print_table(table: &str, s: &Solution, output: Option<&Path>, seconds: f64) -> anyhow::Result<()> {
    let unmet = s.diagnostics.iter().filter(|d| d.cell.is_some()).count();
    let extra = |n: usize, what: &str, remarks: usize| {
        if n == 0 { String::new() } else { format!(", {n} {what} ({remarks} with remarks)") }
    };
    let with_remarks =
        |f: fn(&Criterion) -> bool| s.diagnostics.iter().filter(|d| d.criterion.as_ref().is_some_and(f)).count();
    let others = extra(s.mixtures.len(), "mixtures", with_remarks(|c| matches!(c, Criterion::Mixture(_))))
        + &extra(s.paths.len(), "paths", with_remarks(|c| matches!(c, Criterion::Path(_))));
    super::out::write(|w| {
        w.write_all(table.as_bytes())?;
        writeln!(
            w,
            "objective {:.6e}, KKT residual {:.1e}, {} cells ({} with remarks){others}, read and solved in {:.3} s{}",
            s.objective,
            s.kkt_residual,
            s.cells.len(),
            unmet,
            seconds,
            match output {
                Some(p) => format!(", solved palette written to {}", crate::fsio::show(p)),
                None => ", solved palette not written (no -o)".into(),
            }
        )
    })?;
    Ok(())
}

/// The JSON report, pretty-printed, and a final newline, written while its long arrays are rendered
/// ([`rendering`]; the command stages it with [`stage_report`]).
#[cfg(test)]
fn write_report(w: &mut impl std::io::Write, report: &Report) -> std::io::Result<()> {
    rendering(report, |report| write_report_value(w, report))
}

/// `write` (the report's serialisation) while the report's long arrays (spectra, cells, diagnostics) are
/// rendered in pieces on the pool's threads ([`Rows::render_in`]): the serialisation writes each piece as it
/// stands as soon as it and those before it are done, the same bytes as serialising the report in one pass
/// ([`Pretty`]), and the file's writes (copies into the page cache, 2.9 MB for a 1200-design batch) overlap
/// the rendering of the pieces after them instead of following the last one. On one of the pool's own
/// threads the pieces are all rendered first (that thread must not wait for work it may hold itself).
fn rendering<T>(report: &Report, write: impl FnOnce(&Report) -> T) -> T {
    fn start<'s>(report: &'s Report, scope: &rayon::Scope<'s>) {
        report.spectra.render_in(scope, SPECTRUM_BYTES);
        report.cells.render_in(scope, CELL_BYTES);
        report.diagnostics.render_in(scope, DIAGNOSTIC_BYTES);
    }
    if rayon::current_thread_index().is_some() {
        rayon::scope(|scope| start(report, scope));
        return write(report);
    }
    rayon::in_place_scope(|scope| {
        start(report, scope);
        write(report)
    })
}

/// The report staged at `path` ([`crate::fsio::stage_writing`]): its pieces start rendering before the
/// staged file is made (its checks and creation, 0.1 ms to a few under load, overlap them). `written` is
/// called once the whole text is in the staged file, before its sync (not when the writing failed).
fn stage_report(
    path: &Path,
    replace: crate::fsio::Replace,
    report: &Report,
    written: impl FnOnce(),
) -> anyhow::Result<crate::fsio::Staged> {
    rendering(report, |report| {
        crate::fsio::stage_writing(path, crate::fsio::Name::User, replace, |w| {
            write_report_value(w, report)?;
            std::io::Write::flush(w)?;
            written();
            Ok(())
        })
    })
    .context("cannot write the report")
}

/// About how many bytes a row of the report takes (a spectrum's 31 samples, a cell, a diagnostic): each
/// piece's buffer is sized for its rows up front (growing them by doubling copied them and faulted in fresh
/// pages twice over).
const SPECTRUM_BYTES: usize = 1100;
const CELL_BYTES: usize = 560;
const DIAGNOSTIC_BYTES: usize = 480;

/// One of the report's long arrays, each of its rows an element. [`Rows::render_in`] serialises the rows
/// in pieces of [`Rows::PIECE`] rows on the pool's threads, each piece as it stands in the report ([`Pretty`]
/// at the array's depth, rows separated as the printer separates them); serialising the array then writes
/// the pieces in order as they are done ([`Pretty::write_byte_array`]), each freed once written. Before
/// `render_in` it serialises as the plain array.
struct Rows<T> {
    items: Vec<T>,
    pieces: Pieces,
}

/// The pieces of a [`Rows`] being rendered: a slot per piece, filled by the thread that renders it and
/// emptied by the serialisation, which waits for it.
#[derive(Default)]
struct Pieces {
    slots: std::sync::Mutex<Vec<Option<std::io::Result<Vec<u8>>>>>,
    /// How many pieces there are (0: not rendered, the rows serialise as they are).
    count: std::sync::atomic::AtomicUsize,
    filled: std::sync::Condvar,
}

impl Pieces {
    fn slots(&self) -> std::sync::MutexGuard<'_, Vec<Option<std::io::Result<Vec<u8>>>>> {
        self.slots.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn count(&self) -> usize {
        self.count.load(std::sync::atomic::Ordering::Acquire)
    }

    fn put(&self, k: usize, piece: std::io::Result<Vec<u8>>) {
        if let Some(slot) = self.slots().get_mut(k) {
            *slot = Some(piece);
        }
        self.filled.notify_all();
    }

    /// Piece `k`, once it is rendered.
    fn take(&self, k: usize) -> std::io::Result<Vec<u8>> {
        let mut slots = self.slots();
        loop {
            match slots.get_mut(k) {
                Some(slot) => {
                    if let Some(piece) = slot.take() {
                        return piece;
                    }
                }
                None => return Err(std::io::Error::other("the report's piece does not exist")),
            }
            slots = self.filled.wait(slots).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
    }
}

/// Fills its piece's slot when dropped without having filled it (its rendering panicked): the
/// serialisation waiting for that piece then fails instead of waiting for ever, and the scope passes the
/// panic on.
struct Filling<'a> {
    pieces: &'a Pieces,
    k: usize,
    done: bool,
}

impl Drop for Filling<'_> {
    fn drop(&mut self) {
        if !self.done {
            self.pieces.put(self.k, Err(std::io::Error::other("a piece of the report was not rendered")));
        }
    }
}

impl<T: Row + Sync> Rows<T> {
    /// Rows a piece: enough work per piece to be worth a task, small enough for two threads to share.
    const PIECE: usize = 96;

    fn new(items: Vec<T>) -> Self {
        Rows { items, pieces: Pieces::default() }
    }

    /// The rows' pieces rendered ahead ([`Rows::pieces`] of these rows, in order): serialising the rows
    /// writes them, and [`Rows::render_in`] leaves them. Pieces that are not these rows' count are not taken.
    fn rendered(&mut self, pieces: Vec<std::io::Result<Vec<u8>>>) {
        if pieces.len() == self.items.len().div_ceil(Self::PIECE) && !pieces.is_empty() {
            let count = pieces.len();
            *self.pieces.slots() = pieces.into_iter().map(Some).collect();
            self.pieces.count.store(count, std::sync::atomic::Ordering::Release);
        }
    }

    /// `rows` rendered into pieces (in parallel), as [`Rows::render_in`] renders them.
    fn pieces(rows: &[T], row_bytes: usize) -> Vec<std::io::Result<Vec<u8>>> {
        use rayon::prelude::*;
        rows.par_chunks(Self::PIECE).map(|rows| Self::piece(rows, row_bytes)).collect()
    }

    /// Start serialising the rows into pieces on `scope`'s threads (see [`Rows`]), unless they were
    /// rendered ahead ([`Rows::rendered`]).
    fn render_in<'s>(&'s self, scope: &rayon::Scope<'s>, row_bytes: usize) {
        if self.pieces.count() > 0 {
            return;
        }
        let count = self.items.len().div_ceil(Self::PIECE);
        *self.pieces.slots() = (0..count).map(|_| None).collect();
        self.pieces.count.store(count, std::sync::atomic::Ordering::Release);
        for (k, rows) in self.items.chunks(Self::PIECE).enumerate() {
            let pieces = &self.pieces;
            scope.spawn(move |_| {
                let mut filling = Filling { pieces, k, done: false };
                let piece = Self::piece(rows, row_bytes);
                filling.done = true;
                pieces.put(k, piece);
            });
        }
    }

    /// `rows` as they stand in the report, separated as the printer separates them.
    fn piece(rows: &[T], row_bytes: usize) -> std::io::Result<Vec<u8>> {
        let mut out = Vec::with_capacity(rows.len() * row_bytes);
        for (k, row) in rows.iter().enumerate() {
            if k > 0 {
                Pretty { level: ROW_LEVEL, has_value: false }.line(&mut out, false)?;
            }
            row.write_row(&mut out)?;
        }
        Ok(out)
    }
}

impl<T: serde::Serialize> serde::Serialize for Rows<T> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::{Error, SerializeSeq};
        let count = self.pieces.count();
        if count == 0 {
            return serializer.collect_seq(&self.items);
        }
        let mut seq = serializer.serialize_seq(Some(count))?;
        for k in 0..count {
            let piece = self.pieces.take(k).map_err(S::Error::custom)?;
            seq.serialize_element(&Piece(&piece))?;
        }
        seq.end()
    }
}

/// The printer's indentation level of the elements of a top-level field's array.
const ROW_LEVEL: usize = 2;

/// A row of one of the report's long arrays ([`Rows`]), written as [`Pretty`] writes it at [`ROW_LEVEL`]
/// (the object's braces and keys included, not the separator before it). The rows of the three long
/// arrays (spectra, cells, diagnostics) are written by hand ([`JsonText`]): the printer's calls per value
/// (a comma and line break, then the value, for each of a spectrum's 31 samples) were half of the
/// report's instructions. The default is the printer itself. Tests compare both ways, row by row and
/// report by report.
trait Row: serde::Serialize {
    fn write_row(&self, out: &mut Vec<u8>) -> std::io::Result<()> {
        let pretty = Pretty { level: ROW_LEVEL, has_value: false };
        self.serialize(&mut serde_json::Serializer::with_formatter(out, pretty)).map_err(std::io::Error::from)
    }
}

impl Row for DiagnosticJson<'_> {
    fn write_row(&self, out: &mut Vec<u8>) -> std::io::Result<()> {
        let mut w = JsonText(out);
        w.raw("{\n      \"cell\": ");
        match &self.cell {
            Some(CellName { light, reflectance }) => {
                w.raw("{\n        \"light\": ");
                w.str(light)?;
                w.raw(",\n        \"reflectance\": ");
                w.str(reflectance)?;
                w.raw("\n      }");
            }
            None => w.raw("null"),
        }
        if let Some(mixture) = &self.mixture {
            w.raw(",\n      \"mixture\": ");
            w.str(mixture)?;
        }
        if let Some(path) = &self.path {
            w.raw(",\n      \"path\": ");
            w.str(path)?;
        }
        w.raw(",\n      \"kind\": ");
        w.str(self.kind)?;
        if let Some(stopped) = self.stopped {
            w.raw(",\n      \"stopped\": ");
            w.str(stopped)?;
        }
        w.raw(",\n      \"message\": ");
        w.str(self.message)?;
        w.raw("\n    }");
        Ok(())
    }
}

/// JSON text written by hand into a report row: the layout (keys, line breaks, indentation) is the row's
/// own, every string and number is written by serde_json's own serializer (its escapes, its shortest
/// round-trip digits, `null` for a number that is not finite), so each is what the printer writes.
struct JsonText<'a>(&'a mut Vec<u8>);

impl JsonText<'_> {
    fn raw(&mut self, text: &str) {
        self.0.extend_from_slice(text.as_bytes());
    }

    fn str(&mut self, value: &str) -> std::io::Result<()> {
        use serde::Serializer as _;
        (&mut serde_json::Serializer::new(&mut *self.0)).serialize_str(value).map_err(std::io::Error::from)
    }

    fn f64(&mut self, value: f64) -> std::io::Result<()> {
        use serde::Serializer as _;
        (&mut serde_json::Serializer::new(&mut *self.0)).serialize_f64(value).map_err(std::io::Error::from)
    }

    fn bool(&mut self, value: bool) {
        self.raw(if value { "true" } else { "false" });
    }

    fn opt_str(&mut self, value: Option<&str>) -> std::io::Result<()> {
        match value {
            Some(v) => self.str(v),
            None => {
                self.raw("null");
                Ok(())
            }
        }
    }

    fn opt_f64(&mut self, value: Option<f64>) -> std::io::Result<()> {
        match value {
            Some(v) => self.f64(v),
            None => {
                self.raw("null");
                Ok(())
            }
        }
    }

    /// An array of numbers that is the value of a key of a row (its elements three levels deep).
    fn numbers(&mut self, values: &[f64]) -> std::io::Result<()> {
        let Some((last, first)) = values.split_last() else {
            self.raw("[]");
            return Ok(());
        };
        self.raw("[");
        for &v in first {
            self.raw("\n        ");
            self.f64(v)?;
            self.raw(",");
        }
        self.raw("\n        ");
        self.f64(*last)?;
        self.raw("\n      ]");
        Ok(())
    }
}

impl Row for SpectrumJson<'_> {
    fn write_row(&self, out: &mut Vec<u8>) -> std::io::Result<()> {
        let mut w = JsonText(out);
        w.raw("{\n      \"name\": ");
        w.str(self.name)?;
        w.raw(",\n      \"kind\": ");
        w.str(self.kind)?;
        w.raw(",\n      \"design\": ");
        w.bool(self.design);
        w.raw(",\n      \"samples\": ");
        w.numbers(self.samples)?;
        w.raw(",\n      \"unphysical\": ");
        w.bool(self.unphysical);
        w.raw("\n    }");
        Ok(())
    }
}

impl Row for CellJson<'_> {
    fn write_row(&self, out: &mut Vec<u8>) -> std::io::Result<()> {
        let mut w = JsonText(out);
        let c = &self.colours;
        w.raw("{\n      \"light\": ");
        w.str(self.light)?;
        w.raw(",\n      \"reflectance\": ");
        w.str(self.reflectance)?;
        w.raw(",\n      \"target\": ");
        w.numbers(&c.target)?;
        w.raw(",\n      \"rgb_full\": ");
        w.numbers(&c.rgb_full)?;
        w.raw(",\n      \"rgb_subspace\": ");
        match &c.rgb_subspace {
            Some(v) => w.numbers(v)?,
            None => w.raw("null"),
        }
        w.raw(",\n      \"delta_e_full\": ");
        w.f64(c.delta_e_full)?;
        w.raw(",\n      \"delta_e_subspace\": ");
        w.opt_f64(c.delta_e_subspace)?;
        w.raw(",\n      \"free\": ");
        w.opt_str(self.free)?;
        w.raw(",\n      \"weight\": ");
        w.f64(self.weight)?;
        w.raw(",\n      \"enabled\": ");
        w.bool(self.enabled);
        w.raw(",\n      \"unphysical\": ");
        w.bool(self.unphysical);
        w.raw("\n    }");
        Ok(())
    }
}

/// Rows serialised ahead ([`Rows::render`]): written as they are by [`Pretty::write_byte_array`].
struct Piece<'a>(&'a [u8]);

impl serde::Serialize for Piece<'_> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_bytes(self.0)
    }
}

/// `value` as pretty JSON ([`Pretty`]) and a final line feed.
fn write_report_value(w: &mut impl std::io::Write, value: &impl serde::Serialize) -> std::io::Result<()> {
    let mut serializer = serde_json::Serializer::with_formatter(&mut *w, Pretty::default());
    value.serialize(&mut serializer).map_err(std::io::Error::from)?;
    w.write_all(b"\n")
}

/// serde_json's `PrettyFormatter` (two spaces an indent level), byte for byte, writing a line break and
/// its indentation in one write instead of one write per level: the indentation's writes were a fifth of
/// the report's instructions (a report holds some 400 000 indented lines).
#[derive(Default)]
struct Pretty {
    level: usize,
    has_value: bool,
}

impl Pretty {
    /// `,` (unless `first`), a line break and the current indentation.
    fn line<W: ?Sized + std::io::Write>(&self, w: &mut W, first: bool) -> std::io::Result<()> {
        /// A comma, a line feed and enough blanks for 64 levels.
        const LINE: [u8; 130] = {
            let mut line = [b' '; 130];
            line[0] = b',';
            line[1] = b'\n';
            line
        };
        let from = usize::from(first);
        match LINE.get(from..2 + 2 * self.level) {
            Some(line) => w.write_all(line),
            None => {
                w.write_all(&LINE[from..2])?;
                (0..self.level).try_for_each(|_| w.write_all(b"  "))
            }
        }
    }
}

impl serde_json::ser::Formatter for Pretty {
    fn begin_array<W: ?Sized + std::io::Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        self.level += 1;
        self.has_value = false;
        w.write_all(b"[")
    }

    fn end_array<W: ?Sized + std::io::Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        self.level -= 1;
        if self.has_value {
            self.line(w, true)?;
        }
        w.write_all(b"]")
    }

    fn begin_array_value<W: ?Sized + std::io::Write>(&mut self, w: &mut W, first: bool) -> std::io::Result<()> {
        self.line(w, first)
    }

    fn end_array_value<W: ?Sized + std::io::Write>(&mut self, _w: &mut W) -> std::io::Result<()> {
        self.has_value = true;
        Ok(())
    }

    fn begin_object<W: ?Sized + std::io::Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        self.level += 1;
        self.has_value = false;
        w.write_all(b"{")
    }

    fn end_object<W: ?Sized + std::io::Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        self.level -= 1;
        if self.has_value {
            self.line(w, true)?;
        }
        w.write_all(b"}")
    }

    fn begin_object_key<W: ?Sized + std::io::Write>(&mut self, w: &mut W, first: bool) -> std::io::Result<()> {
        self.line(w, first)
    }

    fn begin_object_value<W: ?Sized + std::io::Write>(&mut self, w: &mut W) -> std::io::Result<()> {
        w.write_all(b": ")
    }

    fn end_object_value<W: ?Sized + std::io::Write>(&mut self, _w: &mut W) -> std::io::Result<()> {
        self.has_value = true;
        Ok(())
    }

    /// Not serde_json's: a byte array here is JSON text serialised ahead by this printer (a [`Piece`] of
    /// [`Rows`]), written as it is. Nothing else in the report serialises bytes.
    fn write_byte_array<W: ?Sized + std::io::Write>(&mut self, w: &mut W, value: &[u8]) -> std::io::Result<()> {
        w.write_all(value)
    }
}

/// The report's spectra rows of palette `p`: its lights, then its reflectances.
fn spectrum_rows<'a>(p: &'a Palette, bad: &Unphysical) -> Vec<SpectrumJson<'a>> {
    (p.lights.iter().zip(&bad.lights))
        .chain(p.reflectances.iter().zip(&bad.reflectances))
        .map(|(e, &bad)| SpectrumJson::new(e, bad))
        .collect()
}

/// The report's spectra rows rendered ahead, as the report renders them ([`Rows::rendered`]).
fn spectra_pieces(rows: &[SpectrumJson<'_>]) -> Vec<std::io::Result<Vec<u8>>> {
    Rows::pieces(rows, SPECTRUM_BYTES)
}

/// One spectrum of the report.
#[derive(serde::Serialize)]
struct SpectrumJson<'a> {
    name: &'a str,
    kind: &'static str,
    design: bool,
    samples: &'a [f64],
    /// A designed reflectance outside [0, 1] or a designed light below 0 (see [`unphysical_range`]).
    unphysical: bool,
}

impl<'a> SpectrumJson<'a> {
    /// `unphysical`: [`unphysical_range`] of `e` is some.
    fn new(e: &'a SpectrumEntry, unphysical: bool) -> Self {
        SpectrumJson {
            name: &e.name,
            kind: e.kind.as_str(),
            design: e.design,
            samples: e.spectrum.as_slice(),
            unphysical,
        }
    }
}

#[derive(serde::Serialize)]
struct FreeJson<'a> {
    name: &'a str,
    rgb: [f64; 3],
}

#[derive(serde::Serialize)]
struct CellJson<'a> {
    light: &'a str,
    reflectance: &'a str,
    #[serde(flatten)]
    colours: ColoursJson,
    free: Option<&'a str>,
    weight: f64,
    enabled: bool,
    /// The cell's light or reflectance is an unphysical design.
    unphysical: bool,
}

/// A cell's or a mixture's target, colours and errors in the report (flattened into its row).
#[derive(serde::Serialize)]
struct ColoursJson {
    target: [f64; 3],
    rgb_full: [f64; 3],
    rgb_subspace: Option<[f64; 3]>,
    delta_e_full: f64,
    delta_e_subspace: Option<f64>,
}

impl ColoursJson {
    fn new(r: &design::CellResult) -> ColoursJson {
        ColoursJson {
            target: arr(&r.target),
            rgb_full: arr(&r.rgb_full),
            rgb_subspace: r.rgb_subspace.as_ref().map(arr),
            delta_e_full: r.delta_e_full,
            delta_e_subspace: r.delta_e_subspace,
        }
    }
}

/// A mixture cell in the report: its name, its weights and how they were given, then the cell's colours.
#[derive(serde::Serialize)]
struct MixtureJson<'a> {
    /// A readable name: `REFLECTANCE × dial(x, y)` or `REFLECTANCE × mix(…)`.
    name: String,
    reflectance: &'a str,
    /// The weight of every light with a weight > 0.
    mix: std::collections::BTreeMap<&'a str, f64>,
    /// The dial position, when the mixture was given as one.
    #[serde(skip_serializing_if = "Option::is_none")]
    dial: Option<[f64; 2]>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    off: Vec<&'a str>,
    #[serde(flatten)]
    colours: ColoursJson,
    free: Option<&'a str>,
    weight: f64,
    enabled: bool,
    unphysical: bool,
}

/// A constancy path in the report: the dense check after the solve.
#[derive(serde::Serialize)]
struct PathJson<'a> {
    name: String,
    reflectance: &'a str,
    target: [f64; 3],
    free: Option<&'a str>,
    samples: usize,
    checked: usize,
    tolerance: f64,
    worst_delta_e: f64,
    worst_at_samples: f64,
    worst_t: f64,
    worst_point: [f64; 2],
    worst_rgb: [f64; 3],
    worst_delta_e_subspace: Option<f64>,
    met: bool,
    weight: f64,
    enabled: bool,
}

#[derive(serde::Serialize)]
struct CellName<'a> {
    light: &'a str,
    reflectance: &'a str,
}

#[derive(serde::Serialize)]
struct DiagnosticJson<'a> {
    cell: Option<CellName<'a>>,
    /// The mixture (`mixtures[i].name`) or path (`paths[i].name`) it is about.
    #[serde(skip_serializing_if = "Option::is_none")]
    mixture: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    path: Option<String>,
    /// [`crate::design::DiagnosticKind::name`].
    kind: &'static str,
    /// Why a joint block stopped early (`stopped_early` only): "time limit", "cancelled", …
    #[serde(skip_serializing_if = "Option::is_none")]
    stopped: Option<&'static str>,
    message: &'a str,
}

impl<'a> DiagnosticJson<'a> {
    fn new(d: &'a crate::design::Diagnostic, cell: Option<CellName<'a>>, p: &Palette) -> Self {
        let stopped = match d.kind {
            crate::design::DiagnosticKind::StoppedEarly(why) => Some(why.as_str()),
            _ => None,
        };
        let (mixture, path) = match d.criterion {
            Some(Criterion::Mixture(k)) => (Some(mixture_name(p, k)), None),
            Some(Criterion::Path(k)) => (None, Some(mixing::path_label(p, &p.paths[k]))),
            None => (None, None),
        };
        DiagnosticJson { cell, mixture, path, kind: d.kind.name(), stopped, message: &d.message }
    }
}

/// `REFLECTANCE × MIXTURE`.
fn mixture_name(p: &Palette, k: usize) -> String {
    let m = &p.mixtures[k];
    format!("{} × {}", p.reflectances[m.reflectance].name, mixing::mix_label(p, &m.spec, &m.mix))
}

/// The JSON report (DESIGN_SPEC §5) plus `kkt_residual`, `diagnostics`, per-cell `weight`/`enabled` and
/// `unphysical` on spectra and cells.
#[derive(serde::Serialize)]
pub(crate) struct Report<'a> {
    palette: &'a str,
    objective: f64,
    /// Wall time to read and solve the palette (writing the outputs not included).
    seconds: f64,
    /// Wall time of the solve itself.
    solve_seconds: f64,
    kkt_residual: f64,
    spectra: Rows<SpectrumJson<'a>>,
    free: Vec<FreeJson<'a>>,
    cells: Rows<CellJson<'a>>,
    /// Criteria under mixtures of lights (`[[mixtures]]`), absent when there are none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    mixtures: Vec<MixtureJson<'a>>,
    /// Constancy paths (`[[paths]]`), absent when there are none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    paths: Vec<PathJson<'a>>,
    diagnostics: Rows<DiagnosticJson<'a>>,
    /// Set when the factor model behind `rgb_subspace` is poor on the solved spectra's own pairs
    /// ([`crate::basis::Report::poor_model`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    basis_warning: Option<&'a str>,
    /// With `--feasibility`: one entry per unmet cell.
    #[serde(skip_serializing_if = "Option::is_none")]
    feasibility: Option<&'a [FeasibilityJson]>,
}

/// The feasibility of one unmet cell's target (`--feasibility`).
#[derive(serde::Serialize)]
pub(crate) struct FeasibilityJson {
    light: String,
    reflectance: String,
    /// "inside" (in the inner region: reachable with the other cells held), "on" (within 0.05 ΔE00 of
    /// its boundary), "undecided" (between the inner and the outer region), "outside" (outside the
    /// outer region: not met by any solution), or null when the region cannot be computed (see `line`).
    placement: Option<&'static str>,
    /// ΔE00 to the inner region's boundary: negative inside, positive outside it.
    signed_delta_e: Option<f64>,
    /// The closest reachable colour (linear sRGB).
    closest: Option<[f64; 3]>,
    /// Reachable when the other cells of the spectrum are released.
    reachable_alone: Option<bool>,
    /// Cells that, released one at a time, make the target reachable ("light × reflectance").
    reachable_if_moves: Vec<String>,
    tolerance: f64,
    volume_lab: Option<f64>,
    l_range: Option<[f64; 2]>,
    /// The line printed in the table.
    line: String,
}

/// The feasibility of every unmet cell of a solution (in parallel; regions shared by one cache).
fn feasibility_of(
    s: &Solution,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    tolerance: f64,
    deadline: Option<std::time::Instant>,
    time_limit: f64,
) -> Vec<FeasibilityJson> {
    use design::feasibility::{self as fz, RegionCache};
    use rayon::prelude::*;
    let p = &s.palette;
    let values = s.values();
    let cache = RegionCache::default();
    let unmet: Vec<usize> = s.unmet_cells().map(|c| c.cell).collect();
    unmet
        .par_iter()
        .map(|&k| {
            let c = &p.colours[k];
            let mut out = FeasibilityJson {
                light: p.lights[c.light].name.clone(),
                reflectance: p.reflectances[c.reflectance].name.clone(),
                placement: None,
                signed_delta_e: None,
                closest: None,
                reachable_alone: None,
                reachable_if_moves: Vec::new(),
                tolerance,
                volume_lab: None,
                l_range: None,
                line: String::new(),
            };
            // A cell is begun only before the deadline (one cell's analysis, a fraction of a second to a
            // few seconds, may run past it on each thread); the rest are reported, not silently dropped.
            if deadline.is_some_and(|d| std::time::Instant::now() >= d) {
                out.line = format!(
                    "cell {}: not analysed: the time limit ({time_limit} s, --time-limit) was reached",
                    fz::cell_label(p, k)
                );
                return out;
            }
            let analysed = fz::Problem::new(p, basis, colorimetry, &values, k, tolerance)
                .and_then(|problem| fz::analyse(&problem, &cache, fz::DEFAULT_DIRECTIONS));
            match analysed {
                Ok(f) => {
                    out.placement = Some(f.verdict.placement.as_str());
                    out.signed_delta_e = Some(f.verdict.signed_delta_e).filter(|v| v.is_finite());
                    out.closest = Some(arr(&f.verdict.closest));
                    out.reachable_alone = Some(f.reachable_alone);
                    out.reachable_if_moves = f.blockers.iter().map(|&b| fz::cell_label(p, b)).collect();
                    out.volume_lab = Some(f.region.volume_lab).filter(|v| v.is_finite());
                    out.l_range = Some([f.region.l_range.0, f.region.l_range.1]);
                    out.line = fz::describe(p, &f, tolerance);
                }
                Err(e) => out.line = format!("cell {}: no region: {e}", fz::cell_label(p, k)),
            }
            out
        })
        .collect()
}

fn arr(c: &Vector3<f64>) -> [f64; 3] {
    [c[0], c[1], c[2]]
}

impl<'a> Report<'a> {
    /// The report of a solution (names, cells and spectra as the solved palette has them).
    pub fn new(s: &'a Solution, bad: &Unphysical, seconds: f64) -> Self {
        let p = &s.palette;
        let names = |k: usize| {
            let c = &p.colours[k];
            CellName { light: &p.lights[c.light].name, reflectance: &p.reflectances[c.reflectance].name }
        };
        Report {
            palette: &p.name,
            objective: s.objective,
            seconds,
            solve_seconds: s.seconds,
            kkt_residual: s.kkt_residual,
            spectra: Rows::new(spectrum_rows(p, bad)),
            free: p.free.iter().zip(&s.free).map(|(g, c)| FreeJson { name: &g.name, rgb: arr(c) }).collect(),
            cells: Rows::new(
                s.cells
                    .iter()
                    .map(|c| {
                        let cell = &p.colours[c.cell];
                        let CellName { light, reflectance } = names(c.cell);
                        CellJson {
                            light,
                            reflectance,
                            colours: ColoursJson::new(c),
                            free: cell.free.map(|g| p.free[g].name.as_str()),
                            weight: cell.weight,
                            enabled: cell.enabled,
                            unphysical: bad.cell(cell),
                        }
                    })
                    .collect(),
            ),
            mixtures: s
                .mixtures
                .iter()
                .map(|r| {
                    let m = &p.mixtures[r.cell];
                    let (dial, off) = match &m.spec {
                        MixSpec::Dial { at, off } => {
                            (Some(*at), off.iter().map(|&i| p.lights[i].name.as_str()).collect())
                        }
                        MixSpec::Weights => (None, Vec::new()),
                    };
                    MixtureJson {
                        name: mixture_name(p, r.cell),
                        reflectance: &p.reflectances[m.reflectance].name,
                        mix: m.mix.iter().map(|&(i, w)| (p.lights[i].name.as_str(), w)).collect(),
                        dial,
                        off,
                        colours: ColoursJson::new(r),
                        free: m.free.map(|g| p.free[g].name.as_str()),
                        weight: m.weight,
                        enabled: m.enabled,
                        unphysical: bad.mixture(m),
                    }
                })
                .collect(),
            paths: s
                .paths
                .iter()
                .map(|r| {
                    let q = &p.paths[r.path];
                    PathJson {
                        name: mixing::path_label(p, q),
                        reflectance: &p.reflectances[q.reflectance].name,
                        target: arr(&r.target),
                        free: q.free.map(|g| p.free[g].name.as_str()),
                        samples: r.samples,
                        checked: r.checked,
                        tolerance: r.tolerance,
                        worst_delta_e: r.worst_delta_e,
                        worst_at_samples: r.worst_at_samples,
                        worst_t: r.worst_t,
                        worst_point: r.worst_point,
                        worst_rgb: arr(&r.worst_rgb),
                        worst_delta_e_subspace: r.worst_delta_e_subspace,
                        met: !r.is_unmet(),
                        weight: q.weight,
                        enabled: q.enabled,
                    }
                })
                .collect(),
            diagnostics: Rows::new(
                s.diagnostics.iter().map(|d| DiagnosticJson::new(d, d.cell.map(names), p)).collect(),
            ),
            basis_warning: None,
            feasibility: None,
        }
    }
}

#[cfg(test)]
mod tests {
    /// The table's numbers written by hand ([`super::push_fixed`], [`super::push_fixed_right`],
    /// `colorimetry::push_hex`) are what `Fixed`, `format!` and `{:02x}` write: every decimal count (7 is past
    /// `Fixed`'s fast case), both signs of zero, numbers that round to zero, halves and near-halves (exact
    /// path), the fast case's upper end, numbers that are not finite, and a sweep of the colours a table
    /// shows.
    #[test]
    fn table_numbers_written_by_hand_are_fixeds() {
        use crate::design::Fixed;
        use std::fmt::Write as _;
        let mut numbers = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.5,
            0.125,
            0.00005,
            -0.00005,
            0.00004999,
            -0.00001,
            1.00005,
            2.675,
            0.045,
            9.99995,
            99.995,
            1e-300,
            -5e-324,
            1234567.891,
            (1u64 << 40) as f64 / 10_000.0,
            (1u64 << 40) as f64 / 10_000.0 - 0.0001,
            1.1e12,
            1e20,
            -3.4e38,
            f64::MAX,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        for k in 0..20_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let unit = (seed >> 11) as f64 / (1u64 << 53) as f64;
            numbers.push(match k % 4 {
                0 => unit * 1.2 - 0.1,
                1 => unit * 120.0,
                2 => -unit * 3.0,
                _ => (unit * 2.0e4).round() / 2.0e4,
            });
        }
        for &x in &numbers {
            for decimals in 0..=7 {
                let mut ours = String::new();
                super::push_fixed(&mut ours, x, decimals);
                assert_eq!(ours, format!("{}", Fixed(x, decimals)), "{x:e} with {decimals} decimals");
                assert_eq!(ours, format!("{x:.decimals$}"), "{x:e} with {decimals} decimals");
                let mut right = String::from("|");
                super::push_fixed_right(&mut right, x, decimals, 7);
                let mut theirs = String::from("|");
                let _ = write!(theirs, "{:>7}", Fixed(x, decimals));
                assert_eq!(right, theirs, "{x:e} with {decimals} decimals, width 7");
            }
            let c = nalgebra::Vector3::new(x, x * 0.5, 1.0 - x);
            let mut hex = String::new();
            crate::colorimetry::push_hex(&mut hex, &c);
            let [r, g, b] = crate::colorimetry::linear_to_srgb8(&c);
            assert_eq!(hex, format!("#{r:02x}{g:02x}{b:02x}"), "{x:e}");
        }
    }

    /// The report's formatter writes what serde_json's pretty printer writes, deep nesting and empty
    /// containers included.
    #[test]
    fn the_report_formatter_is_serde_jsons_pretty_printer() {
        let mut deep = serde_json::json!([1.5, {"a": []}]);
        for i in 0..70 {
            deep = serde_json::json!({ "level": i, "inner": deep, "empty": {}, "list": [[], [0.25, -3e-9]] });
        }
        for value in [serde_json::json!({}), serde_json::json!([]), serde_json::json!(null), deep] {
            let mut ours = Vec::new();
            super::write_report_value(&mut ours, &value).unwrap();
            let mut theirs = serde_json::to_vec_pretty(&value).unwrap();
            theirs.push(b'\n');
            assert_eq!(String::from_utf8(ours).unwrap(), String::from_utf8(theirs).unwrap());
        }
    }

    /// The rows written by hand ([`super::Row`]) are the printer's rows: names that need escapes (quotes,
    /// backslashes, control characters, bidirectional controls, non-ASCII), numbers that are not finite, of
    /// every magnitude and both signs of zero, empty and one-element sample lists, cells with and without
    /// subspace colours and free colours.
    #[test]
    fn rows_written_by_hand_are_the_printers_rows() {
        use super::{CellJson, ColoursJson, Pretty, ROW_LEVEL, Row, SpectrumJson};
        fn printer(row: &impl serde::Serialize) -> Vec<u8> {
            let mut out = Vec::new();
            let pretty = Pretty { level: ROW_LEVEL, has_value: false };
            row.serialize(&mut serde_json::Serializer::with_formatter(&mut out, pretty)).unwrap();
            out
        }
        fn by_hand(row: &impl Row) -> Vec<u8> {
            let mut out = Vec::new();
            row.write_row(&mut out).unwrap();
            out
        }
        let names = ["r0", "", "a \"quoted\" \\ name", "tab\there\nnew line\u{1}\u{7f}", "ΔE ×\u{202e}rtl", "/slash"];
        let numbers = [
            0.0,
            -0.0,
            1.0,
            -1.5,
            0.1,
            1e-7,
            1.9414804882152623e-6,
            123456789012345680.0,
            1e300,
            f64::MIN_POSITIVE,
            5e-324,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let sample_lists: [&[f64]; 4] = [&[], &[0.5], &numbers, &[f64::NAN, 0.25]];
        for (k, name) in names.iter().enumerate() {
            for samples in sample_lists {
                let row =
                    SpectrumJson { name, kind: "reflectance", design: k % 2 == 0, samples, unphysical: k % 3 == 0 };
                assert_eq!(String::from_utf8(by_hand(&row)).unwrap(), String::from_utf8(printer(&row)).unwrap());
            }
            for (j, &x) in numbers.iter().enumerate() {
                let y = numbers[(j + k) % numbers.len()];
                let row = CellJson {
                    light: name,
                    reflectance: names[(k + 1) % names.len()],
                    colours: ColoursJson {
                        target: [x, y, 0.5],
                        rgb_full: [y, x, -0.0],
                        rgb_subspace: (j % 2 == 0).then_some([x, 1.0, y]),
                        delta_e_full: y,
                        delta_e_subspace: (j % 3 != 0).then_some(x),
                    },
                    free: (j % 2 == 1).then_some(names[j % names.len()]),
                    weight: x,
                    enabled: j % 2 == 0,
                    unphysical: j % 5 == 0,
                };
                assert_eq!(String::from_utf8(by_hand(&row)).unwrap(), String::from_utf8(printer(&row)).unwrap());
            }
        }
    }

    /// Diagnostics written by hand are the printer's: with and without a cell, a mixture, a path and why
    /// a block stopped, messages needing escapes.
    #[test]
    fn diagnostics_written_by_hand_are_the_printers() {
        use super::{CellName, DiagnosticJson, Pretty, ROW_LEVEL, Row};
        let messages = ["cell D65 × r0 not met (ΔE00 1.65)", "", "\"quoted\" \\ \u{1b}[31m\t\r\n\u{2028}"];
        for k in 0..32 {
            let message = messages[k % messages.len()];
            let row = DiagnosticJson {
                cell: (k % 2 == 0).then_some(CellName { light: message, reflectance: "r\"1" }),
                mixture: (k % 4 < 2).then(|| format!("r{k} × dial(0.5, {message})")),
                path: (k % 8 < 4).then(|| format!("path {k}\u{0}")),
                kind: if k % 3 == 0 { "unmet" } else { "stopped_early" },
                stopped: (k % 16 < 8).then_some("time limit"),
                message,
            };
            let mut printer = Vec::new();
            let pretty = Pretty { level: ROW_LEVEL, has_value: false };
            serde::Serialize::serialize(&row, &mut serde_json::Serializer::with_formatter(&mut printer, pretty))
                .unwrap();
            let mut by_hand = Vec::new();
            row.write_row(&mut by_hand).unwrap();
            assert_eq!(String::from_utf8(by_hand).unwrap(), String::from_utf8(printer).unwrap());
        }
    }

    /// A piece whose rendering panics fails the serialisation waiting for it instead of leaving it
    /// waiting for ever; the panic then goes on to the caller. The pieces before it are written.
    #[test]
    fn a_piece_that_panics_does_not_leave_the_writer_waiting() {
        #[derive(serde::Serialize)]
        struct Boom(bool);
        impl super::Row for Boom {
            fn write_row(&self, out: &mut Vec<u8>) -> std::io::Result<()> {
                assert!(!self.0, "this row cannot be written");
                out.extend_from_slice(b"0");
                Ok(())
            }
        }
        let rows = super::Rows::new((0..500).map(|k| Boom(k == 300)).collect());
        let mut written = Vec::new();
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            rayon::in_place_scope(|scope| {
                rows.render_in(scope, 1);
                let mut serializer = serde_json::Serializer::with_formatter(&mut written, super::Pretty::default());
                serde::Serialize::serialize(&rows, &mut serializer).map_err(|e| e.to_string())
            })
        }));
        assert!(outcome.is_err(), "the panic reaches the caller");
        // The three pieces before the one that panicked (rows 0 to 287) were written, and no other.
        assert_eq!(written.iter().filter(|&&b| b == b'0').count(), 3 * super::Rows::<Boom>::PIECE);
    }

    /// A random batch of `designs` bounded designs (seed `seed`) solved, and its unphysical entries.
    fn solved_batch(designs: usize, seed: u64) -> (crate::design::Solution, super::Unphysical) {
        let colorimetry = crate::colorimetry::Colorimetry::default();
        let palette = crate::palette::random::batch_palette(designs, seed, &colorimetry);
        let solution =
            crate::design::solve(&palette, None, &colorimetry, &crate::design::SolveOptions::default()).unwrap();
        let bad = super::Unphysical::of(&solution.palette);
        (solution, bad)
    }

    /// The table's cell rows formatted in pieces are the rows formatted in one pass: pieces of 7 and of the
    /// command's size over a batch of 900 cells.
    #[test]
    fn the_tables_rows_in_pieces_are_the_rows_in_one_pass() {
        let (solution, bad) = solved_batch(300, 5);
        assert!(solution.cells.len() > super::TABLE_PIECE, "{} cells", solution.cells.len());
        let one = super::cell_rows(&solution.palette, &solution.cells, &bad, usize::MAX);
        assert_eq!(one.lines().count(), solution.cells.len());
        for piece in [7, super::TABLE_PIECE] {
            assert_eq!(super::cell_rows(&solution.palette, &solution.cells, &bad, piece), one, "pieces of {piece}");
        }
    }

    /// The report written with its long arrays in pieces ([`super::Rows`]) is byte for byte serde_json's
    /// pretty printer of the same report in one pass: a random batch (more rows than a piece in every
    /// array: spectra, cells and diagnostics), and shipped palettes with mixtures, paths and free colours.
    #[test]
    fn the_report_in_pieces_is_the_report_in_one_pass() {
        use crate::colorimetry::Colorimetry;
        use crate::design::{self, SolveOptions};
        let colorimetry = Colorimetry::default();
        let mut palettes = vec![crate::palette::random::batch_palette(150, 7, &colorimetry)];
        for name in ["dial_mixtures", "constancy", "metamers"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("palettes/{name}.toml"));
            palettes.push(crate::palette::PaletteFile::load(&path).unwrap().palette);
        }
        for palette in &palettes {
            let solution = design::solve(palette, None, &colorimetry, &SolveOptions::default()).unwrap();
            let report = super::Report::new(&solution, &super::Unphysical::of(&solution.palette), 0.25);
            let mut theirs = serde_json::to_vec_pretty(&report).unwrap();
            theirs.push(b'\n');
            let mut ours = Vec::new();
            super::write_report(&mut ours, &report).unwrap();
            assert!(report.cells.pieces.count() > 1 || palette.colours.len() <= 96);
            assert_eq!(
                String::from_utf8(ours).unwrap(),
                String::from_utf8(theirs.clone()).unwrap(),
                "{}",
                palette.name
            );
            // The spectra rows rendered ahead (as `metamer solve -o` renders them inside the solve) give the
            // same report.
            let bad = super::Unphysical::of(&solution.palette);
            let mut ahead = super::Report::new(&solution, &bad, 0.25);
            ahead.spectra.rendered(super::spectra_pieces(&super::spectrum_rows(&solution.palette, &bad)));
            assert_eq!(ahead.spectra.pieces.count(), ahead.spectra.items.len().div_ceil(96));
            let mut ours = Vec::new();
            super::write_report(&mut ours, &ahead).unwrap();
            assert_eq!(String::from_utf8(ours).unwrap(), String::from_utf8(theirs).unwrap(), "{}", palette.name);
        }
    }

    #[test]
    fn a_gate_lets_its_waiter_through_when_opened_or_when_its_opener_is_dropped() {
        let through = |open: &dyn Fn(super::GateOpener<'_>)| {
            let gate = super::Gate::default();
            let (tx, rx) = std::sync::mpsc::channel();
            std::thread::scope(|scope| {
                let opener = gate.opener();
                let gate = &gate;
                scope.spawn(move || {
                    gate.wait();
                    let _ = tx.send(());
                });
                assert!(rx.recv_timeout(std::time::Duration::from_millis(50)).is_err(), "the waiter waits");
                open(opener);
                let passed = rx.recv_timeout(std::time::Duration::from_secs(20)).is_ok();
                // A waiter left waiting would hold the scope: let it through before failing.
                gate.open();
                passed
            })
        };
        assert!(through(&|opener| opener.open()), "opened");
        assert!(through(&|opener| drop(opener)), "its opener dropped (an error or a panic on the way)");
        // Once open, a later wait returns at once.
        let gate = super::Gate::default();
        gate.opener().open();
        gate.wait();
    }

    #[test]
    fn the_reports_text_is_whole_in_its_staged_file_when_the_table_is_let_through() {
        let (solution, bad) = solved_batch(300, 11);
        let mut whole = Vec::new();
        super::write_report(&mut whole, &super::Report::new(&solution, &bad, 0.25)).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.json");
        let report = super::Report::new(&solution, &bad, 0.25);
        // The staged file's content when `written` is called: the whole report, not yet in place.
        let mut seen = None;
        let staged = super::stage_report(&path, crate::fsio::Replace::Writable, &report, || {
            let staged: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().path()).collect();
            assert_eq!(staged.len(), 1, "{staged:?}");
            seen = Some(std::fs::read(&staged[0]).unwrap());
        })
        .unwrap();
        assert!(!path.exists(), "staged, not in place");
        assert!(whole.len() > 100_000, "a report of several pieces");
        assert!(seen.as_ref() == Some(&whole), "the report's text is whole in the staged file when written is called");
        staged.commit().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), whole);
        // A report that cannot be staged never calls it.
        let nowhere = dir.path().join("no such folder").join("r.json");
        let mut called = false;
        assert!(super::stage_report(&nowhere, crate::fsio::Replace::Writable, &report, || called = true).is_err());
        assert!(!called);
    }

    /// The solved palette prepared inside the solve and staged to its end ([`PreparedEnd::stage_to_end`],
    /// what `metamer solve -o` does) is the save staged in place, by tables and through the whole document;
    /// a save that cannot be staged fails and writes nothing.
    #[test]
    fn a_save_staged_to_its_end_is_the_save_and_a_failed_one_writes_nothing() {
        use crate::colorimetry::Colorimetry;
        use crate::design::{self, SolveOptions};
        use crate::fsio::Replace;
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.toml");
        let shipped = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/metamers.toml");
        std::fs::copy(&shipped, &input).unwrap();
        let file = crate::palette::PaletteFile::load(&input).unwrap();
        let solved = design::solve(&file.palette, None, &Colorimetry::default(), &SolveOptions::default()).unwrap();
        let to_end = |palette: &crate::palette::Palette, out: &std::path::Path| {
            file.prepare_save_to_end(palette, out).and_then(|p| p.stage_to_end(Replace::Writable))
        };
        let (here, there) = (dir.path().join("here.toml"), dir.path().join("there.toml"));
        file.stage_save_as(&solved.palette, &here, Replace::Writable)
            .unwrap()
            .commit_only_in(&mut Default::default())
            .unwrap();
        let mut folders = crate::fsio::FolderSync::default();
        to_end(&solved.palette, &there).unwrap().commit_only_in(&mut folders).unwrap();
        folders.sync();
        assert_eq!(std::fs::read(&there).unwrap(), std::fs::read(&here).unwrap());
        // A save through the whole document (the palette renamed: not a save by tables) too.
        let mut renamed = solved.palette.clone();
        renamed.name = "renamed".into();
        let (whole_here, whole_there) = (dir.path().join("whole_here.toml"), dir.path().join("whole_there.toml"));
        file.stage_save_as(&renamed, &whole_here, Replace::Writable)
            .unwrap()
            .commit_only_in(&mut Default::default())
            .unwrap();
        to_end(&renamed, &whole_there).unwrap().commit_only_in(&mut Default::default()).unwrap();
        assert_eq!(std::fs::read(&whole_there).unwrap(), std::fs::read(&whole_here).unwrap());
        assert_ne!(std::fs::read(&whole_there).unwrap(), std::fs::read(&here).unwrap());
        let files = || {
            let mut names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
            names.sort();
            names
        };
        let before = files();
        // An output in a folder that does not exist cannot be staged: it fails and writes nothing.
        let nowhere = dir.path().join("no such folder").join("out.toml");
        assert!(to_end(&solved.palette, &nowhere).is_err());
        assert_eq!(files(), before);
    }
}
