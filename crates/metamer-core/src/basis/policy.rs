//! The one basis policy: which spectral factor basis a set of spectra uses, in one place.
//!
//! [`basis_for`] is the only entry point the product uses (`metamer basis`, `solve`'s subspace colours, the
//! designer's V7 colours, the renderer's factor mode). The basis is keyed by the exact spectra it is for
//! (every light × reflectance, designed ones *after* solving), the dimension m and
//! [`super::train::TRAINING_VERSION`] ([`super::store::cache_key`]), and trained with
//! [`TrainOptions::default`]. It is looked up first in this process's memory, then in the palette's
//! `.basis.json` sidecar (when a path is given); only on a miss in both is it trained, measured once
//! ([`super::store::AccuracyReport`]) and stored in both. A hit does no training and no accuracy work.
//!
//! [`Report::poor_model`] says when the factor model is not trustworthy on the spectra's own pairs:
//! mean ΔE00 above [`POOR_MODEL_MEAN_DE00`] against full 31-sample colour.

use super::Basis;
use super::set::TrainingSet;
use super::store::{self, Report, StoreError};
use super::train::TrainOptions;
use crate::palette::Palette;
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

/// Above this mean ΔE00 of the factor model on the spectra's own light × reflectance pairs (against full
/// 31-sample colour), `basis`, `solve`, `render` and the designer warn that the model is poor.
pub const POOR_MODEL_MEAN_DE00: f64 = 1.0;

/// At most this many bases are kept in memory (the oldest go first).
pub(crate) const MEMORY_ENTRIES: usize = 64;

/// A basis and its report, shared.
pub type Resolved = Arc<(Basis, Report)>;

#[derive(Default)]
struct Memory {
    entries: HashMap<String, Resolved>,
    order: Vec<String>,
}

fn memory() -> &'static Mutex<Memory> {
    static MEMORY: OnceLock<Mutex<Memory>> = OnceLock::new();
    MEMORY.get_or_init(Mutex::default)
}

/// The basis of dimension m for these spectra: from memory, else from `sidecar`, else trained (and stored
/// in both). The returned report has `from_cache` set for a memory or sidecar hit.
pub fn basis_for(set: &TrainingSet, m: usize, sidecar: Option<&Path>) -> Result<Resolved, StoreError> {
    let key = store::cache_key(set, m);
    if let Some(hit) = cached(&key) {
        return Ok(hit);
    }
    let (basis, report) = store::for_set(set, m, sidecar, &TrainOptions::default())?;
    let resolved: Resolved = Arc::new((basis, report));
    let mut stored = resolved.clone();
    if let Ok(mut mem) = memory().lock() {
        // Another thread may have trained the same spectra meanwhile: keep the first, so every caller of
        // one key sees one basis.
        if let Some(existing) = mem.entries.get(&key) {
            stored = existing.clone();
        } else {
            if mem.order.len() >= MEMORY_ENTRIES {
                let oldest = mem.order.remove(0);
                mem.entries.remove(&oldest);
            }
            let mut hit = (*resolved).clone();
            hit.1.from_cache = true;
            mem.entries.insert(key.clone(), Arc::new(hit));
            mem.order.push(key);
        }
    }
    Ok(if Arc::ptr_eq(&stored, &resolved) { resolved } else { stored })
}

/// The basis of a palette's spectra (designed ones at their current samples) of its `basis_dimension`.
pub fn basis_for_palette(palette: &Palette, sidecar: Option<&Path>) -> Result<Resolved, StoreError> {
    basis_for(&TrainingSet::from_palette(palette)?, palette.settings.basis_dimension, sidecar)
}

/// A basis already in memory under this key, without any work.
pub fn cached(key: &str) -> Option<Resolved> {
    memory().lock().ok().and_then(|m| m.entries.get(key).cloned())
}

impl Report {
    /// When the factor model is poor on the spectra's own pairs: a plain sentence with the fix.
    pub fn poor_model(&self) -> Option<String> {
        let f = &self.accuracy.factor_model;
        (f.count > 0 && (f.mean.is_nan() || f.mean > POOR_MODEL_MEAN_DE00)).then(|| {
            format!(
                "the spectral factor model (m = {}) is poor for these spectra: mean ΔE00 {:.2} (p95 {:.2}) against \
                 full 31-sample colour on their own {} light × reflectance pairs, above {POOR_MODEL_MEAN_DE00}; \
                 factor-mode frames and V7 colours will be off. Fix: raise basis_dimension, add the \
                 subspace_error weight, or set fit_in_subspace",
                self.dimension, f.mean, f.p95, f.count
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::Colorimetry;

    #[test]
    fn a_second_call_is_a_memory_hit_with_the_same_basis() {
        let c = Colorimetry::default();
        let full = TrainingSet::colorchecker_seven_lights(&c);
        let set = TrainingSet::new(vec![full.lights[0], full.lights[4]], full.reflectances[3..7].to_vec()).unwrap();
        let first = basis_for(&set, 4, None).unwrap();
        let key = store::cache_key(&set, 4);
        let hit = cached(&key).expect("in memory after the first call");
        assert!(hit.1.from_cache);
        let second = basis_for(&set, 4, None).unwrap();
        // The very same stored basis and report: no training, no accuracy work.
        assert!(Arc::ptr_eq(&hit, &second));
        assert_eq!(first.0, second.0);
        assert_eq!(first.1.accuracy, second.1.accuracy);
        // Another m is another basis.
        assert!(cached(&store::cache_key(&set, 5)).is_none());
    }

    #[test]
    fn a_poor_model_says_so_with_the_fix() {
        let c = Colorimetry::default();
        let full = TrainingSet::colorchecker_seven_lights(&c);
        // Seven lights × 24 reflectances with m = 3 cannot be held by the factor model.
        let resolved = basis_for(&full, 3, None).unwrap();
        let mean = resolved.1.accuracy.factor_model.mean;
        assert!(mean > POOR_MODEL_MEAN_DE00, "{mean}");
        let w = resolved.1.poor_model().expect("warned");
        assert!(w.contains("raise basis_dimension") && w.contains("subspace_error") && w.contains("fit_in_subspace"));
        let small = TrainingSet::new(vec![full.lights[0]], full.reflectances[..4].to_vec()).unwrap();
        let good = basis_for(&small, 5, None).unwrap();
        assert!(good.1.poor_model().is_none(), "{:?}", good.1.accuracy.factor_model);
    }
}
