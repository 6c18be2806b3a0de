//! The solved numbers of the palette's criteria along the light dial (`[[mixtures]]`, `[[paths]]`), as the
//! designer's list shows them: taken from the one [`Solution`] the solver returned for the palette on
//! screen (the same `Solution::mixtures` and `Solution::paths` `metamer solve` draws its table and report
//! from), with the factor-model colours set by [`Solution::set_subspace`] in the basis of the solved
//! spectra once it has arrived — as `metamer solve` does. Nothing is recomputed here; while a newer
//! palette is being solved there are no numbers (the list says "solving…").

use crate::basis::Basis;
use crate::colorimetry::Colorimetry;
use crate::design::{CellResult, Criterion, PathResult, Solution};

/// The solve's results for the mixtures and paths of the palette on screen (empty when it is not solved).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DialResults {
    /// One per `palette.mixtures` entry.
    pub mixtures: Vec<CellResult>,
    /// Whether the solve calls each mixture unmet (its UNMET diagnostic, the table's tag).
    pub unmet_mixtures: Vec<bool>,
    /// One per `palette.paths` entry.
    pub paths: Vec<PathResult>,
    /// The solve's sentence on each mixture, then each path, that has one (why it is unmet).
    pub remarks: Vec<(Criterion, String)>,
    /// The factor-model numbers are in (the basis of the solved spectra was given).
    pub subspace: bool,
}

impl DialResults {
    /// The results of `solution` (the current palette's, else none) with the factor model of `basis` (the
    /// basis of the solved spectra) when there is one.
    pub(crate) fn of(solution: Option<&Solution>, basis: Option<&Basis>, colorimetry: &Colorimetry) -> DialResults {
        let Some(s) = solution.filter(|s| !(s.mixtures.is_empty() && s.paths.is_empty())) else {
            return DialResults::default();
        };
        let with_basis;
        let s = match basis {
            Some(b) => {
                let mut copy = s.clone();
                copy.set_subspace(b, colorimetry);
                with_basis = copy;
                &with_basis
            }
            None => s,
        };
        let unmet = |c: Criterion| s.diagnostics.iter().any(|d| d.criterion == Some(c) && d.is_unmet());
        DialResults {
            unmet_mixtures: (0..s.mixtures.len()).map(|k| unmet(Criterion::Mixture(k))).collect(),
            mixtures: s.mixtures.clone(),
            paths: s.paths.clone(),
            remarks: s.diagnostics.iter().filter_map(|d| Some((d.criterion?, d.message.clone()))).collect(),
            subspace: basis.is_some(),
        }
    }
}
