//! The solve: the latest solution of the palette (and the one running), the basis of the spectra the
//! matrix shows, the colours derived from them for the view, and the mismatch region of a cell.

use crate::basis::Basis;
use crate::basis::Resolved;
use crate::basis::TrainingSet;
use crate::colorimetry::Colorimetry;
use crate::design::{DesignError, Solution};
use crate::palette::Palette;
use crate::tui::derived::Derived;
use crate::tui::msg::Effect;
use crate::tui::worker::Reply;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The key of a basis: the exact spectra it is trained on and m ([`crate::basis::cache_key`]).
/// The shown basis, the basis asked for and the derived colours compare these, never strings.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct BasisKey(String);

impl BasisKey {
    /// The key of the basis of dimension `m` for `set`.
    pub fn of(set: &TrainingSet, m: usize) -> BasisKey {
        BasisKey(crate::basis::cache_key(set, m))
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
    /// The generation and mismatch-region cell the newest request was for (a palette or a cell not asked
    /// for yet is solved: [`SolveState::wants_solve`]).
    pub(crate) asked: Option<(u64, Option<usize>)>,
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
    /// The solve's numbers for the palette's mixtures and paths (of the current palette only).
    pub dial: crate::tui::dial_results::DialResults,
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

    /// The latest solution's diagnostics (of the current palette, else the last one solved).
    pub fn diagnostics(&self) -> &[crate::design::Diagnostic] {
        self.latest().map_or(&[], |s| s.diagnostics.as_slice())
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

    /// The palette changed into one the current solution already describes (its designed spectra replaced
    /// by the solution's, on saving): a new generation whose solution, request and mismatch region are the
    /// old one's, so nothing is solved again and nothing on screen changes.
    pub(crate) fn carry_to_next_generation(&mut self) {
        let old = self.generation;
        self.generation += 1;
        if let Some((g, _)) = self.solution.as_mut().filter(|(g, _)| *g == old) {
            *g = self.generation;
        }
        if let Some((g, _)) = self.asked.as_mut().filter(|(g, _)| *g == old) {
            *g = self.generation;
        }
        if let Some(v) = self.feasibility.as_mut().filter(|v| v.generation == old) {
            v.generation = self.generation;
        }
    }

    /// True when the palette of the current generation, or the region of `feasibility`, was not asked for
    /// yet (turning the overlay off asks for nothing).
    pub(crate) fn wants_solve(&self, feasibility: Option<usize>) -> bool {
        match self.asked {
            None => true,
            Some((generation, cell)) => generation != self.generation || (feasibility.is_some() && feasibility != cell),
        }
    }

    /// Recompute the colours the view shows of `palette` (after a change of palette, solution or basis).
    pub(crate) fn derive(&mut self, palette: &Palette, colorimetry: &Colorimetry) {
        self.derived =
            Derived::compute(palette, self.latest(), colorimetry, self.basis.as_ref().map(|b| (&b.key, b.basis())));
        let basis = self.basis_of_shown().map(ShownBasis::basis);
        self.dial = crate::tui::dial_results::DialResults::of(self.current(), basis, colorimetry);
    }

    /// Solve `palette` (the current generation) as it stands, with the mismatch region of `feasibility`;
    /// the newest request cancels the running one. Returns the effects: the solve, and the basis of the
    /// shown spectra when it is missing.
    pub(crate) fn submit(&mut self, palette: &Palette, feasibility: Option<usize>) -> Vec<Effect> {
        self.tickets += 1;
        let solve =
            Effect::Solve { ticket: self.tickets, generation: self.generation, palette: palette.clone(), feasibility };
        self.asked = Some((self.generation, feasibility));
        self.running = Some(self.generation);
        // The loop's clock comes back with `SolveMsg::Started`.
        self.started = None;
        self.running_for = Duration::ZERO;
        let mut effects = self.ensure_basis(palette).effects;
        effects.insert(0, solve);
        effects
    }

    /// Have the basis of the spectra the matrix shows: asked of the worker, which answers from the basis
    /// memory when it holds it and trains it otherwise (the V7 half shows "updating" meanwhile); the
    /// update step reads no memory shared with the worker. Nothing is asked while a solve of a palette
    /// with designed spectra is under way (the shown spectra are about to change), nor for spectra asked
    /// for already.
    fn ensure_basis(&mut self, palette: &Palette) -> SolveUpdate {
        let mut update = SolveUpdate::default();
        let Some(key) = self.derived.basis_key.clone() else { return update };
        if self.basis.as_ref().is_some_and(|b| b.key == key) {
            return update;
        }
        if !self.trains_bases {
            self.basis_error = Some("basis training is off".into());
            return update;
        }
        let designs = palette.lights.iter().chain(&palette.reflectances).any(|e| e.design);
        if (designs && self.running.is_some()) || self.basis_asked.as_ref() == Some(&key) {
            return update;
        }
        match TrainingSet::new(self.derived.light_spectra.clone(), self.derived.reflectance_spectra.clone()) {
            Ok(set) => {
                let m = palette.settings.basis_dimension;
                update.effects.push(Effect::TrainBasis { generation: self.generation, key: key.clone(), set, m });
                self.basis_asked = Some(key);
                self.training = true;
            }
            Err(e) => self.basis_error = Some(format!("cannot train the basis: {e}")),
        }
        update
    }

    /// Handle one message of the solve: a worker reply (only the newest request's solve counts), the
    /// loop's clock for a solve, a tick of the progress clock.
    pub(crate) fn update(&mut self, msg: SolveMsg, palette: &Palette, colorimetry: &Colorimetry) -> SolveUpdate {
        match msg {
            SolveMsg::Started { ticket, at } => {
                if ticket == self.tickets {
                    self.started = Some(at);
                }
                SolveUpdate::default()
            }
            SolveMsg::Tick(now) => {
                if let Some(started) = self.started
                    && (self.running.is_some() || self.training)
                {
                    self.running_for = now.saturating_duration_since(started);
                }
                SolveUpdate::default()
            }
            SolveMsg::Worker(Reply::Trained(t)) => {
                if self.basis_asked.as_ref() == Some(&t.key) {
                    self.training = false;
                }
                if self.derived.basis_key.as_ref() != Some(&t.key) {
                    // For spectra no longer shown (it stays in the basis memory if they come back).
                    return self.ensure_basis(palette);
                }
                match t.result {
                    Ok(resolved) => {
                        self.basis = Some(ShownBasis::new(t.key, resolved));
                        self.basis_error = None;
                    }
                    Err(e) => self.basis_error = Some(e),
                }
                self.refreshed(palette, colorimetry)
            }
            SolveMsg::Worker(Reply::Solved(s)) => {
                if s.ticket != self.tickets {
                    // A request a newer one replaced (cancelled, or solved before the newer arrived).
                    return SolveUpdate::default();
                }
                self.running = None;
                if s.generation != self.generation {
                    // Stale: the palette changed since (a newer solve is on its way).
                    return SolveUpdate::default();
                }
                self.last_time = Some(s.elapsed);
                if let Some((cell, result)) = s.feasibility {
                    self.feasibility = Some(FeasibilityView { generation: s.generation, cell, result });
                }
                match s.result {
                    Ok(solution) => {
                        self.solution = Some((s.generation, solution));
                        self.error = None;
                    }
                    Err(e) => self.error = Some(e),
                }
                self.refreshed(palette, colorimetry)
            }
        }
    }

    /// Derive again, then have the basis of the spectra now shown.
    fn refreshed(&mut self, palette: &Palette, colorimetry: &Colorimetry) -> SolveUpdate {
        self.derive(palette, colorimetry);
        let mut update = self.ensure_basis(palette);
        update.derived = true;
        update
    }
}

/// A message for the solve.
#[derive(Debug)]
pub(crate) enum SolveMsg {
    /// The solve or basis worker finished something.
    Worker(Reply),
    /// The loop's clock when it handed solve `ticket` to the worker.
    Started { ticket: u64, at: Instant },
    /// The progress clock.
    Tick(Instant),
}

/// What a solve message asks for: effects for the loop, and whether the derived colours changed (the
/// preview relights).
#[derive(Default)]
#[must_use]
pub(crate) struct SolveUpdate {
    pub(crate) effects: Vec<Effect>,
    pub(crate) derived: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_progress_clock_is_the_loop_s_own() {
        let (mut solve, palette, c) = (SolveState::default(), Palette::default(), Colorimetry::default());
        let first = solve.submit(&palette, None);
        assert!(matches!(first.as_slice(), [Effect::Solve { ticket: 1, .. }]));
        assert!(!solve.wants_solve(None), "asked for");
        let t0 = Instant::now();
        // No clock read here: until the loop says when it started the solve, no time passes.
        let _ = solve.update(SolveMsg::Tick(t0 + Duration::from_secs(5)), &palette, &c);
        assert_eq!(solve.running_for, Duration::ZERO);
        let _ = solve.update(SolveMsg::Started { ticket: 1, at: t0 }, &palette, &c);
        let _ = solve.update(SolveMsg::Tick(t0 + Duration::from_millis(1500)), &palette, &c);
        assert_eq!(solve.running_for, Duration::from_millis(1500));
        // A newer request: the older one's clock is ignored.
        solve.generation += 1;
        assert!(solve.wants_solve(None));
        let _ = solve.submit(&palette, None);
        let _ = solve.update(SolveMsg::Started { ticket: 1, at: t0 }, &palette, &c);
        assert_eq!(solve.started, None);
        // The overlay of a cell not asked for is a reason to solve; turning it off is not.
        assert!(solve.wants_solve(Some(0)));
        assert!(!solve.wants_solve(None));
    }
}
