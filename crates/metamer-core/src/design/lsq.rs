//! Bounded linear least squares `min ‖A x − b‖²`, `lower ≤ x ≤ upper`:
//!
//! 1. the minimum-norm unconstrained solution by SVD (singular values below
//!    `max(rows, n) · ε · σ_max` are dropped, as LAPACK's `gelsd` default does); when A is ill conditioned
//!    (see [`NORMAL_EQUATIONS_MAX_COND`]) one step of refinement by QR of A with the rows sorted by weight
//!    recovers what the SVD's normwise rounding and cut-off lose on graded rows. If it already satisfies the
//!    bounds exactly, that is the answer;
//! 2. otherwise L-BFGS-B ([`super::lbfgsb`]) from the SVD solution projected onto the box, which finds
//!    the active set approximately;
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
//! The reported objective and KKT residual are computed from the residual `Ax − b`.
//! The factorisation (SVD pseudo-inverse, `AᵀA` and `cond(A)`) depends on A only; [`Factor`]s are shared
//! between systems with the same A (e.g. many reflectances under the same lights).

use super::lbfgsb::{self, LBfgsB, projected_gradient_norm};
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
}

impl Factor {
    pub fn new(a: &DMatrix<f64>) -> Factor {
        let (pinv, cond) = svd_pseudo_inverse(a);
        Factor { pinv, h: a.tr_mul(a), cond }
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
    /// L-BFGS-B iterations and active-set steps used.
    pub lbfgsb_iterations: u64,
    pub active_set_steps: usize,
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
            return Ok((&self.sys.a * x - &self.sys.b).norm_squared());
        }
        Ok((x.dot(&self.hx(x)) - 2.0 * self.atb.dot(x) + self.bb).max(0.0))
    }
}

impl Gradient for Objective<'_> {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;
    fn gradient(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        if self.from_residual {
            return Ok(self.sys.a.tr_mul(&(&self.sys.a * x - &self.sys.b)) * 2.0);
        }
        let mut g = self.hx(x);
        g -= self.atb;
        g *= 2.0;
        Ok(g)
    }
}

/// The scaled KKT residual of x (see [`LsqOutcome::kkt`]) from its residual `r = Ax − b`.
fn kkt_of(sys: &LinearSystem, x: &DVector<f64>, r: &DVector<f64>, grad_scale: f64) -> f64 {
    let g = sys.a.tr_mul(r) * 2.0;
    projected_gradient_norm(x, &g, &sys.lower, &sys.upper) / grad_scale
}

/// Solve the bounded system. `factor` must be `Factor::new(&sys.a)`.
pub fn solve(sys: &LinearSystem, factor: &Factor) -> LsqOutcome {
    with_work(sys, factor.needs_qr(), |work| solve_in(sys, factor, work))
}

fn solve_in(sys: &LinearSystem, factor: &Factor, work: &mut Work) -> LsqOutcome {
    let n = sys.a.ncols();
    let atb = sys.a.tr_mul(&sys.b);
    let grad_scale = 1.0 + 2.0 * atb.amax();
    let residual_of = |x: &DVector<f64>| &sys.a * x - &sys.b;
    let residual = |x: &DVector<f64>| residual_of(x).norm_squared();
    let use_qr = work.use_qr;
    let mut x_svd = &factor.pinv * &sys.b;
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
    if feasible || n == 0 {
        let r = residual_of(&x_svd);
        let objective = r.norm_squared();
        let kkt = kkt_of(sys, &x_svd, &r, grad_scale);
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
    let bb = sys.b.norm_squared();
    let problem = Objective { sys, h: &factor.h, atb: &atb, bb, from_residual: use_qr, last: Default::default() };
    // L-BFGS-B only has to find the active set roughly; the active-set finish makes it exact.
    let solver = LBfgsB::new(sys.lower.clone(), sys.upper.clone())
        .with_memory(5)
        .with_pg_tol(1e-9 * grad_scale)
        .with_f_tol(1e-12, bb);
    let (x1, iters) = match run_lbfgsb(problem, solver, x0.clone(), LBFGSB_ITERATIONS) {
        Some(r) => r,
        None => (x0, 0),
    };
    let steps = if use_qr {
        // A QR solve per step costs O(m·n·|F|): let the normal equations find the active set first (they
        // hand over to QR by themselves when their Cholesky factor degrades), then finish exactly by QR
        // from there, which then needs only a step or two.
        work.set_path(false);
        work.rough = true;
        let rough = work.finish(sys, &factor.h, &atb, &x1);
        let x_rough = DVector::from_column_slice(&work.x);
        work.rough = false;
        work.set_path(true);
        rough + work.finish(sys, &factor.h, &atb, &x_rough)
    } else {
        work.finish(sys, &factor.h, &atb, &x1)
    };
    let x2 = DVector::from_column_slice(&work.x);
    // Keep whichever is better (the finish can only improve on a convex problem; this guards rounding).
    let (r1, r2) = (residual_of(&x1), residual_of(&x2));
    let (f1, f2) = (r1.norm_squared(), r2.norm_squared());
    let (x, r, objective) = if f2 <= f1 { (x2, r2, f2) } else { (x1, r1, f1) };
    let kkt = kkt_of(sys, &x, &r, grad_scale);
    LsqOutcome { x, objective, kkt, bounds_active: true, lbfgsb_iterations: iters, active_set_steps: steps }
}

fn run_lbfgsb(problem: Objective, solver: LBfgsB, x0: DVector<f64>, max_iters: u64) -> Option<(DVector<f64>, u64)> {
    let run = crate::optimize::run(problem, solver, x0, &crate::optimize::Limits::iterations(max_iters)).ok()?;
    let iters = run.iterations();
    let x = run.state.param?;
    x.iter().all(|v| v.is_finite()).then_some((x, iters))
}

#[path = "lsq_kernels.rs"]
mod kernels;
use kernels::{Cholesky, Qr, Status, axpy, column};

/// Buffers and state of the exact active-set finish (reused across its steps: no allocation per step).
struct Work {
    n: usize,
    /// Current point, status and free list.
    x: Vec<f64>,
    status: Vec<Status>,
    is_free: Vec<bool>,
    free: Vec<usize>,
    /// Working on A (QR, residual multipliers) rather than on `AᵀA`.
    use_qr: bool,
    chol: Cholesky,
    qr: Qr,
    /// `H x_B` (the bound variables' part of Hx), kept up to date on the normal-equations path.
    hb: Vec<f64>,
    z: Vec<f64>,
    /// Half-gradient `Aᵀ(Ax − b)` (on the normal-equations path only at bound variables) and its rounding
    /// level; residual and `|A||x| + |b|`.
    g: DVector<f64>,
    noise: DVector<f64>,
    r: DVector<f64>,
    mag: DVector<f64>,
    stuck: Vec<bool>,
    newly_bound: Vec<usize>,
    /// The last free solve was by QR at the current point, so its multipliers are current.
    qr_current: bool,
    /// Only looking for an active set (an exact QR finish follows): keep the Cholesky path even when its
    /// factor is poorly conditioned.
    rough: bool,
    /// `‖H‖max` and `‖Aᵀb‖∞` (NaN until first needed).
    h_max: f64,
    atb_max: f64,
}

thread_local! {
    /// One [`Work`] per thread, reused by every solve on it: the batch path solves thousands of small systems
    /// and would otherwise allocate a dozen buffers for each.
    static WORK: std::cell::RefCell<Work> = std::cell::RefCell::new(Work::new(0, 0, false));
}

/// Run `f` with this thread's [`Work`] prepared for `sys` (a fresh one if it is already in use).
fn with_work<R>(sys: &LinearSystem, use_qr: bool, f: impl FnOnce(&mut Work) -> R) -> R {
    let (m, n) = sys.a.shape();
    WORK.with(|cell| match cell.try_borrow_mut() {
        Ok(mut w) => {
            w.reset(m, n, use_qr);
            f(&mut w)
        }
        Err(_) => f(&mut Work::new(m, n, use_qr)),
    })
}

impl Work {
    fn new(m: usize, n: usize, use_qr: bool) -> Work {
        Work {
            n,
            x: vec![0.0; n],
            status: vec![Status::Free; n],
            is_free: vec![true; n],
            free: Vec::with_capacity(n),
            use_qr,
            chol: Cholesky::new(n, !use_qr),
            qr: Qr::default(),
            hb: vec![0.0; n],
            z: Vec::with_capacity(n),
            g: DVector::zeros(n),
            noise: DVector::zeros(n),
            r: DVector::zeros(m),
            mag: DVector::zeros(m),
            stuck: vec![false; n],
            newly_bound: Vec::with_capacity(n),
            qr_current: false,
            rough: false,
            h_max: f64::NAN,
            atb_max: f64::NAN,
        }
    }

    /// Work on A by QR (`true`) or on `AᵀA` by Cholesky (`false`) in the next [`Work::finish`].
    fn set_path(&mut self, qr: bool) {
        self.use_qr = qr;
        self.chol.ok = !qr;
        if !qr {
            self.chol.l.resize(self.n * self.n, 0.0);
        }
    }

    /// Prepare for an m×n system, keeping the buffers' storage.
    fn reset(&mut self, m: usize, n: usize, use_qr: bool) {
        self.n = n;
        self.x.resize(n, 0.0);
        self.status.resize(n, Status::Free);
        self.is_free.resize(n, true);
        self.free.clear();
        self.use_qr = use_qr;
        self.chol.n = n;
        self.chol.ok = !use_qr;
        if !use_qr {
            self.chol.l.resize(n * n, 0.0);
        }
        // A new matrix: the QR's row order and |A| are recomputed on first use.
        self.qr.order.clear();
        self.hb.resize(n, 0.0);
        self.z.clear();
        for v in [&mut self.g, &mut self.noise] {
            if v.len() != n {
                *v = DVector::zeros(n);
            }
        }
        for v in [&mut self.r, &mut self.mag] {
            if v.len() != m {
                *v = DVector::zeros(m);
            }
        }
        self.stuck.resize(n, false);
        self.newly_bound.clear();
        self.qr_current = false;
        self.rough = false;
        self.h_max = f64::NAN;
        self.atb_max = f64::NAN;
    }

    /// QR solve of the free set with the other variables at `x`, into `self.z`.
    fn qr_solve(&mut self, sys: &LinearSystem, x: &[f64]) -> bool {
        self.qr.solve(sys, x, &self.free, &self.is_free, &mut self.z)
    }

    fn bind(&mut self, h: &DMatrix<f64>, i: usize, to: Status) {
        self.status[i] = to;
        self.is_free[i] = false;
        if let Some(k) = self.free.iter().position(|&f| f == i) {
            let nf = self.free.len();
            self.free.remove(k);
            self.chol.remove(k, nf);
        }
        if !self.use_qr && self.x[i] != 0.0 {
            axpy(self.x[i], column(h, i), &mut self.hb);
        }
    }

    fn release(&mut self, h: &DMatrix<f64>, j: usize) {
        self.status[j] = Status::Free;
        self.is_free[j] = true;
        if !self.use_qr && self.x[j] != 0.0 {
            axpy(-self.x[j], column(h, j), &mut self.hb);
        }
        self.chol.add(h, &self.free, j);
        self.free.push(j);
    }

    /// Least squares over the free set into `self.z`: Cholesky of `H_FF` while it is healthy, else QR (for
    /// the rest of the finish). False when neither gives a finite result.
    fn solve_free(&mut self, sys: &LinearSystem, atb: &DVector<f64>) -> bool {
        if !self.use_qr && self.chol.ok && (self.rough || self.chol.well_conditioned(self.free.len())) {
            self.z.clear();
            self.z.extend(self.free.iter().map(|&i| atb[i] - self.hb[i]));
            self.chol.solve_in_place(&mut self.z);
            if self.z.iter().all(|v| v.is_finite()) {
                return true;
            }
        }
        self.use_qr = true;
        self.chol.ok = false;
        let x = std::mem::take(&mut self.x);
        let ok = self.qr.solve(sys, &x, &self.free, &self.is_free, &mut self.z);
        self.x = x;
        ok
    }

    /// The half-gradient `g = Aᵀ(Ax − b)` at `self.x` and, per component, the level below which its sign is
    /// rounding noise. Normal equations: `g = Hx − Aᵀb`, noise `2(n+1)²ε·max(‖Aᵀb‖∞, ‖H‖max‖x‖∞)` (the worst
    /// case of the product's rounding). QR path: from the last QR solve when it is current (see [`Qr::solve`];
    /// noise `4mε·Σ|(Qᵀa_j)_i t_i|`), else from the residual with noise `8ε·(|A|ᵀ(|A||x| + |b|))ᵢ`, about the
    /// typical rounding of each component. Smaller multipliers are not trusted.
    fn gradient(&mut self, sys: &LinearSystem, h: &DMatrix<f64>, atb: &DVector<f64>) {
        if self.h_max.is_nan() {
            // H is positive semidefinite: |H_ij| ≤ √(H_ii H_jj), so its largest entry is on the diagonal.
            self.h_max = h.diagonal().iter().fold(0.0, |m, v| m.max(v.abs()));
            self.atb_max = atb.iter().fold(0.0, |m, v| m.max(v.abs()));
        }
        if self.use_qr && self.qr_current {
            for i in 0..self.n {
                (self.g[i], self.noise[i]) =
                    if self.is_free[i] { (0.0, 0.0) } else { (self.qr.mult[i], self.qr.mult_noise[i]) };
            }
        } else if self.use_qr {
            self.qr.prepare(&sys.a);
            let x = nalgebra::DVectorView::from_slice(&self.x, self.n);
            self.r.copy_from(&sys.b);
            self.r.gemv(1.0, &sys.a, &x, -1.0);
            self.g.gemv_tr(1.0, &sys.a, &self.r, 0.0);
            let xabs = x.abs();
            self.mag.copy_from(&sys.b.abs());
            self.mag.gemv(1.0, &self.qr.abs_a, &xabs, 1.0);
            self.noise.gemv_tr(8.0 * f64::EPSILON, &self.qr.abs_a, &self.mag, 0.0);
        } else {
            // Only the bound variables' components are needed: g_i = (H x_B)_i + H_iF x_F − (Aᵀb)_i, with
            // `hb = H x_B` kept up to date (H is symmetric: row i is column i).
            for i in 0..self.n {
                self.g[i] = if self.is_free[i] {
                    0.0
                } else {
                    let col = column(h, i);
                    self.free.iter().fold(self.hb[i] - atb[i], |v, &k| v + col[k] * self.x[k])
                };
            }
            let n = self.n as f64;
            let level = 2.0
                * (n + 1.0)
                * (n + 1.0)
                * f64::EPSILON
                * self.atb_max.max(self.h_max * self.x.iter().fold(0.0f64, |m, v| m.max(v.abs())));
            self.noise.fill(level);
        }
    }

    /// The exact active-set finish from `x0` projected onto the box (see the module docs). Leaves the result
    /// in `self.x`; returns the number of releases (outer steps).
    fn finish(&mut self, sys: &LinearSystem, h: &DMatrix<f64>, atb: &DVector<f64>, x0: &DVector<f64>) -> usize {
        let n = self.n;
        let (lo, hi) = (sys.lower.as_slice(), sys.upper.as_slice());
        self.free.clear();
        self.hb.iter_mut().for_each(|v| *v = 0.0);
        self.stuck.iter_mut().for_each(|v| *v = false);
        for i in 0..n {
            let v = if x0[i].is_finite() { x0[i] } else { 0.0 };
            if v <= lo[i] {
                self.x[i] = lo[i];
                self.status[i] = Status::Lower;
                self.is_free[i] = false;
            } else if v >= hi[i] {
                self.x[i] = hi[i];
                self.status[i] = Status::Upper;
                self.is_free[i] = false;
            } else {
                self.x[i] = v;
                self.status[i] = Status::Free;
                self.is_free[i] = true;
                self.chol.add(h, &self.free, i);
                self.free.push(i);
            }
        }
        if !self.use_qr {
            for j in 0..n {
                if !self.is_free[j] && self.x[j] != 0.0 {
                    axpy(self.x[j], column(h, j), &mut self.hb);
                }
            }
        }
        let mut released: Option<(usize, Status)> = None;
        let max_steps = 4 * n + 20;
        let mut steps = 0;
        while steps < max_steps {
            steps += 1;
            // Inner loop: solve on the free set, walking back to the box when the solution leaves it.
            self.qr_current = false;
            for _ in 0..=2 * n {
                if self.free.is_empty() || !self.solve_free(sys, atb) {
                    break;
                }
                // A variable released a moment ago that wants straight back out on the same side: its
                // multiplier was rounding noise. Bind it again and skip it until another release succeeds.
                if let Some((j, from)) = released.take() {
                    let k = self.free.iter().position(|&f| f == j).unwrap_or(0);
                    let back = match from {
                        Status::Lower => self.z[k] <= lo[j],
                        Status::Upper => self.z[k] >= hi[j],
                        Status::Free => false,
                    };
                    if back {
                        self.stuck[j] = true;
                        self.bind(h, j, from);
                        continue;
                    }
                    self.stuck.iter_mut().for_each(|s| *s = false);
                }
                let mut alpha: f64 = 1.0;
                let mut hit: Option<usize> = None;
                for (k, &i) in self.free.iter().enumerate() {
                    let (zi, xi) = (self.z[k], self.x[i]);
                    let a = if zi < lo[i] {
                        (lo[i] - xi) / (zi - xi)
                    } else if zi > hi[i] {
                        (hi[i] - xi) / (zi - xi)
                    } else {
                        continue;
                    };
                    let a = if a.is_finite() { a.clamp(0.0, 1.0) } else { 0.0 };
                    if hit.is_none() || a < alpha {
                        alpha = a;
                        hit = Some(i);
                    }
                }
                let Some(hit) = hit else {
                    for (k, &i) in self.free.iter().enumerate() {
                        self.x[i] = self.z[k];
                    }
                    self.qr_current = self.use_qr;
                    break;
                };
                self.newly_bound.clear();
                for (k, &i) in self.free.iter().enumerate() {
                    let zk = self.z[k];
                    let v = (self.x[i] + alpha * (zk - self.x[i])).max(lo[i]).min(hi[i]);
                    self.x[i] = v;
                    if zk < lo[i] && (i == hit || v - lo[i] <= 1e-14 * (1.0 + lo[i].abs())) {
                        self.x[i] = lo[i];
                        self.newly_bound.push(i);
                    } else if zk > hi[i] && (i == hit || hi[i] - v <= 1e-14 * (1.0 + hi[i].abs())) {
                        self.x[i] = hi[i];
                        self.newly_bound.push(i);
                    }
                }
                for t in 0..self.newly_bound.len() {
                    let i = self.newly_bound[t];
                    let to = if self.x[i] == lo[i] { Status::Lower } else { Status::Upper };
                    self.bind(h, i, to);
                }
            }
            // Multipliers: the half-gradient at bound variables must point out of the box.
            self.gradient(sys, h, atb);
            let mut worst: Option<(usize, f64)> = None;
            let (g, noise) = (self.g.as_slice(), self.noise.as_slice());
            for i in 0..n {
                if self.stuck[i] || lo[i] == hi[i] {
                    continue;
                }
                let v = match self.status[i] {
                    Status::Lower => -g[i],
                    Status::Upper => g[i],
                    Status::Free => continue,
                };
                if v > noise[i] && worst.is_none_or(|(_, w)| v > w) {
                    worst = Some((i, v));
                }
            }
            let Some((j, _)) = worst else { break };
            released = Some((j, self.status[j]));
            self.release(h, j);
        }
        steps
    }
}

/// Warm-started bounded solve for repeated problems (alternating joint design): the exact active-set
/// finish from `x0` projected onto the box, without SVD or L-BFGS-B. On a convex problem it ends at an
/// exact minimiser (the minimum-norm one is not guaranteed when A is rank deficient). It works on `h = AᵀA`
/// while the Cholesky factors of its free blocks stay well conditioned, else on A by QR.
pub(crate) fn solve_from(sys: &LinearSystem, h: &DMatrix<f64>, x0: &DVector<f64>) -> LsqOutcome {
    let atb = sys.a.tr_mul(&sys.b);
    let (steps, x) = with_work(sys, false, |work| {
        let steps = work.finish(sys, h, &atb, x0);
        (steps, DVector::from_column_slice(&work.x))
    });
    let r = &sys.a * &x - &sys.b;
    let kkt = kkt_of(sys, &x, &r, 1.0 + 2.0 * atb.amax());
    let objective = r.norm_squared();
    LsqOutcome { x, objective, kkt, bounds_active: true, lbfgsb_iterations: 0, active_set_steps: steps }
}

/// Plain entry for tests and benchmarks: factor and solve in one call.
pub(crate) fn solve_system(sys: &LinearSystem) -> LsqOutcome {
    solve(sys, &Factor::new(&sys.a))
}

/// Re-export for callers who only need L-BFGS-B.
pub use lbfgsb::minimize as lbfgsb_minimize;

#[cfg(test)]
#[path = "lsq_tests.rs"]
mod tests;
