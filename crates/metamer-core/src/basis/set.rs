//! The spectra a basis is trained from, why a set or a training is refused, and the stable hash the
//! basis cache keys use.

use super::BasisError;
use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use crate::spectrum::{Normalize, SAMPLES, Spectrum};
use nalgebra::DMatrix;

/// The lights of [`TrainingSet::colorchecker_seven_lights`].
const REFERENCE_LIGHTS: [&str; 7] = ["D65", "A", "F2", "F7", "F11", "LED_B3", "D50"];

/// Why a basis cannot be trained.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TrainError {
    /// The set has no light or no reflectance, so there is no pair to train on.
    #[error("training needs at least one light and one reflectance (got {lights} lights, {reflectances} reflectances)")]
    NoSpectra {
        /// Number of lights given.
        lights: usize,
        /// Number of reflectances given.
        reflectances: usize,
    },
    /// A spectrum of the set has a NaN or infinite sample.
    #[error("{kind} {index} has a non-finite sample")]
    NotFinite {
        /// Which side: `light` or `reflectance`.
        kind: &'static str,
        /// Index of the spectrum in the set's lights or reflectances.
        index: usize,
    },
    /// The dimension m asked for (the number) is outside 1 ..= 31.
    #[error("basis dimension must be between 1 and {SAMPLES}, got {0}")]
    BadDimension(usize),
    /// The trained matrix did not make a basis (non-finite entries, dependent columns).
    #[error(transparent)]
    Basis(#[from] BasisError),
}

/// The spectra a basis is trained from: every light is paired with every reflectance.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainingSet {
    /// The lights, at least one; every sample finite when made by `TrainingSet::new`.
    pub lights: Vec<Spectrum>,
    /// The reflectances, at least one; every sample finite when made by `TrainingSet::new`.
    pub reflectances: Vec<Spectrum>,
}

impl TrainingSet {
    /// A training set; every sample must be finite and both sides non-empty.
    pub fn new(lights: Vec<Spectrum>, reflectances: Vec<Spectrum>) -> Result<TrainingSet, TrainError> {
        if lights.is_empty() || reflectances.is_empty() {
            return Err(TrainError::NoSpectra { lights: lights.len(), reflectances: reflectances.len() });
        }
        if let Some(index) = lights.iter().position(|s| !s.is_finite()) {
            return Err(TrainError::NotFinite { kind: "light", index });
        }
        if let Some(index) = reflectances.iter().position(|s| !s.is_finite()) {
            return Err(TrainError::NotFinite { kind: "reflectance", index });
        }
        Ok(TrainingSet { lights, reflectances })
    }

    /// All lights × all reflectances of a palette, designed ones at their current samples.
    pub fn from_palette(palette: &Palette) -> Result<TrainingSet, TrainError> {
        TrainingSet::new(
            palette.lights.iter().map(|e| e.spectrum).collect(),
            palette.reflectances.iter().map(|e| e.spectrum).collect(),
        )
    }

    /// The reference set of the accuracy check: the 24 ColorChecker reflectances under D65, A, F2, F7, F11,
    /// LED_B3 and D50, each light normalised to luminance 1.
    pub fn colorchecker_seven_lights(colorimetry: &Colorimetry) -> TrainingSet {
        let weights = colorimetry.luminance();
        let lights = REFERENCE_LIGHTS
            .iter()
            .filter_map(|n| Spectrum::illuminant(n))
            .filter_map(|s| s.normalized(Normalize::Luminance, &weights).ok())
            .collect();
        let reflectances = Spectrum::colorchecker_names().filter_map(Spectrum::colorchecker).collect();
        TrainingSet { lights, reflectances }
    }

    /// Number of light × reflectance pairs.
    pub(crate) fn pairs(&self) -> usize {
        self.lights.len() * self.reflectances.len()
    }

    /// The colour signals `E_l ∘ S_r` as the columns of a 31×(lights·reflectances) matrix, light-major.
    pub(crate) fn signals(&self) -> DMatrix<f64> {
        let mut x = DMatrix::zeros(SAMPLES, self.pairs());
        let mut col = 0;
        for e in &self.lights {
            for s in &self.reflectances {
                x.column_mut(col).copy_from(&e.0.component_mul(&s.0));
                col += 1;
            }
        }
        x
    }

    /// A stable 64-bit hash (FNV-1a over the IEEE bit patterns) of the spectra, in order.
    pub(crate) fn content_hash(&self) -> u64 {
        let mut h = Fnv1a::new();
        h.write(&(self.lights.len() as u64).to_le_bytes());
        h.write(&(self.reflectances.len() as u64).to_le_bytes());
        for s in self.lights.iter().chain(&self.reflectances) {
            for v in s.as_slice() {
                h.write(&v.to_bits().to_le_bytes());
            }
        }
        h.finish()
    }
}

/// FNV-1a, 64 bit: stable across platforms and Rust versions (unlike `DefaultHasher`), which a cache key
/// stored on disk needs.
pub(crate) struct Fnv1a(u64);

impl Fnv1a {
    pub(crate) fn new() -> Fnv1a {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }

    pub(crate) fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 ^= u64::from(*b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    pub(crate) fn finish(&self) -> u64 {
        self.0
    }
}
