//! Bounded linear least squares `min ‖A x − b‖²`, `lower ≤ x ≤ upper`:
//!
//! 1. the minimum-norm unconstrained solution by SVD (singular values below
//!    `max(rows, n) · ε · σ_max` are dropped, as LAPACK's `gelsd` default does); when A is ill conditioned
//!    (see [`NORMAL_EQUATIONS_MAX_COND`]) one step of refinement by QR of A with the rows sorted by weight
//!    recovers what the SVD's normwise rounding and cut-off lose on graded rows. If it already satisfies the
//!    bounds exactly, that is the answer;
//! 2. otherwise, on ill-conditioned systems (the QR path below), L-BFGS-B ([`super::lbfgsb`]) from the SVD
//!    solution projected onto the box, which finds the active set approximately; well-conditioned systems
//!    start the finish from the projected SVD solution itself (its clamped support is the first guess of the
//!    active set). On the batch designs that takes about 16 releases per design against 11 from L-BFGS-B's
//!    point, but saves the L-BFGS-B run, which cost more than the releases (12 % of the whole process);
//! 3. then an exact active-set finish (bounded-variable least squares in the manner of Stark & Parker
//!    1995): fix the active bounds, solve the free variables' least squares exactly, walk back to the
//!    box when the solution leaves it (adding the bounds it hits), and release the bound whose Lagrange
//!    multiplier has the wrong sign by more than its rounding level, until none has. On a convex problem
//!    this ends at the exact optimum; it is capped at `4n + 20` releases so it cannot loop. Well-conditioned
//!    systems (`cond(A) ≤ 1e6`, the batch path) work on `H = AᵀA` with an incremental Cholesky factor;
//!    ill-conditioned ones (weights over many decades, nearly identical lights, fewer rows than unknowns)
//!    on A itself: Householder QR of the free columns with rows sorted by weight (Powell & Reid), one step of
//!    iterative refinement, and multipliers from the transformed residual, so that the light rows keep
//!    their own precision instead of drowning in the heavy rows' rounding. There the normal equations first
//!    find the active set roughly and the QR finish starts from it, which keeps the QR solves few.
//!
//! On the normal-equations path the final free set is solved once more from a fresh factor (free
//! variables in ascending order, `Work::polish` in `lsq/finish.rs`), so the result is a function of the
//! active set alone, whatever path of binds and releases led to it: both starts give the same bits.
//! From the clamped start the active set is first guessed by the same steps worked out on the bound
//! variables with `G = H⁻¹` (`lsq/guess.rs`: a few unknowns per step instead of 20–30); the guessed set is
//! solved as the polish solves the finish's final set and kept only when the result passes the finish's
//! own test of optimality, else the finish runs as above.
//!
//! The reported objective and KKT residual are computed from the residual `Ax − b`.
//! The factorisation (SVD pseudo-inverse, `AᵀA` and `cond(A)`) depends on A only; [`Factor`]s are shared
//! between systems with the same A (e.g. many reflectances under the same lights).

use super::lbfgsb::{LBfgsB, projected_gradient_norm};
use super::system::LinearSystem;
use argmin::core::{CostFunction, Error, Gradient};
use nalgebra::{DMatrix, DVector};

/// L-BFGS-B iterations before the active-set finish. Its generalised Cauchy points identify most of the
/// active bounds within a few iterations; the exact finish then needs only a few releases.
pub(crate) const LBFGSB_ITERATIONS: u64 = 2;

/// Largest `cond(A)` (σ_max/σ_min from the SVD of [`Factor::new`]) for which the active-set finish works
/// on the normal equations `H = AᵀA` (incremental Cholesky of `H_FF`, multipliers `Hx − Aᵀb`). Below it
/// `cond(H_FF) ≤ cond(H) ≤ 1e12` for every free set (interlacing), so the free solves lose at most about
/// `1e12·ε ≈ 2e-4` relative in the weakest direction — a change of the objective far below rounding — and the
/// multipliers are exact to `ε·‖H‖‖x‖`, the same as from the residual. Above it (weights over many decades,
/// nearly dependent rows, fewer rows than unknowns) the finish works on A itself by QR (see the module docs).
pub(crate) const NORMAL_EQUATIONS_MAX_COND: f64 = 1e6;

/// Reusable factorisation of A.
#[derive(Clone, Debug)]
pub struct Factor {
    /// Minimum-norm pseudo-inverse A⁺ (n×rows).
    pub pinv: DMatrix<f64>,
    /// `AᵀA`.
    pub(crate) h: DMatrix<f64>,
    /// `σ_max/σ_min` of A; infinite when A has fewer rows than columns or a zero singular value.
    pub(crate) cond: f64,
    /// Where A's columns are zero (a design's smoothness rows are sparse), for the products `Aᵀv` with
    /// nalgebra's bits that leave those zeros out; None when A is not finite.
    pub(crate) zero_chunks: Option<kernels::ZeroChunks>,
    /// Cholesky factors of `H_FF` by free set F, shared by the systems that share this factorisation.
    pub(crate) free_sets: FreeSets,
    /// `H⁻¹` and the factor of all of H for the guess of the active set (`lsq/guess.rs`), made on first
    /// use; None on the QR path or when they are not finite.
    dual: std::sync::OnceLock<Option<Dual>>,
}

impl Factor {
    pub fn new(a: &DMatrix<f64>) -> Factor {
        let (pinv, cond) = svd_pseudo_inverse(a);
        Factor {
            pinv,
            h: a.tr_mul(a),
            cond,
            zero_chunks: kernels::ZeroChunks::of(a),
            free_sets: FreeSets::default(),
            dual: std::sync::OnceLock::new(),
        }
    }

    fn dual(&self) -> Option<&Dual> {
        if self.needs_qr() {
            return None;
        }
        self.dual.get_or_init(|| Dual::of(&self.pinv, &self.h)).as_ref()
    }

    /// Whether the bounded solve must work on A rather than on `AᵀA` (see [`NORMAL_EQUATIONS_MAX_COND`]).
    pub(crate) fn needs_qr(&self) -> bool {
        self.cond.is_nan() || self.cond > NORMAL_EQUATIONS_MAX_COND
    }
}

/// The pseudo-inverse (singular values below `max(rows, n) · ε · σ_max` dropped, LAPACK `gelsd`'s default)
/// and `σ_max/σ_min`.
fn svd_pseudo_inverse(a: &DMatrix<f64>) -> (DMatrix<f64>, f64) {
    let (r, n) = a.shape();
    if r == 0 || n == 0 || a.iter().any(|v| !v.is_finite()) {
        return (DMatrix::zeros(n, r), f64::INFINITY);
    }
    let svd = a.clone().svd(true, true);
    let smax = svd.singular_values.iter().cloned().fold(0.0, f64::max);
    let smin = svd.singular_values.iter().cloned().fold(f64::INFINITY, f64::min);
    let cond = if r >= n && smin > 0.0 { smax / smin } else { f64::INFINITY };
    let tol = (r.max(n) as f64) * f64::EPSILON * smax;
    match svd.pseudo_inverse(tol.max(f64::MIN_POSITIVE)) {
        Ok(p) if p.iter().all(|v| v.is_finite()) => (p, cond),
        _ => (DMatrix::zeros(n, r), f64::INFINITY),
    }
}

/// The outcome of a bounded solve.
#[derive(Clone, Debug)]
pub struct LsqOutcome {
    pub x: DVector<f64>,
    /// `‖A x − b‖²`, computed from the residual.
    pub(crate) objective: f64,
    /// `‖x − P(x − ∇f)‖∞ / (1 + ‖∇f(0)‖∞)` with `∇f = 2Aᵀ(Ax − b)` computed from the residual.
    pub(crate) kkt: f64,
    /// False when the unconstrained solution already satisfied the bounds.
    pub(crate) bounds_active: bool,
    /// L-BFGS-B iterations and active-set steps used: counted for a reader in a debugger; neither the
    /// report nor a test reads them.
    #[expect(dead_code, reason = "diagnostics kept for debugging, not reported")]
    pub(crate) lbfgsb_iterations: u64,
    #[expect(dead_code, reason = "diagnostics kept for debugging, not reported")]
    pub(crate) active_set_steps: usize,
}

/// `‖Ax − b‖²` as an argmin problem: through `H = AᵀA` and `Aᵀb` when A is well conditioned, else from the
/// residual (the normal form cancels catastrophically when the rows' weights span many decades).
struct Objective<'a> {
    sys: &'a LinearSystem,
    h: &'a DMatrix<f64>,
    atb: &'a DVector<f64>,
    bb: f64,
    from_residual: bool,
    /// The last point and its `Hx` (argmin asks for the cost, then the gradient, at the same point).
    last: std::cell::RefCell<Option<(DVector<f64>, DVector<f64>)>>,
}

impl Objective<'_> {
    /// `Hx`, reusing the previous product when x is the same point.
    fn hx(&self, x: &DVector<f64>) -> DVector<f64> {
        if let Ok(last) = self.last.try_borrow()
            && let Some((lx, hx)) = last.as_ref()
            && lx == x
        {
            return hx.clone();
        }
        let hx = self.h * x;
        if let Ok(mut last) = self.last.try_borrow_mut() {
            *last = Some((x.clone(), hx.clone()));
        }
        hx
    }
}

impl CostFunction for Objective<'_> {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, x: &DVector<f64>) -> Result<f64, Error> {
        if self.from_residual {
            return Ok((&*self.sys.a * x - &self.sys.b).norm_squared());
        }
        Ok((x.dot(&self.hx(x)) - 2.0 * self.atb.dot(x) + self.bb).max(0.0))
    }
}

impl Gradient for Objective<'_> {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;
    fn gradient(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        if self.from_residual {
            return Ok(self.sys.a.tr_mul(&(&*self.sys.a * x - &self.sys.b)) * 2.0);
        }
        let mut g = self.hx(x);
        g -= self.atb;
        g *= 2.0;
        Ok(g)
    }
}

/// The scaled KKT residual of x (see [`LsqOutcome::kkt`]) from its residual `r = Ax − b`; `zero_chunks` is
/// [`Factor::zero_chunks`] of `sys.a` (the same bits either way).
fn kkt_of(
    sys: &LinearSystem,
    zero_chunks: Option<&kernels::ZeroChunks>,
    x: &DVector<f64>,
    r: &DVector<f64>,
    grad_scale: f64,
) -> f64 {
    let mut g = DVector::zeros(sys.a.ncols());
    match zero_chunks {
        Some(chunks) => kernels::gemv_tr_zero_chunks(&sys.a, chunks, r.as_slice(), g.as_mut_slice()),
        None => kernels::gemv_tr(&sys.a, r.as_slice(), g.as_mut_slice()),
    }
    g *= 2.0;
    projected_gradient_norm(x, &g, &sys.lower, &sys.upper) / grad_scale
}

/// Where the active-set finish starts when the unconstrained solution leaves the box.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Start {
    /// The unconstrained (SVD) solution clamped to the box: its clamped support is the first guess of the
    /// active set (the normal-equations path).
    Clamped,
    /// L-BFGS-B's point after [`LBFGSB_ITERATIONS`] from the clamped solution (always on the QR path; on the
    /// normal-equations path only for the tests that check both starts end at the same bits).
    Lbfgsb,
    /// [`Start::Clamped`] without the guess of the active set (`lsq/guess.rs`): the finish's own steps from
    /// the clamped solution, for the tests that check the guess ends at the same bits.
    #[cfg(test)]
    ClampedUnguessed,
}

/// Solve the bounded system. `factor` must be `Factor::new(&sys.a)`.
pub fn solve(sys: &LinearSystem, factor: &Factor) -> LsqOutcome {
    solve_from_start(sys, factor, Start::Clamped)
}

/// [`solve`] with the finish's start chosen (the QR path always starts from L-BFGS-B).
pub(crate) fn solve_from_start(sys: &LinearSystem, factor: &Factor, start: Start) -> LsqOutcome {
    with_work(sys, factor.needs_qr(), |work| solve_in(sys, factor, work, start))
}

fn solve_in(sys: &LinearSystem, factor: &Factor, work: &mut Work, start: Start) -> LsqOutcome {
    let n = sys.a.ncols();
    // The products by the hand kernels, which give nalgebra's bits (`A.tr_mul(b)`, `A x − b`, `A⁺ b`).
    let mut atb = DVector::zeros(n);
    // A (and A⁺) finite on the normal-equations path: the right-hand side's trailing zeros (the smoothness
    // rows') can be left out of the products with the same bits.
    let finite = !factor.needs_qr();
    // `Aᵀv` without A's zero chunks (most of a design's smoothness rows), with nalgebra's bits too.
    let zero_chunks = factor.zero_chunks.as_ref();
    if let Some(chunks) = zero_chunks {
        kernels::gemv_tr_zero_chunks(&sys.a, chunks, sys.b.as_slice(), atb.as_mut_slice());
    } else if finite {
        kernels::gemv_tr_trailing_zeros(&sys.a, sys.b.as_slice(), atb.as_mut_slice());
    } else {
        kernels::gemv_tr(&sys.a, sys.b.as_slice(), atb.as_mut_slice());
    }
    let grad_scale = 1.0 + 2.0 * atb.amax();
    let residual_of = |x: &DVector<f64>| {
        let mut r = DVector::zeros(sys.a.nrows());
        kernels::gemv(&sys.a, x.as_slice(), r.as_mut_slice());
        r -= &sys.b;
        r
    };
    let residual = |x: &DVector<f64>| residual_of(x).norm_squared();
    let use_qr = work.use_qr;
    let mut x_svd = DVector::zeros(n);
    if finite {
        kernels::gemv_trailing_zeros(&factor.pinv, sys.b.as_slice(), x_svd.as_mut_slice());
    } else {
        kernels::gemv(&factor.pinv, sys.b.as_slice(), x_svd.as_mut_slice());
    }
    if use_qr && n > 0 && x_svd.iter().all(|v| v.is_finite()) {
        // Ill-conditioned A: one step of refinement of the SVD solution by QR of A (rows sorted by weight),
        // numerically dependent columns held at their SVD values. It recovers what the SVD's normwise
        // rounding and relative cut-off lose on graded rows (weights over many decades).
        let mut refined = x_svd.clone();
        work.free.clear();
        work.free.extend(0..n);
        work.is_free.iter_mut().for_each(|f| *f = true);
        if work.qr_solve(sys, refined.as_slice()) {
            for (k, &i) in work.free.iter().enumerate() {
                refined[i] = work.z[k];
            }
            if residual(&refined) <= residual(&x_svd) {
                x_svd = refined;
            }
        }
    }
    let feasible = (0..n).all(|i| x_svd[i] >= sys.lower[i] && x_svd[i] <= sys.upper[i]);
    // On the normal-equations path from the clamped start, the active set guessed on the bound variables
    // and its solution tested as the finish tests its own (`lsq/guess.rs`); else the finish runs, from the
    // guess's point when it handed over, from the clamped solution when it gave up or its set failed.
    let guess = match factor.dual() {
        Some(dual) if !feasible && !use_qr && start == Start::Clamped => {
            match work.guess(dual, &factor.h, &atb, x_svd.as_slice(), sys) {
                Guess::Set if work.settle(dual, sys, &factor.h, &atb, Some(&factor.free_sets)) => Guess::Set,
                Guess::Set => Guess::GaveUp,
                other => other,
            }
        }
        _ => Guess::GaveUp,
    };
    if feasible || n == 0 {
        let r = residual_of(&x_svd);
        let objective = r.norm_squared();
        let kkt = kkt_of(sys, zero_chunks, &x_svd, &r, grad_scale);
        return LsqOutcome {
            x: x_svd,
            objective,
            kkt,
            bounds_active: false,
            lbfgsb_iterations: 0,
            active_set_steps: 0,
        };
    }
    let mut x0 = x_svd;
    for i in 0..n {
        x0[i] = if x0[i].is_finite() { x0[i] } else { 0.0 }.max(sys.lower[i]).min(sys.upper[i]);
    }
    let (x1, iters) = if use_qr || start == Start::Lbfgsb {
        let bb = sys.b.norm_squared();
        let problem = Objective { sys, h: &factor.h, atb: &atb, bb, from_residual: use_qr, last: Default::default() };
        // L-BFGS-B only has to find the active set roughly; the active-set finish makes it exact.
        let solver = LBfgsB::new(sys.lower.clone(), sys.upper.clone())
            .with_memory(5)
            .with_pg_tol(1e-9 * grad_scale)
            .with_f_tol(1e-12, bb);
        match run_lbfgsb(problem, solver, x0.clone(), LBFGSB_ITERATIONS) {
            Some(r) => r,
            None => (x0, 0),
        }
    } else {
        (x0, 0)
    };
    let steps = if use_qr {
        // A QR solve per step costs O(m·n·|F|): let the normal equations find the active set first (they
        // hand over to QR by themselves when their Cholesky factor degrades), then finish exactly by QR
        // from there, which then needs only a step or two.
        work.set_path(false);
        work.rough = true;
        let rough = work.finish(sys, &factor.h, &atb, &x1, Some(&factor.free_sets));
        let x_rough = DVector::from_column_slice(&work.x);
        work.rough = false;
        work.set_path(true);
        rough + work.finish(sys, &factor.h, &atb, &x_rough, Some(&factor.free_sets))
    } else if guess == Guess::Set {
        0
    } else {
        work.chol.ok = true;
        let from = if guess == Guess::HandOver { DVector::from_column_slice(&work.x) } else { x1.clone() };
        let steps = work.finish(sys, &factor.h, &atb, &from, Some(&factor.free_sets));
        work.polish(sys, &factor.h, &atb, Some(&factor.free_sets), finish::Rows::Start);
        steps
    };
    let x2 = DVector::from_column_slice(&work.x);
    let r2 = residual_of(&x2);
    let f2 = r2.norm_squared();
    // Keep whichever is better (the finish can only improve on a convex problem; this guards rounding).
    // Not when the guessed set was accepted: `Work::settle` tested x2 itself, the polished point, by the
    // finish's own test of optimality (inside the box, its factor healthy and well conditioned, no
    // multiplier of the wrong sign beyond its rounding level), so x2 is the minimiser of the strictly
    // convex objective (H positive definite on this path, cond(A) ≤ 1e6) to rounding, and x1 — the clamped
    // unconstrained solution, which was outside the box — could win the comparison only by a difference
    // at rounding level between two points that are not the same: a guard against nothing there.
    let (x, r, objective) = if guess == Guess::Set {
        (x2, r2, f2)
    } else {
        let r1 = residual_of(&x1);
        let f1 = r1.norm_squared();
        if f2 <= f1 { (x2, r2, f2) } else { (x1, r1, f1) }
    };
    let kkt = kkt_of(sys, zero_chunks, &x, &r, grad_scale);
    LsqOutcome { x, objective, kkt, bounds_active: true, lbfgsb_iterations: iters, active_set_steps: steps }
}

fn run_lbfgsb(problem: Objective, solver: LBfgsB, x0: DVector<f64>, max_iters: u64) -> Option<(DVector<f64>, u64)> {
    let run = crate::optimize::run(problem, solver, x0, &crate::optimize::Limits::iterations(max_iters)).ok()?;
    let iters = run.iterations();
    let x = run.state.param?;
    x.iter().all(|v| v.is_finite()).then_some((x, iters))
}

mod kernels;

mod finish;
mod guess;
pub(crate) use finish::FreeSets;
use finish::{Work, with_work};
use guess::{Dual, Guess};

/// Warm-started bounded solve for repeated problems (alternating joint design): the exact active-set
/// finish from `x0` projected onto the box, without SVD or L-BFGS-B. On a convex problem it ends at an
/// exact minimiser (the minimum-norm one is not guaranteed when A is rank deficient). It works on `h = AᵀA`
/// while the Cholesky factors of its free blocks stay well conditioned, else on A by QR.
pub(crate) fn solve_from(sys: &LinearSystem, h: &DMatrix<f64>, x0: &DVector<f64>) -> LsqOutcome {
    let atb = sys.a.tr_mul(&sys.b);
    let (steps, x) = with_work(sys, false, |work| {
        let steps = work.finish(sys, h, &atb, x0, None);
        (steps, DVector::from_column_slice(&work.x))
    });
    let r = &*sys.a * &x - &sys.b;
    let kkt = kkt_of(sys, None, &x, &r, 1.0 + 2.0 * atb.amax());
    let objective = r.norm_squared();
    LsqOutcome { x, objective, kkt, bounds_active: true, lbfgsb_iterations: 0, active_set_steps: steps }
}

/// Plain entry for the tests and [`super::solve::solve_dense`]: factor and solve in one call.
pub(crate) fn solve_system(sys: &LinearSystem) -> LsqOutcome {
    solve(sys, &Factor::new(&sys.a))
}

#[cfg(test)]
mod tests;
