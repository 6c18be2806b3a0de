//! The spectral factor model (seed §2): an m-dimensional basis B (31×m) of colour signals, sharpened so
//! that light × reflectance is (nearly) a componentwise product of coefficients, `c ≈ e ∘ s`.
//!
//! [`Basis`] holds B and everything derived from it: `Q_m,31 = B⁺`, `Q_rgb,m = Q_rgb,31 B`, and the
//! product tensor `G_ijk = B⁺_i (B_j ∘ B_k)` from which Λ(x) (seed Eq. 7) is formed.
//!
//! - [`train`]: PCA of a palette's colour signals, several sharpening starts (the PCA basis, interval
//!   sharpening, projected and positive band indicators), each refined by L-BFGS (T, then all of B) against
//!   the factor-model colour error in a local CIEDE2000 metric with a conditioning term; the best kept.
//! - [`policy`]: [`basis_for`], the one place that decides which basis a set of spectra uses (memory, then
//!   sidecar, else trained), and the poor-model warning ([`POOR_MODEL_MEAN_DE00`]).
//! - [`accuracy`]: ΔE00 of the factor model (and the RGB factor model, the unsharpened projection, the
//!   full-Λ model) against full 31-sample colour; off-diagonal mass of Λ.
//! - [`store`]: the `NAME.basis.json` sidecar keyed by the spectra, m and the training version, holding
//!   each basis with the accuracy report measured when it was trained.
//!
//! Λ and the factor model: refining all of B optimises the factor model `c = e ∘ s` (what
//! post-illumination renders) together with the full-Λ model of Eq. 7 (`rgb_lambda`, `subspace_operator`,
//! used by the design criteria), so both reproduce full colour closely even though Λ itself keeps sizeable
//! off-diagonal entries (they act in directions `Q_rgb,m` barely sees). `metamer basis` reports both.

pub mod accuracy;
pub(crate) mod policy;
pub(crate) mod refine;
pub(crate) mod set;
pub(crate) mod sharpen;
pub(crate) mod store;
pub(crate) mod train;

pub use policy::{POOR_MODEL_MEAN_DE00, Resolved, basis_for, basis_for_palette, cached};
pub use set::{TrainError, TrainingSet};
pub use store::{AccuracyReport, Report, cache_key, for_palette, for_set, palette_uses_basis, sidecar_path};
pub use train::{
    CandidateSummary, StageResult, Start, TrainOptions, Trained, balanced_condition, train, train_for_palette,
};

use crate::colorimetry::{Colorimetry, Q31};
use crate::spectrum::{SAMPLES, Spectrum};
use nalgebra::{DMatrix, DVector, Vector3};

use crate::spectrum::BASIS_DIMENSIONS as DIMENSIONS;

/// The basis-dimension rule, in one place: `Ok(m)` when m is in [`DIMENSIONS`], else
/// [`BasisError::BadDimension`].
pub fn check_dimension(m: usize) -> Result<usize, BasisError> {
    if DIMENSIONS.contains(&m) { Ok(m) } else { Err(BasisError::BadDimension(m)) }
}

/// m moved into [`DIMENSIONS`] (for callers that take any m and use the nearest allowed one).
pub fn clamp_dimension(m: usize) -> usize {
    m.clamp(*DIMENSIONS.start(), *DIMENSIONS.end())
}

/// Why a basis cannot be built from a matrix.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BasisError {
    /// The matrix does not have one row per sample; the number is the rows it has.
    #[error("a basis needs {SAMPLES} rows (one per sample), got {0}")]
    WrongRows(usize),
    /// The dimension m (the number) is outside `BASIS_DIMENSIONS`, 1 ..= 31.
    #[error("basis dimension must be between 1 and {SAMPLES}, got {0}")]
    BadDimension(usize),
    /// An entry of B is NaN or infinite, or the SVD or pseudo-inverse of B failed.
    #[error("the basis has a non-finite entry")]
    NotFinite,
    /// The columns of B are linearly dependent, so B⁺ does not invert B on its span.
    #[error("the basis columns are linearly dependent (rank {rank} < {m})")]
    RankDeficient {
        /// The numerical rank of B (singular values above 31·10⁻¹² of the largest).
        rank: usize,
        /// The number of columns of B, the dimension asked for.
        m: usize,
    },
}

/// A (sharpened) spectral basis and its derived operators.
#[derive(Clone, Debug, PartialEq)]
pub struct Basis {
    /// B: 31×m, columns are the basis spectra.
    pub b: DMatrix<f64>,
    /// `Q_m,31 = B⁺`: m×31.
    pub b_pinv: DMatrix<f64>,
    /// `Q_rgb,m = Q_rgb,31 B`: 3×m.
    pub q_rgb_m: DMatrix<f64>,
    /// `products[k]` is the m×m matrix `G_·,·,k` with `G_ijk = B⁺_i (B_j ∘ B_k)`, so
    /// `Λ(x) = Σ_k x_k products[k]` (seed Eq. 7).
    pub(crate) products: Vec<DMatrix<f64>>,
    /// `P = B B⁺ = U Uᵀ` (31×31, U an orthonormal basis of span B): the orthogonal projector onto the
    /// subspace. The full-Λ model depends on B only through it — `B Λ(B⁺p) B⁺ x = P (Pp ∘ Px)` — so it is
    /// evaluated that way, independent of how B's columns are scaled (the coefficient route loses ~1e-7
    /// relative when the columns' norms differ by 10³, as trained bases' can).
    pub(crate) projector: DMatrix<f64>,
    /// `Q_rgb,31 P`: 3×31.
    pub(crate) q_rgb_projector: DMatrix<f64>,
}

impl Basis {
    /// Build a basis from its 31×m matrix B.
    pub fn from_matrix(b: DMatrix<f64>, colorimetry: &Colorimetry) -> Result<Basis, BasisError> {
        if b.nrows() != SAMPLES {
            return Err(BasisError::WrongRows(b.nrows()));
        }
        let m = check_dimension(b.ncols())?;
        if b.iter().any(|v| !v.is_finite()) {
            return Err(BasisError::NotFinite);
        }
        let svd = b.clone().svd(true, true);
        let smax = svd.singular_values.max();
        let tol = smax * 1e-12 * SAMPLES as f64;
        let rank = svd.singular_values.iter().filter(|s| **s > tol).count();
        if rank < m {
            return Err(BasisError::RankDeficient { rank, m });
        }
        let u = svd.u.as_ref().ok_or(BasisError::NotFinite)?.columns(0, m).into_owned();
        let b_pinv = svd.pseudo_inverse(tol).map_err(|_| BasisError::NotFinite)?;
        let q_rgb = DMatrix::from_column_slice(3, SAMPLES, colorimetry.q_rgb.as_slice());
        let q_rgb_m = &q_rgb * &b;
        let products = (0..m)
            .map(|k| {
                let bk = b.column(k);
                let mut bjk = b.clone();
                for mut col in bjk.column_iter_mut() {
                    col.component_mul_assign(&bk);
                }
                &b_pinv * bjk
            })
            .collect();
        let projector = &u * u.transpose();
        let q_rgb_projector = &q_rgb * &projector;
        Ok(Basis { b, b_pinv, q_rgb_m, products, projector, q_rgb_projector })
    }

    /// The dimension m.
    pub fn dimension(&self) -> usize {
        self.b.ncols()
    }

    /// Coefficients `B⁺ x` of a spectrum.
    pub fn coefficients(&self, x: &Spectrum) -> DVector<f64> {
        &self.b_pinv * DVector::from_column_slice(x.as_slice())
    }

    /// Λ(x) for coefficients x (seed Eq. 7): `Λ_ij(x) = Σ_k G_ijk x_k`.
    pub fn lambda(&self, x: &DVector<f64>) -> DMatrix<f64> {
        let m = self.dimension();
        let mut l = DMatrix::zeros(m, m);
        for (k, g) in self.products.iter().enumerate() {
            l += g * x[k];
        }
        l
    }

    /// `Q_rgb,m Λ(Q_m,31 p) Q_m,31`: the 3×31 map from the designed spectrum to its subspace colour
    /// when its partner is `p` (DESIGN_SPEC §2, "colour in the subspace").
    ///
    /// Evaluated as `Q_rgb,31 P diag(P p) P` (the same map, see [`Basis::projector`]).
    pub(crate) fn subspace_operator(&self, p: &Spectrum) -> Q31 {
        let pp = &self.projector * DVector::from_column_slice(p.as_slice());
        let mut q = self.q_rgb_projector.clone();
        for (mut col, v) in q.column_iter_mut().zip(pp.iter()) {
            col *= *v;
        }
        let op = q * &self.projector;
        Q31::from_column_slice(op.as_slice())
    }

    /// `Q_rgb,m diag(Q_m,31 p) Q_m,31`: the 3×31 map from the designed spectrum to its colour in the spectral
    /// factor model (Eq. 15, Λ replaced by its diagonal) when its partner is `p` — exactly what
    /// post-illumination renders.
    #[cfg(test)]
    pub(crate) fn factor_operator(&self, p: &Spectrum) -> Q31 {
        let mut q = self.q_rgb_m.clone();
        for (mut col, pk) in q.column_iter_mut().zip(self.coefficients(p).iter()) {
            col *= *pk;
        }
        let op = q * &self.b_pinv;
        Q31::from_column_slice(op.as_slice())
    }

    /// Colour of light `e` on reflectance `s` in the subspace model with the full Λ (Eq. 7).
    ///
    /// Evaluated as `Q_rgb,31 P (Pe ∘ Ps)` (the same colour, see [`Basis::projector`]).
    pub(crate) fn rgb_lambda(&self, e: &Spectrum, s: &Spectrum) -> Vector3<f64> {
        let pe = &self.projector * DVector::from_column_slice(e.as_slice());
        let ps = &self.projector * DVector::from_column_slice(s.as_slice());
        let v = &self.q_rgb_projector * pe.component_mul(&ps);
        Vector3::new(v[0], v[1], v[2])
    }

    /// Colour of light `e` on reflectance `s` in the spectral factor model `Q_rgb,m (e ∘ s)` (Eq. 15):
    /// what the renderer's post-illumination computes.
    pub fn rgb_factor(&self, e: &Spectrum, s: &Spectrum) -> Vector3<f64> {
        let c = self.coefficients(e).component_mul(&self.coefficients(s));
        let v = &self.q_rgb_m * c;
        Vector3::new(v[0], v[1], v[2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn operators_agree_with_the_direct_colours() {
        let c = Colorimetry::default();
        let set = TrainingSet::colorchecker_seven_lights(&c);
        let opts =
            TrainOptions { sharpen: true, transform_iterations: 50, full_iterations: 50, ..TrainOptions::default() };
        let basis = train(&set, 6, &c, &opts).unwrap().basis;
        let (e, s) = (&set.lights[1], &set.reflectances[5]);
        let via_light = basis.factor_operator(e) * s.0;
        let via_refl = basis.factor_operator(s) * e.0;
        let direct = basis.rgb_factor(e, s);
        assert!((via_light - direct).amax() < 1e-12 && (via_refl - direct).amax() < 1e-12);
        let lambda = basis.subspace_operator(e) * s.0;
        assert!((lambda - basis.rgb_lambda(e, s)).amax() < 1e-12);
    }
}
