//! L-BFGS-B (Byrd, Lu, Nocedal & Zhu 1995; Morales & Nocedal 2011) as an argmin [`Solver`].
//!
//! Each iteration
//! 1. builds the compact limited-memory representation `B = θI − W M Wᵀ` (`W = [Y, θS]`),
//! 2. finds the generalised Cauchy point (GCP): the first local minimiser of the quadratic model along
//!    the projected steepest-descent path `P(x − t g)`, walking the breakpoints in order,
//! 3. minimises the model over the variables that are free at the GCP (direct primal method, through
//!    the Sherman–Morrison–Woodbury form of the reduced `B`),
//! 4. applies the Morales–Nocedal fix: the subspace step is projected onto the box, and if that is not a
//!    descent direction it is truncated to the box instead,
//! 5. runs a line search that never leaves the box (step ≤ the largest feasible step along the
//!    direction, strong-Wolfe bracketing and zoom with safeguarded cubic interpolation, Armijo fallback),
//! 6. updates the memory when the curvature condition `sᵀy > ε‖y‖²` holds.
//!
//! Iterates stay feasible throughout. It stops when the projected gradient `‖x − P(x − ∇f)‖∞` is at
//! most `pg_tol`, when the relative decrease of f falls below `f_tol`, when the line search cannot
//! decrease f even from steepest descent ([`crate::optimize::NO_DECREASE`]), or when the cancel flag is set
//! (`TerminationReason::Interrupt`); the iteration cap and the deadline are the executor's
//! ([`crate::optimize::run`]).

use argmin::core::{
    CostFunction, Error, Gradient, IterState, KV, Problem, Solver, State, TerminationReason, TerminationStatus,
};
use nalgebra::{DMatrix, DVector};
use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// The argmin state L-BFGS-B runs on.
pub(crate) type LbState = IterState<DVector<f64>, DVector<f64>, (), (), (), f64>;

/// L-BFGS-B with box bounds (`-inf`/`inf` for a missing side).
#[derive(Clone, Debug)]
pub struct LBfgsB {
    lower: DVector<f64>,
    upper: DVector<f64>,
    /// Number of correction pairs kept.
    memory: usize,
    /// Stop when the projected gradient's largest component is at most this.
    pg_tol: f64,
    /// Stop when `(f_k − f_{k+1}) ≤ f_tol · max(|f_k|, |f_{k+1}|, f_floor)`.
    f_tol: f64,
    f_floor: f64,
    s: VecDeque<DVector<f64>>,
    y: VecDeque<DVector<f64>>,
    theta: f64,
    cancel: Option<Arc<AtomicBool>>,
    stop: Option<TerminationReason>,
}

impl LBfgsB {
    /// A solver for `lower ≤ x ≤ upper`.
    pub fn new(lower: DVector<f64>, upper: DVector<f64>) -> LBfgsB {
        LBfgsB {
            lower,
            upper,
            memory: 7,
            pg_tol: 1e-10,
            f_tol: 1e-15,
            f_floor: 0.0,
            s: VecDeque::new(),
            y: VecDeque::new(),
            theta: 1.0,
            cancel: None,
            stop: None,
        }
    }

    /// Number of correction pairs (default 7).
    pub(crate) fn with_memory(mut self, m: usize) -> Self {
        self.memory = m.max(1);
        self
    }

    /// Projected-gradient tolerance (default 1e-10).
    pub(crate) fn with_pg_tol(mut self, tol: f64) -> Self {
        self.pg_tol = tol;
        self
    }

    /// Relative-decrease tolerance (default 1e-15) and the floor of its denominator (default 0).
    pub(crate) fn with_f_tol(mut self, tol: f64, floor: f64) -> Self {
        self.f_tol = tol;
        self.f_floor = floor;
        self
    }

    /// Stop (with `TerminationReason::Interrupt`) when the flag becomes true.
    pub(crate) fn with_cancel(mut self, cancel: Option<Arc<AtomicBool>>) -> Self {
        self.cancel = cancel;
        self
    }

    fn project(&self, x: &mut DVector<f64>) {
        for i in 0..x.len() {
            x[i] = x[i].max(self.lower[i]).min(self.upper[i]);
        }
    }

    /// The compact representation: W (n×2k) and M (2k×2k); None without memory or when singular.
    fn compact(&self, n: usize) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
        let k = self.s.len();
        if k == 0 {
            return None;
        }
        let theta = self.theta;
        let mut w = DMatrix::zeros(n, 2 * k);
        for j in 0..k {
            w.column_mut(j).copy_from(&self.y[j]);
            w.column_mut(k + j).copy_from(&(&self.s[j] * theta));
        }
        let mut minv = DMatrix::zeros(2 * k, 2 * k);
        for i in 0..k {
            for j in 0..k {
                let sy = self.s[i].dot(&self.y[j]);
                if i == j {
                    minv[(i, i)] = -sy;
                } else if i > j {
                    // L_ij = s_iᵀ y_j for i > j: lower-left block L, upper-right block Lᵀ.
                    minv[(k + i, j)] = sy;
                    minv[(j, k + i)] = sy;
                }
                minv[(k + i, k + j)] = theta * self.s[i].dot(&self.s[j]);
            }
        }
        let m = minv.try_inverse()?;
        m.iter().all(|v| v.is_finite()).then_some((w, m))
    }

    /// The generalised Cauchy point and `c = Wᵀ(xcp − x)`.
    fn cauchy_point(
        &self,
        x: &DVector<f64>,
        g: &DVector<f64>,
        wm: Option<&(DMatrix<f64>, DMatrix<f64>)>,
    ) -> (DVector<f64>, DVector<f64>) {
        let n = x.len();
        let theta = self.theta;
        let mut xcp = x.clone();
        let mut d = DVector::zeros(n);
        let mut breaks: Vec<(f64, usize)> = Vec::new();
        for i in 0..n {
            let t = if g[i] < 0.0 {
                (x[i] - self.upper[i]) / g[i]
            } else if g[i] > 0.0 {
                (x[i] - self.lower[i]) / g[i]
            } else {
                f64::INFINITY
            };
            if t > 0.0 && g[i] != 0.0 {
                d[i] = -g[i];
                if t.is_finite() {
                    breaks.push((t, i));
                }
            }
        }
        let two_k = wm.map(|(w, _)| w.ncols()).unwrap_or(0);
        let mut c = DVector::zeros(two_k);
        let mut p = match wm {
            Some((w, _)) => w.tr_mul(&d),
            None => DVector::zeros(0),
        };
        let mp = |v: &DVector<f64>| -> DVector<f64> {
            match wm {
                Some((_, m)) => m * v,
                None => DVector::zeros(0),
            }
        };
        let mut f1 = -d.dot(&d);
        if f1 == 0.0 {
            return (xcp, c);
        }
        let mut f2 = -theta * f1 - if two_k > 0 { p.dot(&mp(&p)) } else { 0.0 };
        let f2_org = f2;
        let mut dt_min = if f2 > 0.0 { -f1 / f2 } else { f64::INFINITY };
        let mut t_old = 0.0;
        breaks.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Row b of W and M·(row b of W), reused for every breakpoint (no allocation in the walk).
        let mut wb = vec![0.0; two_k];
        let mut mwb = vec![0.0; two_k];
        for &(tb, b) in &breaks {
            let dt = tb - t_old;
            if dt_min < dt {
                break;
            }
            xcp[b] = if d[b] > 0.0 { self.upper[b] } else { self.lower[b] };
            let zb = xcp[b] - x[b];
            let gb = g[b];
            if two_k > 0 {
                c.axpy(dt, &p, 1.0);
            }
            let (mut wmc, mut wmp, mut wmw) = (0.0, 0.0, 0.0);
            if let Some((w, m)) = wm {
                for (j, v) in wb.iter_mut().enumerate() {
                    *v = w[(b, j)];
                }
                for (r, v) in mwb.iter_mut().enumerate() {
                    *v = (0..two_k).map(|j| m[(r, j)] * wb[j]).sum();
                }
                for j in 0..two_k {
                    wmc += mwb[j] * c[j];
                    wmp += mwb[j] * p[j];
                    wmw += mwb[j] * wb[j];
                }
            }
            f1 += dt * f2 + gb * gb + theta * gb * zb - gb * wmc;
            f2 -= theta * gb * gb + 2.0 * gb * wmp + gb * gb * wmw;
            for j in 0..two_k {
                p[j] += wb[j] * gb;
            }
            d[b] = 0.0;
            f2 = f2.max(f64::EPSILON * f2_org);
            dt_min = if f2 > 0.0 { -f1 / f2 } else { f64::INFINITY };
            t_old = tb;
            if f1 >= 0.0 {
                dt_min = 0.0;
                break;
            }
        }
        let dt_min = if dt_min.is_finite() { dt_min.max(0.0) } else { 0.0 };
        let t = t_old + dt_min;
        for i in 0..n {
            if d[i] != 0.0 {
                xcp[i] = (x[i] + t * d[i]).max(self.lower[i]).min(self.upper[i]);
            }
        }
        if two_k > 0 {
            c.axpy(dt_min, &p, 1.0);
        }
        (xcp, c)
    }

    /// Minimise the model over the variables free at the GCP; Morales–Nocedal projection/truncation.
    fn subspace_step(
        &self,
        x: &DVector<f64>,
        g: &DVector<f64>,
        xcp: &DVector<f64>,
        c: &DVector<f64>,
        wm: Option<&(DMatrix<f64>, DMatrix<f64>)>,
    ) -> DVector<f64> {
        let n = x.len();
        let theta = self.theta;
        let free: Vec<usize> = (0..n).filter(|&i| xcp[i] > self.lower[i] && xcp[i] < self.upper[i]).collect();
        if free.is_empty() {
            return xcp.clone();
        }
        let nf = free.len();
        // Reduced gradient of the model at xcp: Zᵀ(g + θ(xcp − x) − W M c).
        let wmc = wm.map(|(w, m)| w * (m * c));
        let mut rc = DVector::zeros(nf);
        for (k, &i) in free.iter().enumerate() {
            rc[k] = g[i] + theta * (xcp[i] - x[i]) - wmc.as_ref().map(|v| v[i]).unwrap_or(0.0);
        }
        let mut du = -&rc / theta;
        if let Some((w, m)) = wm {
            let wz = DMatrix::from_fn(nf, w.ncols(), |r, col| w[(free[r], col)]);
            let two_k = w.ncols();
            let nmat = DMatrix::identity(two_k, two_k) - m * wz.tr_mul(&wz) / theta;
            let v = m * wz.tr_mul(&rc);
            if let Some(sol) = nmat.lu().solve(&v)
                && sol.iter().all(|s| s.is_finite())
            {
                du -= &wz * sol / (theta * theta);
            }
        }
        // Morales–Nocedal: project the subspace minimiser onto the box; keep it if it is a descent
        // direction from x, otherwise truncate the step at the box.
        let mut xbar = xcp.clone();
        for (k, &i) in free.iter().enumerate() {
            xbar[i] = (xcp[i] + du[k]).max(self.lower[i]).min(self.upper[i]);
        }
        if (&xbar - x).dot(g) < 0.0 {
            return xbar;
        }
        let mut alpha: f64 = 1.0;
        for (k, &i) in free.iter().enumerate() {
            if du[k] > 0.0 {
                alpha = alpha.min((self.upper[i] - xcp[i]) / du[k]);
            } else if du[k] < 0.0 {
                alpha = alpha.min((self.lower[i] - xcp[i]) / du[k]);
            }
        }
        let alpha = alpha.max(0.0);
        let mut xbar = xcp.clone();
        for (k, &i) in free.iter().enumerate() {
            xbar[i] = (xcp[i] + alpha * du[k]).max(self.lower[i]).min(self.upper[i]);
        }
        xbar
    }

    /// Largest step along d that stays in the box.
    fn max_step(&self, x: &DVector<f64>, d: &DVector<f64>) -> f64 {
        let mut t = f64::INFINITY;
        for i in 0..x.len() {
            if d[i] > 0.0 {
                t = t.min((self.upper[i] - x[i]) / d[i]);
            } else if d[i] < 0.0 {
                t = t.min((self.lower[i] - x[i]) / d[i]);
            }
        }
        t.max(0.0)
    }

    fn reset_memory(&mut self) {
        self.s.clear();
        self.y.clear();
        self.theta = 1.0;
    }
}

/// Projected gradient `x − P(x − g)` in the infinity norm.
pub(crate) fn projected_gradient_norm(
    x: &DVector<f64>,
    g: &DVector<f64>,
    lower: &DVector<f64>,
    upper: &DVector<f64>,
) -> f64 {
    let mut m: f64 = 0.0;
    for i in 0..x.len() {
        let p = (x[i] - g[i]).max(lower[i]).min(upper[i]);
        m = m.max((x[i] - p).abs());
    }
    m
}

/// Result of a line search.
struct Step {
    alpha: f64,
    x: DVector<f64>,
    f: f64,
    g: DVector<f64>,
}

/// Strong-Wolfe line search on `[0, alpha_max]` (Nocedal & Wright Alg. 3.5/3.6), returning the best
/// Armijo point when the curvature condition cannot be met within the evaluation budget.
#[allow(clippy::too_many_arguments)]
fn line_search<O>(
    problem: &mut Problem<O>,
    x: &DVector<f64>,
    f0: f64,
    g0: &DVector<f64>,
    d: &DVector<f64>,
    alpha_init: f64,
    alpha_max: f64,
    (lower, upper): (&DVector<f64>, &DVector<f64>),
) -> Result<Option<Step>, Error>
where
    O: CostFunction<Param = DVector<f64>, Output = f64> + Gradient<Param = DVector<f64>, Gradient = DVector<f64>>,
{
    const C1: f64 = 1e-4;
    const C2: f64 = 0.9;
    const MAX_EVALS: usize = 30;
    let dphi0 = g0.dot(d);
    if dphi0 >= 0.0 || !dphi0.is_finite() {
        return Ok(None);
    }
    let mut evals = 0;
    let eval = |alpha: f64, problem: &mut Problem<O>| -> Result<Step, Error> {
        let mut xa = x + d * alpha;
        for i in 0..xa.len() {
            xa[i] = xa[i].max(lower[i]).min(upper[i]);
        }
        let f = problem.cost(&xa)?;
        let g = problem.gradient(&xa)?;
        Ok(Step { alpha, x: xa, f, g })
    };
    let armijo = |s: &Step| s.f.is_finite() && s.f <= f0 + C1 * s.alpha * dphi0;
    let curvature = |s: &Step| s.g.dot(d).abs() <= C2 * dphi0.abs();
    let mut best: Option<Step> = None;
    let keep_best = |s: &Step, best: &mut Option<Step>| {
        if armijo(s) && best.as_ref().is_none_or(|b| s.f < b.f) {
            *best = Some(Step { alpha: s.alpha, x: s.x.clone(), f: s.f, g: s.g.clone() });
        }
    };
    // Bracketing phase.
    let mut lo = (0.0, f0, dphi0);
    let mut alpha = alpha_init.min(alpha_max);
    let mut hi: Option<(f64, f64, f64)> = None;
    while evals < MAX_EVALS {
        evals += 1;
        let s = eval(alpha, problem)?;
        keep_best(&s, &mut best);
        let dphi = s.g.dot(d);
        if !armijo(&s) || (evals > 1 && s.f >= lo.1) {
            hi = Some((alpha, s.f, dphi));
            break;
        }
        if curvature(&s) {
            return Ok(Some(s));
        }
        if dphi >= 0.0 {
            hi = Some(lo);
            lo = (alpha, s.f, dphi);
            break;
        }
        lo = (alpha, s.f, dphi);
        if alpha >= alpha_max {
            // Cannot go further inside the box: accept the Armijo point at the boundary.
            return Ok(Some(s));
        }
        alpha = (alpha * 4.0).min(alpha_max);
    }
    // Zoom phase between lo (Armijo, lowest f) and hi.
    if let Some(mut hi) = hi {
        while evals < MAX_EVALS {
            evals += 1;
            let (a_lo, f_lo, g_lo) = lo;
            let (a_hi, f_hi, g_hi) = hi;
            let width = (a_hi - a_lo).abs();
            if width <= f64::EPSILON * a_lo.abs().max(a_hi.abs()).max(1e-300) {
                break;
            }
            // Cubic interpolation, safeguarded to the inner 80% of the interval.
            let d1 = g_lo + g_hi - 3.0 * (f_lo - f_hi) / (a_lo - a_hi);
            let disc = d1 * d1 - g_lo * g_hi;
            let mut a = if disc >= 0.0 {
                let d2 = disc.sqrt().copysign(a_hi - a_lo);
                a_hi - (a_hi - a_lo) * (g_hi + d2 - d1) / (g_hi - g_lo + 2.0 * d2)
            } else {
                f64::NAN
            };
            let (amin, amax) = (a_lo.min(a_hi), a_lo.max(a_hi));
            if !a.is_finite() || a < amin + 0.1 * width || a > amax - 0.1 * width {
                a = 0.5 * (a_lo + a_hi);
            }
            let s = eval(a, problem)?;
            keep_best(&s, &mut best);
            let dphi = s.g.dot(d);
            if !armijo(&s) || s.f >= f_lo {
                hi = (a, s.f, dphi);
            } else {
                if curvature(&s) {
                    return Ok(Some(s));
                }
                if dphi * (a_hi - a_lo) >= 0.0 {
                    hi = lo;
                }
                lo = (a, s.f, dphi);
            }
        }
    }
    Ok(best)
}

impl<O> Solver<O, LbState> for LBfgsB
where
    O: CostFunction<Param = DVector<f64>, Output = f64> + Gradient<Param = DVector<f64>, Gradient = DVector<f64>>,
{
    fn name(&self) -> &str {
        "L-BFGS-B"
    }

    fn init(&mut self, problem: &mut Problem<O>, mut state: LbState) -> Result<(LbState, Option<KV>), Error> {
        let mut x = state
            .take_param()
            .ok_or_else(|| Error::msg("L-BFGS-B needs a starting point (Executor::configure(|s| s.param(x)))"))?;
        if x.len() != self.lower.len() || x.len() != self.upper.len() {
            return Err(Error::msg("L-BFGS-B: bounds and starting point differ in length"));
        }
        self.project(&mut x);
        let f = problem.cost(&x)?;
        let g = problem.gradient(&x)?;
        self.reset_memory();
        self.stop = None;
        Ok((state.param(x).cost(f).gradient(g), None))
    }

    fn next_iter(&mut self, problem: &mut Problem<O>, mut state: LbState) -> Result<(LbState, Option<KV>), Error> {
        let x = state.take_param().ok_or_else(|| Error::msg("L-BFGS-B: no parameter in state"))?;
        let g = state.take_gradient().ok_or_else(|| Error::msg("L-BFGS-B: no gradient in state"))?;
        let f = state.get_cost();
        let n = x.len();
        let mut retried = false;
        loop {
            let wm = self.compact(n);
            if wm.is_none() && !self.s.is_empty() {
                self.reset_memory();
            }
            let (xcp, c) = self.cauchy_point(&x, &g, wm.as_ref());
            let xbar = self.subspace_step(&x, &g, &xcp, &c, wm.as_ref());
            let d = &xbar - &x;
            let dnorm = d.norm();
            if dnorm == 0.0 || !dnorm.is_finite() {
                self.stop = Some(TerminationReason::SolverConverged);
                return Ok((state.param(x).cost(f).gradient(g), None));
            }
            let alpha_max = self.max_step(&x, &d);
            let alpha_init = if self.s.is_empty() { (1.0 / dnorm).min(1.0).min(alpha_max) } else { 1.0 };
            let step = line_search(problem, &x, f, &g, &d, alpha_init, alpha_max, (&self.lower, &self.upper))?;
            match step {
                Some(st) if st.f < f || (st.f <= f && st.alpha > 0.0) => {
                    let s = &st.x - &x;
                    let y = &st.g - &g;
                    let sy = s.dot(&y);
                    let yy = y.dot(&y);
                    if sy > f64::EPSILON * yy && sy.is_finite() && yy > 0.0 {
                        if self.s.len() == self.memory {
                            self.s.pop_front();
                            self.y.pop_front();
                        }
                        self.s.push_back(s);
                        self.y.push_back(y);
                        self.theta = yy / sy;
                    }
                    let scale = f.abs().max(st.f.abs()).max(self.f_floor);
                    if f - st.f <= self.f_tol * scale {
                        self.stop = Some(TerminationReason::SolverConverged);
                    }
                    if self.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed)) {
                        self.stop = Some(TerminationReason::Interrupt);
                    }
                    return Ok((state.param(st.x).cost(st.f).gradient(st.g), None));
                }
                _ => {
                    // No decrease along this direction: drop the memory and retry once from steepest descent.
                    if retried || self.s.is_empty() {
                        self.stop = Some(TerminationReason::SolverExit(crate::optimize::NO_DECREASE.into()));
                        return Ok((state.param(x).cost(f).gradient(g), None));
                    }
                    self.reset_memory();
                    retried = true;
                }
            }
        }
    }

    fn terminate(&mut self, state: &LbState) -> TerminationStatus {
        if let Some(r) = &self.stop {
            return TerminationStatus::Terminated(r.clone());
        }
        if let (Some(x), Some(g)) = (state.get_param(), state.get_gradient())
            && projected_gradient_norm(x, g, &self.lower, &self.upper) <= self.pg_tol
        {
            return TerminationStatus::Terminated(TerminationReason::SolverConverged);
        }
        TerminationStatus::NotTerminated
    }
}

/// Run L-BFGS-B from `x0` (projected onto the box) for at most `max_iters` iterations, through the one
/// argmin set-up ([`crate::optimize::run`]). Returns the final point, its cost and gradient. (The
/// design calls L-BFGS-B through its own problems in `lsq.rs` and `joint.rs`; this entry serves the tests.)
#[cfg(test)]
pub(crate) fn minimize<O>(
    problem: O,
    solver: LBfgsB,
    x0: DVector<f64>,
    max_iters: u64,
) -> Result<(DVector<f64>, f64, DVector<f64>), Error>
where
    O: CostFunction<Param = DVector<f64>, Output = f64> + Gradient<Param = DVector<f64>, Gradient = DVector<f64>>,
{
    let mut st = crate::optimize::run(problem, solver, x0, &crate::optimize::Limits::iterations(max_iters))?.state;
    let f = st.get_cost();
    let x = st.take_param().ok_or_else(|| Error::msg("L-BFGS-B: no result"))?;
    let g = st.take_gradient().ok_or_else(|| Error::msg("L-BFGS-B: no gradient"))?;
    Ok((x, f, g))
}

#[cfg(test)]
mod tests;
