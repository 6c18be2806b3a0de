//! Editing a palette (for the terminal designer): pure data operations on [`Palette`] that keep it
//! consistent — indices of cells and free groups follow removals, names stay unique, and every change of
//! a spectrum's source, normalisation or scale re-resolves its samples.

use super::source::{SourceError, finish, spectra_agree};
use super::{ColourCell, FreeGroup, Kind, Palette, Source, SpectrumEntry, TargetNotation};
use crate::colorimetry::Colorimetry;
use crate::spectrum::{Normalize, NormalizeError, Spectrum};
use nalgebra::Vector3;

/// Why an edit was refused (the palette is then unchanged).
#[derive(Debug, thiserror::Error)]
pub enum EditError {
    /// The index is past the end of the light or reflectance list.
    #[error("there is no {} number {index}", kind.as_str())]
    NoSuchEntry {
        /// Which list was indexed.
        kind: Kind,
        /// The index asked for, into [`Palette::lights`] or [`Palette::reflectances`].
        index: usize,
    },
    /// The free group index (the number) is past the end of [`Palette::free`].
    #[error("there is no free group number {0}")]
    NoSuchFreeGroup(usize),
    /// No colour cell joins this light and this reflectance.
    #[error("light {light} on reflectance {reflectance} has no colour cell")]
    NoSuchCell {
        /// Index into [`Palette::lights`].
        light: usize,
        /// Index into [`Palette::reflectances`].
        reflectance: usize,
    },
    /// Another light (or reflectance) already has the name.
    #[error("a {} named `{name}` already exists", kind.as_str())]
    DuplicateName {
        /// The list in which the name clashes.
        kind: Kind,
        /// The name asked for.
        name: String,
    },
    /// The free group name is already used by another group; the string is that name.
    #[error("a free group named `{0}` already exists")]
    DuplicateFreeGroup(String),
    /// A light, reflectance or free group was given an empty (or all-blank) name.
    #[error("a name must not be empty")]
    EmptyName,
    /// The entry is named by `[[mixtures]]` or `[[paths]]` tables, whose meaning a removal would change.
    #[error("{what} is used by {by}: remove or edit those tables in the file first")]
    InUse {
        /// What the removal would take away, for the message (e.g. "reflectance `grey`").
        what: String,
        /// The tables that use it, for the message (e.g. "mixtures[0], paths[1]").
        by: String,
    },
    /// There is no `[[mixtures]]` (or `[[paths]]`) entry at that index.
    #[error("there is no {table}[{index}]")]
    NoSuchCriterion {
        /// `mixtures` or `paths`.
        table: &'static str,
        /// The index asked for.
        index: usize,
    },
    /// A count outside the range the file format allows (a path's samples).
    #[error("{what} must be {low} to {high}, got {value}")]
    BadCount {
        /// What the count is, for the message.
        what: &'static str,
        /// The smallest allowed.
        low: usize,
        /// The largest allowed.
        high: usize,
        /// The count given.
        value: usize,
    },
    /// A dial position was given but no light of the palette is placed on the dial.
    #[error("a dial position needs lights placed on the dial: no light of the palette has `dial = [x, y]`")]
    NotOnDial,
    /// A mixture would be black: every light off, or every weight 0.
    #[error("the mixture would be black: switch a light on (or give one a weight > 0)")]
    AllOff,
    /// The dial refused the position or the lights (the renderer's reason).
    #[error("{0}")]
    Dial(String),
    /// A number outside what the edit accepts (NaN, infinite, or a negative weight).
    #[error("{what} must be {rule}, got {value}")]
    BadNumber {
        /// What the number is, for the message (`scale`, `a weight`, `a target channel`, `a bound`).
        what: &'static str,
        /// What it must be, for the message (`a finite number ≥ 0`, …).
        rule: &'static str,
        /// The number given.
        value: f64,
    },
    /// A new free group's lower bound is above its upper bound on some channel.
    #[error("inverted bounds: lower {lower} is above upper {upper}")]
    InvertedBounds {
        /// That channel's lower bound, linear sRGB.
        lower: f64,
        /// That channel's upper bound, linear sRGB.
        upper: f64,
    },
    /// A normalisation was asked of a reflectance; reflectances are never normalised.
    #[error("only lights are normalised")]
    NotALight,
    /// A designed or edited spectrum has scale 0, so dividing by the old scale cannot recover its samples.
    #[error("the samples were scaled by 0, so their shape cannot be recovered: set a source first")]
    ZeroScale,
    /// A source gave no samples (adding a spectrum or changing its source): an unknown built-in name, a bad
    /// temperature, a wrong sample count, …
    #[error(transparent)]
    Source(#[from] SourceError),
    /// A light could not be normalised (zero luminance or norm) or its resolved samples are not finite.
    #[error(transparent)]
    Normalize(#[from] NormalizeError),
}

fn check_number(what: &'static str, rule: &'static str, value: f64, ok: bool) -> Result<(), EditError> {
    if ok { Ok(()) } else { Err(EditError::BadNumber { what, rule, value }) }
}

impl Palette {
    /// The entries of one side, for editing.
    pub fn entries_mut(&mut self, kind: Kind) -> &mut Vec<SpectrumEntry> {
        match kind {
            Kind::Light => &mut self.lights,
            Kind::Reflectance => &mut self.reflectances,
        }
    }

    fn entry_mut(&mut self, kind: Kind, index: usize) -> Result<&mut SpectrumEntry, EditError> {
        self.entries_mut(kind).get_mut(index).ok_or(EditError::NoSuchEntry { kind, index })
    }

    fn check_new_name(&self, kind: Kind, name: &str, except: Option<usize>) -> Result<(), EditError> {
        if name.trim().is_empty() {
            return Err(EditError::EmptyName);
        }
        let clash = self.entries(kind).iter().enumerate().any(|(i, e)| e.name == name && Some(i) != except);
        if clash { Err(EditError::DuplicateName { kind, name: name.to_string() }) } else { Ok(()) }
    }

    /// Add a light or reflectance from a built-in source (not `csv`: that needs the file's folder, see
    /// [`Palette::add_spectrum_in`]), with the default normalisation and scale 1, not designed. Returns its index.
    pub fn add_spectrum(
        &mut self,
        kind: Kind,
        name: &str,
        source: Source,
        colorimetry: &Colorimetry,
    ) -> Result<usize, EditError> {
        self.add_spectrum_in(kind, name, source, None, colorimetry)
    }

    /// [`Palette::add_spectrum`] for any source: a `csv` path is read relative to `base_dir` (the palette
    /// file's folder).
    pub fn add_spectrum_in(
        &mut self,
        kind: Kind,
        name: &str,
        source: Source,
        base_dir: Option<&std::path::Path>,
        colorimetry: &Colorimetry,
    ) -> Result<usize, EditError> {
        self.check_new_name(kind, name, None)?;
        let raw = source.raw_spectrum(base_dir)?;
        let normalize = Normalize::default();
        let spectrum = finish(&raw, kind, normalize, 1.0, &colorimetry.luminance())?;
        let entries = self.entries_mut(kind);
        entries.push(SpectrumEntry::resolved(name, kind, source, normalize, spectrum));
        let index = entries.len() - 1;
        if kind == Kind::Light
            && let Err(e) = self.re_resolve_dial_mixtures()
        {
            self.lights.pop();
            return Err(e);
        }
        Ok(index)
    }

    /// Remove a light or reflectance with its colour cells; the cells of later entries are re-indexed, and
    /// so are the `[[mixtures]]` and `[[paths]]` that name later reflectances. Refused (nothing changes)
    /// for a reflectance a mixture or path uses, and for any light while the palette has mixtures or paths:
    /// their weights and routes were resolved over all the lights (the dial's Shepard weights move when a
    /// light goes), so no re-indexing keeps them meaning what the file says.
    pub fn remove_spectrum(&mut self, kind: Kind, index: usize) -> Result<SpectrumEntry, EditError> {
        if index >= self.entries(kind).len() {
            return Err(EditError::NoSuchEntry { kind, index });
        }
        let name = &self.entries(kind)[index].name;
        let users = match kind {
            Kind::Light => self.dial_criteria(),
            Kind::Reflectance => self.dial_users(|r, _| r == index),
        };
        if let Some(by) = users {
            return Err(EditError::InUse { what: format!("{} `{name}`", kind.as_str()), by });
        }
        let removed = self.entries_mut(kind).remove(index);
        if kind == Kind::Reflectance {
            let shift = |r: &mut usize| *r -= usize::from(*r > index);
            self.mixtures.iter_mut().for_each(|m| shift(&mut m.reflectance));
            self.paths.iter_mut().for_each(|q| shift(&mut q.reflectance));
        }
        fn side(kind: Kind, c: &mut ColourCell) -> &mut usize {
            match kind {
                Kind::Light => &mut c.light,
                Kind::Reflectance => &mut c.reflectance,
            }
        }
        self.colours.retain_mut(|c| *side(kind, c) != index);
        for c in &mut self.colours {
            let i = side(kind, c);
            if *i > index {
                *i -= 1;
            }
        }
        Ok(removed)
    }

    /// Rename a light or reflectance (names stay unique; cells refer by index so they follow).
    pub fn rename_spectrum(&mut self, kind: Kind, index: usize, name: &str) -> Result<(), EditError> {
        self.check_new_name(kind, name, Some(index))?;
        self.entry_mut(kind, index)?.name = name.to_string();
        Ok(())
    }

    /// The `[[mixtures]]` and `[[paths]]` whose (reflectance, free group) `uses`, as words
    /// (`mixtures[0] and paths[2]`), or `None` when none does.
    fn dial_users(&self, uses: impl Fn(usize, Option<usize>) -> bool) -> Option<String> {
        let mixtures = self.mixtures.iter().enumerate().filter(|(_, m)| uses(m.reflectance, m.free));
        let paths = self.paths.iter().enumerate().filter(|(_, q)| uses(q.reflectance, q.free));
        let named: Vec<String> =
            mixtures.map(|(k, _)| format!("mixtures[{k}]")).chain(paths.map(|(k, _)| format!("paths[{k}]"))).collect();
        (!named.is_empty()).then(|| named.join(" and "))
    }

    /// Rename a free-colour group (names stay unique; cells, mixtures and paths refer by index so they
    /// follow, and saving writes the new name wherever the file named the old one).
    pub fn rename_free_group(&mut self, index: usize, name: &str) -> Result<(), EditError> {
        if name.trim().is_empty() {
            return Err(EditError::EmptyName);
        }
        if self.free.iter().enumerate().any(|(g, f)| f.name == name && g != index) {
            return Err(EditError::DuplicateFreeGroup(name.to_string()));
        }
        self.free.get_mut(index).ok_or(EditError::NoSuchFreeGroup(index))?.name = name.to_string();
        Ok(())
    }

    /// Flip whether a spectrum is designed; returns the new state.
    pub fn toggle_design(&mut self, kind: Kind, index: usize) -> Result<bool, EditError> {
        let e = self.entry_mut(kind, index)?;
        e.design = !e.design;
        Ok(e.design)
    }

    /// Make a spectrum a Planck black body at `kelvin` (keeping its normalisation and scale).
    pub fn make_planck(
        &mut self,
        kind: Kind,
        index: usize,
        kelvin: f64,
        colorimetry: &Colorimetry,
    ) -> Result<(), EditError> {
        let e = self.entry_mut(kind, index)?;
        let source = Source::Planck(kelvin);
        let spectrum = finish(&source.raw_spectrum(None)?, e.kind, e.normalize, e.scale, &colorimetry.luminance())?;
        e.source = source;
        e.spectrum = spectrum;
        Ok(())
    }

    /// Set a light's normalisation and re-resolve its samples.
    pub fn set_normalize(&mut self, index: usize, how: Normalize, colorimetry: &Colorimetry) -> Result<(), EditError> {
        let e = self.entry_mut(Kind::Light, index)?;
        let scale = e.scale;
        re_resolve(e, Some(how), scale, colorimetry)
    }

    /// Normalise a light to luminance 1 (before its scale).
    #[cfg(test)]
    pub(crate) fn normalize_luminance(&mut self, index: usize, colorimetry: &Colorimetry) -> Result<(), EditError> {
        self.set_normalize(index, Normalize::Luminance, colorimetry)
    }

    /// Normalise a light to unit L2 norm (before its scale).
    #[cfg(test)]
    pub(crate) fn normalize_l2(&mut self, index: usize, colorimetry: &Colorimetry) -> Result<(), EditError> {
        self.set_normalize(index, Normalize::L2, colorimetry)
    }

    /// Set a spectrum's scale and re-resolve its samples.
    pub fn set_scale(
        &mut self,
        kind: Kind,
        index: usize,
        scale: f64,
        colorimetry: &Colorimetry,
    ) -> Result<(), EditError> {
        check_number("scale", "a finite number", scale, scale.is_finite())?;
        re_resolve(self.entry_mut(kind, index)?, None, scale, colorimetry)
    }

    /// Index of the colour cell at (light, reflectance).
    pub fn cell_index(&self, light: usize, reflectance: usize) -> Option<usize> {
        self.colours.iter().position(|c| c.light == light && c.reflectance == reflectance)
    }

    /// The cell at (light, reflectance), created (target black, weight 1, in use) when there is none.
    fn cell_mut_or_new(&mut self, light: usize, reflectance: usize) -> Result<&mut ColourCell, EditError> {
        if light >= self.lights.len() {
            return Err(EditError::NoSuchEntry { kind: Kind::Light, index: light });
        }
        if reflectance >= self.reflectances.len() {
            return Err(EditError::NoSuchEntry { kind: Kind::Reflectance, index: reflectance });
        }
        let i = match self.cell_index(light, reflectance) {
            Some(i) => i,
            None => {
                self.colours.push(ColourCell {
                    light,
                    reflectance,
                    target: Vector3::zeros(),
                    notation: TargetNotation::Hex,
                    weight: 1.0,
                    free: None,
                    enabled: true,
                });
                self.colours.len() - 1
            }
        };
        Ok(&mut self.colours[i])
    }

    fn cell_mut(&mut self, light: usize, reflectance: usize) -> Result<&mut ColourCell, EditError> {
        let i = self.cell_index(light, reflectance).ok_or(EditError::NoSuchCell { light, reflectance })?;
        Ok(&mut self.colours[i])
    }

    /// Set the target (linear sRGB) of the cell at (light, reflectance), creating the cell if needed.
    pub fn set_target(&mut self, light: usize, reflectance: usize, rgb: Vector3<f64>) -> Result<(), EditError> {
        if let Some(v) = rgb.iter().find(|v| !v.is_finite()) {
            return Err(EditError::BadNumber { what: "a target channel", rule: "finite", value: *v });
        }
        self.cell_mut_or_new(light, reflectance)?.target = rgb;
        Ok(())
    }

    /// Remove the cell at (light, reflectance) — its target, weight and free group — if there is one.
    #[cfg(test)]
    pub(crate) fn clear_cell(&mut self, light: usize, reflectance: usize) -> Option<ColourCell> {
        self.cell_index(light, reflectance).map(|i| self.colours.remove(i))
    }

    /// Set the weight of an existing cell.
    pub fn set_weight(&mut self, light: usize, reflectance: usize, weight: f64) -> Result<(), EditError> {
        check_number("a weight", "a finite number ≥ 0", weight, weight.is_finite() && weight >= 0.0)?;
        self.cell_mut(light, reflectance)?.weight = weight;
        Ok(())
    }

    /// Put an existing cell in or out of use (`use = false` keeps it in the file but out of the design).
    pub fn set_enabled(&mut self, light: usize, reflectance: usize, enabled: bool) -> Result<(), EditError> {
        self.cell_mut(light, reflectance)?.enabled = enabled;
        Ok(())
    }

    /// Put the cell at (light, reflectance) into a free group (creating the cell if needed), or take it out.
    pub fn set_free(&mut self, light: usize, reflectance: usize, group: Option<usize>) -> Result<(), EditError> {
        if let Some(g) = group
            && g >= self.free.len()
        {
            return Err(EditError::NoSuchFreeGroup(g));
        }
        match group {
            Some(_) => self.cell_mut_or_new(light, reflectance)?.free = group,
            None => self.cell_mut(light, reflectance)?.free = None,
        }
        Ok(())
    }

    /// Add a free-colour group with per-channel bounds in linear sRGB. Returns its index.
    pub fn add_free_group(&mut self, name: &str, lower: Vector3<f64>, upper: Vector3<f64>) -> Result<usize, EditError> {
        if name.trim().is_empty() {
            return Err(EditError::EmptyName);
        }
        if self.free.iter().any(|g| g.name == name) {
            return Err(EditError::DuplicateFreeGroup(name.to_string()));
        }
        for c in 0..3 {
            check_number("a bound", "a number (not NaN)", lower[c], !lower[c].is_nan())?;
            check_number("a bound", "a number (not NaN)", upper[c], !upper[c].is_nan())?;
            if lower[c] > upper[c] {
                return Err(EditError::InvertedBounds { lower: lower[c], upper: upper[c] });
            }
        }
        self.free.push(FreeGroup { name: name.to_string(), lower, upper });
        Ok(self.free.len() - 1)
    }

    /// Remove a free group: its cells leave it (keeping their targets), later groups are re-indexed (in
    /// cells, mixtures and paths). Refused while a mixture or path is in the group.
    pub fn remove_free_group(&mut self, index: usize) -> Result<FreeGroup, EditError> {
        if index >= self.free.len() {
            return Err(EditError::NoSuchFreeGroup(index));
        }
        if let Some(by) = self.dial_users(|_, g| g == Some(index)) {
            return Err(EditError::InUse { what: format!("free group `{}`", self.free[index].name), by });
        }
        let removed = self.free.remove(index);
        let follow = |free: &mut Option<usize>| {
            *free = match *free {
                Some(g) if g == index => None,
                Some(g) if g > index => Some(g - 1),
                other => other,
            }
        };
        self.colours.iter_mut().for_each(|c| follow(&mut c.free));
        self.mixtures.iter_mut().for_each(|m| follow(&mut m.free));
        self.paths.iter_mut().for_each(|q| follow(&mut q.free));
        Ok(removed)
    }

    /// The linear sRGB colour the current spectra give at (light, reflectance).
    pub(crate) fn colour_of(
        &self,
        light: usize,
        reflectance: usize,
        colorimetry: &Colorimetry,
    ) -> Option<Vector3<f64>> {
        let e = self.lights.get(light)?;
        let s = self.reflectances.get(reflectance)?;
        Some(colorimetry.rgb(&e.spectrum, &s.spectrum))
    }

    /// Set the target of the cell at (light, reflectance) to what the current spectra produce (creating the
    /// cell if needed).
    pub fn fit_cell(&mut self, light: usize, reflectance: usize, colorimetry: &Colorimetry) -> Result<(), EditError> {
        let rgb =
            self.colour_of(light, reflectance, colorimetry).ok_or(EditError::NoSuchCell { light, reflectance })?;
        self.set_target(light, reflectance, rgb)
    }

    /// Set every existing cell's target to what the current spectra produce.
    #[cfg(test)]
    pub(crate) fn fit_all(&mut self, colorimetry: &Colorimetry) {
        for i in 0..self.colours.len() {
            let (l, r) = (self.colours[i].light, self.colours[i].reflectance);
            if let Some(rgb) = self.colour_of(l, r, colorimetry) {
                self.colours[i].target = rgb;
            }
        }
    }
}

/// Re-resolve an entry's samples for a new normalisation (`None`: only the scale changes) and scale.
///
/// When the samples are what the source gives, they are recomputed from the source. When they were designed
/// or edited, the current samples divided by the old scale stand in for the source (and become the source):
/// a new normalisation applies to them, a new scale only rescales them (a designed spectrum is never
/// normalised again). A CSV source is not re-read by an edit: its samples are rescaled or renormalised
/// in place, which is what re-reading would give unless the samples were designed.
fn re_resolve(
    e: &mut SpectrumEntry,
    how: Option<Normalize>,
    scale: f64,
    colorimetry: &Colorimetry,
) -> Result<(), EditError> {
    if e.kind == Kind::Reflectance && how.is_some_and(|h| h != e.normalize) {
        return Err(EditError::NotALight);
    }
    let lum = colorimetry.luminance();
    let from_source = match &e.source {
        Source::Csv(_) => None,
        source => source.raw_spectrum(None).ok().filter(|raw| {
            finish(raw, e.kind, e.normalize, e.scale, &lum).is_ok_and(|r| spectra_agree(&r, &e.spectrum))
        }),
    };
    let (raw, normalize, new_source) = match from_source {
        Some(raw) => (raw, how.unwrap_or(e.normalize), None),
        None => {
            if e.scale == 0.0 {
                return Err(EditError::ZeroScale);
            }
            let current = e.spectrum.scaled(1.0 / e.scale);
            let csv = matches!(e.source, Source::Csv(_));
            match how {
                // Only the factor changes: the CSV source (normalised as before) still describes it.
                None if csv => (current, Normalize::None, None),
                None => (current, Normalize::None, Some(Source::Samples(current.to_vec()))),
                Some(h) => {
                    let csv_holds = csv && (e.normalize == Normalize::None || h != Normalize::None);
                    (current, h, (!csv_holds).then(|| Source::Samples(current.to_vec())))
                }
            }
        }
    };
    let spectrum: Spectrum = finish(&raw, e.kind, normalize, scale, &lum)?;
    let csv_keeps_normalize = matches!(e.source, Source::Csv(_)) && how.is_none();
    if let Some(s) = new_source {
        e.source = s;
    }
    if !csv_keeps_normalize {
        e.normalize = normalize;
    }
    e.scale = scale;
    e.spectrum = spectrum;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::palette::Settings;

    #[test]
    fn csv_spectra_are_read_relative_to_the_palette_folder() {
        let c = Colorimetry::default();
        let dir = tempfile::tempdir().unwrap();
        let rows: String = (0..=30).map(|i| format!("{},{}\n", 400 + 10 * i, 0.25)).collect();
        std::fs::write(dir.path().join("grey.csv"), rows).unwrap();
        let mut p = Palette::default();
        let source = Source::Csv("grey.csv".into());
        assert!(p.add_spectrum(Kind::Reflectance, "grey", source.clone(), &c).is_err());
        let i = p.add_spectrum_in(Kind::Reflectance, "grey", source, Some(dir.path()), &c).unwrap();
        assert!(p.reflectances[i].spectrum.0.iter().all(|v| (v - 0.25).abs() < 1e-12));
        let dup = p.add_spectrum_in(Kind::Reflectance, "grey", Source::Flat(1.0), Some(dir.path()), &c);
        assert!(dup.is_err());
    }

    fn palette() -> (Palette, Colorimetry) {
        let c = Colorimetry::default();
        let mut p = Palette { name: "t".into(), settings: Settings::default(), ..Default::default() };
        p.add_spectrum(Kind::Light, "d65", Source::Illuminant("D65".into()), &c).unwrap();
        p.add_spectrum(Kind::Light, "a", Source::Illuminant("A".into()), &c).unwrap();
        p.add_spectrum(Kind::Light, "f11", Source::Illuminant("F11".into()), &c).unwrap();
        p.add_spectrum(Kind::Reflectance, "red", Source::ColorChecker("red".into()), &c).unwrap();
        p.add_spectrum(Kind::Reflectance, "grey", Source::Flat(0.5), &c).unwrap();
        for l in 0..3 {
            for r in 0..2 {
                p.fit_cell(l, r, &c).unwrap();
            }
        }
        (p, c)
    }

    #[test]
    fn removing_a_light_drops_its_cells_and_reindexes() {
        let (mut p, c) = palette();
        assert_eq!(p.colours.len(), 6);
        let f11_on_grey = p.colour_of(2, 1, &c).unwrap();
        p.remove_spectrum(Kind::Light, 1).unwrap();
        assert_eq!(p.colours.len(), 4);
        assert!(p.colours.iter().all(|c| c.light < 2));
        // The former light 2 (F11) is now light 1 and its cell kept its target.
        let i = p.cell_index(1, 1).unwrap();
        assert_eq!(p.lights[1].name, "f11");
        assert!((p.colours[i].target - f11_on_grey).norm() < 1e-15);
        assert!(matches!(p.remove_spectrum(Kind::Light, 5), Err(EditError::NoSuchEntry { .. })));
        p.remove_spectrum(Kind::Reflectance, 0).unwrap();
        assert_eq!(p.colours.len(), 2);
        assert!(p.colours.iter().all(|c| c.reflectance == 0));
    }

    /// Removals keep the `[[mixtures]]` and `[[paths]]` pointing at what they named: a reflectance they use
    /// and any light (their weights are resolved over all lights) are refused, later reflectances and free
    /// groups are re-indexed in them.
    #[test]
    fn removals_keep_mixtures_and_paths_consistent() {
        let (mut p, _) = palette();
        let g = p.add_free_group("A", Vector3::zeros(), Vector3::repeat(1.0)).unwrap();
        let h = p.add_free_group("B", Vector3::zeros(), Vector3::repeat(1.0)).unwrap();
        p.mixtures.push(crate::palette::MixtureCell {
            reflectance: 1,
            mix: vec![(0, 0.5), (1, 0.5)],
            spec: crate::palette::MixSpec::Weights,
            target: Vector3::zeros(),
            notation: TargetNotation::Hex,
            weight: 1.0,
            free: Some(h),
            enabled: true,
        });
        let before = p.clone();
        assert!(matches!(p.remove_spectrum(Kind::Light, 2), Err(EditError::InUse { .. })));
        let e = p.remove_spectrum(Kind::Reflectance, 1).unwrap_err();
        assert_eq!(
            e.to_string(),
            "reflectance `grey` is used by mixtures[0]: remove or edit those tables in the file first"
        );
        assert!(matches!(p.remove_free_group(h), Err(EditError::InUse { .. })));
        assert_eq!(p, before, "a refused removal changes nothing");
        p.remove_spectrum(Kind::Reflectance, 0).unwrap();
        p.remove_free_group(g).unwrap();
        assert_eq!((p.mixtures[0].reflectance, p.mixtures[0].free), (0, Some(0)));
        assert_eq!(p.reflectances[0].name, "grey");
        p.rename_free_group(0, "warm").unwrap();
        assert_eq!(p.free[0].name, "warm");
        assert!(matches!(p.rename_free_group(3, "x"), Err(EditError::NoSuchFreeGroup(3))));
    }

    #[test]
    fn names_stay_unique() {
        let (mut p, c) = palette();
        assert!(matches!(p.rename_spectrum(Kind::Light, 0, "a"), Err(EditError::DuplicateName { .. })));
        assert!(matches!(p.rename_spectrum(Kind::Light, 0, " "), Err(EditError::EmptyName)));
        p.rename_spectrum(Kind::Light, 0, "d65").unwrap();
        p.rename_spectrum(Kind::Light, 0, "daylight").unwrap();
        assert_eq!(p.light_index("daylight"), Some(0));
        let dup = p.add_spectrum(Kind::Reflectance, "red", Source::Flat(1.0), &c);
        assert!(matches!(dup, Err(EditError::DuplicateName { .. })));
        // A light may share a name with a reflectance: they are different sides.
        p.add_spectrum(Kind::Light, "red", Source::Flat(1.0), &c).unwrap();
    }

    #[test]
    fn cells_targets_weights_and_groups() {
        let (mut p, _) = palette();
        p.set_target(0, 0, Vector3::new(0.1, 0.2, 0.3)).unwrap();
        assert_eq!(p.cell(0, 0).unwrap().target, Vector3::new(0.1, 0.2, 0.3));
        assert!(p.set_target(0, 0, Vector3::new(f64::NAN, 0.0, 0.0)).is_err());
        assert!(p.set_weight(0, 0, -1.0).is_err());
        p.set_weight(0, 0, 0.0).unwrap();
        assert!(!p.cell(0, 0).unwrap().is_active());
        p.set_enabled(0, 1, false).unwrap();
        assert!(!p.cell(0, 1).unwrap().enabled);
        let g = p.add_free_group("A", Vector3::zeros(), Vector3::repeat(1.0)).unwrap();
        let h = p.add_free_group("B", Vector3::zeros(), Vector3::repeat(1.0)).unwrap();
        assert!(p.add_free_group("B", Vector3::zeros(), Vector3::zeros()).is_err());
        assert!(p.add_free_group("C", Vector3::repeat(1.0), Vector3::zeros()).is_err());
        p.set_free(1, 0, Some(g)).unwrap();
        p.set_free(2, 0, Some(h)).unwrap();
        assert!(p.set_free(2, 0, Some(7)).is_err());
        p.remove_free_group(g).unwrap();
        assert_eq!(p.cell(1, 0).unwrap().free, None);
        assert_eq!(p.cell(2, 0).unwrap().free, Some(0), "later groups are re-indexed");
        assert!(p.clear_cell(2, 0).is_some());
        assert!(p.cell(2, 0).is_none());
        assert!(matches!(p.set_weight(2, 0, 1.0), Err(EditError::NoSuchCell { .. })));
    }

    #[test]
    fn normalisation_and_scale_re_resolve() {
        let (mut p, c) = palette();
        p.set_scale(Kind::Light, 1, 2.0, &c).unwrap();
        let y = c.xyz(&p.lights[1].spectrum, &Spectrum::flat(1.0))[1];
        assert!((y - 2.0).abs() < 1e-12, "luminance then scale 2: Y = {y}");
        p.normalize_l2(1, &c).unwrap();
        assert!((p.lights[1].spectrum.l2_norm() - 2.0).abs() < 1e-12);
        assert_eq!(p.lights[1].source, Source::Illuminant("A".into()), "the source is kept");
        assert!(matches!(p.set_normalize(0, Normalize::None, &c), Ok(())));
        assert_eq!(p.lights[0].spectrum, Spectrum::illuminant("D65").unwrap());
        // A designed (edited) light keeps its shape through a rescale and its source becomes the samples.
        let shape = Spectrum::from_slice(&(0..31).map(|i| 1.0 + i as f64).collect::<Vec<_>>()).unwrap();
        p.lights[2].spectrum = shape;
        p.set_scale(Kind::Light, 2, 3.0, &c).unwrap();
        assert!(spectra_agree(&p.lights[2].spectrum, &shape.scaled(3.0)));
        assert!(matches!(p.lights[2].source, Source::Samples(_)));
        assert_eq!(p.lights[2].normalize, Normalize::None, "designed samples are not normalised again");
        p.make_planck(Kind::Light, 2, 6500.0, &c).unwrap();
        assert_eq!(p.lights[2].spectrum, Spectrum::planck(6500.0).unwrap().scaled(3.0));
        p.normalize_luminance(2, &c).unwrap();
        let y = c.xyz(&p.lights[2].spectrum, &Spectrum::flat(1.0))[1];
        assert!((y - 3.0).abs() < 1e-12);
        assert!(p.make_planck(Kind::Light, 2, -1.0, &c).is_err());
        assert!(matches!(p.set_normalize(9, Normalize::L2, &c), Err(EditError::NoSuchEntry { .. })));
        // Reflectances are scaled, never normalised.
        p.set_scale(Kind::Reflectance, 1, 0.5, &c).unwrap();
        assert_eq!(p.reflectances[1].spectrum, Spectrum::flat(0.25));
    }

    #[test]
    fn fitting_sets_targets_to_current_colours() {
        let (mut p, c) = palette();
        p.set_target(1, 1, Vector3::zeros()).unwrap();
        p.set_target(2, 0, Vector3::repeat(9.0)).unwrap();
        p.fit_all(&c);
        for cell in &p.colours {
            let rgb = c.rgb(&p.lights[cell.light].spectrum, &p.reflectances[cell.reflectance].spectrum);
            assert_eq!(cell.target, rgb);
        }
        assert!(p.fit_cell(7, 0, &c).is_err());
        // Flat grey 0.5 under a luminance-normalised light has Y = 0.5.
        let y = c.rgb_to_xyz(&p.cell(0, 1).unwrap().target)[1];
        assert!((y - 0.5).abs() < 1e-12);
    }
}
