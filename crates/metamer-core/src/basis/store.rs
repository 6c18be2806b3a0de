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
//! **The product reaches this only through [`super::policy::basis_for`]**, which adds a process-wide
//! memory in front of the sidecar. Callers ask only when they need the factor model — the solver when
//! [`palette_uses_basis`] says so (`fit_in_subspace` or `subspace_error > 0`), `solve`'s subspace colours,
//! the designer's V7 colours, the renderer in `factor` mode, `metamer basis`. A sidecar hit does no
//! training and no accuracy work: each entry stores the [`AccuracyReport`] measured at training.

use super::accuracy::{self, ErrorStats, LambdaMass, Model};
use super::set::{Fnv1a, TrainError, TrainingSet};
use super::train::{self, CandidateSummary, StageResult, Start, TRAINING_VERSION, TrainOptions};
use super::{Basis, BasisError};
use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use crate::spectrum::SAMPLES;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Identifies the sidecar format.
pub(crate) const FORMAT: &str = "metamer-basis-cache/1";
/// At most this many trained bases are kept per sidecar (the most recent ones).
pub(crate) const MAX_ENTRIES: usize = 8;

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
/// pairs: every figure is ΔE00 of some model's colour against the full 31-sample colour
/// `Q_rgb,31 (E ∘ S)` of the same pair (see [`accuracy`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AccuracyReport {
    /// The spectral factor model `Q_rgb,31 B (B⁺E ∘ B⁺S)` (Eq. 15) with the accepted basis: what
    /// post-illumination renders and the designer's V7 half shows.
    pub factor_model: ErrorStats,
    /// The factor model with the best basis that stays in the PCA span (refining only T), when known.
    pub factor_model_pca_span: Option<ErrorStats>,
    /// The factor model with the unsharpened, orthonormal PCA basis (the start the accepted basis is
    /// guaranteed not to be worse than).
    pub pca_factor_model: ErrorStats,
    /// No factor model: each colour signal `E ∘ S` itself orthogonally projected onto the top-m principal
    /// components, `Q_rgb,31 P (E ∘ S)` — how well the PCA span holds the signals.
    pub pca_signal_projection: ErrorStats,
    /// The RGB factor model (seed Eq. 9).
    pub rgb_factor_model: ErrorStats,
    /// The accepted basis with the full Λ of Eq. 7 instead of its diagonal (what the design criteria use).
    pub full_lambda_model: ErrorStats,
    /// Off-diagonal mass of Λ for the accepted basis.
    pub lambda_offdiagonal: LambdaMass,
}

impl AccuracyReport {
    /// Measure a basis (and the PCA basis it came from) on a training set.
    pub(crate) fn measure(
        set: &TrainingSet,
        basis: &Basis,
        pca_span: Option<&Basis>,
        pca: &Basis,
        colorimetry: &Colorimetry,
    ) -> AccuracyReport {
        AccuracyReport {
            factor_model: accuracy::stats(set, Model::Factor(basis), colorimetry),
            factor_model_pca_span: pca_span.map(|b| accuracy::stats(set, Model::Factor(b), colorimetry)),
            pca_factor_model: accuracy::stats(set, Model::Factor(pca), colorimetry),
            pca_signal_projection: accuracy::stats(set, Model::SignalProjection(pca), colorimetry),
            rgb_factor_model: accuracy::stats(set, Model::Rgb, colorimetry),
            full_lambda_model: accuracy::stats(set, Model::Lambda(basis), colorimetry),
            lambda_offdiagonal: accuracy::lambda_mass(basis, set),
        }
    }
}

/// What [`for_palette`] did and how good the basis is.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Report {
    /// m, the number of basis spectra (columns of B).
    pub dimension: usize,
    /// Number of light × reflectance pairs trained on.
    pub pairs: usize,
    /// Rank of the colour signals; `padded` columns were added outside their span when it is below m.
    pub signal_rank: usize,
    /// Columns added outside the signals' span: `m − min(signal_rank, m)`.
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
    /// What each training stage reached (its objective and iterations), in order.
    pub stages: Vec<StageResult>,
    /// The start the accepted basis was refined from, and every candidate tried.
    pub start: Option<Start>,
    /// Every candidate tried, in order (the last is the unrefined PCA basis).
    pub candidates: Vec<CandidateSummary>,
    /// Condition number of the accepted B with unit-norm columns (B⁺ loses about log10 of it in digits).
    pub condition: f64,
    /// Measured once, when the basis was trained, and stored with it.
    pub accuracy: AccuracyReport,
    /// Things the user should know: padding, a skipped or failed stage, a sidecar ignored or not written.
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
    #[serde(default)]
    start: Option<Start>,
    #[serde(default)]
    candidates: Vec<CandidateSummary>,
    #[serde(default)]
    condition: Option<f64>,
    /// The accuracy report measured at training (an entry without one is retrained).
    #[serde(default)]
    accuracy: Option<AccuracyReport>,
    /// SHA-256 (hex) of the entry's own content, everything above serialised as compact JSON with this field
    /// absent ([`Entry::content_checksum`]). An entry without one, or whose content does not hash to it, is
    /// not used.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    checksum: Option<String>,
}

impl Entry {
    /// SHA-256 of the entry as compact JSON without its checksum. Numbers are written with serde_json's
    /// shortest round-trip formatting and read back bit-identical (`float_roundtrip`), so a stored entry
    /// hashes to the same value when it is read again.
    fn content_checksum(&self) -> String {
        use sha2::{Digest, Sha256};
        let unsigned = Entry { checksum: None, ..self.clone() };
        // Serialising this plain struct of numbers, strings and vectors cannot fail.
        let bytes = serde_json::to_vec(&unsigned).unwrap_or_default();
        Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect()
    }
}

/// The largest balanced condition number (unit-norm columns) a stored basis may have: above it `B⁺` loses
/// more than half of f64's digits and the factor model's colours are not to be trusted. The training's
/// conditioning term (negligible up to ~10³, see [`train::DEFAULT_CONDITIONING_WEIGHT`]) keeps trained
/// bases far below it; a basis trained above it would be retrained on every load, with the note saying why.
pub(crate) const MAX_STORED_CONDITION: f64 = 1e8;

/// Relative tolerance of the accuracy re-measured on load against the stored figure: the same arithmetic
/// on bit-identical inputs gives identical results; the margin covers a different summation order only.
const ACCURACY_RECHECK_TOLERANCE: f64 = 1e-9;

/// Check a stored entry before it is believed: its checksum, the basis's invariants (finite `B`, `B⁺` and
/// product tensor, full rank — [`Basis::from_matrix`] — and a balanced condition number below
/// [`MAX_STORED_CONDITION`] that agrees with the stored one), and its stored factor-model accuracy
/// re-measured on this training set's pairs. `Err` says why, for the note that goes with the retraining.
fn verify(
    entry: &Entry,
    basis: &Basis,
    set: &TrainingSet,
    colorimetry: &Colorimetry,
) -> Result<AccuracyReport, String> {
    match &entry.checksum {
        None => return Err("it has no checksum (written by an older metamer or by hand)".into()),
        Some(c) if *c != entry.content_checksum() => {
            return Err("its content does not match its checksum (edited or corrupted)".into());
        }
        Some(_) => {}
    }
    let finite = |m: &DMatrix<f64>| m.iter().all(|v| v.is_finite());
    if !finite(&basis.b_pinv) || !basis.products.iter().all(finite) {
        return Err("its pseudo-inverse is not finite".into());
    }
    let condition = train::balanced_condition(&basis.b);
    if condition.is_nan() || condition > MAX_STORED_CONDITION {
        return Err(format!("its condition number {condition:.3e} exceeds {MAX_STORED_CONDITION:.0e}"));
    }
    let close = |a: f64, b: f64| (a - b).abs() <= ACCURACY_RECHECK_TOLERANCE * a.abs().max(b.abs()).max(1.0);
    if let Some(stored) = entry.condition
        && !close(stored, condition)
    {
        return Err(format!("its stored condition number {stored:.6e} is not its basis's ({condition:.6e})"));
    }
    let Some(accuracy) = entry.accuracy.clone() else {
        return Err("it has no accuracy report".into());
    };
    let measured = accuracy::stats(set, Model::Factor(basis), colorimetry);
    let stored = &accuracy.factor_model;
    if !(measured.mean.is_finite() && measured.max.is_finite()) {
        return Err("its factor-model colours on this palette are not finite".into());
    }
    if measured.count != stored.count || !close(measured.mean, stored.mean) || !close(measured.max, stored.max) {
        return Err(format!(
            "its stored accuracy (mean ΔE00 {:.6}, max {:.6}) is not what it gives on this palette's pairs \
             (mean {:.6}, max {:.6})",
            stored.mean, stored.max, measured.mean, measured.max
        ));
    }
    Ok(accuracy)
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

/// The palette's basis of dimension m, without the process memory of [`super::policy::basis_for`] (which
/// is what the product uses): loaded from the sidecar `cache` when one trained from exactly these
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

/// As [`for_palette_with`] for any training set (e.g. a scene's dial lights × its materials). A sidecar hit
/// does no training and no accuracy work: the report is the one stored at training.
pub fn for_set(
    set: &TrainingSet,
    m: usize,
    cache: Option<&Path>,
    options: &TrainOptions,
) -> Result<(Basis, Report), StoreError> {
    let colorimetry = Colorimetry::default();
    let key = cache_key(set, m);
    let mut notes = Vec::new();
    let mut stored = false;
    let mut sidecar = match cache {
        Some(path) => read_sidecar(path, &mut notes),
        None => Sidecar { format: FORMAT.into(), entries: Vec::new() },
    };
    let hit = sidecar.entries.iter().find(|e| e.key == key).and_then(|e| entry_basis(e, m, &colorimetry));
    let verified = hit.and_then(|(basis, entry)| match verify(entry, &basis, set, &colorimetry) {
        Ok(accuracy) => Some((basis, entry, accuracy)),
        Err(why) => {
            notes.push(format!(
                "did not use the stored basis {key} in {}: {why}; trained it again",
                cache.map(crate::fsio::show).unwrap_or_default()
            ));
            None
        }
    });
    if let Some((basis, entry, accuracy)) = verified {
        notes.extend(entry.notes.iter().cloned());
        let report = Report {
            dimension: m,
            pairs: set.pairs(),
            signal_rank: entry.signal_rank,
            padded: entry.padded,
            key,
            from_cache: true,
            stored: false,
            training_seconds: entry.training_seconds,
            stages: entry.stages.clone(),
            start: entry.start,
            candidates: entry.candidates.clone(),
            condition: entry.condition.unwrap_or_else(|| train::balanced_condition(&basis.b)),
            accuracy,
            notes,
        };
        return Ok((basis, report));
    }
    let start = Instant::now();
    let trained = train::train(set, m, &colorimetry, options)?;
    let seconds = start.elapsed().as_secs_f64();
    notes.extend(trained.notes.iter().cloned());
    let pca = Basis::from_matrix(trained.pca.clone(), &colorimetry)?;
    let pca_span = Basis::from_matrix(trained.transform_only.clone(), &colorimetry).ok();
    let accuracy = AccuracyReport::measure(set, &trained.basis, pca_span.as_ref(), &pca, &colorimetry);
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
            start: Some(trained.start),
            candidates: trained.candidates.clone(),
            condition: Some(trained.condition),
            accuracy: Some(accuracy.clone()),
            checksum: None,
        });
        if let Some(e) = sidecar.entries.last_mut() {
            e.checksum = Some(e.content_checksum());
        }
        let excess = sidecar.entries.len().saturating_sub(MAX_ENTRIES);
        sidecar.entries.drain(..excess);
        match write_sidecar(path, &sidecar) {
            Ok(()) => stored = true,
            Err(e) => notes.push(format!("did not store the basis in {}: {}", crate::fsio::show(path), e.reason())),
        }
    }
    let report = Report {
        dimension: m,
        pairs: set.pairs(),
        signal_rank: trained.signal_rank,
        padded: trained.padded,
        key,
        from_cache: false,
        stored,
        training_seconds: seconds,
        stages: trained.stages,
        start: Some(trained.start),
        candidates: trained.candidates,
        condition: trained.condition,
        accuracy,
        notes,
    };
    Ok((trained.basis, report))
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

/// The sidecar at `path` (empty when there is none or it cannot be used, with a note). Whether it may be
/// replaced is the writer's question ([`write_sidecar`]).
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

/// Write the sidecar through the one atomic writer as a file whose name the tool chose
/// ([`crate::fsio::write_chosen`]: a symbolic link there, `p.basis.json -> p.toml`, is never written
/// through), and never over a file this process read as anything but a sidecar (the palette, a CSV source
/// named `p.basis.json`, a hard link to one of them: [`crate::fsio::Outputs`]).
fn write_sidecar(path: &Path, sidecar: &Sidecar) -> Result<(), crate::fsio::FsError> {
    let mut files = crate::fsio::Outputs::new();
    files.inputs_read(&crate::fsio::read_by_this_process(|k| k != crate::fsio::Kind::Sidecar));
    files.output("basis sidecar", path)?;
    let mut text = serde_json::to_vec_pretty(sidecar)
        .map_err(|e| crate::fsio::FsError::Write { path: path.to_path_buf(), source: std::io::Error::other(e) })?;
    text.push(b'\n');
    crate::fsio::write_chosen(path, &text, crate::fsio::Replace::Writable)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::palette::{Kind, SpectrumEntry};
    use crate::spectrum::{Normalize, Spectrum};

    fn entry(name: &str, kind: Kind, spectrum: Spectrum) -> SpectrumEntry {
        SpectrumEntry::resolved(
            name,
            kind,
            crate::palette::Source::Samples(spectrum.to_vec()),
            Normalize::None,
            spectrum,
        )
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

    /// Train into a sidecar, then rewrite its one entry with `edit` (re-signing it when `resign`), and load.
    fn load_after_edit(edit: impl Fn(&mut Entry), resign: bool) -> (Basis, Basis, Report) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.basis.json");
        let p = palette();
        let (trained, r) = for_palette_with(&p, 5, Some(&path), &quick()).unwrap();
        assert!(r.stored);
        let mut sidecar: Sidecar = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        assert_eq!(sidecar.entries.len(), 1);
        let e = &mut sidecar.entries[0];
        assert_eq!(e.checksum.as_deref(), Some(e.content_checksum().as_str()), "stored entries are signed");
        edit(e);
        if resign {
            e.checksum = Some(e.content_checksum());
        }
        write_sidecar(&path, &sidecar).unwrap();
        let (loaded, report) = for_palette_with(&p, 5, Some(&path), &quick()).unwrap();
        // Whatever was refused, the retrained entry is stored again and is then believed.
        if !report.from_cache {
            let (again, r2) = for_palette_with(&p, 5, Some(&path), &quick()).unwrap();
            assert!(r2.from_cache && r2.notes.is_empty(), "{:?}", r2.notes);
            assert_eq!(again, loaded);
        }
        (trained, loaded, report)
    }

    fn refused_because(report: &Report, why: &str) {
        assert!(!report.from_cache, "a refused entry must not be used");
        assert!(
            report
                .notes
                .iter()
                .any(|n| n.contains("did not use the stored basis") && n.contains("p.basis.json") && n.contains(why)),
            "{:?}",
            report.notes
        );
    }

    #[test]
    fn an_untouched_entry_is_believed() {
        let (trained, loaded, report) = load_after_edit(|_| {}, false);
        assert!(report.from_cache && report.notes.is_empty(), "{:?}", report.notes);
        assert_eq!(trained, loaded);
    }

    #[test]
    fn a_basis_edited_under_the_right_key_is_retrained_not_believed() {
        // Another valid basis (one column scaled, one shifted) under the same key and the old checksum.
        let edit = |e: &mut Entry| {
            e.basis[0].iter_mut().for_each(|v| *v *= 1.5);
            e.basis[1][10] += 0.2;
        };
        let (trained, loaded, report) = load_after_edit(edit, false);
        refused_because(&report, "does not match its checksum");
        assert_eq!(trained, loaded, "the retrained basis is the trained one");
    }

    #[test]
    fn a_re_signed_foreign_basis_fails_its_accuracy_recheck() {
        // The checksum and the stored condition number made to agree with the edited content: only the
        // re-measured accuracy gives it away.
        let edit = |e: &mut Entry| {
            e.basis[1][10] += 0.2;
            e.basis[3].reverse();
            let b = columns_basis(&e.basis, 5, &Colorimetry::default()).unwrap();
            e.condition = Some(train::balanced_condition(&b.b));
        };
        let (trained, loaded, report) = load_after_edit(edit, true);
        refused_because(&report, "stored accuracy");
        assert_eq!(trained, loaded);
    }

    #[test]
    fn a_sidecar_of_tiny_numbers_never_reaches_the_colours() {
        // Re-signed, so only the basis's own invariants can refuse it.
        let edit = |e: &mut Entry| e.basis.iter_mut().flatten().for_each(|v| *v *= 1e-300);
        let (trained, loaded, report) = load_after_edit(edit, true);
        assert!(!report.from_cache, "{:?}", report.notes);
        assert!(report.notes.iter().any(|n| n.contains("did not use the stored basis")), "{:?}", report.notes);
        assert_eq!(trained, loaded);
        let c = Colorimetry::default();
        let stats = accuracy::stats(&TrainingSet::from_palette(&palette()).unwrap(), Model::Factor(&loaded), &c);
        assert!(stats.mean.is_finite() && stats.max.is_finite());
    }

    #[test]
    fn an_unsigned_entry_is_retrained_once() {
        let (trained, loaded, report) = load_after_edit(|e| e.checksum = None, false);
        refused_because(&report, "no checksum");
        assert_eq!(trained, loaded);
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
        assert!(r.notes.iter().any(|n| n.contains("did not store the basis in")), "{:?}", r.notes);
    }

    #[test]
    fn an_empty_palette_is_a_clear_error() {
        let mut p = palette();
        p.lights.clear();
        let err = for_palette(&p, 7, None).unwrap_err().to_string();
        assert!(err.contains("at least one light"), "{err}");
    }
}
