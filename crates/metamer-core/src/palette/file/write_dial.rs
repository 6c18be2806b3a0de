//! Saving `[[mixtures]]` and `[[paths]]`: each entry of the model is paired with the table it was read
//! from by what it is (its reflectance, and its dial position, weights or route — which no edit changes),
//! the edited values (target, weight, use, free group, a path's samples and tolerance) are written into
//! that table in place, an entry without a table gets a new one, and a table whose entry was removed goes.
//! Comments, key order and formatting of the rest stay as written.

use super::read_mix::{DEFAULT_PATH_SAMPLES, DEFAULT_PATH_TOLERANCE};
use super::write::{float_array, put, sync_value, target_text};
use crate::palette::mixing::dial_lights;
use crate::palette::{MixSpec, MixtureCell, Palette, PathConstancy, Route};
use nalgebra::Vector3;
use toml_edit::{Array, InlineTable, TableLike, Value};

/// `old` index of each `new` light, reflectance and free group (from the writer's name pairing).
pub(super) struct Pairing<'a> {
    pub(super) lights: &'a [Option<usize>],
    pub(super) reflectances: &'a [Option<usize>],
}

impl Pairing<'_> {
    fn light(&self, new: usize) -> Option<usize> {
        self.lights.get(new).copied().flatten()
    }

    fn same_lights(&self, old: &[usize], new: &[usize]) -> bool {
        old.len() == new.len() && old.iter().zip(new).all(|(&o, &n)| self.light(n) == Some(o))
    }

    fn same_reflectance(&self, old: usize, new: usize) -> bool {
        self.reflectances.get(new).copied().flatten() == Some(old)
    }
}

/// For each new item the old item it continues: the first unpaired old item that `same` says is it.
fn pair<T>(old: &[T], new: &[T], same: impl Fn(&T, &T) -> bool) -> Vec<Option<usize>> {
    let mut taken = vec![false; old.len()];
    new.iter()
        .map(|n| {
            let o = (0..old.len()).find(|&o| !taken[o] && same(&old[o], n))?;
            taken[o] = true;
            Some(o)
        })
        .collect()
}

/// The old mixture each new one continues: same reflectance and the same dial point and lights off, or
/// the same explicit weights.
pub(super) fn pair_mixtures(old: &[MixtureCell], new: &[MixtureCell], p: &Pairing) -> Vec<Option<usize>> {
    pair(old, new, |o, n| {
        p.same_reflectance(o.reflectance, n.reflectance)
            && match (&o.spec, &n.spec) {
                (MixSpec::Dial { at: a, off: x }, MixSpec::Dial { at: b, off: y }) => a == b && p.same_lights(x, y),
                (MixSpec::Weights, MixSpec::Weights) => {
                    let (ol, nl): (Vec<usize>, Vec<usize>) =
                        (o.mix.iter().map(|m| m.0).collect(), n.mix.iter().map(|m| m.0).collect());
                    p.same_lights(&ol, &nl) && o.mix.iter().zip(&n.mix).all(|(a, b)| a.1 == b.1)
                }
                _ => false,
            }
    })
}

/// The old path each new one continues: same reflectance and the same route.
pub(super) fn pair_paths(old: &[PathConstancy], new: &[PathConstancy], p: &Pairing) -> Vec<Option<usize>> {
    pair(old, new, |o, n| {
        p.same_reflectance(o.reflectance, n.reflectance)
            && match (&o.route, &n.route) {
                (Route::Lights(a), Route::Lights(b)) => p.same_lights(a, b),
                (Route::Dial { through: a, off: x }, Route::Dial { through: b, off: y }) => {
                    a == b && p.same_lights(x, y)
                }
                _ => false,
            }
    })
}

/// What a mixture and a path share, old (when the table is kept) and new.
struct Rest<'a> {
    target: Vector3<f64>,
    hex: bool,
    weight: f64,
    free: Option<&'a str>,
    enabled: bool,
}

fn rest_of_mixture<'a>(m: &MixtureCell, p: &'a Palette) -> Rest<'a> {
    Rest {
        target: m.target,
        hex: m.notation == crate::palette::TargetNotation::Hex,
        weight: m.weight,
        free: m.free.and_then(|g| p.free.get(g)).map(|g| g.name.as_str()),
        enabled: m.enabled,
    }
}

fn rest_of_path<'a>(q: &PathConstancy, p: &'a Palette) -> Rest<'a> {
    Rest {
        target: q.target,
        hex: q.notation == crate::palette::TargetNotation::Hex,
        weight: q.weight,
        free: q.free.and_then(|g| p.free.get(g)).map(|g| g.name.as_str()),
        enabled: q.enabled,
    }
}

/// Write the shared keys that changed (all of them into a new table).
fn sync_rest(t: &mut dyn TableLike, old: Option<Rest>, new: Rest) {
    // A free entry's target is ignored by the design; written when the file has one or it is set.
    let shown = new.free.is_none() || t.contains_key("target") || new.target != Vector3::zeros();
    let same = old.as_ref().is_some_and(|o| o.target == new.target && o.hex == new.hex);
    if shown && !same {
        put(t, "target", target_text(&new.target, new.hex));
    }
    sync_value(t, "weight", old.as_ref().map(|o| o.weight), new.weight, 1.0, Value::from);
    if old.as_ref().map(|o| o.free) != Some(new.free) {
        match new.free {
            Some(g) => put(t, "free", Value::from(g)),
            None => {
                t.remove("free");
            }
        }
    }
    sync_value(t, "use", old.as_ref().map(|o| o.enabled), new.enabled, true, Value::from);
}

fn names(p: &Palette, lights: &[usize]) -> Value {
    let mut a = Array::new();
    for &i in lights {
        a.push(p.lights.get(i).map_or("", |l| l.name.as_str()));
    }
    Value::Array(a)
}

/// Sync a `[[mixtures]]` table: a new table gets the reflectance and the mixture as the model says it.
pub(super) fn sync_mixture(
    t: &mut dyn TableLike,
    old: Option<(&MixtureCell, &Palette)>,
    new: &MixtureCell,
    p: &Palette,
) {
    if old.is_none() {
        put(t, "reflectance", Value::from(p.reflectances.get(new.reflectance).map_or("", |r| r.name.as_str())));
        match &new.spec {
            MixSpec::Dial { at, off } => {
                put(t, "dial", float_array(at));
                if !off.is_empty() {
                    put(t, "off", names(p, off));
                }
            }
            MixSpec::Weights => {
                let mut mix = InlineTable::new();
                for &(i, w) in &new.mix {
                    mix.insert(p.lights.get(i).map_or("", |l| l.name.as_str()), Value::from(w));
                }
                put(t, "mix", Value::InlineTable(mix));
            }
        }
    }
    sync_rest(t, old.map(|(o, op)| rest_of_mixture(o, op)), rest_of_mixture(new, p));
}

/// Sync a `[[paths]]` table: a new table gets the reflectance, the route, samples and tolerance.
pub(super) fn sync_path(
    t: &mut dyn TableLike,
    old: Option<(&PathConstancy, &Palette)>,
    new: &PathConstancy,
    p: &Palette,
) {
    if old.is_none() {
        put(t, "reflectance", Value::from(p.reflectances.get(new.reflectance).map_or("", |r| r.name.as_str())));
        match &new.route {
            Route::Lights(order) => put(t, "lights", names(p, order)),
            Route::Dial { through, off } => {
                // A point at a placed light's vertex is written as the light's name (as the file allows).
                let vertices = dial_lights(&p.lights);
                let mut a = Array::new();
                for q in through {
                    let named = p.lights.iter().zip(&vertices).find(|(l, v)| l.dial.is_some() && v.position == *q);
                    match named {
                        Some((l, _)) => a.push(l.name.as_str()),
                        None => a.push(float_array(q)),
                    }
                }
                put(t, "through", Value::Array(a));
                if !off.is_empty() {
                    put(t, "off", names(p, off));
                }
            }
        }
    }
    let (old_samples, old_tolerance) = match old {
        Some((o, _)) => (Some(o.samples as i64), Some(o.tolerance)),
        None => (None, None),
    };
    sync_value(t, "samples", old_samples, new.samples as i64, DEFAULT_PATH_SAMPLES as i64, Value::from);
    sync_value(t, "tolerance", old_tolerance, new.tolerance, DEFAULT_PATH_TOLERANCE, Value::from);
    sync_rest(t, old.map(|(o, op)| rest_of_path(o, op)), rest_of_path(new, p));
}
