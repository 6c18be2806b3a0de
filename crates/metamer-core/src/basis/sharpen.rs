//! Interval-based spectral sharpening (Finlayson, Drew & Funt 1994, "sensor-based sharpening"), applied to a
//! spectral basis instead of camera sensors.
//!
//! The 31 samples are cut into m contiguous bands `I_k`. For each band we look for the combination
//! `b = B0 t` of the basis vectors whose energy is most concentrated inside the band, i.e. the `t` maximising
//! the Rayleigh quotient
//!
//! ```text
//!     tᵀ B0ᵀ D_k B0 t  /  tᵀ B0ᵀ B0 t          (D_k = diag(indicator of I_k))
//! ```
//!
//! which is the generalised symmetric eigenproblem `A_k t = μ M t` (`A_k = B0ᵀ D_k B0`, `M = B0ᵀ B0`);
//! its top eigenvector is column k of T. We solve it through the Cholesky factor `M = L Lᵀ`
//! (`L⁻¹ A_k L⁻ᵀ y = μ y`, `t = L⁻ᵀ y`), so B0 need not be orthonormal.
//!
//! Finally every column is scaled so that a flat spectrum has unit coefficients, `B⁺ 1 = 1`: the basis
//! vectors then behave like band indicators of height one (the spectral analogue of the paper's unit-L1
//! camera filters, Eq. 13), and a flat white reflectance leaves a light's coefficients unchanged under the
//! factor model `c = e ∘ s`.

use crate::spectrum::SAMPLES;
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use std::ops::Range;

/// T is rejected (and refinement starts from the PCA basis) when its condition number exceeds this.
pub(crate) const MAX_CONDITION: f64 = 1e8;

/// The 31 samples cut into m contiguous bands of (nearly) equal width, the wider ones first.
pub(crate) fn equal_bands(m: usize) -> Vec<Range<usize>> {
    let m = super::clamp_dimension(m);
    let base = SAMPLES / m;
    let extra = SAMPLES % m;
    let mut start = 0;
    (0..m)
        .map(|k| {
            let width = base + usize::from(k < extra);
            let r = start..start + width;
            start += width;
            r
        })
        .collect()
}

/// The sharpening transform T (m×m) for the basis `b0` (31×m) with equal-width bands, columns scaled so that
/// `(B0 T)⁺ 1 = 1`. `None` when the eigenproblems are singular or T is ill-conditioned
/// (condition number above [`MAX_CONDITION`]).
pub(crate) fn interval_transform(b0: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    interval_transform_with_bands(b0, &equal_bands(b0.ncols()))
}

/// As [`interval_transform`], with explicit bands (one per column).
pub(crate) fn interval_transform_with_bands(b0: &DMatrix<f64>, bands: &[Range<usize>]) -> Option<DMatrix<f64>> {
    let m = b0.ncols();
    if bands.len() != m || b0.nrows() != SAMPLES {
        return None;
    }
    let metric = b0.transpose() * b0;
    let chol = metric.cholesky()?;
    let l = chol.l();
    let l_inv = l.clone().try_inverse()?;
    let mut t = DMatrix::zeros(m, m);
    for (k, band) in bands.iter().enumerate() {
        let mut a = DMatrix::zeros(m, m);
        for i in band.clone() {
            let row = b0.row(i);
            a += row.transpose() * row;
        }
        let c = &l_inv * a * l_inv.transpose();
        // Symmetrise against rounding before the symmetric eigensolver.
        let c = (&c + c.transpose()) * 0.5;
        let eig = SymmetricEigen::new(c);
        let top = (0..m).max_by(|&x, &y| eig.eigenvalues[x].total_cmp(&eig.eigenvalues[y]))?;
        let y: DVector<f64> = eig.eigenvectors.column(top).into_owned();
        let tk = l_inv.transpose() * y;
        t.set_column(k, &tk);
    }
    normalise_to_flat(b0, t)
}

/// Box band indicators (31×m, 1 inside band k, 0 outside; [`equal_bands`]): non-negative and perfectly
/// sharp (`B⁺(B_j ∘ B_k) = δ_jk e_k`), a flat spectrum has unit coefficients.
pub(crate) fn positive_bands(m: usize) -> DMatrix<f64> {
    let bands = equal_bands(m);
    DMatrix::from_fn(SAMPLES, bands.len(), |i, k| if bands[k].contains(&i) { 1.0 } else { 0.0 })
}

/// The least-squares projection of the box band indicators onto the span of an orthonormal `b0`:
/// `T = B0ᵀ Box`, then scaled as [`normalise_to_flat`]. `None` when ill-conditioned.
pub(crate) fn projected_bands_transform(b0: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    if b0.nrows() != SAMPLES {
        return None;
    }
    let t = b0.transpose() * positive_bands(b0.ncols());
    normalise_to_flat(b0, t)
}

/// Scale the columns of T so that `(B0 T)⁺ 1 = 1`; columns whose flat coefficient is (nearly) zero are
/// instead scaled to unit L1 norm with a non-negative sum. `None` if T is ill-conditioned.
pub(crate) fn normalise_to_flat(b0: &DMatrix<f64>, mut t: DMatrix<f64>) -> Option<DMatrix<f64>> {
    let sv = t.clone().singular_values();
    let (smax, smin) = (sv.max(), sv.min());
    if !(smax.is_finite() && smin > smax / MAX_CONDITION) {
        return None;
    }
    let b = b0 * &t;
    let pinv = b.clone().pseudo_inverse(smin * 1e-12).ok()?;
    let flat = &pinv * DVector::from_element(SAMPLES, 1.0);
    let largest = flat.amax();
    for k in 0..t.ncols() {
        let d = flat[k];
        let scale = if d.abs() > 1e-6 * largest {
            // B' = B D, B'⁺ = D⁻¹ B⁺, so the flat coefficient becomes 1.
            d
        } else {
            let col = b.column(k);
            let l1 = col.abs().sum();
            if l1 <= f64::MIN_POSITIVE {
                return None;
            }
            if col.sum() < 0.0 { -1.0 / l1 } else { 1.0 / l1 }
        };
        t.column_mut(k).scale_mut(scale);
    }
    t.iter().all(|v| v.is_finite()).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_bands_cover_every_sample_once() {
        for m in 1..=SAMPLES {
            let bands = equal_bands(m);
            assert_eq!(bands.len(), m);
            assert_eq!(bands[0].start, 0);
            assert_eq!(bands[m - 1].end, SAMPLES);
            for w in bands.windows(2) {
                assert_eq!(w[0].end, w[1].start);
                assert!(!w[0].is_empty());
            }
        }
    }

    #[test]
    fn band_indicator_basis_is_already_sharp() {
        // A basis of band indicators: each column's energy is all in its band, so the transform must be a
        // (positive) diagonal, scaled so that a flat spectrum has coefficients 1 — i.e. the identity.
        let m = 5;
        let bands = equal_bands(m);
        let b0 = DMatrix::from_fn(SAMPLES, m, |i, k| if bands[k].contains(&i) { 0.3 } else { 0.0 });
        let t = interval_transform(&b0).expect("well-conditioned");
        let b = &b0 * &t;
        let flat = b.clone().pseudo_inverse(1e-12).unwrap() * DVector::from_element(SAMPLES, 1.0);
        for k in 0..m {
            assert!((flat[k] - 1.0).abs() < 1e-9, "flat coefficient {k} = {}", flat[k]);
            for i in 0..SAMPLES {
                let want = if bands[k].contains(&i) { 1.0 } else { 0.0 };
                assert!((b[(i, k)] - want).abs() < 1e-9);
            }
        }
    }
}
