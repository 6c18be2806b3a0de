//! Reading `[[mixtures]]` (a target under a mixture of lights) and `[[paths]]` (a colour kept along a
//! dial path). The weights come from the one dial model ([`crate::palette::mixing`]); errors name the
//! key and the reason, as for every other table.

use super::doc::{Doc, TableRef};
use super::read::{CellRest, Reader, Res, Value, integer_of, names};
use crate::palette::mixing::{dial_lights, dial_mix, mix_of};
use crate::palette::{FreeGroup, Mix, MixSpec, MixtureCell, PathConstancy, Route, SpectrumEntry};
use crate::render::dial::MAX_DIAL_COORDINATE;

const MIXTURE_KEYS: &[&str] = &["reflectance", "dial", "off", "mix", "target", "weight", "free", "use"];
const PATH_KEYS: &[&str] =
    &["reflectance", "through", "lights", "off", "target", "weight", "free", "use", "samples", "tolerance"];

/// The design samples of a path when the file does not say.
pub const DEFAULT_PATH_SAMPLES: usize = 9;
/// The most design samples a path may ask for.
pub const MAX_PATH_SAMPLES: usize = 1024;
/// A path's tolerance (ΔE00) when the file does not say.
pub const DEFAULT_PATH_TOLERANCE: f64 = 1.0;

impl Reader<'_> {
    fn light_named(&self, v: &Value, key: &str, lights: &[SpectrumEntry]) -> Res<usize> {
        let name = self.string(v, key)?;
        lights
            .iter()
            .position(|l| l.name == name)
            .ok_or_else(|| self.invalid(key, format!("unknown light `{name}` (known: {})", names(lights))))
    }

    fn reflectance_of(&self, t: TableRef, at: &str, reflectances: &[SpectrumEntry], what: &str) -> Res<usize> {
        let key = format!("{at}.reflectance");
        let v = t
            .value("reflectance")
            .ok_or_else(|| self.invalid(&key, format!("missing: {what} names its reflectance")))?;
        let name = self.string(v, &key)?;
        reflectances
            .iter()
            .position(|r| r.name == name)
            .ok_or_else(|| self.invalid(&key, format!("unknown reflectance `{name}` (known: {})", names(reflectances))))
    }

    /// A dial point `[x, y]`, finite and within the dial.
    fn dial_point(&self, v: &Value, key: &str) -> Res<[f64; 2]> {
        let p = self.numbers(v, key, Some(2), false)?;
        if p.iter().any(|c| c.abs() > MAX_DIAL_COORDINATE) {
            return Err(self.invalid(
                key,
                format!(
                    "[{:e}, {:e}] is outside the dial (coordinates within ±{MAX_DIAL_COORDINATE:e}; the light mix's \
                     distances would overflow)",
                    p[0], p[1]
                ),
            ));
        }
        Ok([p[0], p[1]])
    }

    /// The palette's lights must have dial vertices for a dial position to mean anything.
    fn placed(&self, key: &str, lights: &[SpectrumEntry]) -> Res<()> {
        if lights.is_empty() {
            return Err(self.invalid(key, "the palette has no lights to mix"));
        }
        if !lights.iter().any(|l| l.dial.is_some()) {
            return Err(self.invalid(
                key,
                "a dial position needs lights placed on the dial: no light of the palette has `dial = [x, y]`",
            ));
        }
        for (i, l) in lights.iter().enumerate() {
            if let Some(p) = l.dial
                && p.iter().any(|c| !c.is_finite() || c.abs() > MAX_DIAL_COORDINATE)
            {
                return Err(self.invalid(
                    format!("lights[{i}].dial"),
                    format!(
                        "[{:e}, {:e}] is outside the dial (coordinates within ±{MAX_DIAL_COORDINATE:e})",
                        p[0], p[1]
                    ),
                ));
            }
        }
        Ok(())
    }

    /// `off = [names]`: indices, not every light.
    fn off_lights(&self, t: TableRef, at: &str, lights: &[SpectrumEntry]) -> Res<Vec<usize>> {
        let Some(v) = t.value("off") else { return Ok(Vec::new()) };
        let key = format!("{at}.off");
        let items = v.as_array().ok_or_else(|| self.wrong_type(&key, "an array of light names", v))?;
        let mut off = Vec::with_capacity(items.len());
        for (i, item) in items.iter().enumerate() {
            let l = self.light_named(item.get_ref(), &format!("{key}[{i}]"), lights)?;
            if !off.contains(&l) {
                off.push(l);
            }
        }
        if off.len() == lights.len() {
            return Err(self.invalid(key, "this switches every light off (the mixture would be black)"));
        }
        Ok(off)
    }

    /// `mix = { light = w, … }`: weights ≥ 0 over named lights, not summing to 0.
    fn explicit_mix(&self, v: &Value, key: &str, lights: &[SpectrumEntry]) -> Res<Mix> {
        let t = self.sub_table(v, key)?;
        let mut w = vec![0.0; lights.len()];
        for (name, x) in t.iter() {
            let k = format!("{key}.{}", name.get_ref());
            let i = lights.iter().position(|l| l.name == *name.get_ref()).ok_or_else(|| {
                self.invalid(&k, format!("unknown light `{}` (known: {})", name.get_ref(), names(lights)))
            })?;
            let x = self.number(x.get_ref(), &k, false)?;
            if x < 0.0 {
                return Err(self.invalid(&k, format!("mixture weights must not be negative, got {x}")));
            }
            w[i] = x;
        }
        if w.iter().sum::<f64>() <= 0.0 {
            return Err(
                self.invalid(key, "the weights sum to 0 (the mixture would be black): give a light a weight > 0")
            );
        }
        Ok(mix_of(&w))
    }

    /// A path's list of positions: an array of at least 2 items.
    fn path_list<'v, 'i>(&self, key: &str, v: &'v Value<'i>) -> Res<Vec<&'v Value<'i>>> {
        let items = v.as_array().ok_or_else(|| self.wrong_type(key, "an array", v))?;
        if items.len() < 2 {
            return Err(self.invalid(key, format!("a path needs at least 2 positions, found {}", items.len())));
        }
        Ok(items.iter().map(|x| x.get_ref()).collect())
    }

    pub(super) fn mixtures(
        &mut self,
        root: &Doc,
        lights: &[SpectrumEntry],
        reflectances: &[SpectrumEntry],
        free: &[FreeGroup],
    ) -> Res<Vec<MixtureCell>> {
        let tables = self.array_of_tables(root, "mixtures")?;
        let mut out = Vec::with_capacity(tables.len());
        for (i, t) in tables.iter().enumerate() {
            let at = format!("mixtures[{i}]");
            let w = self.unknown_keys(t, MIXTURE_KEYS, &at);
            self.warnings.extend(w);
            let reflectance = self.reflectance_of(t, &at, reflectances, "a mixture")?;
            let (mix, spec) = match (t.value("dial"), t.value("mix")) {
                (Some(_), Some(_)) => {
                    return Err(
                        self.invalid(&at, "give either `dial = [x, y]` or `mix = { light = weight, … }`, not both")
                    );
                }
                (None, None) => {
                    return Err(self.invalid(
                        &at,
                        "missing: a mixture needs `dial = [x, y]` (a dial position) or `mix = { light = weight, … }`",
                    ));
                }
                (Some(v), None) => {
                    let key = format!("{at}.dial");
                    self.placed(&key, lights)?;
                    let p = self.dial_point(v, &key)?;
                    let off = self.off_lights(t, &at, lights)?;
                    let mix = dial_mix(lights, p, &off).map_err(|e| self.invalid(&key, e.to_string()))?;
                    if mix.is_empty() {
                        return Err(self.invalid(&key, "the dial's weights at this point are all 0"));
                    }
                    (mix, MixSpec::Dial { at: p, off })
                }
                (None, Some(v)) => {
                    if t.value("off").is_some() {
                        return Err(self.invalid(
                            format!("{at}.off"),
                            "`off` switches lights off on the dial: it goes with `dial = [x, y]`, not with `mix` (leave the light out of `mix` instead)",
                        ));
                    }
                    (self.explicit_mix(v, &format!("{at}.mix"), lights)?, MixSpec::Weights)
                }
            };
            let CellRest { free, target, notation, weight, enabled } = self.cell_rest(t, &at, free)?;
            out.push(MixtureCell { reflectance, mix, spec, target, notation, weight, free, enabled });
        }
        Ok(out)
    }

    pub(super) fn paths(
        &mut self,
        root: &Doc,
        lights: &[SpectrumEntry],
        reflectances: &[SpectrumEntry],
        free: &[FreeGroup],
    ) -> Res<Vec<PathConstancy>> {
        let tables = self.array_of_tables(root, "paths")?;
        let mut out = Vec::with_capacity(tables.len());
        for (i, t) in tables.iter().enumerate() {
            let at = format!("paths[{i}]");
            let w = self.unknown_keys(t, PATH_KEYS, &at);
            self.warnings.extend(w);
            let reflectance = self.reflectance_of(t, &at, reflectances, "a path")?;
            let route = match (t.value("through"), t.value("lights")) {
                (Some(_), Some(_)) => {
                    return Err(self.invalid(&at, "give either `through = [...]` or `lights = [...]`, not both"));
                }
                (None, None) => {
                    return Err(self.invalid(
                        &at,
                        "missing: a path needs `through = [...]` (dial points or light names) or `lights = [...]` (lights mixed pairwise)",
                    ));
                }
                (Some(v), None) => {
                    let key = format!("{at}.through");
                    self.placed(&key, lights)?;
                    let vertices = dial_lights(lights);
                    let mut through = Vec::new();
                    for (j, item) in self.path_list(&key, v)?.into_iter().enumerate() {
                        let k = format!("{key}[{j}]");
                        through.push(match item {
                            Value::String(_) => vertices[self.light_named(item, &k, lights)?].position,
                            _ => self.dial_point(item, &k)?,
                        });
                    }
                    let off = self.off_lights(t, &at, lights)?;
                    Route::Dial { through, off }
                }
                (None, Some(v)) => {
                    let key = format!("{at}.lights");
                    if t.value("off").is_some() {
                        return Err(self.invalid(
                            format!("{at}.off"),
                            "`off` goes with `through` (a dial path); `lights` mixes only the lights it names",
                        ));
                    }
                    let order = self
                        .path_list(&key, v)?
                        .into_iter()
                        .enumerate()
                        .map(|(j, item)| self.light_named(item, &format!("{key}[{j}]"), lights))
                        .collect::<Res<Vec<_>>>()?;
                    Route::Lights(order)
                }
            };
            let samples = match t.value("samples") {
                Some(v) => {
                    let key = format!("{at}.samples");
                    let n = integer_of(v).ok_or_else(|| self.wrong_type(&key, "an integer", v))?;
                    if !(2..=MAX_PATH_SAMPLES as i64).contains(&n) {
                        return Err(self.invalid(key, format!("{n} samples: give 2 to {MAX_PATH_SAMPLES}")));
                    }
                    n as usize
                }
                None => DEFAULT_PATH_SAMPLES,
            };
            let tolerance = match t.value("tolerance") {
                Some(v) => {
                    let key = format!("{at}.tolerance");
                    let x = self.number(v, &key, false)?;
                    if x <= 0.0 {
                        return Err(self.invalid(key, format!("the tolerance is a ΔE00 > 0, got {x}")));
                    }
                    x
                }
                None => DEFAULT_PATH_TOLERANCE,
            };
            let CellRest { free, target, notation, weight, enabled } = self.cell_rest(t, &at, free)?;
            out.push(PathConstancy { reflectance, route, target, notation, weight, free, enabled, samples, tolerance });
        }
        Ok(out)
    }
}
