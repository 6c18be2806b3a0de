//! Joint design of a block with bilinear cells (light and reflectance both designed).
//!
//! The objective is a sum of squares of bilinear residuals, convex in the lights for fixed reflectances
//! and in the reflectances for fixed lights. The solve is deterministic:
//!
//! 1. alternating exact bounded solves (block coordinate descent): reflectances and free colours with the
//!    lights fixed, then lights and free colours with the reflectances fixed. Each half-step is an exact
//!    convex minimisation ([`super::lsq::solve_from`], warm-started from the current values, independent
//!    spectra in parallel), so the objective never increases; each round tries an extrapolated step that
//!    is kept only if it lowers the objective;
//! 2. L-BFGS-B ([`super::lbfgsb`]) on all unknowns of the block at once, whose line search only accepts
//!    decrease;
//! 3. a last round of alternating solves, which can only decrease the objective further and leaves every
//!    factor at its exact conditional optimum.
//!
//! Every stage checks the deadline and the cancel flag; a step that would raise the objective (rounding)
//! is rejected, so the recorded history is monotone.
//!
//! The problem is nonconvex (with nonnegative spectra it has many local minima: on the 15×15 capacity
//! palettes, local solves from different starts end with objectives between about 0.4 and 0.8), so
//! [`solve_block`] runs stage 1 of blocks with enough bilinear cells ([`JointLimits::multi_start_min_cells`]) from
//! [`JointLimits::starts`] starts at once — the given one and
//! deterministic perturbations of it, each on its own thread — and finishes the one with the lowest
//! objective.
//! Per-wavelength rank-one block steps, basin hopping and structured starts (flat, random, growing the
//! palette one light and reflectance at a time) were tried on those palettes and did no better on average
//! than independent starts.

use super::lbfgsb::{LBfgsB, projected_gradient_norm};
use super::lsq;
use super::system::{Block, Design, Form, Layout, Unit, Values, smoothness_grad, smoothness_scale, smoothness_sq};
use crate::optimize::{Limits, Termination};
use argmin::core::{CostFunction, Error, Gradient};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// The objective of a set of terms as a function of a layout's unknowns (others held at `base`).
pub struct NonlinearProblem<'a> {
    /// The design whose terms and smoothness make the objective.
    pub design: &'a Design<'a>,
    /// Where each unknown unit sits in the vector `x`.
    pub layout: &'a Layout,
    /// Indices into `Design::terms` of the terms summed (a block's).
    pub terms: &'a [usize],
    /// The values of every unit not in `layout`, held fixed.
    pub base: &'a Values,
}

impl NonlinearProblem<'_> {
    fn values_at(&self, x: &DVector<f64>) -> Values {
        let mut v = self.base.clone();
        self.layout.scatter(x, &mut v);
        v
    }

    /// Objective at x.
    pub fn value(&self, x: &DVector<f64>) -> f64 {
        let v = self.values_at(x);
        let mut f = 0.0;
        for &ti in self.terms {
            let (c, e) = self.design.term_residuals(&self.design.terms[ti], &v);
            f += c.norm_squared() + e.norm_squared();
        }
        let w = self.design.smoothness * smoothness_scale();
        if w > 0.0 {
            for (u, _) in &self.layout.units {
                if !matches!(u, Unit::Free(_)) {
                    f += smoothness_sq(v.get(*u), w);
                }
            }
        }
        f
    }

    /// Gradient at x.
    pub fn grad(&self, x: &DVector<f64>) -> DVector<f64> {
        let d = self.design;
        let v = self.values_at(x);
        let mut g = DVector::zeros(x.len());
        for &ti in self.terms {
            let t = &d.terms[ti];
            let (rc, re) = d.term_residuals(t, &v);
            let e = &d.term_light(t, &v);
            let s = &v.reflectances[t.reflectance];
            let mut rows = vec![(t.form, t.scale, rc)];
            if t.error_scale > 0.0 {
                rows.push((Form::Error, t.error_scale, re));
            }
            for (form, scale, r) in rows {
                // ∂‖r‖²/∂S = 2·scale·op(E)ᵀ r and likewise for E (the forms are symmetric).
                if let Some(off) = self.layout.offset(Unit::Reflectance(t.reflectance)) {
                    let gs = d.operator(form, e).tr_mul(&r) * (2.0 * scale);
                    g.rows_mut(off, 31).add_assign(&gs);
                }
                // A mixture's light Σ wᵢ Eᵢ: ∂/∂Eᵢ = wᵢ ∂/∂E.
                let mut ge = None;
                for &(i, w) in &t.lights {
                    if let Some(off) = self.layout.offset(Unit::Light(i)) {
                        let ge = ge.get_or_insert_with(|| d.operator(form, s).tr_mul(&r) * (2.0 * scale));
                        g.rows_mut(off, 31).add_assign(&(*ge * w));
                    }
                }
                if form != Form::Error
                    && let Some(gi) = t.free
                    && let Some(off) = self.layout.offset(Unit::Free(gi))
                {
                    let gf = r * (-2.0 * scale);
                    g.rows_mut(off, 3).add_assign(&gf);
                }
            }
        }
        let w = d.smoothness * smoothness_scale();
        if w > 0.0 {
            for (u, off) in &self.layout.units {
                if !matches!(u, Unit::Free(_)) {
                    let mut gs = vec![0.0; u.len()];
                    smoothness_grad(v.get(*u), w, &mut gs);
                    for (k, val) in gs.iter().enumerate() {
                        g[off + k] += val;
                    }
                }
            }
        }
        g
    }
}

use std::ops::AddAssign;

impl CostFunction for NonlinearProblem<'_> {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, x: &DVector<f64>) -> Result<f64, Error> {
        Ok(self.value(x))
    }
}

impl Gradient for NonlinearProblem<'_> {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;
    fn gradient(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        Ok(self.grad(x))
    }
}

/// What a joint solve did.
#[derive(Clone, Debug, Default)]
pub(crate) struct JointOutcome {
    /// The block objective after each accepted stage (alternating rounds and the L-BFGS-B run), starting
    /// with the start value; non-increasing.
    pub(crate) history: Vec<f64>,
    /// Scaled projected-gradient norm at the end.
    pub(crate) kkt: f64,
    /// Alternating rounds, summed over all starts.
    pub(crate) alternating_rounds: usize,
    pub(crate) lbfgsb_iterations: u64,
    /// Why it stopped early, if it did ([`Termination::TimeLimit`] or [`Termination::Cancelled`]).
    pub(crate) stopped: Option<Termination>,
}

/// Default number of starts of a joint solve ([`JointLimits::starts`]).
pub(crate) const DEFAULT_STARTS: usize = 8;

/// Default of [`JointLimits::multi_start_min_cells`]: up to about 8×8 a single start already fits the
/// capacity palettes to ΔE*ab ≈ 0, and the terminal designer re-solves such palettes on every edit.
pub(crate) const MULTI_START_MIN_CELLS: usize = 64;

/// Limits of the joint solve.
#[derive(Clone, Debug)]
pub struct JointLimits {
    pub(crate) deadline: Instant,
    pub(crate) cancel: Option<Arc<AtomicBool>>,
    /// Alternating rounds before L-BFGS-B.
    pub(crate) first_rounds: usize,
    /// L-BFGS-B iteration cap.
    pub(crate) lbfgsb_iterations: u64,
    /// Alternating rounds after L-BFGS-B.
    pub(crate) last_rounds: usize,
    /// Stop a stage when the relative decrease per round stays below this (3 rounds in a row).
    pub(crate) rel_tol: f64,
    /// … or the objective is below this.
    pub(crate) abs_tol: f64,
    /// Starts of the first alternating stage (the given one and `starts − 1` deterministic perturbations
    /// of it), run in parallel; the lowest objective after it goes on. 1 = the given start only.
    pub(crate) starts: usize,
    /// Blocks with fewer bilinear cells than this run the given start only.
    pub(crate) multi_start_min_cells: usize,
}

impl JointLimits {
    /// Limits that stop at `deadline` or when `cancel` is set, with the default rounds, tolerances and starts.
    pub fn new(deadline: Instant, cancel: Option<Arc<AtomicBool>>) -> JointLimits {
        JointLimits {
            deadline,
            cancel,
            first_rounds: 400,
            lbfgsb_iterations: 100,
            last_rounds: 200,
            rel_tol: 1e-5,
            abs_tol: 1e-14,
            starts: DEFAULT_STARTS,
            multi_start_min_cells: MULTI_START_MIN_CELLS,
        }
    }

    fn out_of_time(&self) -> Option<Termination> {
        if self.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed)) {
            return Some(Termination::Cancelled);
        }
        (Instant::now() >= self.deadline).then_some(Termination::TimeLimit)
    }
}

/// One alternating half-step: solve `units` exactly with everything else fixed; independent components
/// (e.g. reflectances that share no free colour) in parallel, sharing factorisations of equal matrices.
/// A component whose solve is not finite keeps its values. `parallel = false` solves the components one
/// after the other on the calling thread (used when the starts of a multi-start run in parallel).
fn exact_half_step(design: &Design, units: &[Unit], terms: &[usize], v: &mut Values, parallel: bool) {
    let cache = NormalCache::default();
    let comps = design.components(units, terms);
    let base: &Values = v;
    let solve_one = |comp: &Block| {
        let layout = Layout::new(&comp.units);
        let sys = design.linear_system(&layout, &comp.terms, base);
        let h = cache.get(&sys.a);
        let out = lsq::solve_from(&sys, &h, &layout.gather(base));
        let x = out.x.iter().all(|x| x.is_finite()).then_some(out.x);
        (layout, x)
    };
    let solved: Vec<(Layout, Option<DVector<f64>>)> =
        if parallel { comps.par_iter().map(solve_one).collect() } else { comps.iter().map(solve_one).collect() };
    for (layout, x) in solved {
        if let Some(x) = x {
            layout.scatter(&x, v);
        }
    }
}

/// A matrix A and its `AᵀA`.
type NormalEntry = (DMatrix<f64>, Arc<DMatrix<f64>>);

/// `AᵀA` shared between components with the same A within one half-step.
#[derive(Default)]
pub(crate) struct NormalCache {
    map: std::sync::Mutex<Vec<NormalEntry>>,
}

impl NormalCache {
    /// `AᵀA`, computed once per distinct A.
    pub fn get(&self, a: &DMatrix<f64>) -> Arc<DMatrix<f64>> {
        if let Ok(list) = self.map.lock()
            && let Some((_, h)) = list.iter().find(|(m, _)| m.shape() == a.shape() && m.as_slice() == a.as_slice())
        {
            return h.clone();
        }
        let h = Arc::new(a.tr_mul(a));
        if let Ok(mut list) = self.map.lock()
            && list.len() < 64
        {
            list.push((a.clone(), h.clone()));
        }
        h
    }
}

/// Alternating rounds until the relative decrease stalls, `rounds` is reached or time runs out.
///
/// Each round is followed by an extrapolation attempt along the round's step (`x + β (x − x_prev)`,
/// projected onto the bounds), accepted only when it lowers the objective; β grows after a success and
/// shrinks after a failure. This is the usual acceleration of alternating least squares and keeps the
/// objective monotone.
fn alternate(
    design: &Design,
    block: &Block,
    v: &mut Values,
    rounds: usize,
    limits: &JointLimits,
    out: &mut JointOutcome,
    parallel: bool,
) {
    let free: Vec<Unit> = block.units.iter().copied().filter(|u| matches!(u, Unit::Free(_))).collect();
    let side = |light: bool| -> Vec<Unit> {
        block
            .units
            .iter()
            .copied()
            .filter(|u| if light { matches!(u, Unit::Light(_)) } else { matches!(u, Unit::Reflectance(_)) })
            .chain(free.iter().copied())
            .collect()
    };
    let (refl_side, light_side) = (side(false), side(true));
    let layout = Layout::new(&block.units);
    let (lo, hi) = layout.bounds(design.palette);
    let mut f = *out.history.last().unwrap_or(&design.block_objective(block, v));
    let mut beta: f64 = 0.5;
    let mut stalled = 0;
    for _ in 0..rounds {
        if let Some(why) = limits.out_of_time() {
            out.stopped = Some(why);
            return;
        }
        let before = layout.gather(v);
        let mut trial = v.clone();
        exact_half_step(design, &refl_side, &block.terms, &mut trial, parallel);
        exact_half_step(design, &light_side, &block.terms, &mut trial, parallel);
        let mut f_new = design.block_objective(block, &trial);
        if f_new.is_nan() || f_new > f {
            return;
        }
        let after = layout.gather(&trial);
        let mut ext = &after + (&after - &before) * beta;
        for i in 0..ext.len() {
            ext[i] = ext[i].max(lo[i]).min(hi[i]);
        }
        let mut ext_values = trial.clone();
        layout.scatter(&ext, &mut ext_values);
        let f_ext = design.block_objective(block, &ext_values);
        if f_ext < f_new {
            trial = ext_values;
            f_new = f_ext;
            beta = (beta * 1.5).min(8.0);
        } else {
            beta = (beta * 0.5).max(0.05);
        }
        *v = trial;
        out.alternating_rounds += 1;
        out.history.push(f_new);
        let small = f - f_new <= limits.rel_tol * f.max(f64::MIN_POSITIVE) || f_new <= limits.abs_tol;
        f = f_new;
        stalled = if small { stalled + 1 } else { 0 };
        if stalled >= 3 {
            return;
        }
    }
}

/// Start values for a joint block: a designed spectrum that starts all zero would leave the bilinear
/// problem at a saddle (zero gradient), so it starts flat at 1 (clamped into its bounds) instead.
fn lift_zero_starts(design: &Design, block: &Block, v: &mut Values) {
    for u in &block.units {
        if matches!(u, Unit::Free(_)) {
            continue;
        }
        if v.get(*u).iter().all(|x| x.abs() < 1e-12) {
            let (lo, hi) = design.bounds_of(*u);
            let x: Vec<f64> = (0..lo.len()).map(|i| 1f64.max(lo[i]).min(hi[i])).collect();
            v.set(*u, &x);
        }
    }
}

/// Start `k` ≥ 1 of a multi-start solve: every designed sample of the block multiplied by a factor
/// `exp(σ (u − ½))`, u uniform from a generator seeded by k (σ = 3: factors between 0.22 and 4.5), after
/// lifting it by 1 % of its spectrum's mean magnitude so zeros can move; then clamped into the bounds.
/// Free colours keep their start. Deterministic: the same block and k give the same start.
fn perturbed_start(design: &Design, block: &Block, v: &Values, k: usize) -> Values {
    const SIGMA: f64 = 3.0;
    let mut rng = crate::optimize::Rng::new(0x5eed_0000 + k as u64);
    let mut w = v.clone();
    for u in &block.units {
        if matches!(u, Unit::Free(_)) {
            continue;
        }
        let x = v.get(*u);
        let lift = 0.01 * x.iter().map(|a| a.abs()).sum::<f64>() / x.len().max(1) as f64;
        let (lo, hi) = design.bounds_of(*u);
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, a)| ((a + lift) * (SIGMA * (rng.uniform() - 0.5)).exp()).max(lo[i]).min(hi[i]))
            .collect();
        w.set(*u, &y);
    }
    w
}

/// Solve a bilinear block in place. The first alternating stage runs from the given start and, when
/// `limits.starts > 1`, from `starts − 1` perturbations of it ([`perturbed_start`]), in parallel threads;
/// the start with the lowest objective after it (ties go to the earlier start) goes on to L-BFGS-B and the
/// last alternating stage ([`finish`]). The history is the given start's first stage, then the winner's
/// objective when another start won, then the finishing stages, so it never rises. Which start wins does
/// not depend on timing unless the time cap or the cancel flag stops the solves.
pub(crate) fn solve_block(design: &Design, block: &Block, v: &mut Values, limits: &JointLimits) -> JointOutcome {
    lift_zero_starts(design, block, v);
    let first_stage = |w: &mut Values, parallel: bool| {
        let mut out = JointOutcome { history: vec![design.block_objective(block, w)], ..Default::default() };
        alternate(design, block, w, limits.first_rounds, limits, &mut out, parallel);
        out
    };
    let bilinear_cells = block.terms.iter().filter(|&&t| design.is_bilinear(&design.terms[t])).count();
    if limits.starts <= 1 || bilinear_cells < limits.multi_start_min_cells {
        let mut out = first_stage(v, true);
        finish(design, block, v, limits, &mut out);
        return out;
    }
    // One scoped OS thread per start, each solving sequentially: the starts never wait on rayon's pool, so
    // a caller running on the pool cannot deadlock it, and other solves in the process (the designer's
    // next request, parallel tests) are not starved by long-running pool tasks.
    let run = |k: usize| {
        let mut w = if k == 0 { v.clone() } else { perturbed_start(design, block, v, k) };
        let out = first_stage(&mut w, false);
        (w, out)
    };
    let runs: Vec<Option<(Values, JointOutcome)>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..limits.starts)
            .map(|k| std::thread::Builder::new().name(format!("joint start {k}")).spawn_scoped(scope, move || run(k)))
            .collect();
        handles.into_iter().map(|h| h.ok().and_then(|h| h.join().ok())).collect()
    });
    // A start whose thread could not be spawned (or failed) is dropped; the given start is then run here.
    let mut runs = runs.into_iter();
    let first = runs.next().flatten().unwrap_or_else(|| run(0));
    let mut runs: Vec<(Values, JointOutcome)> = std::iter::once(first).chain(runs.flatten()).collect();
    let total_rounds: usize = runs.iter().map(|r| r.1.alternating_rounds).sum();
    let objective_of = |r: &(Values, JointOutcome)| {
        let f = design.block_objective(block, &r.0);
        if f.is_finite() { f } else { f64::INFINITY }
    };
    let mut best = 0;
    let mut f_best = objective_of(&runs[0]);
    for (k, r) in runs.iter().enumerate().skip(1) {
        let f = objective_of(r);
        if f < f_best {
            best = k;
            f_best = f;
        }
    }
    let mut out = if best == 0 {
        let (w, out) = runs.swap_remove(0);
        *v = w;
        out
    } else {
        // best > 0, so swap_remove(best) leaves the given start's run at index 0.
        let (w_best, out_best) = runs.swap_remove(best);
        let (_, mut out) = runs.swap_remove(0);
        *v = w_best;
        out.history.push(f_best);
        out.stopped = out.stopped.or(out_best.stopped);
        out
    };
    out.alternating_rounds = total_rounds;
    finish(design, block, v, limits, &mut out);
    out
}

/// The finishing stages of a joint solve in place: L-BFGS-B on all unknowns, then the last alternating
/// stage, then the KKT residual.
fn finish(design: &Design, block: &Block, v: &mut Values, limits: &JointLimits, out: &mut JointOutcome) {
    let layout = Layout::new(&block.units);
    let (lo, hi) = layout.bounds(design.palette);
    if out.stopped.is_none() {
        let base = v.clone();
        let problem = NonlinearProblem { design, layout: &layout, terms: &block.terms, base: &base };
        let x0 = layout.gather(v);
        let f0 = problem.value(&x0);
        let solver = LBfgsB::new(lo.clone(), hi.clone())
            .with_memory(10)
            .with_pg_tol(1e-12 * (1.0 + f0))
            .with_f_tol(1e-13, 0.0)
            .with_cancel(limits.cancel.clone());
        let run_limits = Limits { deadline: Some(limits.deadline), ..Limits::iterations(limits.lbfgsb_iterations) };
        if let Ok(res) = crate::optimize::run(problem, solver, x0, &run_limits) {
            out.lbfgsb_iterations = res.iterations();
            // The executor's own reason when the deadline or a cancel ended the run.
            if matches!(res.termination, Termination::TimeLimit | Termination::Cancelled) {
                out.stopped = Some(res.termination);
            }
            if let Some(x) = res.state.param.as_ref() {
                let mut trial = v.clone();
                layout.scatter(x, &mut trial);
                let f_new = design.block_objective(block, &trial);
                if f_new <= *out.history.last().unwrap_or(&f64::INFINITY) && x.iter().all(|x| x.is_finite()) {
                    *v = trial;
                    out.history.push(f_new);
                }
            }
        }
        if let Some(why) = limits.out_of_time() {
            out.stopped = Some(why);
        }
    }
    if out.stopped.is_none() {
        alternate(design, block, v, limits.last_rounds, limits, out, true);
    }
    let base = v.clone();
    let problem = NonlinearProblem { design, layout: &layout, terms: &block.terms, base: &base };
    let x = layout.gather(v);
    let g = problem.grad(&x);
    out.kkt = projected_gradient_norm(&x, &g, &lo, &hi) / (1.0 + problem.value(&x));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::Colorimetry;
    use crate::palette::random;
    use std::time::Duration;

    fn limits(starts: usize) -> JointLimits {
        JointLimits {
            starts,
            multi_start_min_cells: 0,
            ..JointLimits::new(Instant::now() + Duration::from_secs(60), None)
        }
    }

    /// Solve the single bilinear block of a capacity palette; returns (final objective, history, values).
    fn solve(n: usize, seed: u64, starts: usize) -> (f64, Vec<f64>, Values) {
        let col = Colorimetry::default();
        let p = random::capacity_palette(n, seed, &col);
        let design = Design::new(&p, None, &col).expect("valid palette");
        let blocks = design.blocks();
        assert_eq!(blocks.len(), 1);
        let mut v = design.start_values();
        let out = solve_block(&design, &blocks[0], &mut v, &limits(starts));
        (design.block_objective(&blocks[0], &v), out.history, v)
    }

    #[test]
    fn multi_start_history_is_monotone_and_other_starts_win_sometimes() {
        let mut won = 0;
        for seed in 0..3 {
            let (f1, h1, _) = solve(5, seed, 1);
            let (f4, h4, _) = solve(5, seed, 4);
            for h in [&h1, &h4] {
                assert!(h.windows(2).all(|w| w[1] <= w[0]), "seed {seed}: history rose: {h:?}");
            }
            assert_eq!(h4.last().copied(), Some(f4));
            assert_eq!(h1.last().copied(), Some(f1));
            // Both start from the same given start.
            assert_eq!(h1[0], h4[0]);
            if f4 != f1 {
                won += 1;
            }
        }
        assert!(won > 0, "the perturbed starts never changed the result");
    }

    #[test]
    fn multi_start_is_deterministic() {
        let (fa, ha, va) = solve(4, 9, 3);
        let (fb, hb, vb) = solve(4, 9, 3);
        assert_eq!(fa, fb);
        assert_eq!(ha, hb);
        assert_eq!(va, vb);
    }

    #[test]
    fn perturbed_starts_differ_and_respect_bounds() {
        let col = Colorimetry::default();
        let mut p = random::capacity_palette(3, 1, &col);
        p.settings.reflectance_bounds = crate::palette::Bounds::new(0.0, 1.0);
        let design = Design::new(&p, None, &col).expect("valid palette");
        let block = &design.blocks()[0];
        let v = design.start_values();
        let a = perturbed_start(&design, block, &v, 1);
        let b = perturbed_start(&design, block, &v, 2);
        assert_ne!(a, b);
        assert_ne!(a, v);
        assert_eq!(a, perturbed_start(&design, block, &v, 1));
        for r in &a.reflectances {
            assert!(r.0.iter().all(|x| (0.0..=1.0).contains(x)), "reflectance outside [0, 1]");
        }
        for l in &a.lights {
            assert!(l.0.iter().all(|x| *x >= 0.0 && x.is_finite()));
        }
    }

    #[test]
    fn cancelled_multi_start_returns_promptly() {
        let col = Colorimetry::default();
        let p = random::capacity_palette(12, 2, &col);
        let design = Design::new(&p, None, &col).expect("valid palette");
        let block = &design.blocks()[0];
        let mut v = design.start_values();
        let flag = Arc::new(AtomicBool::new(true));
        let lim = JointLimits {
            starts: 4,
            multi_start_min_cells: 0,
            ..JointLimits::new(Instant::now() + Duration::from_secs(60), Some(flag))
        };
        let t = Instant::now();
        let out = solve_block(&design, block, &mut v, &lim);
        assert!(t.elapsed() < Duration::from_secs(2), "took {:?}", t.elapsed());
        assert_eq!(out.stopped, Some(Termination::Cancelled));
        assert!(out.history.windows(2).all(|w| w[1] <= w[0]));
    }
}
