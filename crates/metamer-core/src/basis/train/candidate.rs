//! One candidate of [`super::train`]: a start refined (the transform in the PCA span, then all of B), and
//! its real factor-model error on the training pairs.

use super::*;

/// Where a candidate's refinement starts: a transform T of the PCA basis (`B = B0 T`) or a whole basis.
#[derive(Clone)]
pub(super) enum StartPoint {
    Transform(DMatrix<f64>),
    Basis(DMatrix<f64>),
}

/// One refined candidate.
pub(super) struct Candidate {
    pub(super) start: Start,
    pub(super) refined: bool,
    /// Refined with the screening budget only.
    pub(super) screened: bool,
    pub(super) basis: DMatrix<f64>,
    /// `B0 T` after refining T (for starts in the PCA span).
    pub(super) transform_only: Option<DMatrix<f64>>,
    pub(super) stats: Option<ErrorStats>,
    pub(super) stages: Vec<StageResult>,
    pub(super) notes: Vec<String>,
}

pub(super) struct CandidateContext<'a> {
    pub(super) set: &'a TrainingSet,
    pub(super) b0: &'a DMatrix<f64>,
    pub(super) colorimetry: &'a Colorimetry,
    pub(super) options: &'a TrainOptions,
    pub(super) factor_objective: &'a Objective,
}

impl CandidateContext<'_> {
    /// Refine one start: T (if it starts in the PCA span), then all of B with the full-Λ weight schedule.
    pub(super) fn refine(&self, start: Start, point: StartPoint, report: &Objective) -> Candidate {
        let (set, colorimetry, options) = (self.set, self.colorimetry, self.options);
        let rho = options.conditioning_weight;
        let factor = self.factor_objective.clone().with_conditioning_weight(rho);
        let mut stages = Vec::new();
        let mut notes = Vec::new();
        let label = start.label();
        let (start_b, transform_only) = match point {
            StartPoint::Transform(t0) => {
                let mut t = t0;
                if start != Start::Pca {
                    stages.push(StageResult {
                        stage: start.stage(),
                        objective: report.cost_of(&(self.b0 * &t)),
                        iterations: 0,
                    });
                }
                if options.transform_iterations > 0 {
                    match refine::refine_transform(&factor, self.b0, &t, options.transform_iterations) {
                        RefineOutcome::Improved { value, iterations, .. } => {
                            t = value;
                            let cost = report.cost_of(&(self.b0 * &t));
                            stages.push(StageResult { stage: Stage::RefinedTransform, objective: cost, iterations });
                        }
                        RefineOutcome::Kept { reason } => {
                            notes.push(format!("{label}: refining T stopped early: {reason}"))
                        }
                    }
                }
                let b = self.b0 * &t;
                (b.clone(), Some(b))
            }
            StartPoint::Basis(b) => {
                stages.push(StageResult { stage: start.stage(), objective: report.cost_of(&b), iterations: 0 });
                (b, None)
            }
        };
        let mut b = start_b.clone();
        if options.full_iterations > 0 {
            // The objective is a local (quadratic) model of ΔE00; the Λ term can dominate it on palettes whose
            // Eq. 7 colours are far off. The factor model is what renders, so a refined B is accepted only if
            // its real factor-model ΔE00 is no worse than its start (within FACTOR_SLACK); otherwise the
            // refinement is redone with a weaker Λ term, and if that does not help either, B stays the start.
            let reference = factor_stats(set, &start_b, colorimetry);
            let weights: Vec<f64> = if options.lambda_weight > 0.0 {
                vec![options.lambda_weight, options.lambda_weight * 0.1, 0.0]
            } else {
                vec![0.0]
            };
            for (attempt, &mu) in weights.iter().enumerate() {
                let obj = factor.clone().with_lambda_weight(mu);
                match refine::refine_basis(&obj, &start_b, options.full_iterations) {
                    RefineOutcome::Improved { value, iterations, .. } => {
                        let refined = factor_stats(set, &value, colorimetry);
                        let acceptable = match (reference, refined) {
                            (Some(r), Some(n)) => n.mean <= r.mean + FACTOR_SLACK.0 && n.p95 <= r.p95 + FACTOR_SLACK.1,
                            (None, Some(_)) => true,
                            _ => false,
                        };
                        if acceptable {
                            let cost = report.cost_of(&value);
                            b = value;
                            stages.push(StageResult { stage: Stage::RefinedBasis, objective: cost, iterations });
                            break;
                        }
                        let next = match weights.get(attempt + 1) {
                            Some(w) if *w > 0.0 => format!("retried with μ = {w}"),
                            Some(_) => "retried on the factor-model error alone".to_string(),
                            None => "kept its start".to_string(),
                        };
                        notes.push(format!(
                            "{label}: refining all of B with full-Λ weight μ = {mu} made the factor model worse; \
                             {next}"
                        ));
                    }
                    RefineOutcome::Kept { reason } => {
                        notes.push(format!("{label}: refining all of B (μ = {mu}) found nothing better ({reason})"));
                        break;
                    }
                }
            }
        }
        let stats = factor_stats(set, &b, colorimetry);
        Candidate { start, refined: true, screened: false, basis: b, transform_only, stats, stages, notes }
    }
}

/// Real factor-model ΔE00 of a candidate B on the training set; `None` if B is not a valid basis.
pub(super) fn factor_stats(set: &TrainingSet, b: &DMatrix<f64>, colorimetry: &Colorimetry) -> Option<ErrorStats> {
    let basis = Basis::from_matrix(b.clone(), colorimetry).ok()?;
    Some(accuracy::stats(set, Model::Factor(&basis), colorimetry))
}
