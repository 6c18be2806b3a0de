//! The design engine (seed §3, DESIGN_SPEC §2): stacked weighted least squares over the samples of every
//! designed spectrum and the free colours, an SVD solve, then bounds by L-BFGS-B.
//!
//! Interface pinned for the other modules (TUI, CLI, renderer); the engine fills it in.
//!
//! * [`system`]: assembly of the exact objective (rows, bounds, blocks; [`layout`]: blocks, stacked layout);
//! * [`lsq`]: minimum-norm SVD least squares, then L-BFGS-B and an exact active-set finish under bounds;
//! * [`lbfgsb`]: L-BFGS-B as an argmin `Solver`;
//! * [`joint`]: bilinear blocks (light and reflectance both designed);
//! * [`solve`](mod@solve): blocks in parallel, shared factorisations;
//! * [`report`]: per-cell colours (full and spectral-factor-model) and diagnostics.
//!
//! A palette that uses `fit_in_subspace` or `subspace_error > 0` needs a basis: without one,
//! [`solve()`] returns [`DesignError::Invalid`] saying so. Without a basis the subspace colours of
//! [`CellResult`] are `None`.
//!
//! `Solution::kkt_residual` is the largest over the blocks of the projected-gradient infinity norm
//! `‖x − P(x − ∇f(x))‖∞` divided by `1 + ‖∇f(0)‖∞` (linear blocks) or `1 + f(x)` (bilinear blocks).

pub mod feasibility;

/// A cell's name, in the one order used everywhere (designer, diagnostics, reports): the light first,
/// then the reflectance it lights — `daylight × petal`.
pub fn cell_name(light: &str, reflectance: &str) -> String {
    format!("{light} × {reflectance}")
}
pub(crate) mod joint;
pub(crate) mod layout;
pub(crate) mod lbfgsb;
pub(crate) mod lsq;
pub(crate) mod report;
pub(crate) mod solve;
pub(crate) mod system;

pub use joint::{JointLimits, NonlinearProblem};
pub use report::{Fixed, pair_colours};
pub use solve::{solve_all, solve_dense};
pub use system::{Design, Layout, Unit, Values};

use crate::basis::Basis;
use crate::colorimetry::Colorimetry;
use crate::palette::{Palette, Source, SpectrumEntry};
use crate::spectrum::Normalize;
use nalgebra::Vector3;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Options of a solve.
#[derive(Clone, Debug)]
pub struct SolveOptions {
    /// Wall-clock cap for the iterative parts (joint bilinear design, L-BFGS-B).
    pub time_limit: Duration,
    /// Set to true from another thread to abandon the solve (the TUI drops stale work this way).
    pub cancel: Option<Arc<AtomicBool>>,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions { time_limit: Duration::from_secs(10), cancel: None }
    }
}

/// Whether a cell's target is met.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CellStatus {
    /// The cell is not used (weight 0 or `use = false`): it has no say in the design.
    NotUsed,
    /// Its full colour is within [`report::MET_DELTA_E`] (CIEDE2000) of its target.
    Met,
    /// It is not; [`Solution::diagnostics`] says why.
    Unmet,
}

/// The colours of one cell at the solution: computed once by the solve ([`report::cell_results`]) and
/// drawn by the CLI's table, the JSON report and the designer's cells.
#[derive(Clone, Debug, PartialEq)]
pub struct CellResult {
    /// Index into `palette.colours`.
    pub cell: usize,
    /// The target (a free cell's target is its group's colour), linear sRGB.
    pub target: Vector3<f64>,
    /// Full 31-sample colour.
    pub rgb_full: Vector3<f64>,
    /// Subspace (spectral factor model) colour, when a basis was given.
    pub rgb_subspace: Option<Vector3<f64>>,
    /// CIEDE2000 of the full colour from the target (under the cell's light); `f64::MAX` when not finite.
    pub delta_e_full: f64,
    /// CIEDE2000 of the subspace colour from the target, when a basis was given; `f64::MAX` when not finite.
    pub delta_e_subspace: Option<f64>,
    pub(crate) status: CellStatus,
}

/// What a [`Diagnostic`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiagnosticKind {
    /// A cell whose target is not met (ΔE00 above [`report::MET_DELTA_E`], or its light is zero), with the
    /// reason and, where one is known, the closest reachable colour.
    Unmet,
    /// A cell that appears more than once (light × reflectance): both count.
    Duplicate,
    /// A designed spectrum that no active cell uses: only smoothness acts on it.
    Unused,
    /// The solve produced non-finite values; the starting spectra were returned.
    NonFinite,
    /// A joint block stopped before converging (time limit, cancel); its best solution was returned.
    StoppedEarly(crate::optimize::Termination),
}

impl DiagnosticKind {
    /// The kind's name in the JSON report (`kind`: `unmet`, `duplicate`, `unused`, `non_finite`,
    /// `stopped_early`).
    pub fn name(self) -> &'static str {
        match self {
            DiagnosticKind::Unmet => "unmet",
            DiagnosticKind::Duplicate => "duplicate",
            DiagnosticKind::Unused => "unused",
            DiagnosticKind::NonFinite => "non_finite",
            DiagnosticKind::StoppedEarly(_) => "stopped_early",
        }
    }
}

/// A criterion that is not an ordinary light × reflectance cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Criterion {
    /// `palette.mixtures[k]`.
    Mixture(usize),
    /// `palette.paths[k]`.
    Path(usize),
}

/// Something the user should know about a design: a cell that cannot be met and why, a degenerate input…
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// Index into `palette.colours` when it is about one cell.
    pub cell: Option<usize>,
    /// The mixture or path it is about (then `cell` is `None`).
    pub criterion: Option<Criterion>,
    /// What the diagnostic is about (unmet, duplicate, unused, non-finite, stopped early).
    pub kind: DiagnosticKind,
    /// The sentence shown to the user (the table's remark, the report's `message`).
    pub message: String,
}

impl Diagnostic {
    /// True for an unmet cell ([`DiagnosticKind::Unmet`]).
    pub fn is_unmet(&self) -> bool {
        self.kind == DiagnosticKind::Unmet
    }
}

/// The result of a solve.
#[derive(Clone, Debug)]
pub struct Solution {
    /// The palette with every designed spectrum replaced by its solution.
    pub palette: Palette,
    /// One colour per free group (same order as `palette.free`).
    pub free: Vec<Vector3<f64>>,
    /// The pinned objective (DESIGN_SPEC §2) at the returned solution.
    pub objective: f64,
    /// Largest violation of the first-order (KKT) conditions, scaled.
    pub kkt_residual: f64,
    /// Wall-clock seconds of the whole solve, checks and report included.
    pub seconds: f64,
    /// One per `palette.colours` entry, in the same order (`CellResult::cell` indexes `palette.colours`).
    pub cells: Vec<CellResult>,
    /// One per `palette.mixtures` entry (`CellResult::cell` indexes `palette.mixtures`).
    pub mixtures: Vec<CellResult>,
    /// One per `palette.paths` entry: the colour checked densely along the path.
    pub paths: Vec<PathResult>,
    /// Remarks on the result, in this order: non-finite values, blocks stopped early, then the cells', the
    /// mixtures' and the paths' (unmet, duplicate, unused).
    pub diagnostics: Vec<Diagnostic>,
}

/// The colour of a path's reflectance checked densely along the path after the solve.
#[derive(Clone, Debug, PartialEq)]
pub struct PathResult {
    /// Index into `palette.paths`.
    pub path: usize,
    /// The target (a free path's is its group's colour), linear sRGB.
    pub target: Vector3<f64>,
    /// The positions the design used (both ends included).
    pub samples: usize,
    /// The positions checked after the solve (evenly along the path, the samples among them).
    pub checked: usize,
    /// The largest ΔE00 of the full colour from the target over the checked positions.
    pub worst_delta_e: f64,
    /// The largest over the design samples alone.
    pub worst_at_samples: f64,
    /// Where the worst is: `t` in [0, 1] along the path, and the slider's point there.
    pub worst_t: f64,
    /// The slider's point in dial coordinates at `worst_t` (`[0, 0]` when the path could not be evaluated).
    pub worst_point: [f64; 2],
    /// The full colour at the worst position.
    pub worst_rgb: Vector3<f64>,
    /// The largest ΔE00 of the factor-model colour over the checked positions, when a basis was given.
    pub worst_delta_e_subspace: Option<f64>,
    /// The largest ΔE00 allowed anywhere along the path (the path's `tolerance`).
    pub tolerance: f64,
    pub(crate) status: CellStatus,
}

impl PathResult {
    /// True when the path is used and its worst ΔE00 is above its tolerance.
    pub fn is_unmet(&self) -> bool {
        self.status == CellStatus::Unmet
    }
}

impl Solution {
    /// `palette` with its designed spectra replaced by this solution's, matched by side, position and name
    /// (a spectrum renamed, added or no longer designed since the solve keeps its own). The solved spectra
    /// are samples, never normalised or scaled again (DESIGN_SPEC §1, §3). This is what a designer saves.
    pub fn apply_to(&self, palette: &Palette) -> Palette {
        let mut out = palette.clone();
        for (own, solved) in
            [(&mut out.lights, &self.palette.lights), (&mut out.reflectances, &self.palette.reflectances)]
        {
            for (e, s) in own.iter_mut().zip(solved) {
                if e.design && e.name == s.name {
                    *e = s.clone();
                }
            }
        }
        out
    }
}

/// Why a solve failed outright (as opposed to a design that is merely infeasible, which is reported in
/// [`Solution::diagnostics`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DesignError {
    /// The solve's cancel flag was set, before it started or while it ran; there is no solution.
    #[error("the solve was cancelled")]
    Cancelled,
    /// The palette cannot be designed (a number too large, a reference that does not exist, a non-finite
    /// objective): the whole message, naming the key where there is one.
    #[error("{0}")]
    Invalid(String),
}

/// Solve a palette's design.
///
/// Returns the optimum of the pinned objective (DESIGN_SPEC §2) for palettes without bilinear cells
/// (exactly, up to rounding), a local optimum reached by a monotone descent for joint designs, and
/// diagnostics for cells that cannot be met. Cancelling returns [`DesignError::Cancelled`]; reaching
/// the time limit returns the best solution so far with a diagnostic.
pub fn solve(
    palette: &Palette,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    options: &SolveOptions,
) -> Result<Solution, DesignError> {
    solve_with(palette, basis, colorimetry, options, true)
}

/// [`solve()`] with block parallelism switchable (benchmarks compare both).
pub fn solve_with(
    palette: &Palette,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    options: &SolveOptions,
    parallel: bool,
) -> Result<Solution, DesignError> {
    solve_with_then(palette, basis, colorimetry, options, parallel, |_| ()).map(|(solution, ())| solution)
}

/// [`solve_with`], and `then` run on the solved palette ([`Solution::palette`]) as soon as the spectra are
/// solved, beside the solve's last part (the objective, the cells' colours, the diagnostics) when
/// `parallel`, on the pool: a command formats an output of the solved palette there (the solved palette's
/// text) while the rest of the solution is computed. The solution is the same, bit for bit; `then` is not
/// run when the solve is cancelled or fails before its last part, and its result is dropped when that part
/// fails.
pub fn solve_with_then<T: Send>(
    palette: &Palette,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    options: &SolveOptions,
    parallel: bool,
    then: impl FnOnce(&Palette) -> T + Send,
) -> Result<(Solution, T), DesignError> {
    let started = Instant::now();
    if parallel {
        // The whole solve on the pool: its serial parts then run on a worker and its joins and parallel
        // loops start from there, where a caller outside the pool (a command's main thread) would hand
        // each of them to the pool and wait for it, a thread woken and one put to sleep each time.
        rayon::scope(|_| solve_from(palette, basis, colorimetry, options, parallel, then, started))
    } else {
        solve_from(palette, basis, colorimetry, options, parallel, then, started)
    }
}

/// [`solve_with_then`]'s work, its time counted from `started`.
fn solve_from<T: Send>(
    palette: &Palette,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    options: &SolveOptions,
    parallel: bool,
    then: impl FnOnce(&Palette) -> T + Send,
    started: Instant,
) -> Result<(Solution, T), DesignError> {
    let cancelled = || options.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed));
    if cancelled() {
        return Err(DesignError::Cancelled);
    }
    // Numbers whose products overflow are input errors, named by key (a palette from a file was checked
    // when read; this covers palettes built or edited in memory). On the pool the check runs beside the
    // terms' building, whose result is dropped when the check fails (its error is the one returned, as when
    // the check runs first; the building does no more than read the palette).
    let invalid = |e: crate::palette::ScaleError| DesignError::Invalid(e.to_string());
    let design = if parallel {
        let (scale, design) =
            rayon::join(|| palette.check_scale(), || system::Design::new(palette, basis, colorimetry));
        scale.map_err(invalid)?;
        design?
    } else {
        palette.check_scale().map_err(invalid)?;
        system::Design::new(palette, basis, colorimetry)?
    };
    // A huge time limit saturates (it cannot overflow `Instant`).
    let deadline = started.checked_add(options.time_limit).unwrap_or_else(|| far_future(started));
    let limits = joint::JointLimits::new(deadline, options.cancel.clone());
    // The start values (and the copy the blocks write their solutions into) beside the blocks.
    let start_and_copy = || {
        let start = design.start_values();
        let copy = start.clone();
        (start, copy)
    };
    let ((start, mut values), units) =
        if parallel { rayon::join(start_and_copy, || design.blocks()) } else { (start_and_copy(), design.blocks()) };
    let blocks = solve::solve_all_into(&design, &units, &start, &mut values, &limits, parallel);
    if cancelled() {
        return Err(DesignError::Cancelled);
    }
    let all_finite = values.lights.iter().chain(&values.reflectances).all(|s| s.is_finite())
        && values.free.iter().all(|f| f.iter().all(|v| v.is_finite()));
    let mut diagnostics = Vec::new();
    let values = if all_finite {
        values
    } else {
        diagnostics.push(Diagnostic {
            cell: None,
            criterion: None,
            kind: DiagnosticKind::NonFinite,
            message: "the solve produced non-finite values; the starting spectra are returned unchanged".into(),
        });
        start
    };
    // The rest of the solution, which `then` does not need.
    let rest = || -> Result<Solution, DesignError> {
        for b in &blocks {
            if let Some(why) = b.stopped {
                diagnostics.push(Diagnostic {
                    cell: None,
                    criterion: None,
                    kind: DiagnosticKind::StoppedEarly(why),
                    message: format!(
                        "joint design of {} unknown spectra stopped early ({why}); objective {:.6e} is the best found",
                        b.spectra, b.objective
                    ),
                });
            }
        }
        // The cells' colours beside the objective's smoothness part, then its terms' part, which takes the
        // cells' full colours from them (the same products, with the same matrix) instead of making them
        // again: what is left of it is a residual a term, summed in order.
        let cells_pass = || report::cell_results(palette, basis, colorimetry, &values);
        let (cells, smoothness) = if parallel {
            rayon::join(cells_pass, || design.smoothness_objective(&values, parallel))
        } else {
            (cells_pass(), design.smoothness_objective(&values, parallel))
        };
        let objective =
            design.terms_objective_with_colours(&values, parallel, &|k| cells.get(k).map(|c| c.rgb_full)) + smoothness;
        if !objective.is_finite() {
            return Err(DesignError::Invalid(format!(
                "the objective at the solution is {objective}, not a finite number: the palette's values are too \
                 large or too far apart in scale for the design"
            )));
        }
        let kkt_residual = blocks.iter().map(|b| b.kkt).fold(0.0, f64::max);
        let mixtures = report::mixture_results(palette, basis, colorimetry, &values);
        let paths = report::path_results(palette, basis, colorimetry, &values);
        diagnostics.extend(report::diagnostics(&design, colorimetry, &values, &cells));
        diagnostics.extend(report::mixture_diagnostics(&design, colorimetry, &values, &mixtures));
        diagnostics.extend(report::path_diagnostics(palette, &paths));
        Ok(Solution {
            // The solved palette is put in below.
            palette: Palette::default(),
            free: values.free.clone(),
            objective,
            kkt_residual,
            // The solve's own time: not the wait for `then`, when that takes longer.
            seconds: started.elapsed().as_secs_f64(),
            cells,
            mixtures,
            paths,
            diagnostics,
        })
    };
    // The solved palette (a copy of the palette with the new spectra) is built beside the rest too: it is
    // `then`'s input only.
    let with_solved = || {
        let solved = solved_palette(palette, &values);
        let t = then(&solved);
        (solved, t)
    };
    let ((solved, then), rest) = if parallel { rayon::join(with_solved, rest) } else { (with_solved(), rest()) };
    let mut solution = rest?;
    solution.palette = solved;
    Ok((solution, then))
}

/// `palette` with every designed spectrum replaced by its value in `values`, given as samples. A designed
/// entry is built anew rather than cloned and then changed (its old source, samples from a file for a batch,
/// would be copied only to be dropped: 1200 copies on the solve's serial part).
fn solved_palette(palette: &Palette, values: &system::Values) -> Palette {
    let entries = |entries: &[SpectrumEntry], spectra: &[crate::spectrum::Spectrum]| -> Vec<SpectrumEntry> {
        entries
            .iter()
            .zip(spectra)
            .map(|(e, s)| match e.design {
                true => SpectrumEntry {
                    name: e.name.clone(),
                    kind: e.kind,
                    source: Source::Samples(s.to_vec()),
                    // The solution is never normalised again (DESIGN_SPEC §1).
                    normalize: Normalize::None,
                    scale: 1.0,
                    design: true,
                    bounds: e.bounds,
                    dial: e.dial,
                    spectrum: *s,
                },
                false => e.clone(),
            })
            // A palette with more entries than values (none is built so) keeps the rest as they are.
            .chain(entries.iter().skip(spectra.len()).cloned())
            .collect()
    };
    let Palette { name, settings, lights, reflectances, colours, free, mixtures, paths } = palette;
    Palette {
        name: name.clone(),
        settings: settings.clone(),
        lights: entries(lights, &values.lights),
        reflectances: entries(reflectances, &values.reflectances),
        colours: colours.clone(),
        free: free.clone(),
        mixtures: mixtures.clone(),
        paths: paths.clone(),
    }
}

impl Solution {
    /// The solved spectra and free colours as the design system's values (what feasibility analyses of
    /// the solution start from).
    pub fn values(&self) -> system::Values {
        system::Values {
            lights: self.palette.lights.iter().map(|e| e.spectrum).collect(),
            reflectances: self.palette.reflectances.iter().map(|e| e.spectrum).collect(),
            free: self.free.clone(),
        }
    }

    /// Give every cell its subspace colour and ΔE00 in `basis` — the basis of the *solved* spectra (the
    /// one basis policy's), which the solve itself cannot know; the full colours are kept.
    pub fn set_subspace(&mut self, basis: &Basis, colorimetry: &Colorimetry) {
        let p = &self.palette;
        for r in &mut self.cells {
            let c = &p.colours[r.cell];
            r.set_subspace(
                Some(basis),
                &p.lights[c.light].spectrum,
                &p.reflectances[c.reflectance].spectrum,
                colorimetry,
            );
        }
        let lights: Vec<_> = p.lights.iter().map(|e| e.spectrum).collect();
        for r in &mut self.mixtures {
            let m = &p.mixtures[r.cell];
            let e = crate::palette::mixing::light_of(&m.mix, &lights);
            r.set_subspace(Some(basis), &e, &p.reflectances[m.reflectance].spectrum, colorimetry);
        }
        let values = self.values();
        for r in &mut self.paths {
            r.worst_delta_e_subspace = report::path_worst_subspace(p, basis, colorimetry, &values, r);
        }
    }

    /// The cells whose target is not met ([`CellStatus::Unmet`]).
    pub fn unmet_cells(&self) -> impl Iterator<Item = &CellResult> {
        self.cells.iter().filter(|c| c.status == CellStatus::Unmet)
    }
}

/// An instant about a century after `from` (the latest a deadline needs to be), or the latest that can
/// be represented.
fn far_future(from: Instant) -> Instant {
    let mut d = Duration::from_secs(100 * 365 * 24 * 3600);
    loop {
        if let Some(t) = from.checked_add(d) {
            return t;
        }
        d /= 2;
    }
}
