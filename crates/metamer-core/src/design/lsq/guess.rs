//! The active set guessed before the exact finish, on the normal-equations path: the same active-set steps
//! as [`Work::finish`] (walk back to the box when the free solution leaves it, release the bound variable
//! whose multiplier has the wrong sign) but worked out on the bound variables instead of the free ones.
//! With `G = H⁻¹` (shared by the designs with the same A, [`Dual`]) and the unconstrained solution
//! `x_u = G Aᵀb`, holding the bound variables B at their values v gives
//!
//! ```text
//! μ = G_BB⁻¹ (v − x_u,B),   x = x_u + G_{:,B} μ,   (Hx − Aᵀb)_B = μ,   (Hx − Aᵀb)_F = 0,
//! ```
//!
//! so each step solves a system of |B| unknowns, not |F|: on the batch designs a few bound variables
//! against 20–30 free ones. The guess is only a guess (G carries `cond(H)·ε` of rounding): the set it ends
//! at is then solved from a fresh factor of `H_FF` exactly as the polish solves the finish's final set, and
//! accepted only when that solution passes the finish's own test of optimality (inside the box, no
//! multiplier of the wrong sign beyond its rounding level). Otherwise the finish runs from the clamped
//! start as it did without the guess. An accepted set is a set at which the finish stops, and its result
//! is the polish's of that set: the same bits as the finish and polish give when they end there.

use super::finish::{Rows, Work, goes_back, step_to_box, step_variable};
use super::kernels::{Cholesky, Status, add_columns};
use super::*;

/// What the guess shares across the designs with one A: `G = H⁻¹ = A⁺A⁺ᵀ` and the Cholesky factor of all
/// of H (free variables in ascending order, its first `full_rows` rows valid), whose leading rows are
/// those of every free set that starts with the same variables.
#[derive(Clone, Debug)]
pub(crate) struct Dual {
    g: DMatrix<f64>,
    full_l: Vec<f64>,
    full_rows: usize,
}

impl Dual {
    /// None when G is not finite or its diagonal not positive.
    pub(super) fn of(pinv: &DMatrix<f64>, h: &DMatrix<f64>) -> Option<Dual> {
        let n = h.ncols();
        let g = pinv * pinv.transpose();
        if g.iter().any(|v| !v.is_finite()) || (0..n).any(|i| g[(i, i)] <= 0.0) {
            return None;
        }
        let mut chol = Cholesky::new(n, true);
        let all: Vec<usize> = (0..n).collect();
        let mut full_rows = 0;
        for k in 0..n {
            chol.add(h, &all[..k], k);
            if !chol.ok {
                break;
            }
            full_rows = k + 1;
        }
        Some(Dual { g, full_l: chol.l, full_rows })
    }
}

/// How [`Work::guess`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Guess {
    /// At a set whose multipliers have the right sign (as far as G tells) and whose free solution is
    /// inside the box: [`Work::settle`] tests it.
    Set,
    /// More than half the variables bound: the finish's own steps on the few free ones are the cheaper,
    /// and they go on from the guess's point `x`, which is inside the box with the bound variables at
    /// their bounds.
    HandOver,
    /// Nothing to go on from (a factor of `G_BB` not clearly positive definite, a result not finite, no end
    /// within the finish's own step limits, or more than half the variables bound at the start): the
    /// finish starts from the clamped solution as without the guess.
    GaveUp,
}

impl Work {
    /// Guess the active set from the unconstrained solution `xu` (see the module docs), leaving it in
    /// `status`/`is_free` and the bound values in `x`. See [`Guess`] for when it stops short.
    pub(super) fn guess(
        &mut self,
        dual: &Dual,
        h: &DMatrix<f64>,
        atb: &DVector<f64>,
        xu: &[f64],
        sys: &LinearSystem,
    ) -> Guess {
        let n = self.n;
        let (lo, hi) = (sys.lower.as_slice(), sys.upper.as_slice());
        let limit = n / 2;
        let g = &dual.g;
        self.bound.clear();
        for i in 0..n {
            let v = xu[i];
            if !v.is_finite() {
                return Guess::GaveUp;
            }
            (self.x[i], self.status[i], self.is_free[i]) = if v <= lo[i] {
                self.bound.push(i);
                (lo[i], Status::Lower, false)
            } else if v >= hi[i] {
                self.bound.push(i);
                (hi[i], Status::Upper, false)
            } else {
                (v, Status::Free, true)
            };
        }
        if self.bound.len() > limit {
            return Guess::GaveUp;
        }
        self.dual_chol.ok = true;
        for k in 0..self.bound.len() {
            self.dual_chol.add(g, &self.bound[..k], self.bound[k]);
        }
        if self.h_max.is_nan() {
            self.h_max = h.diagonal().iter().fold(0.0, |m, v| m.max(v.abs()));
            self.atb_max = atb.iter().fold(0.0, |m, v| m.max(v.abs()));
        }
        self.stuck.iter_mut().for_each(|s| *s = false);
        let mut released: Option<(usize, Status)> = None;
        for _ in 0..4 * n + 20 {
            let mut settled = false;
            for _ in 0..=2 * n {
                if !self.dual_chol.ok {
                    return Guess::GaveUp;
                }
                if self.bound.len() > limit {
                    return Guess::HandOver;
                }
                // μ = G_BB⁻¹ (v − x_u,B), then z = x_u + G_{:,B} μ.
                self.mu.clear();
                self.mu.extend(self.bound.iter().map(|&i| self.x[i] - xu[i]));
                self.dual_chol.solve_in_place(&mut self.mu);
                add_columns(g.as_slice(), n, xu, &self.bound, &self.mu, &mut self.zd);
                if !(self.zd.iter().all(|v| v.is_finite()) && self.mu.iter().all(|v| v.is_finite())) {
                    return Guess::GaveUp;
                }
                if let Some((j, from)) = released.take() {
                    let back = goes_back(from, self.zd[j], lo[j], hi[j]);
                    if back {
                        self.stuck[j] = true;
                        self.bind_dual(g, j, from);
                        continue;
                    }
                    self.stuck.iter_mut().for_each(|s| *s = false);
                }
                let (alpha, hit) =
                    step_to_box((0..n).filter(|&i| self.is_free[i]).map(|i| (i, self.zd[i])), &self.x, lo, hi);
                let Some(hit) = hit else {
                    for i in 0..n {
                        if self.is_free[i] {
                            self.x[i] = self.zd[i];
                        }
                    }
                    settled = true;
                    break;
                };
                for i in 0..n {
                    if !self.is_free[i] {
                        continue;
                    }
                    let (v, bound) = step_variable(i == hit, self.x[i], self.zd[i], alpha, lo[i], hi[i]);
                    self.x[i] = v;
                    if let Some(to) = bound {
                        self.bind_dual(g, i, to);
                    }
                }
            }
            if !settled {
                return Guess::GaveUp;
            }
            // The multipliers are the last μ (the bound list did not change since it was solved). Their
            // rounding is G's, far above the finish's level: a multiplier within it is left for the exact
            // test of the set to judge.
            let level = 2.0
                * (n as f64 + 1.0).powi(2)
                * f64::EPSILON
                * self.atb_max.max(self.h_max * self.x.iter().fold(0.0f64, |m, v| m.max(v.abs())));
            let mut worst: Option<(usize, f64)> = None;
            for (k, &i) in self.bound.iter().enumerate() {
                if self.stuck[i] || lo[i] == hi[i] {
                    continue;
                }
                let v = match self.status[i] {
                    Status::Lower => -self.mu[k],
                    Status::Upper => self.mu[k],
                    Status::Free => continue,
                };
                if v > level && worst.is_none_or(|(_, w)| v > w) {
                    worst = Some((k, v));
                }
            }
            let Some((k, _)) = worst else { return Guess::Set };
            let j = self.bound[k];
            released = Some((j, self.status[j]));
            let nb = self.bound.len();
            self.dual_chol.remove(k, nb);
            self.bound.remove(k);
            self.status[j] = Status::Free;
            self.is_free[j] = true;
        }
        Guess::GaveUp
    }

    fn bind_dual(&mut self, g: &DMatrix<f64>, i: usize, to: Status) {
        self.status[i] = to;
        self.is_free[i] = false;
        self.dual_chol.add(g, &self.bound, i);
        self.bound.push(i);
    }

    /// Solve the guessed set as the polish solves the finish's final set (fresh factor of `H_FF` in
    /// ascending order, its leading rows from the factor of all of H or its whole from `sets`; `H x_B` in
    /// ascending order) and test the result as the finish tests its own point before it stops: inside the
    /// box, the factor healthy and well conditioned, and no bound variable's multiplier of the wrong sign
    /// beyond its rounding level. True when the result in `x` passes.
    pub(super) fn settle(
        &mut self,
        dual: &Dual,
        sys: &LinearSystem,
        h: &DMatrix<f64>,
        atb: &DVector<f64>,
        sets: Option<&FreeSets>,
    ) -> bool {
        self.start_valid = false;
        self.stuck.iter_mut().for_each(|s| *s = false);
        let inside = self.polish(sys, h, atb, sets, Rows::Full(&dual.full_l, dual.full_rows));
        if !inside || !self.chol.ok || !self.chol.well_conditioned(self.free.len()) {
            return false;
        }
        self.gradient(sys, h, atb);
        self.worst_multiplier(sys.lower.as_slice(), sys.upper.as_slice()).is_none()
    }
}
