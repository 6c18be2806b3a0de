//! Editing the criteria along the light dial (for the terminal designer): a `[[mixtures]]` or `[[paths]]`
//! entry's target, weight, use and free group, a path's samples and tolerance, adding a mixture at a dial
//! position and removing either. Pure data operations on [`Palette`], like [`super::edit`]; a refused
//! edit returns an [`EditError`] and changes nothing.

use super::edit::EditError;
use super::file::MAX_PATH_SAMPLES;
use super::mixing::dial_mix;
use super::{Kind, MixSpec, MixtureCell, Palette, TargetNotation};
use crate::render::dial::MAX_DIAL_COORDINATE;
use nalgebra::Vector3;

/// One criterion along the light dial: `palette.mixtures[k]` or `palette.paths[k]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DialEntry {
    /// `palette.mixtures[k]`.
    Mixture(usize),
    /// `palette.paths[k]`.
    Path(usize),
}

/// What a mixture and a path share: the colour kept (or its free group), the weight and the use flag.
struct Rest<'a> {
    target: &'a mut Vector3<f64>,
    weight: &'a mut f64,
    free: &'a mut Option<usize>,
    enabled: &'a mut bool,
}

fn no_such(which: DialEntry) -> EditError {
    match which {
        DialEntry::Mixture(k) => EditError::NoSuchCriterion { table: "mixtures", index: k },
        DialEntry::Path(k) => EditError::NoSuchCriterion { table: "paths", index: k },
    }
}

impl Palette {
    /// The criteria along the dial, mixtures first, then paths (the designer's list order).
    pub fn dial_entries(&self) -> Vec<DialEntry> {
        (0..self.mixtures.len()).map(DialEntry::Mixture).chain((0..self.paths.len()).map(DialEntry::Path)).collect()
    }

    fn rest_mut(&mut self, which: DialEntry) -> Result<Rest<'_>, EditError> {
        match which {
            DialEntry::Mixture(k) => self.mixtures.get_mut(k).map(|m| Rest {
                target: &mut m.target,
                weight: &mut m.weight,
                free: &mut m.free,
                enabled: &mut m.enabled,
            }),
            DialEntry::Path(k) => self.paths.get_mut(k).map(|q| Rest {
                target: &mut q.target,
                weight: &mut q.weight,
                free: &mut q.free,
                enabled: &mut q.enabled,
            }),
        }
        .ok_or(no_such(which))
    }

    /// Set a mixture's or path's target (linear sRGB).
    pub fn set_dial_target(&mut self, which: DialEntry, rgb: Vector3<f64>) -> Result<(), EditError> {
        if let Some(v) = rgb.iter().find(|v| !v.is_finite()) {
            return Err(EditError::BadNumber { what: "a target channel", rule: "finite", value: *v });
        }
        *self.rest_mut(which)?.target = rgb;
        Ok(())
    }

    /// Set a mixture's or path's weight (finite, ≥ 0; 0 leaves it out of the design).
    pub fn set_dial_weight(&mut self, which: DialEntry, weight: f64) -> Result<(), EditError> {
        if !(weight.is_finite() && weight >= 0.0) {
            return Err(EditError::BadNumber { what: "a weight", rule: "a finite number ≥ 0", value: weight });
        }
        *self.rest_mut(which)?.weight = weight;
        Ok(())
    }

    /// Put a mixture or path in or out of use (`use = false` keeps it in the file but out of the design).
    pub fn set_dial_enabled(&mut self, which: DialEntry, enabled: bool) -> Result<(), EditError> {
        *self.rest_mut(which)?.enabled = enabled;
        Ok(())
    }

    /// Put a mixture or path into free group `group`, or take it out (`None`: its own target again).
    pub fn set_dial_free(&mut self, which: DialEntry, group: Option<usize>) -> Result<(), EditError> {
        if let Some(g) = group
            && g >= self.free.len()
        {
            return Err(EditError::NoSuchFreeGroup(g));
        }
        *self.rest_mut(which)?.free = group;
        Ok(())
    }

    /// Set the number of design samples of path `k` (2 to [`MAX_PATH_SAMPLES`], as the file allows).
    pub fn set_path_samples(&mut self, k: usize, samples: usize) -> Result<(), EditError> {
        if !(2..=MAX_PATH_SAMPLES).contains(&samples) {
            return Err(EditError::BadCount {
                what: "a path's samples",
                low: 2,
                high: MAX_PATH_SAMPLES,
                value: samples,
            });
        }
        self.paths.get_mut(k).ok_or(no_such(DialEntry::Path(k)))?.samples = samples;
        Ok(())
    }

    /// Set the tolerance (the largest ΔE00 allowed along the path) of path `k`: finite and > 0.
    pub fn set_path_tolerance(&mut self, k: usize, tolerance: f64) -> Result<(), EditError> {
        if !(tolerance.is_finite() && tolerance > 0.0) {
            return Err(EditError::BadNumber { what: "a tolerance", rule: "a finite ΔE00 > 0", value: tolerance });
        }
        self.paths.get_mut(k).ok_or(no_such(DialEntry::Path(k)))?.tolerance = tolerance;
        Ok(())
    }

    /// Remove a mixture or a path (the later ones move up by one).
    pub fn remove_dial_entry(&mut self, which: DialEntry) -> Result<(), EditError> {
        match which {
            DialEntry::Mixture(k) if k < self.mixtures.len() => drop(self.mixtures.remove(k)),
            DialEntry::Path(k) if k < self.paths.len() => drop(self.paths.remove(k)),
            _ => return Err(no_such(which)),
        }
        Ok(())
    }

    /// Add a target for reflectance `reflectance` under the dial's light at `at` with the lights `off`
    /// switched off — the Shepard weights of the palette's own dial (as a `dial = [x, y]` mixture in the
    /// file reads) — with target `rgb`, weight 1, in use. Returns its index in [`Palette::mixtures`].
    pub fn add_dial_mixture(
        &mut self,
        reflectance: usize,
        at: [f64; 2],
        off: Vec<usize>,
        rgb: Vector3<f64>,
    ) -> Result<usize, EditError> {
        if reflectance >= self.reflectances.len() {
            return Err(EditError::NoSuchEntry { kind: Kind::Reflectance, index: reflectance });
        }
        if let Some(&i) = off.iter().find(|&&i| i >= self.lights.len()) {
            return Err(EditError::NoSuchEntry { kind: Kind::Light, index: i });
        }
        if !self.lights.iter().any(|l| l.dial.is_some()) {
            return Err(EditError::NotOnDial);
        }
        if let Some(v) = at.iter().find(|v| !(v.is_finite() && v.abs() <= MAX_DIAL_COORDINATE)) {
            return Err(EditError::BadNumber { what: "a dial coordinate", rule: "finite, within ±1e6", value: *v });
        }
        let mut off = off;
        off.sort_unstable();
        off.dedup();
        if off.len() >= self.lights.len() {
            return Err(EditError::AllOff);
        }
        let mix = dial_mix(&self.lights, at, &off).map_err(|e| EditError::Dial(e.to_string()))?;
        if mix.is_empty() {
            return Err(EditError::AllOff);
        }
        if let Some(v) = rgb.iter().find(|v| !v.is_finite()) {
            return Err(EditError::BadNumber { what: "a target channel", rule: "finite", value: *v });
        }
        self.add_mixture(MixtureCell {
            reflectance,
            mix,
            spec: MixSpec::Dial { at, off },
            target: rgb,
            notation: TargetNotation::Hex,
            weight: 1.0,
            free: None,
            enabled: true,
        })
    }

    /// Add a target under explicit weights `mix` (light index, weight ≥ 0, not all 0) for reflectance
    /// `reflectance`, target `rgb`. Returns its index in [`Palette::mixtures`].
    pub fn add_weighted_mixture(
        &mut self,
        reflectance: usize,
        weights: &[(usize, f64)],
        rgb: Vector3<f64>,
    ) -> Result<usize, EditError> {
        if reflectance >= self.reflectances.len() {
            return Err(EditError::NoSuchEntry { kind: Kind::Reflectance, index: reflectance });
        }
        let mut w = vec![0.0; self.lights.len()];
        for &(i, x) in weights {
            if i >= self.lights.len() {
                return Err(EditError::NoSuchEntry { kind: Kind::Light, index: i });
            }
            if !(x.is_finite() && x >= 0.0) {
                return Err(EditError::BadNumber { what: "a mixture weight", rule: "a finite number ≥ 0", value: x });
            }
            w[i] += x;
        }
        if w.iter().sum::<f64>() <= 0.0 {
            return Err(EditError::AllOff);
        }
        if let Some(v) = rgb.iter().find(|v| !v.is_finite()) {
            return Err(EditError::BadNumber { what: "a target channel", rule: "finite", value: *v });
        }
        self.add_mixture(MixtureCell {
            reflectance,
            mix: super::mixing::mix_of(&w),
            spec: MixSpec::Weights,
            target: rgb,
            notation: TargetNotation::Hex,
            weight: 1.0,
            free: None,
            enabled: true,
        })
    }

    fn add_mixture(&mut self, m: MixtureCell) -> Result<usize, EditError> {
        self.mixtures.push(m);
        Ok(self.mixtures.len() - 1)
    }

    /// Resolve every `dial = [x, y]` mixture's weights again over the lights as they are now (after a
    /// light was added: the dial's Shepard weights are over every light, so a new light changes them, as
    /// reading the saved file would).
    pub(crate) fn re_resolve_dial_mixtures(&mut self) -> Result<(), EditError> {
        let lights = &self.lights;
        let mut fresh = Vec::with_capacity(self.mixtures.len());
        for m in &self.mixtures {
            fresh.push(match &m.spec {
                MixSpec::Dial { at, off } => {
                    Some(dial_mix(lights, *at, off).map_err(|e| EditError::Dial(e.to_string()))?)
                }
                MixSpec::Weights => None,
            });
        }
        for (m, mix) in self.mixtures.iter_mut().zip(fresh) {
            if let Some(mix) = mix {
                m.mix = mix;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::Colorimetry;
    use crate::palette::{PathConstancy, Route, Source};

    /// Three lights on the dial, two reflectances, one free group, one mixture of each kind and one path.
    fn palette() -> Palette {
        let c = Colorimetry::default();
        let mut p = Palette::default();
        for (name, at) in [("day", [0.0, 0.0]), ("lamp", [1.0, 0.0]), ("glow", [0.5, 0.8])] {
            let i = p.add_spectrum(Kind::Light, name, Source::Illuminant("D65".into()), &c).unwrap();
            p.lights[i].dial = Some(at);
        }
        p.add_spectrum(Kind::Reflectance, "leaf", Source::ColorChecker("foliage".into()), &c).unwrap();
        p.add_spectrum(Kind::Reflectance, "grey", Source::Flat(0.5), &c).unwrap();
        p.add_free_group("A", Vector3::zeros(), Vector3::repeat(1.0)).unwrap();
        p.add_weighted_mixture(0, &[(0, 0.5), (1, 0.5)], Vector3::new(0.1, 0.2, 0.1)).unwrap();
        p.paths.push(PathConstancy {
            reflectance: 1,
            route: Route::Lights(vec![0, 1]),
            target: Vector3::repeat(0.2),
            notation: TargetNotation::Hex,
            weight: 1.0,
            free: None,
            enabled: true,
            samples: 9,
            tolerance: 1.0,
        });
        p
    }

    #[test]
    fn targets_weights_use_and_groups_of_mixtures_and_paths() {
        let mut p = palette();
        let (m, q) = (DialEntry::Mixture(0), DialEntry::Path(0));
        assert_eq!(p.dial_entries(), vec![m, q]);
        p.set_dial_target(m, Vector3::new(0.3, 0.2, 0.1)).unwrap();
        assert_eq!(p.mixtures[0].target, Vector3::new(0.3, 0.2, 0.1));
        assert!(p.set_dial_target(q, Vector3::new(f64::NAN, 0.0, 0.0)).is_err());
        p.set_dial_weight(q, 2.5).unwrap();
        assert_eq!(p.paths[0].weight, 2.5);
        assert!(p.set_dial_weight(m, -1.0).is_err());
        p.set_dial_enabled(m, false).unwrap();
        assert!(!p.mixtures[0].is_active());
        p.set_dial_free(q, Some(0)).unwrap();
        assert_eq!(p.paths[0].free, Some(0));
        assert!(matches!(p.set_dial_free(m, Some(3)), Err(EditError::NoSuchFreeGroup(3))));
        p.set_path_samples(0, 17).unwrap();
        assert_eq!(p.paths[0].samples, 17);
        assert!(p.set_path_samples(0, 1).is_err() && p.set_path_samples(0, MAX_PATH_SAMPLES + 1).is_err());
        p.set_path_tolerance(0, 0.5).unwrap();
        assert_eq!(p.paths[0].tolerance, 0.5);
        assert!(p.set_path_tolerance(0, 0.0).is_err() && p.set_path_tolerance(0, f64::INFINITY).is_err());
        let e = p.set_dial_weight(DialEntry::Path(4), 1.0).unwrap_err();
        assert_eq!(e.to_string(), "there is no paths[4]");
        let before = p.clone();
        assert!(p.remove_dial_entry(DialEntry::Mixture(1)).is_err());
        assert_eq!(p, before, "a refused edit changes nothing");
        p.remove_dial_entry(m).unwrap();
        assert!(p.mixtures.is_empty() && p.paths.len() == 1);
        p.remove_dial_entry(q).unwrap();
        assert!(p.dial_entries().is_empty());
    }

    /// A mixture added at a dial point has the weights a `dial = [x, y]` mixture of the file gets: the
    /// renderer's Shepard weights over the palette's vertices, the lights off left out.
    #[test]
    fn a_mixture_added_at_a_dial_point_has_the_dials_weights() {
        let mut p = palette();
        let rgb = Vector3::new(0.2, 0.3, 0.1);
        let k = p.add_dial_mixture(1, [0.4, 0.3], vec![2], rgb).unwrap();
        let m = &p.mixtures[k];
        assert_eq!(m.mix, dial_mix(&p.lights, [0.4, 0.3], &[2]).unwrap());
        assert!(m.mix.iter().all(|&(i, _)| i != 2), "glow is off");
        assert!((m.mix.iter().map(|w| w.1).sum::<f64>() - 1.0).abs() < 1e-12);
        assert_eq!((m.reflectance, m.target, m.weight, m.free, m.enabled), (1, rgb, 1.0, None, true));
        assert_eq!(m.spec, MixSpec::Dial { at: [0.4, 0.3], off: vec![2] });
        assert!(matches!(p.add_dial_mixture(1, [0.0, 0.0], vec![0, 1, 2], rgb), Err(EditError::AllOff)));
        assert!(p.add_dial_mixture(5, [0.0, 0.0], vec![], rgb).is_err());
        assert!(p.add_dial_mixture(0, [f64::NAN, 0.0], vec![], rgb).is_err());
        assert!(p.add_weighted_mixture(0, &[(0, 0.0)], rgb).is_err());
        assert_eq!(p.mixtures.len(), 2, "refused additions add nothing");
    }

    /// A light added to the palette moves every dial mixture's weights (Shepard weights are over every
    /// light), as reading the saved file does; explicit weights stay as written.
    #[test]
    fn adding_a_light_re_resolves_dial_mixtures() {
        let c = Colorimetry::default();
        let mut p = palette();
        let k = p.add_dial_mixture(0, [0.4, 0.3], vec![], Vector3::zeros()).unwrap();
        let weighted = p.mixtures[0].mix.clone();
        let before = p.mixtures[k].mix.clone();
        let i = p.add_spectrum(Kind::Light, "new", Source::Illuminant("A".into()), &c).unwrap();
        assert_ne!(p.mixtures[k].mix, before);
        assert!(p.mixtures[k].mix.iter().any(|&(l, _)| l == i));
        assert_eq!(p.mixtures[k].mix, dial_mix(&p.lights, [0.4, 0.3], &[]).unwrap());
        assert_eq!(p.mixtures[0].mix, weighted);
    }
}
