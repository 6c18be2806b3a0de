//! Refining a basis by minimising the factor-model colour error over training pairs (argmin L-BFGS).
//!
//! For light `E_l`, reflectance `S_r` and basis B (31×m) with `P = B⁺ = (BᵀB)⁻¹Bᵀ`, the factor model predicts
//! `r̂ = Q_rgb,31 B (P E_l ∘ P S_r)`; the truth is `r = Q_rgb,31 (E_l ∘ S_r)`. The objective is
//!
//! ```text
//!     f(B) = (1/N) Σ_pairs ‖W_p (r̂_p − r_p)‖²
//! ```
//!
//! where `W_p` (3×3) is the local CIEDE2000 metric at the true colour under the pair's light: `WᵀW = H`,
//! `ΔE00(r, r + δ)² ≈ δᵀ H δ` for small δ (H found by polarisation from [`Colorimetry::delta_e00_under`], with
//! a step giving ΔE00 ≈ 0.5, the scale of the errors being minimised). So f is the mean squared ΔE00 to
//! second order, a smooth function of B. The weights are fixed (the true colours do not move).
//!
//! Gradient (with `g_p = (2/N) W_pᵀ W_p (r̂_p − r_p)`, `c_p = e_l ∘ s_r`, `γ_p = Bᵀ Qᵀ g_p`,
//! `G_P = Σ_p (γ_p ∘ s_r) E_lᵀ + (γ_p ∘ e_l) S_rᵀ`, `K = (BᵀB)⁻¹`):
//!
//! ```text
//!     ∂f/∂B = Qᵀ Σ_p g_p c_pᵀ  −  Pᵀ G_P Pᵀ  +  (I − B P) G_Pᵀ K
//! ```
//!
//! using `dP = −P dB P + K dBᵀ (I − B P)` for a full-column-rank B. For `B = B0 T`, `∂f/∂T = B0ᵀ ∂f/∂B`.
//! Both are checked against central finite differences in the tests.

use super::set::TrainingSet;
use crate::colorimetry::Colorimetry;
use crate::spectrum::{SAMPLES, Spectrum};
use argmin::core::{CostFunction, Error, Gradient};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::quasinewton::LBFGS;
use nalgebra::{DMatrix, DVector, Matrix3, SymmetricEigen, Vector3};
use std::sync::Mutex;

/// Target size (ΔE00) of the probe steps used to measure the local metric.
const METRIC_PROBE_DELTA_E: f64 = 0.5;
/// Refinement stops once the objective (mean squared ΔE00) is below this: an RMS error of 0.01 ΔE00 is a
/// hundredth of a just-noticeable difference, and small palettes reach it long before the iteration limit.
pub(crate) const TARGET_COST: f64 = 1e-4;
/// L-BFGS history length.
const LBFGS_MEMORY: usize = 12;

/// One light × reflectance pair of the objective.
#[derive(Clone, Debug)]
struct PairTerm {
    light: usize,
    reflectance: usize,
    target: Vector3<f64>,
    /// W, row-major.
    weight: [[f64; 3]; 3],
}

/// The perceptually weighted factor-model error over a training set.
#[derive(Clone, Debug)]
pub(crate) struct Objective {
    /// 31×L and its transpose.
    lights: DMatrix<f64>,
    lights_t: DMatrix<f64>,
    /// 31×R and its transpose.
    reflectances: DMatrix<f64>,
    reflectances_t: DMatrix<f64>,
    /// `Q_rgb,31` and its transpose.
    q_rgb: DMatrix<f64>,
    q_rgb_t: DMatrix<f64>,
    pairs: Vec<PairTerm>,
    scale: f64,
    /// μ ≥ 0: weight of the full-Λ (Eq. 7) colour error beside the factor-model error.
    lambda_weight: f64,
    /// ρ ≥ 0: weight of the conditioning term `Σ_k VIF_k − m` (see [`Objective::with_conditioning_weight`]).
    conditioning_weight: f64,
}

impl Objective {
    /// Every light × reflectance pair whose light has positive luminance (CIELAB needs a white).
    pub fn new(set: &TrainingSet, colorimetry: &Colorimetry) -> Objective {
        let lights = DMatrix::from_columns(
            &set.lights.iter().map(|s| DVector::from_column_slice(s.as_slice())).collect::<Vec<_>>(),
        );
        let reflectances = DMatrix::from_columns(
            &set.reflectances.iter().map(|s| DVector::from_column_slice(s.as_slice())).collect::<Vec<_>>(),
        );
        let q_rgb = DMatrix::from_column_slice(3, SAMPLES, colorimetry.q_rgb.as_slice());
        let mut pairs = Vec::with_capacity(set.pairs());
        for (l, e) in set.lights.iter().enumerate() {
            if colorimetry.xyz_of_signal(e)[1] <= f64::MIN_POSITIVE {
                continue;
            }
            for (r, s) in set.reflectances.iter().enumerate() {
                let target = colorimetry.rgb(e, s);
                let w = local_metric(colorimetry, &target, e);
                let weight = [0, 1, 2].map(|i| [w[(i, 0)], w[(i, 1)], w[(i, 2)]]);
                pairs.push(PairTerm { light: l, reflectance: r, target, weight });
            }
        }
        let scale = if pairs.is_empty() { 0.0 } else { 1.0 / pairs.len() as f64 };
        Objective {
            lights_t: lights.transpose(),
            lights,
            reflectances_t: reflectances.transpose(),
            reflectances,
            q_rgb_t: q_rgb.transpose(),
            q_rgb,
            pairs,
            scale,
            lambda_weight: 0.0,
            conditioning_weight: 0.0,
        }
    }

    /// Also add `rho · (Σ_k VIF_k − m)`, the variance inflation factors of B's columns,
    /// `VIF_k = ‖b_k‖² [(BᵀB)⁻¹]_kk = 1 / (1 − R_k²)` (R_k the multiple correlation of column k with the
    /// others). The term is 0 for orthogonal columns, invariant to the columns' scales, and grows like the
    /// squared condition number of the column-balanced B as columns become dependent: a soft barrier that
    /// keeps `B⁺` stable in double precision. Gradient: `2ρ B (diag K − K N K)`, `K = (BᵀB)⁻¹`,
    /// `N = diag(‖b_k‖²)`.
    pub(crate) fn with_conditioning_weight(mut self, rho: f64) -> Objective {
        self.conditioning_weight = if rho.is_finite() { rho.max(0.0) } else { 0.0 };
        self
    }

    /// Also weigh the colour error of the full-Λ model (seed Eq. 7, `Q_rgb,31 B B⁺(B e ∘ B s)`) by `mu`, so
    /// that refining B keeps its span good for Λ too (the design criteria of DESIGN_SPEC §2 use Λ).
    pub(crate) fn with_lambda_weight(mut self, mu: f64) -> Objective {
        self.lambda_weight = if mu.is_finite() { mu.max(0.0) } else { 0.0 };
        self
    }

    /// Number of pairs in the objective.
    pub(crate) fn pairs(&self) -> usize {
        self.pairs.len()
    }

    /// f(B); `+∞` when B does not have full column rank.
    pub(crate) fn cost_of(&self, b: &DMatrix<f64>) -> f64 {
        self.evaluate(b, false).map_or(f64::INFINITY, |(c, _)| c)
    }

    /// f(B) and ∂f/∂B (31×m); `None` when B does not have full column rank or the result is not finite.
    pub(crate) fn cost_and_gradient(&self, b: &DMatrix<f64>) -> Option<(f64, DMatrix<f64>)> {
        self.evaluate(b, true).map(|(c, g)| (c, g.unwrap_or_else(|| DMatrix::zeros(b.nrows(), b.ncols()))))
    }

    fn evaluate(&self, b: &DMatrix<f64>, with_gradient: bool) -> Option<(f64, Option<DMatrix<f64>>)> {
        // Dense products go through nalgebra (matrixmultiply for the larger ones); the per-pair loop is
        // written on slices so it stays fast in unoptimised builds too.
        let m = b.ncols();
        let bt = b.transpose();
        let chol = (&bt * b).cholesky()?;
        let k = chol.inverse();
        let p = &k * &bt;
        let e = &p * &self.lights;
        let s = &p * &self.reflectances;
        let qm = &self.q_rgb * b;
        let (es, ss, qs) = (e.as_slice(), s.as_slice(), qm.as_slice());
        let mut cost = 0.0;
        let mut g_qm = DMatrix::<f64>::zeros(3, m);
        let mut ge = DMatrix::<f64>::zeros(m, e.ncols());
        let mut gs = DMatrix::<f64>::zeros(m, s.ncols());
        let mut c = vec![0.0; m];
        for pair in &self.pairs {
            let (eo, so) = (pair.light * m, pair.reflectance * m);
            let mut pred = [0.0; 3];
            for (kk, ck) in c.iter_mut().enumerate() {
                *ck = es[eo + kk] * ss[so + kk];
                pred[0] += qs[3 * kk] * *ck;
                pred[1] += qs[3 * kk + 1] * *ck;
                pred[2] += qs[3 * kk + 2] * *ck;
            }
            let w = &pair.weight;
            let d = [pred[0] - pair.target[0], pred[1] - pair.target[1], pred[2] - pair.target[2]];
            let res = [
                w[0][0] * d[0] + w[0][1] * d[1] + w[0][2] * d[2],
                w[1][0] * d[0] + w[1][1] * d[1] + w[1][2] * d[2],
                w[2][0] * d[0] + w[2][1] * d[1] + w[2][2] * d[2],
            ];
            cost += res[0] * res[0] + res[1] * res[1] + res[2] * res[2];
            if with_gradient {
                let f = 2.0 * self.scale;
                let g = [
                    f * (w[0][0] * res[0] + w[1][0] * res[1] + w[2][0] * res[2]),
                    f * (w[0][1] * res[0] + w[1][1] * res[1] + w[2][1] * res[2]),
                    f * (w[0][2] * res[0] + w[1][2] * res[1] + w[2][2] * res[2]),
                ];
                let (gq, ges, gss) = (g_qm.as_mut_slice(), ge.as_mut_slice(), gs.as_mut_slice());
                for (kk, ck) in c.iter().enumerate() {
                    gq[3 * kk] += g[0] * ck;
                    gq[3 * kk + 1] += g[1] * ck;
                    gq[3 * kk + 2] += g[2] * ck;
                    let gamma = qs[3 * kk] * g[0] + qs[3 * kk + 1] * g[1] + qs[3 * kk + 2] * g[2];
                    ges[eo + kk] += gamma * ss[so + kk];
                    gss[so + kk] += gamma * es[eo + kk];
                }
            }
        }
        cost *= self.scale;
        let mut grad_direct = None;
        if self.lambda_weight > 0.0 && !self.pairs.is_empty() {
            cost += self.lambda_term(b, &p, &e, &s, &qm, with_gradient.then_some((&mut g_qm, &mut ge, &mut gs))).map(
                |(c, g)| {
                    grad_direct = g;
                    c
                },
            )?;
        }
        let rho = self.conditioning_weight;
        let norms: Vec<f64> = if rho > 0.0 { b.column_iter().map(|c| c.norm_squared()).collect() } else { Vec::new() };
        if rho > 0.0 {
            cost += rho * (norms.iter().enumerate().map(|(j, n)| n * k[(j, j)]).sum::<f64>() - m as f64);
        }
        if !cost.is_finite() {
            return None;
        }
        if !with_gradient {
            return Some((cost, None));
        }
        if rho > 0.0 {
            // 2ρ B (diag K − K N K)
            let mut kn = k.clone();
            for (j, mut col) in kn.column_iter_mut().enumerate() {
                col *= norms[j];
            }
            let mut inner = -(&kn * &k);
            for j in 0..m {
                inner[(j, j)] += k[(j, j)];
            }
            let extra = b * inner * (2.0 * rho);
            grad_direct = Some(match grad_direct {
                Some(d) => d + extra,
                None => extra,
            });
        }
        let g_p = &ge * &self.lights_t + &gs * &self.reflectances_t;
        let pt = p.transpose();
        let gpt_k = g_p.transpose() * &k;
        let mut grad = &self.q_rgb_t * g_qm - &pt * (&g_p * &pt) + &gpt_k - b * (&p * &gpt_k);
        if let Some(d) = grad_direct {
            grad += d;
        }
        grad.iter().all(|v| v.is_finite()).then_some((cost, Some(grad)))
    }

    /// The full-Λ term `μ/N Σ ‖W_p (Q B P (B e_l ∘ B s_r) − r_p)‖²` (seed Eq. 7 colours). With a gradient
    /// request it adds into the accumulators of `Q B` (`g_qm`), `e` (`ge`) and `s` (`gs`) and returns the
    /// part of ∂/∂B that enters through the projections `u = B e`, `v = B s`.
    #[allow(clippy::type_complexity)]
    fn lambda_term(
        &self,
        b: &DMatrix<f64>,
        p: &DMatrix<f64>,
        e: &DMatrix<f64>,
        s: &DMatrix<f64>,
        qm: &DMatrix<f64>,
        grads: Option<(&mut DMatrix<f64>, &mut DMatrix<f64>, &mut DMatrix<f64>)>,
    ) -> Option<(f64, Option<DMatrix<f64>>)> {
        let n = self.pairs.len();
        let u = b * e;
        let v = b * s;
        let (us, vs) = (u.as_slice(), v.as_slice());
        let mut w = DMatrix::<f64>::zeros(SAMPLES, n);
        for (col, pair) in w.as_mut_slice().chunks_exact_mut(SAMPLES).zip(&self.pairs) {
            let uc = &us[pair.light * SAMPLES..(pair.light + 1) * SAMPLES];
            let vc = &vs[pair.reflectance * SAMPLES..(pair.reflectance + 1) * SAMPLES];
            for ((x, a), b) in col.iter_mut().zip(uc).zip(vc) {
                *x = a * b;
            }
        }
        let c = p * &w;
        let pred = qm * &c;
        let mu = self.lambda_weight * self.scale;
        let mut cost = 0.0;
        let mut g = DMatrix::<f64>::zeros(3, n);
        for ((pr, gc), pair) in
            pred.as_slice().chunks_exact(3).zip(g.as_mut_slice().chunks_exact_mut(3)).zip(&self.pairs)
        {
            let wt = &pair.weight;
            let d = [pr[0] - pair.target[0], pr[1] - pair.target[1], pr[2] - pair.target[2]];
            let res = [0, 1, 2].map(|i| wt[i][0] * d[0] + wt[i][1] * d[1] + wt[i][2] * d[2]);
            cost += res[0] * res[0] + res[1] * res[1] + res[2] * res[2];
            for (j, gj) in gc.iter_mut().enumerate() {
                *gj = 2.0 * mu * (wt[0][j] * res[0] + wt[1][j] * res[1] + wt[2][j] * res[2]);
            }
        }
        cost *= mu;
        let Some((g_qm, ge, gs)) = grads else {
            return Some((cost, None));
        };
        *g_qm += &g * c.transpose();
        let gamma = qm.transpose() * &g;
        // c = P w with w = u ∘ v: ∂/∂w = Pᵀγ, ∂/∂u = Pᵀγ ∘ v, ∂/∂v = Pᵀγ ∘ u; u = B e, v = B s.
        let omega = p.transpose() * &gamma;
        let mut du = DMatrix::<f64>::zeros(SAMPLES, u.ncols());
        let mut dv = DMatrix::<f64>::zeros(SAMPLES, v.ncols());
        let (dus, dvs) = (du.as_mut_slice(), dv.as_mut_slice());
        for (om, pair) in omega.as_slice().chunks_exact(SAMPLES).zip(&self.pairs) {
            let (lo, ro) = (pair.light * SAMPLES, pair.reflectance * SAMPLES);
            for (i, o) in om.iter().enumerate() {
                dus[lo + i] += o * vs[ro + i];
                dvs[ro + i] += o * us[lo + i];
            }
        }
        *ge += b.transpose() * &du;
        *gs += b.transpose() * &dv;
        // ∂/∂P through c = P w is γ wᵀ, chained through P = B⁺ as in the module docs.
        let g_p_extra = &gamma * w.transpose();
        let k = (b.transpose() * b).try_inverse()?;
        let pt = p.transpose();
        let gpt_k = g_p_extra.transpose() * &k;
        let direct = du * e.transpose() + dv * s.transpose() - &pt * (&g_p_extra * &pt) + &gpt_k - b * (p * &gpt_k);
        Some((cost, Some(direct)))
    }
}

/// The 3×3 W with `WᵀW ≈ H`, the local quadratic form of ΔE00² around the linear colour `rgb` seen under
/// `light` (see the module docs).
pub(crate) fn local_metric(colorimetry: &Colorimetry, rgb: &Vector3<f64>, light: &Spectrum) -> Matrix3<f64> {
    let white_y = colorimetry.xyz_of_signal(light)[1].abs().max(f64::MIN_POSITIVE);
    let de = |d: Vector3<f64>| colorimetry.delta_e00_under(rgb, &(rgb + d), light);
    // Choose the probe step so that the largest axis step gives ΔE00 ≈ METRIC_PROBE_DELTA_E.
    let h0 = 1e-3 * white_y;
    let probe = (0..3).map(|i| de(Vector3::ith(i, h0))).fold(0.0, f64::max);
    let h = if probe.is_finite() && probe > 0.0 { h0 * METRIC_PROBE_DELTA_E / probe } else { h0 };
    // q(v) = ΔE(r, r + h v)² / h², averaged over ±v.
    let q = |v: Vector3<f64>| (de(v * h).powi(2) + de(-v * h).powi(2)) / (2.0 * h * h);
    let mut hm = Matrix3::zeros();
    for i in 0..3 {
        hm[(i, i)] = q(Vector3::ith(i, 1.0));
    }
    for i in 0..3 {
        for j in (i + 1)..3 {
            let plus = q(Vector3::ith(i, 1.0) + Vector3::ith(j, 1.0));
            let minus = q(Vector3::ith(i, 1.0) - Vector3::ith(j, 1.0));
            hm[(i, j)] = (plus - minus) / 4.0;
            hm[(j, i)] = hm[(i, j)];
        }
    }
    if !hm.iter().all(|v| v.is_finite()) {
        return Matrix3::zeros();
    }
    // Square root of the positive part.
    let eig = SymmetricEigen::new(hm);
    let top = eig.eigenvalues.max().max(0.0);
    let floor = top * 1e-9;
    let roots = eig.eigenvalues.map(|l| l.max(floor).sqrt());
    // W = diag(√λ) Vᵀ, so WᵀW = V diag(λ) Vᵀ.
    Matrix3::from_diagonal(&roots) * eig.eigenvectors.transpose()
}

/// What a refinement stage produced.
#[derive(Clone, Debug)]
pub(crate) enum RefineOutcome {
    /// A better matrix (T or B) and the iterations taken.
    Improved { value: DMatrix<f64>, iterations: u64 },
    /// Nothing better was found; the reason.
    Kept { reason: String },
}

/// Tracks the best point any evaluation has seen, so that an aborted run still returns progress.
struct Best(Mutex<Option<(f64, DVector<f64>)>>);

impl Best {
    fn record(&self, cost: f64, x: &DVector<f64>) {
        if let Ok(mut guard) = self.0.lock()
            && guard.as_ref().is_none_or(|(c, _)| cost < *c)
        {
            *guard = Some((cost, x.clone()));
        }
    }

    fn take(self) -> Option<(f64, DVector<f64>)> {
        self.0.into_inner().ok().flatten()
    }
}

/// The objective as a function of a flat parameter vector.
/// The last evaluation: argmin's L-BFGS asks for the cost and then (twice) the gradient at the same point,
/// so every evaluation computes both and keeps them.
type LastEvaluation = Option<(DVector<f64>, f64, DVector<f64>)>;

struct Problem<'a> {
    objective: &'a Objective,
    /// `Some(B0)`: the parameters are T (m×m, column-major) and `B = B0 T`. `None`: they are B itself.
    b0: Option<&'a DMatrix<f64>>,
    m: usize,
    best: &'a Best,
    last: Mutex<LastEvaluation>,
}

impl Problem<'_> {
    fn basis(&self, x: &DVector<f64>) -> DMatrix<f64> {
        match self.b0 {
            Some(b0) => b0 * DMatrix::from_column_slice(self.m, self.m, x.as_slice()),
            None => DMatrix::from_column_slice(SAMPLES, self.m, x.as_slice()),
        }
    }

    fn eval(&self, x: &DVector<f64>) -> Result<(f64, DVector<f64>), Error> {
        if let Ok(guard) = self.last.lock()
            && let Some((lx, cost, grad)) = guard.as_ref()
            && lx == x
        {
            return Ok((*cost, grad.clone()));
        }
        let b = self.basis(x);
        let (cost, grad_b) =
            self.objective.cost_and_gradient(&b).ok_or_else(|| Error::msg("the basis became rank deficient"))?;
        self.best.record(cost, x);
        let grad = match self.b0 {
            Some(b0) => b0.tr_mul(&grad_b),
            None => grad_b,
        };
        let grad = DVector::from_column_slice(grad.as_slice());
        if let Ok(mut guard) = self.last.lock() {
            *guard = Some((x.clone(), cost, grad.clone()));
        }
        Ok((cost, grad))
    }
}

impl CostFunction for Problem<'_> {
    type Param = DVector<f64>;
    type Output = f64;

    fn cost(&self, x: &Self::Param) -> Result<f64, Error> {
        self.eval(x).map(|(c, _)| c)
    }
}

impl Gradient for Problem<'_> {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;

    fn gradient(&self, x: &Self::Param) -> Result<DVector<f64>, Error> {
        self.eval(x).map(|(_, g)| g)
    }
}

fn run(objective: &Objective, b0: Option<&DMatrix<f64>>, start: &DMatrix<f64>, iterations: u64) -> RefineOutcome {
    let m = start.ncols();
    let x0 = DVector::from_column_slice(start.as_slice());
    let best = Best(Mutex::new(None));
    let problem = Problem { objective, b0, m, best: &best, last: Mutex::new(None) };
    let start_cost = match problem.cost(&x0) {
        Ok(c) => c,
        Err(e) => return RefineOutcome::Kept { reason: e.to_string() },
    };
    if objective.pairs() == 0 || start_cost == 0.0 {
        return RefineOutcome::Kept { reason: "nothing to fit (no pairs with a lit white, or zero error)".into() };
    }
    let solver = match LBFGS::new(MoreThuenteLineSearch::new(), LBFGS_MEMORY)
        .with_tolerance_grad(1e-12)
        .and_then(|s| s.with_tolerance_cost(1e-15))
    {
        Ok(s) => s,
        Err(e) => return RefineOutcome::Kept { reason: e.to_string() },
    };
    let limits =
        crate::optimize::Limits { target_cost: Some(TARGET_COST), ..crate::optimize::Limits::iterations(iterations) };
    let (iters, aborted) = match crate::optimize::run(problem, solver, x0, &limits) {
        Ok(r) => (r.iterations(), None),
        Err(e) => (iterations, Some(e.to_string())),
    };
    // The best point seen by any evaluation (a line search may end on a worse one than it tried, and an
    // aborted run still keeps its progress).
    match best.take() {
        Some((cost, x)) if cost < start_cost => {
            let value = match b0 {
                Some(_) => DMatrix::from_column_slice(m, m, x.as_slice()),
                None => DMatrix::from_column_slice(SAMPLES, m, x.as_slice()),
            };
            RefineOutcome::Improved { value, iterations: iters }
        }
        _ => RefineOutcome::Kept { reason: aborted.unwrap_or_else(|| "no improvement".into()) },
    }
}

/// Refine T for `B = B0 T`, starting from `t0`, with at most `iterations` L-BFGS iterations.
pub(crate) fn refine_transform(
    objective: &Objective,
    b0: &DMatrix<f64>,
    t0: &DMatrix<f64>,
    iterations: u64,
) -> RefineOutcome {
    run(objective, Some(b0), t0, iterations)
}

/// Refine all of B (31×m), starting from `b`, with at most `iterations` L-BFGS iterations.
pub(crate) fn refine_basis(objective: &Objective, b: &DMatrix<f64>, iterations: u64) -> RefineOutcome {
    run(objective, None, b, iterations)
}
