//! What the view shows, derived once per change (not per frame) from the palette and the latest
//! solution: the colour of every light × reflectance cell in the full 31-sample model and in the
//! subspace model, its desired colour and the CIEDE2000 errors between them.
//!
//! A cell with a criterion draws the solve's own [`CellResult`] ([`Solution::cells`]) while that result
//! holds for what is shown; its subspace colour is set from the basis of the shown spectra, which the
//! one basis policy delivers later (until then the view says "updating", [`Derived::subspace_pending`]).
//! Cells without a criterion, and cells edited since the solve, are computed by the same domain functions
//! ([`CellResult::new`], [`pair_colours`]).

use crate::basis::Basis;
use crate::basis::TrainingSet;
use crate::colorimetry::Colorimetry;
use crate::design::{CellResult, Solution, pair_colours};
use crate::palette::{Palette, SpectrumEntry};
use crate::spectrum::Spectrum;
use crate::tui::model::BasisKey;
use nalgebra::Vector3;

/// One cell of the design matrix as drawn.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CellView {
    /// The desired colour (a free cell's is its group's solved colour, once solved), linear sRGB.
    pub desired: Option<Vector3<f64>>,
    /// The colour in the full 31-sample model.
    pub full: Vector3<f64>,
    /// The colour in the spectral factor model (`Basis::rgb_factor`, what post-illumination renders and
    /// what the solver reports), when a basis is available.
    pub(crate) subspace: Option<Vector3<f64>>,
    pub delta_e_full: Option<f64>,
    pub delta_e_subspace: Option<f64>,
    /// The cell has a colour criterion in the palette.
    pub(crate) has_criterion: bool,
    /// The criterion contributes to the objective (use colour on, weight > 0).
    pub(crate) active: bool,
    /// The free-colour group of the cell.
    pub(crate) free: Option<usize>,
}

/// Derived colours of a palette.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Derived {
    pub(crate) lights: usize,
    pub(crate) reflectances: usize,
    /// Row-major: `cells[reflectance * lights + light]`.
    pub cells: Vec<CellView>,
    /// Each light on a flat white reflectance.
    pub light_swatches: Vec<Vector3<f64>>,
    /// Each reflectance under a flat white light.
    pub reflectance_swatches: Vec<Vector3<f64>>,
    /// The spectra as they stand (solved where a current solution has them).
    pub light_spectra: Vec<Spectrum>,
    pub reflectance_spectra: Vec<Spectrum>,
    /// Largest full-model CIEDE2000 over the active cells.
    pub(crate) worst_delta_e: Option<f64>,
    /// True when the shown spectra come from a solution.
    pub solved: bool,
    /// The basis key of the shown spectra and m ([`BasisKey`]): the subspace colours
    /// are computed only with the basis of exactly these spectra.
    pub basis_key: Option<BasisKey>,
    /// The shown spectra have a key but the basis given was not theirs: the subspace colours are not
    /// shown (rather than stale ones) until it arrives.
    pub subspace_pending: bool,
}

/// The solve's result for cell `k` of `palette` when it holds for the cell as shown: the solution's cell
/// `k` has the same light, reflectance, target and free group, and the shown spectra are the ones it was
/// solved with. `None` for a stale solution (the palette was edited since).
fn solved_cell(solution: &Solution, k: usize, palette: &Palette, (e, s): (&Spectrum, &Spectrum)) -> Option<CellResult> {
    let (now, then) = (palette.colours.get(k)?, solution.palette.colours.get(k)?);
    let same_cell = now.light == then.light
        && now.reflectance == then.reflectance
        && now.target == then.target
        && now.free == then.free
        && now.is_active() == then.is_active();
    let same_spectra = solution.palette.lights.get(now.light).is_some_and(|l| l.spectrum == *e)
        && solution.palette.reflectances.get(now.reflectance).is_some_and(|r| r.spectrum == *s);
    let r = solution.cells.get(k)?;
    (same_cell && same_spectra && r.cell == k).then(|| r.clone())
}

/// True when `a` and `b` list the same spectra by name, in order.
fn same_names(a: &[SpectrumEntry], b: &[SpectrumEntry]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.name == y.name)
}

impl Derived {
    /// Derive the view of `palette`, taking the spectra from `solution` when it solved a palette with the
    /// same lights and reflectances (a stale solution keeps the matrix steady while the next one runs).
    pub(crate) fn compute(
        palette: &Palette,
        solution: Option<&Solution>,
        colorimetry: &Colorimetry,
        basis: Option<(&BasisKey, &Basis)>,
    ) -> Derived {
        let solution = solution.filter(|s| {
            same_names(&s.palette.lights, &palette.lights) && same_names(&s.palette.reflectances, &palette.reflectances)
        });
        let pick = |own: &SpectrumEntry, solved: Option<&SpectrumEntry>| match solved {
            Some(s) if own.design => s.spectrum,
            _ => own.spectrum,
        };
        let light_spectra: Vec<Spectrum> = palette
            .lights
            .iter()
            .enumerate()
            .map(|(j, e)| pick(e, solution.and_then(|s| s.palette.lights.get(j))))
            .collect();
        let reflectance_spectra: Vec<Spectrum> = palette
            .reflectances
            .iter()
            .enumerate()
            .map(|(i, e)| pick(e, solution.and_then(|s| s.palette.reflectances.get(i))))
            .collect();
        let basis_key = TrainingSet::new(light_spectra.clone(), reflectance_spectra.clone())
            .ok()
            .map(|set| BasisKey::of(&set, palette.settings.basis_dimension));
        let basis = basis
            .filter(|(k, b)| Some(*k) == basis_key.as_ref() && b.b.nrows() == crate::spectrum::SAMPLES)
            .map(|(_, b)| b);
        let subspace_pending = basis_key.is_some() && basis.is_none();
        let white = Spectrum::flat(1.0);
        let light_swatches = light_spectra.iter().map(|e| colorimetry.rgb(e, &white)).collect();
        let reflectance_swatches = reflectance_spectra.iter().map(|s| colorimetry.rgb(&white, s)).collect();
        let (nl, nr) = (light_spectra.len(), reflectance_spectra.len());
        let mut cells = Vec::with_capacity(nl * nr);
        let mut worst: Option<f64> = None;
        for (i, s) in reflectance_spectra.iter().enumerate() {
            for (j, e) in light_spectra.iter().enumerate() {
                let index = palette.colours.iter().position(|c| c.light == j && c.reflectance == i);
                let criterion = index.map(|k| &palette.colours[k]);
                let desired = criterion.and_then(|c| match c.free {
                    Some(g) => solution.and_then(|s| s.free.get(g).copied()),
                    None => Some(c.target),
                });
                // The solve's own result for this cell when it holds for what is shown (the same spectra
                // and criterion); otherwise (no criterion, an edit not solved yet) the same computation here.
                let result = match (index, desired) {
                    (Some(k), Some(d)) => Some(match solution.and_then(|sol| solved_cell(sol, k, palette, (e, s))) {
                        Some(mut r) => {
                            r.set_subspace(basis, e, s, colorimetry);
                            r
                        }
                        None => CellResult::new(k, d, (e, s), palette.colours[k].is_active(), basis, colorimetry),
                    }),
                    _ => None,
                };
                let (full, subspace) = match &result {
                    Some(r) => (r.rgb_full, r.rgb_subspace),
                    None => pair_colours(e, s, basis, colorimetry),
                };
                let delta_e_full = result.as_ref().map(|r| r.delta_e_full);
                let delta_e_subspace = result.as_ref().and_then(|r| r.delta_e_subspace);
                let active = criterion.is_some_and(|c| c.is_active());
                if active && let Some(d) = delta_e_full.filter(|d| d.is_finite()) {
                    worst = Some(worst.map_or(d, |w: f64| w.max(d)));
                }
                cells.push(CellView {
                    desired,
                    full,
                    subspace,
                    delta_e_full,
                    delta_e_subspace,
                    has_criterion: criterion.is_some(),
                    active,
                    free: criterion.and_then(|c| c.free),
                });
            }
        }
        Derived {
            lights: nl,
            reflectances: nr,
            cells,
            light_swatches,
            reflectance_swatches,
            light_spectra,
            reflectance_spectra,
            worst_delta_e: worst,
            solved: solution.is_some(),
            basis_key,
            subspace_pending,
        }
    }

    /// The cell of light `light` on reflectance `reflectance`.
    pub fn cell(&self, light: usize, reflectance: usize) -> Option<&CellView> {
        if light < self.lights { self.cells.get(reflectance * self.lights + light) } else { None }
    }
}
