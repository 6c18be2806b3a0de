//! Joint design of a block with bilinear cells (light and reflectance both designed).
//!
//! The objective is a sum of squares of bilinear residuals, convex in the lights for fixed reflectances
//! and in the reflectances for fixed lights. The solve is deterministic:
//!
//! 1. alternating exact bounded solves (block coordinate descent): reflectances and free colours with the
//!    lights fixed, then lights and free colours with the reflectances fixed. Each half-step is an exact
//!    convex minimisation ([`super::lsq`]), so the objective never increases;
//! 2. L-BFGS-B ([`super::lbfgsb`]) on all unknowns of the block at once, whose line search only accepts
//!    decrease;
//! 3. a last round of alternating solves, which can only decrease the objective further and leaves every
//!    factor at its exact conditional optimum.
//!
//! Every stage checks the deadline and the cancel flag; a step that would raise the objective (rounding)
//! is rejected, so the recorded history is monotone.

use super::lbfgsb::{LBfgsB, projected_gradient_norm};
use super::lsq;
use super::solve::FactorCache;
use super::system::{Block, Design, Form, Layout, Unit, Values, smoothness_grad, smoothness_scale, smoothness_sq};
use argmin::core::{CostFunction, Error, Gradient};
use nalgebra::DVector;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// The objective of a set of terms as a function of a layout's unknowns (others held at `base`).
pub struct NonlinearProblem<'a> {
    pub design: &'a Design<'a>,
    pub layout: &'a Layout,
    pub terms: &'a [usize],
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
            let e = &v.lights[t.light];
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
                if let Some(off) = self.layout.offset(Unit::Light(t.light)) {
                    let ge = d.operator(form, s).tr_mul(&r) * (2.0 * scale);
                    g.rows_mut(off, 31).add_assign(&ge);
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
pub struct JointOutcome {
    /// The block objective after each accepted stage (alternating rounds and the L-BFGS-B run), starting
    /// with the start value; non-increasing.
    pub history: Vec<f64>,
    /// Scaled projected-gradient norm at the end.
    pub kkt: f64,
    pub alternating_rounds: usize,
    pub lbfgsb_iterations: u64,
    /// Why it stopped early, if it did ("time limit", "cancelled").
    pub stopped: Option<String>,
}

/// Limits of the joint solve.
#[derive(Clone, Debug)]
pub struct JointLimits {
    pub deadline: Instant,
    pub cancel: Option<Arc<AtomicBool>>,
    /// Alternating rounds before L-BFGS-B.
    pub first_rounds: usize,
    /// L-BFGS-B iteration cap.
    pub lbfgsb_iterations: u64,
    /// Alternating rounds after L-BFGS-B.
    pub last_rounds: usize,
    /// Stop a stage when the relative decrease per round falls below this.
    pub rel_tol: f64,
}

impl JointLimits {
    pub fn new(deadline: Instant, cancel: Option<Arc<AtomicBool>>) -> JointLimits {
        JointLimits { deadline, cancel, first_rounds: 30, lbfgsb_iterations: 3000, last_rounds: 200, rel_tol: 1e-12 }
    }

    fn out_of_time(&self) -> Option<String> {
        if self.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed)) {
            return Some("cancelled".into());
        }
        (Instant::now() >= self.deadline).then(|| "time limit".into())
    }
}

/// One alternating half-step: solve `units` exactly with everything else fixed. Returns false if a
/// sub-solve failed to produce finite values (values are then left unchanged).
fn exact_half_step(design: &Design, units: &[Unit], terms: &[usize], v: &mut Values, cache: &FactorCache) {
    for comp in design.components(units, terms) {
        let layout = Layout::new(&comp.units);
        let sys = design.linear_system(&layout, &comp.terms, v);
        let factor = cache.get(&sys.a);
        let out = lsq::solve(&sys, &factor);
        if out.x.iter().all(|x| x.is_finite()) {
            layout.scatter(&out.x, v);
        }
    }
}

/// Alternating rounds until the relative decrease stalls, `rounds` is reached or time runs out.
fn alternate(
    design: &Design,
    block: &Block,
    v: &mut Values,
    cache: &FactorCache,
    rounds: usize,
    limits: &JointLimits,
    out: &mut JointOutcome,
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
    let mut f = *out.history.last().unwrap_or(&design.block_objective(block, v));
    for _ in 0..rounds {
        if let Some(why) = limits.out_of_time() {
            out.stopped = Some(why);
            return;
        }
        let mut trial = v.clone();
        exact_half_step(design, &refl_side, &block.terms, &mut trial, cache);
        exact_half_step(design, &light_side, &block.terms, &mut trial, cache);
        let f_new = design.block_objective(block, &trial);
        if f_new.is_nan() || f_new > f {
            return;
        }
        *v = trial;
        out.alternating_rounds += 1;
        out.history.push(f_new);
        let done = f - f_new <= limits.rel_tol * f.max(f64::MIN_POSITIVE);
        f = f_new;
        if done {
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

/// Solve a bilinear block in place.
pub fn solve_block(
    design: &Design,
    block: &Block,
    v: &mut Values,
    cache: &FactorCache,
    limits: &JointLimits,
) -> JointOutcome {
    lift_zero_starts(design, block, v);
    let mut out = JointOutcome { history: vec![design.block_objective(block, v)], ..Default::default() };
    alternate(design, block, v, cache, limits.first_rounds, limits, &mut out);
    let layout = Layout::new(&block.units);
    let (lo, hi) = layout.bounds(design);
    if out.stopped.is_none() {
        let base = v.clone();
        let problem = NonlinearProblem { design, layout: &layout, terms: &block.terms, base: &base };
        let x0 = layout.gather(v);
        let f0 = problem.value(&x0);
        let solver = LBfgsB::new(lo.clone(), hi.clone())
            .with_memory(10)
            .with_pg_tol(1e-12 * (1.0 + f0))
            .with_f_tol(1e-13, 0.0)
            .with_deadline(Some(limits.deadline))
            .with_cancel(limits.cancel.clone());
        let res = argmin::core::Executor::new(problem, solver)
            .configure(|s| s.param(x0).max_iters(limits.lbfgsb_iterations))
            .ctrlc(false)
            .timer(false)
            .run();
        if let Ok(res) = res {
            out.lbfgsb_iterations = argmin::core::State::get_iter(&res.state);
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
        alternate(design, block, v, cache, limits.last_rounds, limits, &mut out);
    }
    let base = v.clone();
    let problem = NonlinearProblem { design, layout: &layout, terms: &block.terms, base: &base };
    let x = layout.gather(v);
    let g = problem.grad(&x);
    out.kkt = projected_gradient_norm(&x, &g, &lo, &hi) / (1.0 + problem.value(&x));
    out
}
