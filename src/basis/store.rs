//! A palette's trained basis, stored so that renders are reproducible and training is skipped when nothing
//! changed.
//!
//! **Choice: a JSON sidecar next to the palette** (`engine.toml` → `engine.basis.json`, see [`sidecar_path`]).
//! It travels with the palette (copy both and the render is identical), needs no cache directory, and
//! leaves the palette TOML — which users edit by hand — untouched. The sidecar holds up to
//! [`MAX_ENTRIES`] trained bases, each under a key that hashes (FNV-1a, stable across platforms) the
//! exact bit patterns of every light and reflectance the basis was trained from, the dimension m and
//! [`TRAINING_VERSION`]. So a basis is retrained exactly when a spectrum changes (e.g. after a solve
//! moves a designed spectrum), when m changes or when training itself changes; numbers are stored with
//! serde_json's shortest round-trip formatting, so a loaded basis is bit-identical to the trained one.
//!
//! A missing, unreadable or stale sidecar is never an error: the basis is trained and the sidecar
//! rewritten atomically (temporary file + rename); a failure to write is reported in
//! [`Report::notes`] and the basis is still returned.
//!
//! **Training is skipped entirely when nothing uses it**: [`for_palette`] is the only entry point, and
//! callers call it only when they need the factor model — the solver when [`palette_uses_basis`] says so
//! (`fit_in_subspace` or `subspace_error > 0`), the renderer in `factor` mode, `metamer basis`.

use super::accuracy::{self, ErrorStats, LambdaMass, Model};
use super::train::{self, Fnv1a, StageResult, TRAINING_VERSION, TrainError, TrainOptions, TrainingSet};
use super::{Basis, BasisError};
use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use crate::spectrum::SAMPLES;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Identifies the sidecar format.
pub const FORMAT: &str = "metamer-basis-cache/1";
/// At most this many trained bases are kept per sidecar (the most recent ones).
pub const MAX_ENTRIES: usize = 8;

/// Why a palette's basis cannot be had.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("cannot train the palette's basis: {0}")]
    Train(#[from] TrainError),
    #[error("cannot train the palette's basis: {0}")]
    Basis(#[from] BasisError),
}

/// True when solving this palette needs its basis (`fit_in_subspace` or a positive `subspace_error`).
pub fn palette_uses_basis(palette: &Palette) -> bool {
    palette.settings.fit_in_subspace || palette.settings.subspace_error > 0.0
}

/// The sidecar of a palette file: same folder and stem, extension `.basis.json`.
pub fn sidecar_path(palette_file: &Path) -> PathBuf {
    let stem = palette_file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "palette".into());
    palette_file.with_file_name(format!("{stem}.basis.json"))
}

/// Accuracy of the factor model and of the comparison models over a palette's own light × reflectance
/// pairs (ΔE00 against the full 31-sample colour, see [`accuracy`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AccuracyReport {
    /// The spectral factor model `Q_rgb,31 B (B⁺E ∘ B⁺S)` with the trained basis.
    pub factor_model: ErrorStats,
    /// The same after refining only T (B in the PCA span), when known.
    pub transform_only: Option<ErrorStats>,
    /// The RGB factor model (seed Eq. 9).
    pub rgb_factor_model: ErrorStats,
    /// The componentwise product in the unsharpened PCA basis.
    pub pca_projection: ErrorStats,
    /// The trained basis with the full Λ of Eq. 7 instead of its diagonal.
    pub full_lambda: ErrorStats,
    /// Off-diagonal mass of Λ for the trained basis.
    pub lambda_offdiagonal: LambdaMass,
}

impl AccuracyReport {
    /// Measure a basis (and the PCA basis it came from) on a training set.
    pub fn measure(
        set: &TrainingSet,
        basis: &Basis,
        transform_only: Option<&Basis>,
        pca: &Basis,
        colorimetry: &Colorimetry,
    ) -> AccuracyReport {
        AccuracyReport {
            factor_model: accuracy::stats(set, Model::Factor(basis), colorimetry),
            transform_only: transform_only.map(|b| accuracy::stats(set, Model::Factor(b), colorimetry)),
            rgb_factor_model: accuracy::stats(set, Model::Rgb, colorimetry),
            pca_projection: accuracy::stats(set, Model::Factor(pca), colorimetry),
            full_lambda: accuracy::stats(set, Model::Lambda(basis), colorimetry),
            lambda_offdiagonal: accuracy::lambda_mass(basis, set),
        }
    }
}

/// What [`for_palette`] did and how good the basis is.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Report {
    pub dimension: usize,
    /// Number of light × reflectance pairs trained on.
    pub pairs: usize,
    /// Rank of the colour signals; `padded` columns were added outside their span when it is below m.
    pub signal_rank: usize,
    pub padded: usize,
    /// The cache key (hex).
    pub key: String,
    /// True when the basis came from the sidecar rather than being trained now.
    pub from_cache: bool,
    /// True when the basis was trained now and written to the sidecar (false when there was no sidecar to
    /// write or the write failed: the reason is among the notes).
    pub stored: bool,
    /// Wall-clock seconds of the training (as recorded when it was trained, for a cached basis).
    pub training_seconds: f64,
    pub stages: Vec<StageResult>,
    pub accuracy: AccuracyReport,
    pub notes: Vec<String>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct Entry {
    key: String,
    training_version: u32,
    dimension: usize,
    signal_rank: usize,
    padded: usize,
    training_seconds: f64,
    notes: Vec<String>,
    /// The columns of B, each 31 samples.
    basis: Vec<Vec<f64>>,
    /// The columns of `B0 T` before all of B was refined.
    #[serde(default)]
    transform_only: Option<Vec<Vec<f64>>>,
    #[serde(default)]
    stages: Vec<StageResult>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct Sidecar {
    format: String,
    entries: Vec<Entry>,
}

/// The cache key of a training set and dimension.
pub fn cache_key(set: &TrainingSet, m: usize) -> String {
    let mut h = Fnv1a::new();
    h.write(&set.content_hash().to_le_bytes());
    h.write(&(m as u64).to_le_bytes());
    h.write(&TRAINING_VERSION.to_le_bytes());
    format!("{:016x}", h.finish())
}

/// The palette's basis of dimension m: loaded from the sidecar `cache` when one trained from exactly these
/// spectra is there, else trained (all lights × reflectances, designed ones at their current samples, with
/// [`TrainOptions::default`]) and stored. `cache = None` always trains and stores nothing.
pub fn for_palette(palette: &Palette, m: usize, cache: Option<&Path>) -> Result<(Basis, Report), StoreError> {
    for_palette_with(palette, m, cache, &TrainOptions::default())
}

/// As [`for_palette`] with explicit training options (which are not part of the key: use `cache = None`
/// when experimenting with them).
pub fn for_palette_with(
    palette: &Palette,
    m: usize,
    cache: Option<&Path>,
    options: &TrainOptions,
) -> Result<(Basis, Report), StoreError> {
    for_set(&TrainingSet::from_palette(palette)?, m, cache, options)
}

/// As [`for_palette_with`] for any training set (e.g. a scene's dial lights × its materials).
pub fn for_set(
    set: &TrainingSet,
    m: usize,
    cache: Option<&Path>,
    options: &TrainOptions,
) -> Result<(Basis, Report), StoreError> {
    let colorimetry = Colorimetry::default();
    let set = set.clone();
    let key = cache_key(&set, m);
    let mut notes = Vec::new();
    let mut stored = false;
    let mut sidecar = match cache {
        Some(path) => read_sidecar(path, &mut notes),
        None => Sidecar { format: FORMAT.into(), entries: Vec::new() },
    };
    let (pca_matrix, rank) = train::principal_components(&set.signals(), m)?;
    let pca = Basis::from_matrix(pca_matrix, &colorimetry)?;

    let cached = sidecar.entries.iter().find(|e| e.key == key).and_then(|e| entry_basis(e, m, &colorimetry));
    let (basis, transform_only, report_base) = match cached {
        Some((basis, entry)) => {
            notes.extend(entry.notes.iter().cloned());
            let t = entry.transform_only.as_ref().and_then(|cols| columns_basis(cols, m, &colorimetry));
            (basis, t, (true, entry.training_seconds, entry.stages.clone(), entry.signal_rank, entry.padded))
        }
        None => {
            let start = Instant::now();
            let trained = train::train(&set, m, &colorimetry, options)?;
            let seconds = start.elapsed().as_secs_f64();
            notes.extend(trained.notes.iter().cloned());
            if let Some(path) = cache {
                sidecar.entries.retain(|e| e.key != key);
                sidecar.entries.push(Entry {
                    key: key.clone(),
                    training_version: TRAINING_VERSION,
                    dimension: m,
                    signal_rank: trained.signal_rank,
                    padded: trained.padded,
                    training_seconds: seconds,
                    notes: trained.notes.clone(),
                    basis: columns(&trained.basis.b),
                    transform_only: Some(columns(&trained.transform_only)),
                    stages: trained.stages.clone(),
                });
                let excess = sidecar.entries.len().saturating_sub(MAX_ENTRIES);
                sidecar.entries.drain(..excess);
                match write_sidecar(path, &sidecar) {
                    Ok(()) => stored = true,
                    Err(e) => notes.push(format!("could not store the basis: {e}")),
                }
            }
            let t = Basis::from_matrix(trained.transform_only.clone(), &colorimetry).ok();
            (trained.basis, t, (false, seconds, trained.stages, trained.signal_rank, trained.padded))
        }
    };
    let (from_cache, training_seconds, stages, signal_rank, padded) = report_base;
    debug_assert!(from_cache || signal_rank == rank);
    let accuracy = AccuracyReport::measure(&set, &basis, transform_only.as_ref(), &pca, &colorimetry);
    let report = Report {
        dimension: m,
        pairs: set.pairs(),
        signal_rank,
        padded,
        key,
        from_cache,
        stored,
        training_seconds,
        stages,
        accuracy,
        notes,
    };
    Ok((basis, report))
}

/// The columns of a 31×m matrix as lists of samples.
fn columns(b: &DMatrix<f64>) -> Vec<Vec<f64>> {
    b.column_iter().map(|c| c.iter().copied().collect()).collect()
}

/// A basis from stored columns; `None` unless there are m columns of 31 finite samples forming a valid basis.
fn columns_basis(cols: &[Vec<f64>], m: usize, colorimetry: &Colorimetry) -> Option<Basis> {
    if cols.len() != m || cols.iter().any(|c| c.len() != SAMPLES) {
        return None;
    }
    let flat: Vec<f64> = cols.iter().flatten().copied().collect();
    Basis::from_matrix(DMatrix::from_column_slice(SAMPLES, m, &flat), colorimetry).ok()
}

fn entry_basis<'a>(entry: &'a Entry, m: usize, colorimetry: &Colorimetry) -> Option<(Basis, &'a Entry)> {
    if entry.training_version != TRAINING_VERSION || entry.dimension != m {
        return None;
    }
    columns_basis(&entry.basis, m, colorimetry).map(|b| (b, entry))
}

fn read_sidecar(path: &Path, notes: &mut Vec<String>) -> Sidecar {
    let empty = Sidecar { format: FORMAT.into(), entries: Vec::new() };
    // Through the one bounded reader: a FIFO or a device as the sidecar is ignored, never waited on.
    let text = match crate::fsio::read_to_string(path, crate::fsio::Kind::Sidecar) {
        Ok(t) => t,
        Err(crate::fsio::FsError::Read { source, .. }) if source.kind() == std::io::ErrorKind::NotFound => {
            return empty;
        }
        Err(e) => {
            notes.push(format!("ignored the basis cache: {e}"));
            return empty;
        }
    };
    match serde_json::from_str::<Sidecar>(&text) {
        Ok(s) if s.format == FORMAT => s,
        Ok(s) => {
            notes.push(format!("ignored the basis cache {}: unknown format {:?}", crate::fsio::show(path), s.format));
            empty
        }
        Err(e) => {
            notes.push(format!("ignored the basis cache {}: {e}", crate::fsio::show(path)));
            empty
        }
    }
}

/// Write the sidecar through the one atomic writer ([`crate::fsio::write_atomic`]).
fn write_sidecar(path: &Path, sidecar: &Sidecar) -> Result<(), crate::fsio::FsError> {
    let mut text = serde_json::to_vec_pretty(sidecar)
        .map_err(|e| crate::fsio::FsError::Write { path: path.to_path_buf(), source: std::io::Error::other(e) })?;
    text.push(b'\n');
    crate::fsio::write_atomic(path, &text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::palette::{Kind, SpectrumEntry};
    use crate::spectrum::{Normalize, Spectrum};

    fn entry(name: &str, kind: Kind, spectrum: Spectrum) -> SpectrumEntry {
        SpectrumEntry {
            name: name.into(),
            kind,
            source: crate::palette::Source::Samples(spectrum.to_vec()),
            normalize: Normalize::None,
            scale: 1.0,
            design: false,
            bounds: None,
            dial: None,
            spectrum,
        }
    }

    fn palette() -> Palette {
        let c = Colorimetry::default();
        let set = TrainingSet::colorchecker_seven_lights(&c);
        Palette {
            name: "t".into(),
            lights: set.lights[..3].iter().enumerate().map(|(i, s)| entry(&format!("l{i}"), Kind::Light, *s)).collect(),
            reflectances: set.reflectances[..8]
                .iter()
                .enumerate()
                .map(|(i, s)| entry(&format!("r{i}"), Kind::Reflectance, *s))
                .collect(),
            ..Palette::default()
        }
    }

    fn quick() -> TrainOptions {
        TrainOptions { sharpen: true, transform_iterations: 100, full_iterations: 100, ..TrainOptions::default() }
    }

    #[test]
    fn sidecar_round_trips_and_retrains_only_on_change() {
        let dir = tempfile::tempdir().unwrap();
        let path = sidecar_path(&dir.path().join("engine.toml"));
        assert_eq!(path.file_name().unwrap(), "engine.basis.json");
        let mut p = palette();
        let (b1, r1) = for_palette_with(&p, 5, Some(&path), &quick()).unwrap();
        assert!(!r1.from_cache && path.exists());
        assert!(r1.notes.is_empty(), "{:?}", r1.notes);
        let (b2, r2) = for_palette_with(&p, 5, Some(&path), &quick()).unwrap();
        assert!(r2.from_cache);
        assert_eq!(b1, b2, "a cached basis is bit-identical");
        assert_eq!(r1.accuracy, r2.accuracy);
        assert_eq!(r1.stages, r2.stages);
        // Another dimension is another entry; the first stays.
        let (_, r3) = for_palette_with(&p, 4, Some(&path), &quick()).unwrap();
        assert!(!r3.from_cache);
        assert!(for_palette_with(&p, 5, Some(&path), &quick()).unwrap().1.from_cache);
        // A designed spectrum moving changes the key.
        p.reflectances[2].spectrum.0[7] += 0.01;
        let (_, r4) = for_palette_with(&p, 5, Some(&path), &quick()).unwrap();
        assert!(!r4.from_cache);
        assert_ne!(r4.key, r1.key);
    }

    #[test]
    fn a_corrupt_sidecar_is_replaced_not_fatal() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.basis.json");
        std::fs::write(&path, b"\x00\x01 not json").unwrap();
        let (_, r) = for_palette_with(&palette(), 3, Some(&path), &quick()).unwrap();
        assert!(!r.from_cache);
        assert!(r.notes.iter().any(|n| n.contains("ignored the basis cache")), "{:?}", r.notes);
        assert!(for_palette_with(&palette(), 3, Some(&path), &quick()).unwrap().1.from_cache);
        // An unwritable location is a note, not an error.
        let (_, r) = for_palette_with(&palette(), 3, Some(&dir.path().join("missing/dir/x.json")), &quick()).unwrap();
        assert!(r.notes.iter().any(|n| n.contains("could not store")), "{:?}", r.notes);
    }

    #[test]
    fn an_empty_palette_is_a_clear_error() {
        let mut p = palette();
        p.lights.clear();
        let err = for_palette(&p, 7, None).unwrap_err().to_string();
        assert!(err.contains("at least one light"), "{err}");
    }
}
