//! How faithfully a factor model reproduces light × reflectance colours: CIEDE2000 between the model's colour
//! and the full 31-sample colour `Q_rgb,31 (E ∘ S)`, with the light on a flat reflectance of 1 as the CIELAB
//! white ([`Colorimetry::delta_e00_under`]).
//!
//! Models compared:
//! - the spectral factor model `Q_rgb,31 B (B⁺E ∘ B⁺S)` (Eq. 15) of a basis ([`Model::Factor`]),
//! - the same basis with the full product matrix Λ of Eq. 7 ([`Model::Lambda`]),
//! - the orthogonal projection of the colour signal itself onto the span of a basis,
//!   `Q_rgb,31 P (E ∘ S)` ([`Model::SignalProjection`]): no factor model at all, the best any basis with
//!   that span can do for a signal it is given whole (the reference of the training guarantee),
//! - the RGB factor model (seed Eq. 9): linear RGB of the light on white times linear RGB of the reflectance
//!   under flat white, componentwise, divided by the "camera scaling" `w = Q_rgb,31 1` (the RGB of the flat
//!   light on flat white, which is not (1, 1, 1) because sRGB's white is D65) ([`Model::Rgb`]).

use super::Basis;
use super::set::TrainingSet;
use crate::colorimetry::Colorimetry;
use crate::spectrum::Spectrum;
use nalgebra::Vector3;

/// A colour model to compare against full spectral colour.
#[derive(Clone, Copy, Debug)]
pub enum Model<'a> {
    /// `Q_rgb,m (B⁺E ∘ B⁺S)`.
    Factor(&'a Basis),
    /// `Q_rgb,m Λ(B⁺E) B⁺S`.
    Lambda(&'a Basis),
    /// `(Q_rgb,31 E) ∘ (Q_rgb,31 S) / (Q_rgb,31 1)` (seed Eq. 9).
    Rgb,
    /// `Q_rgb,31 P (E ∘ S)`, `P = B B⁺`: the colour signal projected onto span B.
    SignalProjection(&'a Basis),
}

impl Model<'_> {
    /// The model's linear sRGB for light `e` on reflectance `s`.
    pub fn rgb(&self, colorimetry: &Colorimetry, e: &Spectrum, s: &Spectrum) -> Vector3<f64> {
        match self {
            Model::Factor(b) => b.rgb_factor(e, s),
            Model::Lambda(b) => b.rgb_lambda(e, s),
            Model::SignalProjection(b) => {
                let v = &b.q_rgb_projector * nalgebra::DVector::from_column_slice(e.product(s).as_slice());
                Vector3::new(v[0], v[1], v[2])
            }
            Model::Rgb => {
                let white = colorimetry.rgb_of_signal(&Spectrum::flat(1.0));
                colorimetry.rgb_of_signal(e).component_mul(&colorimetry.rgb_of_signal(s)).component_div(&white)
            }
        }
    }
}

/// JSON has no infinity: serde_json writes a non-finite f64 as `null`, read back here as +∞ (how
/// [`ErrorStats`] counts a non-finite error).
pub(crate) fn f64_or_infinity<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v: Option<f64> = serde::Deserialize::deserialize(d)?;
    Ok(v.unwrap_or(f64::INFINITY))
}

/// Summary of a set of ΔE00 values.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ErrorStats {
    /// Mean ΔE00 (+∞ when any value is not finite); 0 when there are no values.
    #[serde(deserialize_with = "f64_or_infinity")]
    pub mean: f64,
    /// 95th percentile, linearly interpolated between order statistics (as numpy's default).
    #[serde(deserialize_with = "f64_or_infinity")]
    pub p95: f64,
    /// Largest ΔE00 (+∞ when any value is not finite).
    #[serde(deserialize_with = "f64_or_infinity")]
    pub max: f64,
    /// Number of values summarised (for a model's accuracy: the light × reflectance pairs whose light has
    /// positive luminance).
    pub count: usize,
}

impl ErrorStats {
    /// Statistics of `values` (non-finite values count as +∞ so they cannot hide); all zero when empty.
    pub fn from_values(values: &[f64]) -> ErrorStats {
        if values.is_empty() {
            return ErrorStats { mean: 0.0, p95: 0.0, max: 0.0, count: 0 };
        }
        let mut v: Vec<f64> = values.iter().map(|x| if x.is_finite() { *x } else { f64::INFINITY }).collect();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let pos = 0.95 * (n - 1) as f64;
        let lo = pos.floor() as usize;
        let hi = (lo + 1).min(n - 1);
        let frac = pos - lo as f64;
        let p95 = if frac == 0.0 { v[lo] } else { v[lo] + (v[hi] - v[lo]) * frac };
        ErrorStats { mean: v.iter().sum::<f64>() / n as f64, p95, max: v[n - 1], count: n }
    }
}

/// ΔE00 of a model against full colour for every light × reflectance pair whose light has positive luminance
/// (a dark light has no CIELAB white), light-major.
pub(crate) fn errors(set: &TrainingSet, model: Model<'_>, colorimetry: &Colorimetry) -> Vec<f64> {
    let mut out = Vec::with_capacity(set.pairs());
    for e in &set.lights {
        if colorimetry.xyz_of_signal(e)[1] <= f64::MIN_POSITIVE {
            continue;
        }
        for s in &set.reflectances {
            let full = colorimetry.rgb(e, s);
            let approx = model.rgb(colorimetry, e, s);
            out.push(colorimetry.delta_e00_under(&full, &approx, e));
        }
    }
    out
}

/// [`ErrorStats`] of a model over a training set.
pub fn stats(set: &TrainingSet, model: Model<'_>, colorimetry: &Colorimetry) -> ErrorStats {
    ErrorStats::from_values(&errors(set, model, colorimetry))
}

/// How far Λ (Eq. 7) is from diagonal.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LambdaMass {
    /// `‖G_ijk, not i=j=k‖_F / ‖G_iii‖_F` over the product tensor `G_ijk = B⁺_i (B_j ∘ B_k)`
    /// (0 for a perfectly sharp basis, for which `G_ijk = δ_ij δ_jk`).
    #[serde(deserialize_with = "f64_or_infinity")]
    pub tensor: f64,
    /// Mean over the reflectances `s = B⁺S` of `‖offdiag Λ(s)‖_F / ‖diag Λ(s)‖_F`: the off-diagonal mass of
    /// the matrices that the factor model replaces by their diagonal.
    #[serde(deserialize_with = "f64_or_infinity")]
    pub reflectances: f64,
}

/// Off-diagonal mass of Λ for a basis, measured on the reflectances of `set`.
pub(crate) fn lambda_mass(basis: &Basis, set: &TrainingSet) -> LambdaMass {
    let m = basis.dimension();
    let (mut diag, mut off) = (0.0, 0.0);
    for (k, g) in basis.products.iter().enumerate() {
        for j in 0..m {
            for i in 0..m {
                let v = g[(i, j)] * g[(i, j)];
                if i == j && j == k {
                    diag += v;
                } else {
                    off += v;
                }
            }
        }
    }
    let ratio = |off: f64, diag: f64| if diag > 0.0 { (off / diag).sqrt() } else { f64::INFINITY };
    let mut sum = 0.0;
    for s in &set.reflectances {
        let l = basis.lambda(&basis.coefficients(s));
        let d: f64 = l.diagonal().norm_squared();
        let o = l.norm_squared() - d;
        sum += ratio(o.max(0.0), d);
    }
    let mean = if set.reflectances.is_empty() { 0.0 } else { sum / set.reflectances.len() as f64 };
    LambdaMass { tensor: ratio(off, diag), reflectances: mean }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentile_interpolates_like_numpy() {
        let v: Vec<f64> = (1..=21).map(f64::from).collect();
        // numpy.percentile(range(1, 22), 95) == 20.0
        let s = ErrorStats::from_values(&v);
        assert!((s.p95 - 20.0).abs() < 1e-12);
        assert!((s.mean - 11.0).abs() < 1e-12);
        assert_eq!(s.max, 21.0);
        // numpy.percentile([0, 10], 95) == 9.5
        assert!((ErrorStats::from_values(&[10.0, 0.0]).p95 - 9.5).abs() < 1e-12);
        assert_eq!(ErrorStats::from_values(&[]).count, 0);
        assert_eq!(ErrorStats::from_values(&[1.0, f64::NAN]).max, f64::INFINITY);
    }
}
