//! Resolving a spectrum entry's source into samples: the raw spectrum its source key names, then (lights)
//! the normalisation and the scale (DESIGN_SPEC §1).

use super::{Kind, Source, SpectrumEntry};
use crate::spectrum::csv::{SpectrumCsvError, read_spectrum_csv};
use crate::spectrum::{Normalize, NormalizeError, SAMPLES, Samples, Spectrum};
use std::path::Path;

/// Why a source cannot give samples.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    #[error("unknown illuminant `{name}` (valid: {valid})")]
    UnknownIlluminant { name: String, valid: String },
    #[error("unknown ColorChecker patch `{name}` (valid: {valid})")]
    UnknownColorChecker { name: String, valid: String },
    #[error("Planck temperature must be a finite number of kelvin above 0, got {0}")]
    BadTemperature(f64),
    #[error("expected {SAMPLES} samples (400..=700 nm in 10 nm steps), got {0}")]
    SampleCount(usize),
    #[error("the samples must be finite numbers")]
    NotFinite,
    #[error("a CSV source needs the palette file's folder to resolve `{0}`")]
    CsvWithoutFolder(String),
    #[error(transparent)]
    Csv(#[from] SpectrumCsvError),
    #[error("{0}")]
    Normalize(#[from] NormalizeError),
}

impl Source {
    /// The source key as written in a palette file.
    pub fn key(&self) -> &'static str {
        match self {
            Source::Illuminant(_) => "illuminant",
            Source::ColorChecker(_) => "colorchecker",
            Source::Planck(_) => "planck",
            Source::Flat(_) => "flat",
            Source::Samples(_) => "samples",
            Source::Csv(_) => "csv",
        }
    }

    /// All source keys a palette file may use.
    pub(crate) const KEYS: [&'static str; 6] = ["illuminant", "colorchecker", "planck", "flat", "samples", "csv"];

    /// The raw samples the source names, before any normalisation or scale. A CSV path is taken relative to
    /// `base_dir` (the palette file's folder); without one a CSV source is an error.
    pub(crate) fn raw_spectrum(&self, base_dir: Option<&Path>) -> Result<Spectrum, SourceError> {
        let spectrum = match self {
            Source::Illuminant(name) => Spectrum::illuminant(name).ok_or_else(|| SourceError::UnknownIlluminant {
                name: name.clone(),
                valid: Spectrum::illuminant_names().collect::<Vec<_>>().join(", "),
            })?,
            Source::ColorChecker(name) => {
                Spectrum::colorchecker(name).ok_or_else(|| SourceError::UnknownColorChecker {
                    name: name.clone(),
                    valid: Spectrum::colorchecker_names().collect::<Vec<_>>().join(", "),
                })?
            }
            Source::Planck(kelvin) => Spectrum::planck(*kelvin).ok_or(SourceError::BadTemperature(*kelvin))?,
            Source::Flat(v) => Spectrum::flat(*v),
            Source::Samples(values) => Spectrum::from_slice(values).ok_or(SourceError::SampleCount(values.len()))?,
            Source::Csv(file) => match base_dir {
                Some(dir) => read_spectrum_csv(&dir.join(file))?,
                None => return Err(SourceError::CsvWithoutFolder(file.clone())),
            },
        };
        if spectrum.is_finite() { Ok(spectrum) } else { Err(SourceError::NotFinite) }
    }
}

/// Apply a spectrum's normalisation (lights only; reflectances are never normalised) and then its scale.
pub(crate) fn finish(
    raw: &Spectrum,
    kind: Kind,
    normalize: Normalize,
    scale: f64,
    luminance_weights: &Samples,
) -> Result<Spectrum, NormalizeError> {
    let normalized = match kind {
        Kind::Light => raw.normalized(normalize, luminance_weights)?,
        Kind::Reflectance => *raw,
    };
    let out = normalized.scaled(scale);
    if out.is_finite() { Ok(out) } else { Err(NormalizeError::NotFinite) }
}

impl SpectrumEntry {
    /// An entry given by `source` (normalised by `normalize`, lights only) whose samples are already
    /// resolved to `spectrum`: scale 1, not designed, no bounds of its own, no dial position.
    pub fn resolved(name: &str, kind: Kind, source: Source, normalize: Normalize, spectrum: Spectrum) -> SpectrumEntry {
        SpectrumEntry {
            name: name.to_string(),
            kind,
            source,
            normalize,
            scale: 1.0,
            design: false,
            bounds: None,
            dial: None,
            spectrum,
        }
    }
}

/// True when two spectra agree to a relative tolerance of 1e-12 of the larger magnitude (plus 1e-300
/// absolute so all-zero spectra compare equal): the threshold below which a spectrum counts as "as its
/// source resolves" rather than "designed or edited".
pub(crate) fn spectra_agree(a: &Spectrum, b: &Spectrum) -> bool {
    let (a, b) = (a.as_slice(), b.as_slice());
    let scale = amax(a.iter().copied()).max(amax(b.iter().copied()));
    amax(a.iter().zip(b).map(|(x, y)| x - y)) <= 1e-12 * scale + 1e-300
}

/// The largest magnitude, as nalgebra's `amax` finds it on plain slices: the first magnitude (0 for none),
/// then each next one taken when the one so far is not `>=` it.
fn amax(mut values: impl Iterator<Item = f64>) -> f64 {
    let first = values.next().map_or(0.0, f64::abs);
    values.fold(first, |m, x| if m >= x.abs() { m } else { x.abs() })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plain-slice `spectra_agree`, `finish` and finiteness give nalgebra's answers and bits: spectra
    /// that agree, differ at the tolerance, hold zeros of both signs, NaN or infinities.
    #[test]
    fn the_slice_loops_give_nalgebras_answers() {
        let base: Vec<f64> = (0..SAMPLES).map(|i| 0.01 + i as f64 / 40.0).collect();
        let mut cases = vec![base.clone(), vec![0.0; SAMPLES], vec![-0.0; SAMPLES]];
        for (i, special) in [f64::NAN, f64::INFINITY, -f64::INFINITY, -3.5, 1e-300, 0.0].into_iter().enumerate() {
            for at in [0, 7, SAMPLES - 1] {
                let mut v = base.clone();
                v[(at + i) % SAMPLES] = special;
                cases.push(v);
            }
        }
        for k in [1e-13, 1e-12, 2e-12, 1e-9] {
            cases.push(base.iter().map(|x| x * (1.0 + k)).collect());
        }
        let spectra: Vec<Spectrum> = cases.iter().map(|v| Spectrum::from_slice(v).unwrap()).collect();
        let lum = crate::colorimetry::Colorimetry::default().luminance();
        for a in &spectra {
            assert_eq!(a.is_finite(), a.0.iter().all(|v| v.is_finite()));
            for b in &spectra {
                let nalgebra = {
                    let scale = a.0.amax().max(b.0.amax());
                    (a.0 - b.0).amax() <= 1e-12 * scale + 1e-300
                };
                assert_eq!(spectra_agree(a, b), nalgebra, "{a:?} {b:?}");
            }
            for (kind, normalize) in
                [(Kind::Reflectance, Normalize::None), (Kind::Light, Normalize::None), (Kind::Light, Normalize::L2)]
            {
                for scale in [1.0, 0.5, -2.0, 1e308, f64::NAN] {
                    let ours = finish(a, kind, normalize, scale, &lum);
                    let normalized = match kind {
                        Kind::Light => a.normalized(normalize, &lum),
                        Kind::Reflectance => Ok(*a),
                    };
                    let theirs = normalized.map(|n| Spectrum(n.0 * scale)).and_then(|s| {
                        if s.0.iter().all(|v| v.is_finite()) { Ok(s) } else { Err(NormalizeError::NotFinite) }
                    });
                    match (ours, theirs) {
                        (Ok(x), Ok(y)) => {
                            assert!(x.as_slice().iter().zip(y.as_slice()).all(|(p, q)| p.to_bits() == q.to_bits()))
                        }
                        (Err(x), Err(y)) => assert_eq!(x.to_string(), y.to_string()),
                        (x, y) => panic!("{x:?} against {y:?}"),
                    }
                }
            }
        }
    }
}
