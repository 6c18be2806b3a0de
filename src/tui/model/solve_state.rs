//! The solve: the latest solution of the palette (and the one running), the basis of the spectra the
//! matrix shows, the colours derived from them for the view, and the mismatch region of a cell.

use crate::basis::Basis;
use crate::basis::policy::Resolved;
use crate::basis::train::TrainingSet;
use crate::design::{DesignError, Solution};
use crate::tui::derived::Derived;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The key of a basis: the exact spectra it is trained on and m ([`crate::basis::store::cache_key`]).
/// The shown basis, the basis asked for and the derived colours compare these, never strings.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct BasisKey(String);

impl BasisKey {
    /// The key of the basis of dimension `m` for `set`.
    pub fn of(set: &TrainingSet, m: usize) -> BasisKey {
        BasisKey(crate::basis::store::cache_key(set, m))
    }

    /// The key as the basis memory and the sidecar cache store it.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

/// A basis delivered by the one basis policy, with the key of the spectra it is for.
#[derive(Clone, Debug)]
pub struct ShownBasis {
    pub key: BasisKey,
    resolved: Resolved,
}

impl ShownBasis {
    pub(crate) fn new(key: BasisKey, resolved: Resolved) -> ShownBasis {
        ShownBasis { key, resolved }
    }

    /// The basis.
    pub fn basis(&self) -> &Basis {
        let (basis, _report) = &*self.resolved;
        basis
    }

    /// The factor model's mean ΔE00 on its own spectra's pairs, when that is poor
    /// ([`crate::basis::Report::poor_model`]).
    pub fn poor_mean(&self) -> Option<f64> {
        let (_basis, report) = &*self.resolved;
        report.poor_model().map(|_| report.accuracy.factor_model.mean)
    }
}

/// A mismatch region computed off the UI thread, for the palette of `generation`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FeasibilityView {
    pub(crate) generation: u64,
    /// Index into `palette.colours`.
    pub(crate) cell: usize,
    pub(crate) result: Result<Arc<crate::design::feasibility::Panel>, String>,
}

/// The latest solve, the basis of the shown spectra and what the view derives from them.
#[derive(Debug, Default)]
pub struct SolveState {
    /// Generation of the palette: bumped by every edit. A reply for an older generation is stale.
    pub generation: u64,
    /// The generation now being solved, if any.
    pub running: Option<u64>,
    /// Solve requests sent so far (the ticket of the newest); only the newest one's reply counts.
    pub(crate) tickets: u64,
    /// When the newest solve started (the loop's clock, sent back as a message; the progress line's clock).
    pub(crate) started: Option<Instant>,
    /// How long the running solve has been going (updated on ticks; shown as progress).
    pub(crate) running_for: Duration,
    /// The latest solution and the generation it belongs to.
    pub solution: Option<(u64, Arc<Solution>)>,
    /// The latest solve's failure, if it failed.
    pub error: Option<DesignError>,
    /// Wall-clock time of the latest finished solve.
    pub(crate) last_time: Option<Duration>,
    /// The worker trains bases (off: `--no-basis`).
    pub trains_bases: bool,
    /// The spectral factor basis for subspace colours (the derived colours use it only while the shown
    /// spectra have its key).
    pub basis: Option<ShownBasis>,
    /// The key of the newest basis asked for (the same spectra are not asked for twice).
    pub(crate) basis_asked: Option<BasisKey>,
    /// A basis is being trained.
    pub(crate) training: bool,
    /// Why the basis could not be trained.
    pub(crate) basis_error: Option<String>,
    /// Colours and errors derived from the palette, the latest solution and the basis (recomputed on
    /// change, not per frame).
    pub derived: Derived,
    /// The latest region computed by the worker for the mismatch overlay.
    pub(crate) feasibility: Option<FeasibilityView>,
}

impl SolveState {
    /// The solution of the current palette, if solved.
    pub fn current(&self) -> Option<&Solution> {
        self.solution.as_ref().filter(|(g, _)| *g == self.generation).map(|(_, s)| s.as_ref())
    }

    /// The solution of the current palette, else the last one solved.
    pub fn latest(&self) -> Option<&Solution> {
        self.current().or(self.solution.as_ref().map(|(_, s)| s.as_ref()))
    }

    /// The factor model's mean ΔE00 on the shown basis's own pairs, when it is poor (above
    /// [`crate::basis::POOR_MODEL_MEAN_DE00`]); nothing when the latest basis could not be had.
    pub fn basis_poor(&self) -> Option<f64> {
        if self.basis_error.is_some() {
            return None;
        }
        self.basis.as_ref().and_then(ShownBasis::poor_mean)
    }

    /// The shown basis when it is the basis of exactly the shown spectra.
    pub(crate) fn basis_of_shown(&self) -> Option<&ShownBasis> {
        self.basis.as_ref().filter(|b| self.derived.basis_key.as_ref() == Some(&b.key))
    }
}
