//! Spectra: 31 point samples on an explicit wavelength grid (400..=700 nm, 10 nm steps),
//! built-in tables (CIE illuminants, ColorChecker reflectances), Planck lights and normalisation.

pub(crate) mod csv;
pub(crate) mod tables;

pub use csv::{parse_spectrum_csv, parse_spectrum_csv_bytes};

use nalgebra::SVector;
use std::fmt;

/// Number of samples of a spectrum on the standard grid.
pub const SAMPLES: usize = 31;

/// The dimensions m a basis of spectra may have, everywhere (palette files, `metamer basis --dimension`,
/// the designer, a basis matrix): 1 ..= 31, one per sample at most. `basis::check_dimension` applies it.
pub const BASIS_DIMENSIONS: std::ops::RangeInclusive<usize> = 1..=SAMPLES;

/// The basis dimension m of a palette that does not set `basis_dimension` (the "V7" model).
pub const DEFAULT_BASIS_DIMENSION: usize = 7;

/// The sample vector type of a spectrum.
pub type Samples = SVector<f64, SAMPLES>;

/// A wavelength grid: `count` point samples from `start_nm` in steps of `step_nm`.
///
/// Palette files record their grid so the format can grow; today only [`Grid::STANDARD`] is supported
/// by the engine (the sample count is a compile-time constant for speed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Wavelength of the first sample, nm (400 on the standard grid).
    pub start_nm: f64,
    pub(crate) step_nm: f64,
    pub(crate) count: usize,
}

impl Grid {
    /// 400..=700 nm in 10 nm steps (31 samples): the grid of DESIGN_SPEC §1.
    pub const STANDARD: Grid = Grid { start_nm: 400.0, step_nm: 10.0, count: SAMPLES };

    /// Wavelength of sample `i` in nanometres.
    pub fn wavelength(&self, i: usize) -> f64 {
        self.start_nm + self.step_nm * i as f64
    }

    /// All wavelengths of the grid, in nanometres.
    pub fn wavelengths(&self) -> Vec<f64> {
        (0..self.count).map(|i| self.wavelength(i)).collect()
    }

    /// Last wavelength of the grid.
    pub fn end_nm(&self) -> f64 {
        self.wavelength(self.count.saturating_sub(1))
    }
}

/// Second radiation constant used for Planck lights (seed Eq. 25), in m·K.
pub const PLANCK_C2: f64 = 1.4388e-2;

/// A spectrum (light power or reflectance) sampled on [`Grid::STANDARD`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spectrum(pub Samples);

/// How a light is normalised before its `scale` is applied (DESIGN_SPEC §1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Normalize {
    /// Scale so that the luminance Y of the light on a flat white reflectance is 1.
    #[default]
    Luminance,
    /// Scale to unit Euclidean norm.
    L2,
    /// Leave as is.
    None,
}

impl Normalize {
    /// The normalisation a palette's `normalize` key names: `luminance`, `l2` or `none`; `None` for any other word.
    pub fn parse(s: &str) -> Option<Normalize> {
        match s {
            "luminance" => Some(Normalize::Luminance),
            "l2" => Some(Normalize::L2),
            "none" => Some(Normalize::None),
            _ => None,
        }
    }

    /// The key's value for this normalisation, as written in palette files: `luminance`, `l2` or `none`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Normalize::Luminance => "luminance",
            Normalize::L2 => "l2",
            Normalize::None => "none",
        }
    }
}

/// Why a spectrum cannot be normalised.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NormalizeError {
    /// The luminance Y of the spectrum is 0 (in magnitude below `f64::MIN_POSITIVE`) or not finite.
    #[error("the spectrum has zero luminance, so it cannot be normalised to luminance 1")]
    ZeroLuminance,
    /// The Euclidean norm of the samples is 0 (below `f64::MIN_POSITIVE`) or not finite.
    #[error("the spectrum has zero L2 norm, so it cannot be normalised to norm 1")]
    ZeroNorm,
    /// A sample is NaN or infinite (checked before any normalisation, and after scaling).
    #[error("the spectrum has a non-finite sample")]
    NotFinite,
}

impl Spectrum {
    /// A flat spectrum with every sample equal to `value`.
    pub fn flat(value: f64) -> Spectrum {
        Spectrum(Samples::from_element(value))
    }

    /// A spectrum from exactly [`SAMPLES`] values; `None` for any other length.
    pub fn from_slice(values: &[f64]) -> Option<Spectrum> {
        (values.len() == SAMPLES).then(|| Spectrum(Samples::from_column_slice(values)))
    }

    /// A spectrum from a fixed array.
    pub const fn from_array(values: [f64; SAMPLES]) -> Spectrum {
        Spectrum(Samples::from_array_storage(nalgebra::ArrayStorage([values])))
    }

    /// A Planckian black-body radiator at `kelvin` (seed Eq. 25), up to the constant c1
    /// (which any normalisation removes): `λ⁻⁵ (exp(c2 / (T λ)) − 1)⁻¹` with λ in metres, scaled so the
    /// largest sample is 1. `None` for a temperature that is not finite and positive.
    pub fn planck(kelvin: f64) -> Option<Spectrum> {
        if !(kelvin.is_finite() && kelvin > 0.0) {
            return None;
        }
        let mut s = Samples::zeros();
        for (i, v) in s.iter_mut().enumerate() {
            let lambda = Grid::STANDARD.wavelength(i) * 1e-9;
            // exp_m1 keeps precision at high temperatures; at very low ones the value underflows to 0.
            *v = lambda.powi(-5) / (PLANCK_C2 / (kelvin * lambda)).exp_m1();
        }
        let max = s.max();
        if !(max.is_finite() && max > 0.0) {
            return None;
        }
        Some(Spectrum(s / max))
    }

    /// A built-in CIE illuminant by name (D65, D50, A, E, F2, F7, F11, LED_B3, HP1_sodium), unnormalised.
    pub fn illuminant(name: &str) -> Option<Spectrum> {
        tables::ILLUMINANTS.iter().find(|(n, _)| *n == name).map(|(_, v)| Spectrum::from_array(*v))
    }

    /// Names of the built-in illuminants.
    pub fn illuminant_names() -> impl Iterator<Item = &'static str> {
        tables::ILLUMINANTS.iter().map(|(n, _)| *n)
    }

    /// A ColorChecker Classic reflectance by its table name (`dark_skin` … `black_2`).
    pub fn colorchecker(name: &str) -> Option<Spectrum> {
        tables::COLORCHECKER24.iter().find(|(n, _)| *n == name).map(|(_, v)| Spectrum::from_array(*v))
    }

    /// Names of the 24 ColorChecker patches, in chart order.
    pub fn colorchecker_names() -> impl Iterator<Item = &'static str> {
        tables::COLORCHECKER24.iter().map(|(n, _)| *n)
    }

    /// Componentwise product (light × reflectance = colour signal).
    pub fn product(&self, other: &Spectrum) -> Spectrum {
        Spectrum(self.0.component_mul(&other.0))
    }

    /// Multiply every sample by `k`.
    pub fn scaled(&self, k: f64) -> Spectrum {
        // Each sample times `k`, as nalgebra's `self.0 * k` computes it, on the plain slice (a palette of
        // thousands of spectra scales each one as it is read).
        let mut out = *self;
        for x in out.0.as_mut_slice() {
            *x *= k;
        }
        out
    }

    /// Euclidean norm of the samples.
    pub fn l2_norm(&self) -> f64 {
        self.0.norm()
    }

    /// True when every sample is finite.
    pub fn is_finite(&self) -> bool {
        self.as_slice().iter().all(|v| v.is_finite())
    }

    /// The samples as a slice.
    pub fn as_slice(&self) -> &[f64] {
        self.0.as_slice()
    }

    /// The samples as a `Vec`.
    pub fn to_vec(&self) -> Vec<f64> {
        self.0.iter().copied().collect()
    }

    /// Apply a normalisation; `luminance_weights` is the Y row of `Q_xyz,31` (see
    /// [`crate::colorimetry::Colorimetry::luminance`]).
    pub fn normalized(&self, how: Normalize, luminance_weights: &Samples) -> Result<Spectrum, NormalizeError> {
        if !self.is_finite() {
            return Err(NormalizeError::NotFinite);
        }
        match how {
            Normalize::None => Ok(*self),
            Normalize::Luminance => {
                let y = luminance_weights.dot(&self.0);
                if y.abs() < f64::MIN_POSITIVE || !y.is_finite() {
                    Err(NormalizeError::ZeroLuminance)
                } else {
                    Ok(self.scaled(1.0 / y))
                }
            }
            Normalize::L2 => {
                let n = self.l2_norm();
                if n < f64::MIN_POSITIVE || !n.is_finite() {
                    Err(NormalizeError::ZeroNorm)
                } else {
                    Ok(self.scaled(1.0 / n))
                }
            }
        }
    }
}

impl fmt::Display for Spectrum {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[")?;
        for (i, v) in self.0.iter().enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{v}")?;
        }
        write!(f, "]")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_are_complete() {
        assert_eq!(Spectrum::illuminant_names().count(), 9);
        assert_eq!(Spectrum::colorchecker_names().count(), 24);
        assert!(Spectrum::illuminant("D65").is_some());
        assert!(Spectrum::colorchecker("white_9_5").is_some());
        assert!(Spectrum::illuminant("D66").is_none());
    }

    #[test]
    fn planck_is_monotone_and_finite() {
        let warm = Spectrum::planck(2000.0).unwrap();
        assert!(warm.0[30] > warm.0[0]);
        let hot = Spectrum::planck(20000.0).unwrap();
        assert!(hot.0[0] > hot.0[30]);
        assert!(Spectrum::planck(0.0).is_none());
        assert!(Spectrum::planck(f64::NAN).is_none());
        assert!(Spectrum::planck(1.0e9).unwrap().is_finite());
    }

    #[test]
    fn grid_is_explicit() {
        assert_eq!(Grid::STANDARD.wavelengths().len(), 31);
        assert_eq!(Grid::STANDARD.end_nm(), 700.0);
    }
}
