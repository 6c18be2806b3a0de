//! Bounded linear least squares `min ‖A x − b‖²`, `lower ≤ x ≤ upper`:
//!
//! 1. the minimum-norm unconstrained solution by SVD (singular values below
//!    `max(rows, n) · ε · σ_max` are dropped, as LAPACK's `gelsd` default does); if it already satisfies
//!    the bounds exactly, that is the answer;
//! 2. otherwise L-BFGS-B ([`super::lbfgsb`]) from the SVD solution projected onto the box, which finds
//!    the active set approximately;
//! 3. then an exact active-set finish (bounded-variable least squares in the manner of Stark & Parker
//!    1995): fix the active bounds, solve the free variables' least squares exactly, walk back to the
//!    box when the solution leaves it (adding the bounds it hits), and release the bound whose Lagrange
//!    multiplier has the wrong sign, until none has. On a convex problem this ends at the exact optimum;
//!    it is capped at `4n + 20` releases so it cannot loop.
//!
//! The factorisation (SVD pseudo-inverse and `AᵀA`) depends on A only; [`Factor`]s are shared between
//! systems with the same A (e.g. many reflectances under the same lights).

use super::lbfgsb::{self, LBfgsB, projected_gradient_norm};
use super::system::LinearSystem;
use argmin::core::{CostFunction, Error, Gradient};
use nalgebra::{DMatrix, DVector};

/// L-BFGS-B iterations before the active-set finish. Its generalised Cauchy points identify most of the
/// active bounds within a few iterations; the exact finish then needs only a few releases.
pub const LBFGSB_ITERATIONS: u64 = 2;

/// Reusable factorisation of A.
#[derive(Clone, Debug)]
pub struct Factor {
    /// Minimum-norm pseudo-inverse A⁺ (n×rows).
    pub pinv: DMatrix<f64>,
    /// `AᵀA`.
    pub h: DMatrix<f64>,
}

impl Factor {
    pub fn new(a: &DMatrix<f64>) -> Factor {
        Factor { pinv: pseudo_inverse(a), h: a.tr_mul(a) }
    }
}

/// Minimum-norm pseudo-inverse by SVD; never fails (non-finite input gives a zero matrix).
pub fn pseudo_inverse(a: &DMatrix<f64>) -> DMatrix<f64> {
    let (r, n) = a.shape();
    if r == 0 || n == 0 || a.iter().any(|v| !v.is_finite()) {
        return DMatrix::zeros(n, r);
    }
    let svd = a.clone().svd(true, true);
    let smax = svd.singular_values.iter().cloned().fold(0.0, f64::max);
    let tol = (r.max(n) as f64) * f64::EPSILON * smax;
    match svd.pseudo_inverse(tol.max(f64::MIN_POSITIVE)) {
        Ok(p) if p.iter().all(|v| v.is_finite()) => p,
        _ => DMatrix::zeros(n, r),
    }
}

/// The outcome of a bounded solve.
#[derive(Clone, Debug)]
pub struct LsqOutcome {
    pub x: DVector<f64>,
    /// `‖A x − b‖²`, computed from the residual.
    pub objective: f64,
    /// `‖x − P(x − ∇f)‖∞ / (1 + ‖∇f(0)‖∞)`.
    pub kkt: f64,
    /// False when the unconstrained solution already satisfied the bounds.
    pub bounds_active: bool,
    /// L-BFGS-B iterations and active-set steps used.
    pub lbfgsb_iterations: u64,
    pub active_set_steps: usize,
}

/// `‖Ax − b‖²` as an argmin problem, evaluated through `H = AᵀA` and `Aᵀb`.
struct NormalForm<'a> {
    h: &'a DMatrix<f64>,
    atb: &'a DVector<f64>,
    bb: f64,
}

impl CostFunction for NormalForm<'_> {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, x: &DVector<f64>) -> Result<f64, Error> {
        Ok((x.dot(&(self.h * x)) - 2.0 * self.atb.dot(x) + self.bb).max(0.0))
    }
}

impl Gradient for NormalForm<'_> {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;
    fn gradient(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        Ok((self.h * x - self.atb) * 2.0)
    }
}

/// Solve the bounded system. `factor` must be `Factor::new(&sys.a)` when given.
pub fn solve(sys: &LinearSystem, factor: &Factor) -> LsqOutcome {
    let n = sys.a.ncols();
    let atb = sys.a.tr_mul(&sys.b);
    let grad_scale = 1.0 + 2.0 * atb.amax();
    let x_svd = &factor.pinv * &sys.b;
    let feasible = (0..n).all(|i| x_svd[i] >= sys.lower[i] && x_svd[i] <= sys.upper[i]);
    let residual = |x: &DVector<f64>| (&sys.a * x - &sys.b).norm_squared();
    let kkt_of = |x: &DVector<f64>| {
        let g = (&factor.h * x - &atb) * 2.0;
        projected_gradient_norm(x, &g, &sys.lower, &sys.upper) / grad_scale
    };
    if feasible || n == 0 {
        let objective = residual(&x_svd);
        let kkt = kkt_of(&x_svd);
        return LsqOutcome {
            x: x_svd,
            objective,
            kkt,
            bounds_active: false,
            lbfgsb_iterations: 0,
            active_set_steps: 0,
        };
    }
    let mut x0 = x_svd.clone();
    for i in 0..n {
        x0[i] = x0[i].max(sys.lower[i]).min(sys.upper[i]);
    }
    let bb = sys.b.norm_squared();
    let problem = NormalForm { h: &factor.h, atb: &atb, bb };
    // L-BFGS-B only has to find the active set roughly; the active-set finish makes it exact.
    let solver = LBfgsB::new(sys.lower.clone(), sys.upper.clone())
        .with_memory(5)
        .with_pg_tol(1e-9 * grad_scale)
        .with_f_tol(1e-12, bb);
    let max_iters: u64 = LBFGSB_ITERATIONS;
    let (x1, iters) = match run_lbfgsb(problem, solver, x0.clone(), max_iters) {
        Some(r) => r,
        None => (x0, 0),
    };
    let (x2, steps) = active_set_finish(sys, factor, &atb, x1.clone());
    // Keep whichever is better (the finish can only improve on a convex problem; this guards rounding).
    let (f1, f2) = (residual(&x1), residual(&x2));
    let (x, objective) = if f2 <= f1 { (x2, f2) } else { (x1, f1) };
    let kkt = kkt_of(&x);
    LsqOutcome { x, objective, kkt, bounds_active: true, lbfgsb_iterations: iters, active_set_steps: steps }
}

fn run_lbfgsb(problem: NormalForm, solver: LBfgsB, x0: DVector<f64>, max_iters: u64) -> Option<(DVector<f64>, u64)> {
    let res = argmin::core::Executor::new(problem, solver)
        .configure(|s| s.param(x0).max_iters(max_iters))
        .ctrlc(false)
        .timer(false)
        .run()
        .ok()?;
    let iters = argmin::core::State::get_iter(&res.state);
    let x = res.state.param?;
    x.iter().all(|v| v.is_finite()).then_some((x, iters))
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Status {
    Free,
    Lower,
    Upper,
}

/// The free variables and the Cholesky factor `L Lᵀ = H_FF` of their block of `H = AᵀA`, kept in step with
/// the free list: a released variable appends a row (one forward substitution), a bound one is deleted
/// with Givens rotations — O(n²) per change instead of a new O(n³) factorisation. When a new pivot is not
/// clearly positive or the factor is poorly conditioned (`cond(H_FF) ≳ 1e12`), the solve falls back to the
/// minimum-norm SVD of the free columns.
struct FreeSet {
    n: usize,
    free: Vec<usize>,
    /// Row-major n×n storage of L (only the leading |free|×|free| part is used).
    l: Vec<f64>,
    ok: bool,
}

impl FreeSet {
    fn new(n: usize) -> FreeSet {
        FreeSet { n, free: Vec::with_capacity(n), l: vec![0.0; n * n], ok: true }
    }

    fn add(&mut self, h: &DMatrix<f64>, j: usize) {
        let (n, k) = (self.n, self.free.len());
        if self.ok {
            let mut yy = 0.0;
            for i in 0..k {
                let mut v = h[(self.free[i], j)];
                for p in 0..i {
                    v -= self.l[i * n + p] * self.l[k * n + p];
                }
                let y = v / self.l[i * n + i];
                self.l[k * n + i] = y;
                yy += y * y;
            }
            let d2 = h[(j, j)] - yy;
            if d2.is_finite() && d2 > 1e-13 * h[(j, j)].abs() && d2 > 0.0 {
                self.l[k * n + k] = d2.sqrt();
            } else {
                self.ok = false;
            }
        }
        self.free.push(j);
    }

    fn remove(&mut self, j: usize) {
        let Some(k) = self.free.iter().position(|&f| f == j) else { return };
        let (n, nf) = (self.n, self.free.len());
        self.free.remove(k);
        if !self.ok {
            return;
        }
        for i in k..nf - 1 {
            for p in 0..=i + 1 {
                self.l[i * n + p] = self.l[(i + 1) * n + p];
            }
        }
        for i in k..nf - 1 {
            let (a, b) = (self.l[i * n + i], self.l[i * n + i + 1]);
            let r = (a * a + b * b).sqrt();
            if r == 0.0 || !r.is_finite() {
                self.ok = false;
                return;
            }
            let (c, s) = (a / r, b / r);
            for row in i..nf - 1 {
                let (x, y) = (self.l[row * n + i], self.l[row * n + i + 1]);
                self.l[row * n + i] = c * x + s * y;
                self.l[row * n + i + 1] = -s * x + c * y;
            }
            self.l[i * n + i + 1] = 0.0;
        }
        for p in 0..n {
            self.l[(nf - 1) * n + p] = 0.0;
        }
    }

    fn well_conditioned(&self) -> bool {
        let n = self.n;
        let (mut dmin, mut dmax) = (f64::INFINITY, 0.0f64);
        for i in 0..self.free.len() {
            let d = self.l[i * n + i].abs();
            dmin = dmin.min(d);
            dmax = dmax.max(d);
        }
        dmin > 1e-6 * dmax
    }

    /// Least squares over the free variables with the others held at x; `hb = H x_B` (the bound
    /// variables' part of `Hx`). Writes z in the order of `self.free`.
    fn solve(
        &self,
        sys: &LinearSystem,
        factor: &Factor,
        atb: &DVector<f64>,
        x: &DVector<f64>,
        hb: &[f64],
        z: &mut Vec<f64>,
    ) {
        let (n, nf) = (self.n, self.free.len());
        z.clear();
        if self.ok && self.well_conditioned() {
            let l = &self.l;
            for (k, &i) in self.free.iter().enumerate() {
                let row = &l[k * n..k * n + k];
                let v = atb[i] - hb[i] - row.iter().zip(z.iter()).map(|(a, b)| a * b).sum::<f64>();
                z.push(v / l[k * n + k]);
            }
            for k in (0..nf).rev() {
                let mut v = z[k];
                for p in k + 1..nf {
                    v -= l[p * n + k] * z[p];
                }
                z[k] = v / l[k * n + k];
            }
            if z.iter().all(|v| v.is_finite()) {
                return;
            }
            z.clear();
        }
        z.extend(solve_free(sys, factor, atb, x, &self.free).iter());
    }
}

/// The exact active-set finish from a feasible `x` (see the module docs). Returns x and the number of
/// releases (outer steps) taken.
pub fn active_set_finish(
    sys: &LinearSystem,
    factor: &Factor,
    atb: &DVector<f64>,
    mut x: DVector<f64>,
) -> (DVector<f64>, usize) {
    let n = x.len();
    let (lo, hi) = (&sys.lower, &sys.upper);
    let h = &factor.h;
    let mut status = vec![Status::Free; n];
    let mut set = FreeSet::new(n);
    for i in 0..n {
        if x[i] <= lo[i] {
            x[i] = lo[i];
            status[i] = Status::Lower;
        } else if x[i] >= hi[i] {
            x[i] = hi[i];
            status[i] = Status::Upper;
        } else {
            set.add(h, i);
        }
    }
    let scale = atb.amax().max(h.amax() * x.amax()).max(f64::MIN_POSITIVE);
    let tol = 1e-11 * scale;
    let mut stuck = vec![false; n];
    let mut released: Option<(usize, Status)> = None;
    // hb = H x_B, kept up to date as variables are bound and released.
    let mut hb = vec![0.0; n];
    let add_column = |hb: &mut [f64], j: usize, v: f64| {
        if v != 0.0 {
            for (t, hv) in hb.iter_mut().zip(h.column(j).iter()) {
                *t += hv * v;
            }
        }
    };
    for j in 0..n {
        if status[j] != Status::Free {
            add_column(&mut hb, j, x[j]);
        }
    }
    let mut z: Vec<f64> = Vec::with_capacity(n);
    let max_steps = 4 * n + 20;
    let mut steps = 0;
    while steps < max_steps {
        steps += 1;
        // Inner loop: solve on the free set, walking back to the box when the solution leaves it.
        for _ in 0..=2 * n {
            if set.free.is_empty() {
                break;
            }
            set.solve(sys, factor, atb, &x, &hb, &mut z);
            // A variable released a moment ago that wants straight back out on the same side: its
            // multiplier was rounding noise. Bind it again and never release it again.
            if let Some((j, from)) = released.take() {
                let k = set.free.iter().position(|&f| f == j).unwrap_or(0);
                let back = match from {
                    Status::Lower => z[k] <= lo[j],
                    Status::Upper => z[k] >= hi[j],
                    Status::Free => false,
                };
                if back {
                    status[j] = from;
                    stuck[j] = true;
                    set.remove(j);
                    add_column(&mut hb, j, x[j]);
                    continue;
                }
            }
            let mut alpha: f64 = 1.0;
            let mut hit: Option<usize> = None;
            for (k, &i) in set.free.iter().enumerate() {
                let (zi, xi) = (z[k], x[i]);
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
                for (k, &i) in set.free.iter().enumerate() {
                    x[i] = z[k];
                }
                break;
            };
            let mut newly_bound = Vec::new();
            for (k, &i) in set.free.iter().enumerate() {
                let v = (x[i] + alpha * (z[k] - x[i])).max(lo[i]).min(hi[i]);
                x[i] = v;
                let at_lo = z[k] < lo[i] && (i == hit || v - lo[i] <= 1e-14 * (1.0 + lo[i].abs()));
                let at_hi = z[k] > hi[i] && (i == hit || hi[i] - v <= 1e-14 * (1.0 + hi[i].abs()));
                if at_lo {
                    x[i] = lo[i];
                    status[i] = Status::Lower;
                    newly_bound.push(i);
                } else if at_hi {
                    x[i] = hi[i];
                    status[i] = Status::Upper;
                    newly_bound.push(i);
                }
            }
            for i in newly_bound {
                set.remove(i);
                add_column(&mut hb, i, x[i]);
            }
        }
        // Multipliers: the half-gradient Hx − Aᵀb at bound variables must point out of the box.
        let g = h * &x - atb;
        let mut worst: Option<(usize, f64)> = None;
        for i in 0..n {
            if stuck[i] || lo[i] == hi[i] {
                continue;
            }
            let v = match status[i] {
                Status::Lower => -g[i],
                Status::Upper => g[i],
                Status::Free => continue,
            };
            if v > tol && worst.is_none_or(|(_, w)| v > w) {
                worst = Some((i, v));
            }
        }
        let Some((j, _)) = worst else { break };
        released = Some((j, status[j]));
        status[j] = Status::Free;
        add_column(&mut hb, j, -x[j]);
        set.add(h, j);
    }
    (x, steps)
}

/// Least squares over the free variables with the bound ones held: `H_FF z = (Aᵀb − H_FB x_B)_F` by
/// Cholesky when well conditioned, else minimum-norm SVD of `A_F`.
fn solve_free(
    sys: &LinearSystem,
    factor: &Factor,
    atb: &DVector<f64>,
    x: &DVector<f64>,
    free: &[usize],
) -> DVector<f64> {
    let n = x.len();
    let nf = free.len();
    let h = &factor.h;
    let is_free = {
        let mut f = vec![false; n];
        for &i in free {
            f[i] = true;
        }
        f
    };
    let mut rhs = DVector::from_fn(nf, |k, _| atb[free[k]]);
    for j in 0..n {
        if !is_free[j] && x[j] != 0.0 {
            for (k, &i) in free.iter().enumerate() {
                rhs[k] -= h[(i, j)] * x[j];
            }
        }
    }
    let hff = DMatrix::from_fn(nf, nf, |r, c| h[(free[r], free[c])]);
    if let Some(ch) = hff.clone().cholesky() {
        let l = ch.l_dirty();
        let (mut dmin, mut dmax) = (f64::INFINITY, 0.0f64);
        for k in 0..nf {
            dmin = dmin.min(l[(k, k)].abs());
            dmax = dmax.max(l[(k, k)].abs());
        }
        // cond(H_FF) ≈ (dmax/dmin)²: use the normal equations only below ~1e12.
        if dmin > 1e-6 * dmax {
            let z = ch.solve(&rhs);
            if z.iter().all(|v| v.is_finite()) {
                return z;
            }
        }
    }
    let a = &sys.a;
    let af = DMatrix::from_fn(a.nrows(), nf, |r, c| a[(r, free[c])]);
    let mut rb = sys.b.clone();
    for j in 0..n {
        if !is_free[j] && x[j] != 0.0 {
            rb -= a.column(j) * x[j];
        }
    }
    pseudo_inverse(&af) * rb
}

/// Warm-started bounded solve for repeated problems (alternating joint design): the exact active-set
/// finish from `x0` projected onto the box, without SVD or L-BFGS-B. On a convex problem it ends at an
/// exact minimiser (the minimum-norm one is not guaranteed when A is rank deficient). Only `AᵀA` is needed.
pub fn solve_from(sys: &LinearSystem, h: &DMatrix<f64>, x0: &DVector<f64>) -> LsqOutcome {
    let n = sys.a.ncols();
    let atb = sys.a.tr_mul(&sys.b);
    let factor = Factor { pinv: DMatrix::zeros(0, 0), h: h.clone() };
    let mut x = x0.clone();
    for i in 0..n {
        x[i] = if x[i].is_finite() { x[i] } else { 0.0 }.max(sys.lower[i]).min(sys.upper[i]);
    }
    let (x, steps) = active_set_finish(sys, &factor, &atb, x);
    let g = (h * &x - &atb) * 2.0;
    let kkt = projected_gradient_norm(&x, &g, &sys.lower, &sys.upper) / (1.0 + 2.0 * atb.amax());
    let objective = (&sys.a * &x - &sys.b).norm_squared();
    LsqOutcome { x, objective, kkt, bounds_active: true, lbfgsb_iterations: 0, active_set_steps: steps }
}

/// Plain entry for tests and benchmarks: factor and solve in one call.
pub fn solve_system(sys: &LinearSystem) -> LsqOutcome {
    solve(sys, &Factor::new(&sys.a))
}

/// Re-export for callers who only need L-BFGS-B.
pub use lbfgsb::minimize as lbfgsb_minimize;

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64)
    }

    /// Brute force over all 3^n active sets for tiny n: the exact optimum of a bounded LS.
    fn brute_force(sys: &LinearSystem) -> f64 {
        let n = sys.a.ncols();
        let mut best = f64::INFINITY;
        for code in 0..3usize.pow(n as u32) {
            let mut c = code;
            let mut x = DVector::zeros(n);
            let mut free = Vec::new();
            for i in 0..n {
                match c % 3 {
                    0 => free.push(i),
                    1 => x[i] = sys.lower[i],
                    _ => x[i] = sys.upper[i],
                }
                c /= 3;
            }
            let f = Factor::new(&sys.a);
            let atb = sys.a.tr_mul(&sys.b);
            if !free.is_empty() {
                let z = solve_free(sys, &f, &atb, &x, &free);
                for (k, &i) in free.iter().enumerate() {
                    x[i] = z[k];
                }
            }
            if (0..n).all(|i| x[i] >= sys.lower[i] - 1e-12 && x[i] <= sys.upper[i] + 1e-12) {
                best = best.min((&sys.a * &x - &sys.b).norm_squared());
            }
        }
        best
    }

    #[test]
    fn matches_brute_force_on_small_random_systems() {
        let mut seed = 7u64;
        for _ in 0..40 {
            let (m, n) = (4 + (lcg(&mut seed) * 4.0) as usize, 2 + (lcg(&mut seed) * 4.0) as usize);
            let a = DMatrix::from_fn(m, n, |_, _| lcg(&mut seed) * 2.0 - 1.0);
            let b = DVector::from_fn(m, |_, _| lcg(&mut seed) * 4.0 - 2.0);
            let lower = DVector::from_fn(n, |_, _| -lcg(&mut seed) * 0.5);
            let upper = DVector::from_fn(n, |_, _| lcg(&mut seed) * 0.5);
            let sys = LinearSystem { a, b, lower, upper };
            let out = solve_system(&sys);
            let best = brute_force(&sys);
            assert!(out.objective <= best * (1.0 + 1e-9) + 1e-14, "{} vs {best}", out.objective);
            assert!((0..n).all(|i| out.x[i] >= sys.lower[i] && out.x[i] <= sys.upper[i]));
            assert!(out.kkt < 1e-9, "kkt {}", out.kkt);
        }
    }

    #[test]
    fn feasible_unconstrained_solution_is_returned_directly() {
        let a = DMatrix::identity(3, 3);
        let b = DVector::from_vec(vec![0.1, 0.2, 0.3]);
        let sys = LinearSystem { a, b: b.clone(), lower: DVector::zeros(3), upper: DVector::from_element(3, 1.0) };
        let out = solve_system(&sys);
        assert!(!out.bounds_active);
        assert!((out.x - b).amax() < 1e-15);
    }

    #[test]
    fn rank_deficient_gives_minimum_norm() {
        // Two identical columns: the minimum-norm solution splits evenly.
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        let b = DVector::from_vec(vec![2.0, 2.0]);
        let inf = f64::INFINITY;
        let sys = LinearSystem { a, b, lower: DVector::from_element(2, -inf), upper: DVector::from_element(2, inf) };
        let out = solve_system(&sys);
        assert!((out.x[0] - 1.0).abs() < 1e-12 && (out.x[1] - 1.0).abs() < 1e-12);
    }
}
