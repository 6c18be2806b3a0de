//! Training a spectral factor basis from lights and reflectances (seed §2.2).
//!
//! 1. **PCA** ([`principal_components`]): the m leading left singular vectors `B0` (31×m, orthonormal) of the
//!    matrix of colour signals `E_l ∘ S_r` over every light × reflectance pair. When the signals have rank
//!    r < m (one light and few reflectances, all-zero spectra, …) the remaining m − r columns are padded
//!    with band vectors orthogonal to the signal span, so the basis keeps its dimension and stays well
//!    conditioned; the training report says so.
//! 2. **Several starts** ([`Start`]), because the factor-model objective is far from convex and one start
//!    can collapse (D65 + A + F11 × four ColorChecker patches, m = 7: interval sharpening alone ended at
//!    mean ΔE00 31, cond(B) ≈ 7e7): the PCA basis itself (T = I); interval sharpening after Finlayson, Drew
//!    & Funt ([`super::sharpen::interval_transform`]); box band indicators projected onto the PCA span
//!    ([`super::sharpen::projected_bands_transform`]); and the box band indicators themselves, the
//!    non-negative, perfectly sharp limit of Drew & Finlayson's sharpening with positivity
//!    ([`super::sharpen::positive_bands`]).
//! 3. **Refining each start**: for starts in the PCA span, L-BFGS (argmin) on T with `B = B0 T`, then on
//!    all 31×m entries of B, minimising the factor-model colour error over the training pairs in a local
//!    CIEDE2000 metric at each true colour ([`super::refine`]), plus μ times the same error of the full-Λ
//!    model of Eq. 7 ([`DEFAULT_LAMBDA_WEIGHT`]; without it B drifts to a span where Eq. 7 is poor), plus ρ
//!    times a conditioning term, the columns' variance inflation factors
//!    ([`DEFAULT_CONDITIONING_WEIGHT`], [`Objective::with_conditioning_weight`]), which keeps B⁺ stable in
//!    double precision. The objective is only a local model of ΔE00, so a refined B is accepted only if its
//!    real factor-model ΔE00 is no worse than its start ([`FACTOR_SLACK`]); otherwise it is redone with
//!    μ/10, then μ = 0, else the start is kept. Every start is first refined with a small budget
//!    ([`DEFAULT_SCREEN_ITERATIONS`] per stage); the most promising is then refined with the full budget.
//! 4. **Choice**: the candidate with the lowest real mean (then p95) factor-model ΔE00 on the training
//!    pairs. The unrefined PCA basis is always a candidate, so the accepted basis is never worse than the
//!    PCA start used as a factor model. [`Trained::candidates`] lists every candidate with its error and
//!    the condition number of its column-balanced B ([`balanced_condition`]).
//!
//! Every stage is deterministic: no randomness, fixed iteration limits, candidates refined in parallel but
//! collected in order.

use super::accuracy::{self, ErrorStats, Model};
use super::refine::{self, Objective, RefineOutcome};
use super::set::{TrainError, TrainingSet};
use super::sharpen;
use super::{Basis, BasisError};
use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use crate::spectrum::SAMPLES;
#[cfg(test)]
use nalgebra::Vector3;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// Bumped whenever a change to training changes its result (it is part of the cache key).
pub(crate) const TRAINING_VERSION: u32 = 5;

/// Default weight μ of the full-Λ colour error while refining all of B. On ColorChecker × 7 lights, m = 7,
/// μ = 0.3 brings the full-Λ model (Eq. 7, which DESIGN_SPEC §2's subspace criteria use) from mean ΔE00
/// ≈ 10 to ≈ 0.2 while the factor model stays at ≈ 0.3 (see the module docs).
pub(crate) const DEFAULT_LAMBDA_WEIGHT: f64 = 0.3;

/// How much worse (mean, p95 ΔE00) the factor model may get when refining all of B with the full-Λ term,
/// compared with the T-only basis, before that refinement is rejected.
pub(crate) const FACTOR_SLACK: (f64, f64) = (0.05, 0.1);

/// Default weight ρ of the conditioning term (sum of the columns' variance inflation factors, see
/// [`Objective::with_conditioning_weight`]): negligible for a balanced condition number up to ~10³ (VIF ≤
/// 10⁶ costs 10⁻³ of mean squared ΔE00), dominant beyond ~10⁵.
pub(crate) const DEFAULT_CONDITIONING_WEIGHT: f64 = 1e-9;

/// Iterations per stage when screening the starts (see [`TrainOptions::screen_iterations`]).
pub(crate) const DEFAULT_SCREEN_ITERATIONS: u64 = 300;

/// A singular value counts towards the rank of the colour signals when it exceeds this fraction of the
/// largest one (the signals are f64 products of tabulated spectra; 1e-9 is far above rounding noise).
pub(crate) const RANK_TOLERANCE: f64 = 1e-9;

/// How far training goes.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainOptions {
    /// Apply interval sharpening (stage 2); without it T starts at the identity.
    pub sharpen: bool,
    /// L-BFGS iterations refining T (stage 3); 0 skips the stage.
    pub transform_iterations: u64,
    /// L-BFGS iterations refining all of B (stage 4); 0 skips the stage.
    pub full_iterations: u64,
    /// Weight μ of the full-Λ (Eq. 7) colour error in the objective (see [`Objective::with_lambda_weight`]).
    pub lambda_weight: f64,
    /// Weight ρ of the conditioning term (see [`Objective::with_conditioning_weight`]).
    pub conditioning_weight: f64,
    /// Refine the further sharpening starts ([`Start::ProjectedBands`], [`Start::PositiveBands`]) beside the
    /// PCA basis and interval sharpening.
    pub multi_start: bool,
    /// With several starts, each is first refined with at most this many iterations per stage; only the
    /// best of them is then refined with the full budget.
    pub screen_iterations: u64,
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            sharpen: true,
            transform_iterations: 5000,
            full_iterations: 5000,
            lambda_weight: DEFAULT_LAMBDA_WEIGHT,
            conditioning_weight: DEFAULT_CONDITIONING_WEIGHT,
            multi_start: true,
            screen_iterations: DEFAULT_SCREEN_ITERATIONS,
        }
    }
}

impl TrainOptions {
    /// Only PCA: the unsharpened basis.
    pub fn pca_only() -> TrainOptions {
        TrainOptions {
            sharpen: false,
            transform_iterations: 0,
            full_iterations: 0,
            lambda_weight: 0.0,
            conditioning_weight: 0.0,
            multi_start: false,
            screen_iterations: 0,
        }
    }

    /// PCA, interval sharpening and the T refinement, but B stays in the PCA span.
    pub fn transform_only() -> TrainOptions {
        TrainOptions { full_iterations: 0, ..TrainOptions::default() }
    }
}

/// A training stage, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    Pca,
    IntervalSharpening,
    ProjectedBands,
    PositiveBands,
    RefinedTransform,
    RefinedBasis,
}

/// Where a candidate's refinement starts (each is refined; the best by factor-model ΔE00 is kept).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Start {
    /// The orthonormal PCA basis itself (T = I).
    Pca,
    /// Interval (sensor-based) sharpening after Finlayson, Drew & Funt: per band the combination of the PCA
    /// vectors most concentrated in it ([`sharpen::interval_transform`]).
    IntervalSharpening,
    /// The least-squares projection of box band indicators onto the PCA span (`T = B0ᵀ Box`), scaled so a
    /// flat spectrum has unit coefficients ([`sharpen::projected_bands_transform`]).
    ProjectedBands,
    /// The non-negative box band indicators themselves, outside the PCA span: the perfectly sharp,
    /// positive limit of sharpening with positivity (Drew & Finlayson), `G_ijk = δ_ij δ_jk`
    /// ([`sharpen::positive_bands`]).
    PositiveBands,
}

impl Start {
    /// The stage that reports the unrefined start.
    pub(crate) fn stage(self) -> Stage {
        match self {
            Start::Pca => Stage::Pca,
            Start::IntervalSharpening => Stage::IntervalSharpening,
            Start::ProjectedBands => Stage::ProjectedBands,
            Start::PositiveBands => Stage::PositiveBands,
        }
    }

    /// A short human-readable name.
    pub fn label(self) -> &'static str {
        match self {
            Start::Pca => "PCA start",
            Start::IntervalSharpening => "interval-sharpening start",
            Start::ProjectedBands => "projected-band start",
            Start::PositiveBands => "positive-band start",
        }
    }
}

/// How one candidate ended: its real factor-model ΔE00 on the training pairs and the condition number of
/// its column-balanced B.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CandidateSummary {
    /// Where the candidate's refinement started.
    pub start: Start,
    /// False for the unrefined PCA basis (the fallback that makes the guarantee hold).
    pub refined: bool,
    /// True when refined with the screening budget only ([`TrainOptions::screen_iterations`]).
    #[serde(default)]
    pub screened: bool,
    /// Mean factor-model ΔE00 on the training pairs (+∞ when not finite).
    #[serde(deserialize_with = "super::accuracy::f64_or_infinity")]
    pub factor_mean: f64,
    /// 95th-percentile factor-model ΔE00 on the training pairs (+∞ when not finite).
    #[serde(deserialize_with = "super::accuracy::f64_or_infinity")]
    pub factor_p95: f64,
    /// Condition number of the candidate's B with unit-norm columns (+∞ when not finite).
    #[serde(deserialize_with = "super::accuracy::f64_or_infinity")]
    pub condition: f64,
    /// True for the candidate that was kept.
    pub accepted: bool,
}

/// What one stage reached: its objective (mean squared local ΔE00 over the pairs) and iterations.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StageResult {
    pub(crate) stage: Stage,
    pub(crate) objective: f64,
    pub(crate) iterations: u64,
}

/// A trained basis with what it took.
#[derive(Clone, Debug)]
pub struct Trained {
    /// The accepted (sharpened, refined) basis.
    pub basis: Basis,
    /// The orthonormal PCA basis `B0` (31×m) it started from (with any padding).
    pub pca: DMatrix<f64>,
    /// `B0 T` after stages 2–3, before all of B was refined (equal to `basis.b` when stage 4 did not run).
    pub transform_only: DMatrix<f64>,
    /// Rank of the colour signals (≤ m; padding fills the rest).
    pub(crate) signal_rank: usize,
    /// Number of padded columns (`m − min(rank, m)`).
    pub(crate) padded: usize,
    pub(crate) stages: Vec<StageResult>,
    /// Anything the user should know (padding, a stage that was skipped or failed).
    pub(crate) notes: Vec<String>,
    /// The start the accepted basis was refined from.
    pub start: Start,
    /// Every candidate tried, in order (the last is the unrefined PCA basis).
    pub(crate) candidates: Vec<CandidateSummary>,
    /// Condition number of the accepted B with unit-norm columns.
    pub condition: f64,
}

/// The m leading principal components of the colour signals (uncentred: the signals' own span), as an
/// orthonormal 31×m matrix, padded with band vectors when the signals have lower rank. Returns the basis
/// and the signals' rank. Columns are signed so that their sum is non-negative (deterministic output).
pub(crate) fn principal_components(signals: &DMatrix<f64>, m: usize) -> Result<(DMatrix<f64>, usize), TrainError> {
    super::check_dimension(m).map_err(|_| TrainError::BadDimension(m))?;
    let mut cols: Vec<DVector<f64>> = Vec::with_capacity(m);
    let mut rank = 0;
    if signals.ncols() > 0 {
        let svd = signals.clone().svd(true, false);
        let u = svd.u.as_ref().ok_or(BasisError::NotFinite)?;
        // nalgebra does not sort singular values: order them, largest first.
        let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
        order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
        let smax = order.first().map_or(0.0, |&i| svd.singular_values[i]);
        if smax.is_finite() && smax > f64::MIN_POSITIVE {
            rank = order.iter().filter(|&&i| svd.singular_values[i] > smax * RANK_TOLERANCE).count();
            for &i in order.iter().take(rank.min(m)) {
                let mut c = u.column(i).into_owned();
                if c.sum() < 0.0 {
                    c.neg_mut();
                }
                cols.push(c);
            }
        }
    }
    pad_with_bands(&mut cols, m);
    let b0 = DMatrix::from_columns(&cols);
    Ok((b0, rank))
}

/// Complete an orthonormal set to m columns with box-shaped band vectors (the 31 samples cut into m equal
/// bands) orthogonalised against it; at each step the band with the largest remaining component is taken.
fn pad_with_bands(cols: &mut Vec<DVector<f64>>, m: usize) {
    let bands = sharpen::equal_bands(m);
    let mut candidates: Vec<DVector<f64>> =
        bands.iter().map(|r| DVector::from_fn(SAMPLES, |i, _| if r.contains(&i) { 1.0 } else { 0.0 })).collect();
    // Single samples as a last resort, so completion can never run out of directions.
    candidates.extend((0..SAMPLES).map(|i| DVector::from_fn(SAMPLES, |j, _| if i == j { 1.0 } else { 0.0 })));
    while cols.len() < m {
        let residual = |v: &DVector<f64>| {
            let mut r = v.clone();
            for c in cols.iter() {
                r -= c * c.dot(&r);
            }
            r
        };
        let best = candidates
            .iter()
            .map(residual)
            .map(|r| {
                let n = r.norm();
                (r, n)
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        match best {
            Some((r, n)) if n > 1e-8 => {
                // Re-orthogonalise once more for numerical safety.
                let mut r = r / n;
                for c in cols.iter() {
                    r -= c * c.dot(&r);
                }
                let n2 = r.norm();
                cols.push(r / n2);
            }
            // Unreachable for m ≤ 31 since the unit vectors span the whole space; stop rather than loop.
            _ => break,
        }
    }
}

/// Train a basis of dimension m on a training set (see the module docs for the stages).
pub fn train(
    set: &TrainingSet,
    m: usize,
    colorimetry: &Colorimetry,
    options: &TrainOptions,
) -> Result<Trained, TrainError> {
    let (b0, rank) = principal_components(&set.signals(), m)?;
    let padded = m.saturating_sub(rank);
    let mut notes = Vec::new();
    if padded > 0 {
        notes.push(format!(
            "the colour signals have rank {rank} < m = {m}: padded the basis with {padded} band vector(s) \
             outside their span"
        ));
    }
    // The full-Λ colours depend only on the span of B, which T does not change: refining T minimises the
    // factor-model term alone; every stage is reported with the whole objective (without the conditioning
    // term, so that stage objectives stay mean squared ΔE00).
    let factor_objective = Objective::new(set, colorimetry);
    let report_objective = factor_objective.clone().with_lambda_weight(options.lambda_weight);
    let pca_stage = StageResult { stage: Stage::Pca, objective: report_objective.cost_of(&b0), iterations: 0 };
    let pca_stats = factor_stats(set, &b0, colorimetry);

    let mut starts: Vec<(Start, StartPoint)> = vec![(Start::Pca, StartPoint::Transform(DMatrix::identity(m, m)))];
    if options.sharpen {
        match sharpen::interval_transform(&b0) {
            Some(t0) => starts.push((Start::IntervalSharpening, StartPoint::Transform(t0))),
            None => notes.push("interval sharpening gave an ill-conditioned transform; not used as a start".into()),
        }
        if options.multi_start {
            match sharpen::projected_bands_transform(&b0) {
                Some(t0) => starts.push((Start::ProjectedBands, StartPoint::Transform(t0))),
                None => notes.push("the projected band start was ill-conditioned; not used as a start".into()),
            }
            starts.push((Start::PositiveBands, StartPoint::Basis(sharpen::positive_bands(m))));
        }
    }
    // Screening: every start refined with a small budget; then the most promising one (by real
    // factor-model ΔE00) is refined again from its start with the whole budget. Both runs stay candidates.
    let screen_options = TrainOptions {
        transform_iterations: options.transform_iterations.min(options.screen_iterations),
        full_iterations: options.full_iterations.min(options.screen_iterations),
        ..options.clone()
    };
    let screening = starts.len() > 1 && screen_options != *options;
    let ctx = CandidateContext {
        set,
        b0: &b0,
        colorimetry,
        options: if screening { &screen_options } else { options },
        factor_objective: &factor_objective,
    };
    let mut candidates: Vec<Candidate> =
        starts.par_iter().map(|(start, point)| ctx.refine(*start, point.clone(), &report_objective)).collect();
    for c in &mut candidates {
        c.screened = screening;
    }
    if screening {
        let promising = candidates
            .iter()
            .enumerate()
            .min_by(|(_, a), (_, b)| rank_key(a).partial_cmp(&rank_key(b)).unwrap_or(std::cmp::Ordering::Equal))
            .map(|(i, _)| i);
        if let Some(i) = promising {
            let full = CandidateContext { options, ..ctx };
            let (start, point) = &starts[i];
            candidates.push(full.refine(*start, point.clone(), &report_objective));
        }
    }
    // The plain PCA basis as a factor model is always a candidate, so the accepted basis can never be worse.
    candidates.push(Candidate {
        start: Start::Pca,
        refined: false,
        screened: false,
        basis: b0.clone(),
        transform_only: Some(b0.clone()),
        stats: pca_stats,
        stages: Vec::new(),
        notes: Vec::new(),
    });
    let best = candidates
        .iter()
        .enumerate()
        .min_by(|(_, a), (_, b)| rank_key(a).partial_cmp(&rank_key(b)).unwrap_or(std::cmp::Ordering::Equal))
        .map(|(i, _)| i)
        .unwrap_or(candidates.len() - 1);
    let summaries: Vec<CandidateSummary> = candidates
        .iter()
        .enumerate()
        .map(|(i, c)| CandidateSummary {
            start: c.start,
            refined: c.refined,
            screened: c.screened,
            factor_mean: c.stats.map_or(f64::INFINITY, |s| s.mean),
            factor_p95: c.stats.map_or(f64::INFINITY, |s| s.p95),
            condition: balanced_condition(&c.basis),
            accepted: i == best,
        })
        .collect();
    // The best basis that stays in the PCA span, refining only T (what `transform_only` reports).
    let transform_only = candidates
        .iter()
        .filter_map(|c| c.transform_only.as_ref().map(|t| (t, factor_stats(set, t, colorimetry))))
        .min_by(|a, b| {
            let key = |s: &Option<ErrorStats>| s.map_or((f64::INFINITY, f64::INFINITY), |s| (s.mean, s.p95));
            key(&a.1).partial_cmp(&key(&b.1)).unwrap_or(std::cmp::Ordering::Equal)
        })
        .map_or_else(|| b0.clone(), |(t, _)| t.clone());
    let chosen = candidates.swap_remove(best);
    notes.extend(chosen.notes);
    let mut stages = vec![pca_stage];
    stages.extend(chosen.stages);
    let basis = Basis::from_matrix(chosen.basis, colorimetry)?;
    let condition = balanced_condition(&basis.b);
    Ok(Trained {
        basis,
        pca: b0,
        transform_only,
        signal_rank: rank,
        padded,
        stages,
        notes,
        start: chosen.start,
        candidates: summaries,
        condition,
    })
}

/// Candidates are ranked by their real factor-model ΔE00 on the training pairs: mean, then p95; an unrefined
/// candidate loses a tie (so the plain PCA basis is kept only when nothing beats it).
fn rank_key(c: &Candidate) -> (f64, f64, u8) {
    match c.stats {
        Some(s) if s.mean.is_finite() => (s.mean, s.p95, u8::from(!c.refined)),
        _ => (f64::INFINITY, f64::INFINITY, 2),
    }
}

/// Condition number of B with its columns scaled to unit norm (what limits the accuracy of `B⁺`; the
/// factor model itself depends on the column scales, so they are not balanced away).
pub fn balanced_condition(b: &DMatrix<f64>) -> f64 {
    let mut bal = b.clone();
    for mut col in bal.column_iter_mut() {
        let n = col.norm();
        if n > 0.0 {
            col /= n;
        }
    }
    let sv = bal.singular_values();
    let (smax, smin) = (sv.max(), sv.min());
    if smin > 0.0 { smax / smin } else { f64::INFINITY }
}

mod candidate;
use candidate::{Candidate, CandidateContext, StartPoint, factor_stats};

/// Train on all lights × reflectances of a palette (designed spectra at their current samples).
pub fn train_for_palette(
    palette: &Palette,
    m: usize,
    colorimetry: &Colorimetry,
    options: &TrainOptions,
) -> Result<Trained, TrainError> {
    train(&TrainingSet::from_palette(palette)?, m, colorimetry, options)
}

#[cfg(test)]
mod tests;
