//! The palette edits the designer performs, as one seam onto the palette model. Each returns a
//! readable reason when the edit cannot be made; the caller keeps the palette unchanged then.

use crate::palette::{ColourCell, FreeGroup, Kind, Palette, Source, TargetNotation};
use nalgebra::Vector3;

/// Why an edit was refused (shown in the message line).
pub type EditResult = Result<(), String>;

/// Index of the criterion at (light, reflectance), creating an enabled one with target `initial` when absent.
pub fn ensure_cell(palette: &mut Palette, light: usize, reflectance: usize, initial: Vector3<f64>) -> usize {
    if let Some(i) = palette.colours.iter().position(|c| c.light == light && c.reflectance == reflectance) {
        return i;
    }
    palette.colours.push(ColourCell {
        light,
        reflectance,
        target: initial,
        notation: TargetNotation::Hex,
        weight: 1.0,
        free: None,
        enabled: true,
    });
    palette.colours.len() - 1
}

/// Set the target of a cell (created if absent).
pub fn set_target(palette: &mut Palette, light: usize, reflectance: usize, rgb: Vector3<f64>) -> EditResult {
    if !rgb.iter().all(|v| v.is_finite()) {
        return Err("the target must be finite".into());
    }
    let i = ensure_cell(palette, light, reflectance, rgb);
    palette.colours[i].target = rgb;
    Ok(())
}

/// Set the weight of an existing criterion.
pub fn set_weight(palette: &mut Palette, light: usize, reflectance: usize, weight: f64) -> EditResult {
    if !(weight.is_finite() && weight >= 0.0) {
        return Err(format!("a weight must be a finite number ≥ 0, not {weight}"));
    }
    let cell = palette
        .colours
        .iter_mut()
        .find(|c| c.light == light && c.reflectance == reflectance)
        .ok_or("this cell has no colour criterion yet (press u to use it)")?;
    cell.weight = weight;
    Ok(())
}

/// Toggle "use colour"; a cell without a criterion gets one with target `current` (its colour now).
pub fn toggle_use(palette: &mut Palette, light: usize, reflectance: usize, current: Vector3<f64>) -> EditResult {
    match palette.colours.iter_mut().find(|c| c.light == light && c.reflectance == reflectance) {
        Some(c) => c.enabled = !c.enabled,
        None => {
            ensure_cell(palette, light, reflectance, current);
        }
    }
    Ok(())
}

/// Put a cell into free-colour group `name` (created with bounds [0, 1] per channel when new), or take it
/// out of its group with `None`. Groups left without cells are kept (they may carry bounds).
pub fn set_free(
    palette: &mut Palette,
    light: usize,
    reflectance: usize,
    name: Option<&str>,
    current: Vector3<f64>,
) -> EditResult {
    let group = match name {
        None => None,
        Some(n) => {
            let n = n.trim();
            if n.is_empty() || n.chars().any(|c| c.is_whitespace() || c == '"') {
                return Err(format!("'{n}' is not a group name (use letters or digits, no spaces)"));
            }
            Some(match palette.free.iter().position(|g| g.name == n) {
                Some(g) => g,
                None => {
                    palette.free.push(FreeGroup {
                        name: n.to_string(),
                        lower: Vector3::zeros(),
                        upper: Vector3::repeat(1.0),
                    });
                    palette.free.len() - 1
                }
            })
        }
    };
    let i = ensure_cell(palette, light, reflectance, current);
    palette.colours[i].free = group;
    Ok(())
}

/// Set the per-channel bounds of a free group.
pub fn set_free_bounds(palette: &mut Palette, group: usize, lower: Vector3<f64>, upper: Vector3<f64>) -> EditResult {
    if (0..3).any(|k| lower[k].is_nan() || upper[k].is_nan() || lower[k] > upper[k]) {
        return Err("each lower bound must be ≤ its upper bound".into());
    }
    let g = palette.free.get_mut(group).ok_or("no such free-colour group")?;
    g.lower = lower;
    g.upper = upper;
    Ok(())
}

/// Open a spectrum to design, or fix it again.
pub fn toggle_design(palette: &mut Palette, kind: Kind, index: usize) -> EditResult {
    let entry = match kind {
        Kind::Light => palette.lights.get_mut(index),
        Kind::Reflectance => palette.reflectances.get_mut(index),
    }
    .ok_or("no such spectrum")?;
    entry.design = !entry.design;
    Ok(())
}

/// Not available until the palette edit operations are on main.
fn pending(what: &str) -> EditResult {
    Err(format!("{what}: waiting for the palette edit operations"))
}

pub fn make_planck(_palette: &mut Palette, _light: usize, _kelvin: f64) -> EditResult {
    pending("make Planck")
}

pub fn normalise(_palette: &mut Palette, _light: usize, _how: crate::spectrum::Normalize) -> EditResult {
    pending("normalise")
}

pub fn scale(_palette: &mut Palette, _kind: Kind, _index: usize, _factor: f64) -> EditResult {
    pending("scale")
}

pub fn add(_palette: &mut Palette, _kind: Kind, _name: &str, _source: Source) -> EditResult {
    pending("add")
}

pub fn remove(_palette: &mut Palette, _kind: Kind, _index: usize) -> EditResult {
    pending("remove")
}

/// A name not yet used on that side of the palette: `base`, else `base_2`, `base_3`…
pub fn unique_name(palette: &Palette, kind: Kind, base: &str) -> String {
    let taken = |n: &str| palette.entries(kind).iter().any(|e| e.name == n);
    if !taken(base) {
        return base.to_string();
    }
    (2..).map(|k| format!("{base}_{k}")).find(|n| !taken(n)).unwrap_or_else(|| base.to_string())
}
