//! A submitted prompt: its text parsed and the edit made, or the reason shown in the prompt.

use super::edit::{add_spectrum, current_colour, start_import};
use crate::colorimetry::{Colorimetry, hex_to_linear};
use crate::palette::{Bounds, Kind, Palette, Source};
use crate::tui::app::{EditKey, Popup, Prompt, PromptPurpose, SettingField};
use crate::tui::edits::{self, EditError, EditResult, FileError};
use crate::tui::model::{Document, PreviewState, SolveState, UiState};
use crate::tui::msg::Effect;
use nalgebra::Vector3;

/// Parse a number the way prompts accept it (`inf`, `-inf` included; NaN refused).
fn parse_number(text: &str) -> Result<f64, EditError> {
    let t = text.trim();
    match t.parse::<f64>() {
        Ok(v) if !v.is_nan() => Ok(v),
        _ => Err(EditError::NotANumber(t.to_string())),
    }
}

/// Carry out a submitted prompt; a refused answer keeps the prompt open with the reason.
pub(super) fn submit_prompt(
    doc: &mut Document,
    ui: &mut UiState,
    solve: &SolveState,
    preview: &PreviewState,
    c: &Colorimetry,
    mut prompt: Prompt,
) -> Vec<Effect> {
    let result: Result<Vec<Effect>, EditError> = (|| {
        let input = prompt.input.as_str().trim().to_string();
        Ok(match prompt.purpose.clone() {
            PromptPurpose::Hex { light, reflectance } => {
                let hex = if input.starts_with('#') { input.clone() } else { format!("#{input}") };
                let rgb = hex_to_linear(&hex).ok_or_else(|| EditError::NotHex(input.clone()))?;
                edit_or_err(doc, c, |p, _| edits::set_target(p, light, reflectance, rgb))?
            }
            PromptPurpose::Weight { light, reflectance } => {
                let w = parse_number(&input)?;
                let now = current_colour(solve, light, reflectance);
                edit_or_err(doc, c, |p, _| edits::set_weight(p, light, reflectance, w, now))?
            }
            PromptPurpose::FreeGroup { light, reflectance } => {
                let now = current_colour(solve, light, reflectance);
                let name = (!input.is_empty()).then_some(input.as_str());
                edit_or_err(doc, c, |p, _| edits::set_free(p, light, reflectance, name, now))?
            }
            PromptPurpose::FreeBounds { group } => {
                let v: Vec<f64> = input
                    .split([' ', ',', '\t'])
                    .filter(|s| !s.is_empty())
                    .map(parse_number)
                    .collect::<Result<_, _>>()?;
                let (lower, upper) = match v.as_slice() {
                    [lo, hi] => (Vector3::repeat(*lo), Vector3::repeat(*hi)),
                    [a, b, c, d, e, f] => (Vector3::new(*a, *b, *c), Vector3::new(*d, *e, *f)),
                    _ => return Err(EditError::BoundsCount),
                };
                edit_or_err(doc, c, |p, _| edits::set_free_bounds(p, group, lower, upper))?
            }
            PromptPurpose::Planck { light } => {
                let t = parse_number(&input)?;
                if !(t.is_finite() && t > 0.0) {
                    return Err(EditError::Temperature);
                }
                edit_or_err(doc, c, |p, c| edits::make_planck(p, light, t, c))?
            }
            PromptPurpose::NewPlanck => {
                let t = parse_number(&input)?;
                if !(t.is_finite() && t > 0.0) {
                    return Err(EditError::Temperature);
                }
                add_spectrum(doc, ui, c, Kind::Light, &format!("planck_{}K", t.round()), Source::Planck(t));
                Vec::new()
            }
            PromptPurpose::Scale { kind, index } => {
                let k = parse_number(&input)?;
                if !(k.is_finite() && k > 0.0) {
                    return Err(EditError::Scale);
                }
                edit_or_err(doc, c, |p, c| edits::scale(p, kind, index, k, c))?
            }
            PromptPurpose::CsvPath(kind) => {
                if input.is_empty() {
                    return Err(EditError::NoPath);
                }
                start_import(doc, ui, c, kind, &input)
            }
            PromptPurpose::SaveAs => {
                if input.is_empty() {
                    return Err(EditError::NoPath);
                }
                // Relative to the palette's folder, as a CSV path is (an absolute path stays as typed).
                let path = doc.base_dir().join(&input);
                // Nothing the user made is replaced unasked: the saver refuses another file at the path
                // once, with the question (`FileError::Exists`); Enter on the same path again replaces it.
                let asked = matches!(
                    prompt.error.as_ref().map(|r| &*r.0),
                    Some(EditError::File(FileError::Exists(p))) if *p == path
                );
                doc.save_as(solve.current(), path, asked)
            }
            PromptPurpose::Rename(what) => {
                let old = what.name(&doc.palette).unwrap_or_default().to_string();
                let effects = edit_or_err(doc, c, |p, _| crate::tui::rename::rename(p, what, &input))?;
                let new = what.name(&doc.palette).unwrap_or_default().to_string();
                if new != old {
                    let scene: Vec<String> = preview
                        .ready
                        .as_ref()
                        .map(|p| p.materials.iter().map(|(n, _)| n.clone()).collect())
                        .unwrap_or_default();
                    ui.say(crate::tui::rename::done_message(&old, &new, what, &scene));
                }
                effects
            }
            PromptPurpose::Dial(p) => {
                crate::tui::dial_list::submit(doc, ui, c, p, &input)?;
                Vec::new()
            }
            PromptPurpose::Setting(field) => {
                let v = parse_number(&input)?;
                edit_or_err(doc, c, |p, _| set_setting(p, field, v))?
            }
        })
    })();
    match result {
        Ok(effects) => effects,
        Err(reason) => {
            ui.message = None;
            prompt.error = Some(reason.into());
            ui.popup = Some(Popup::Prompt(prompt));
            Vec::new()
        }
    }
}

/// An edit of the document whose refusal is an error for the prompt to show (an edit needs no
/// effect: the update step solves the new generation).
fn edit_or_err(
    doc: &mut Document,
    c: &Colorimetry,
    f: impl FnOnce(&mut Palette, &Colorimetry) -> EditResult,
) -> Result<Vec<Effect>, EditError> {
    doc.edit(EditKey::Other, c, f).map(|_| Vec::new())
}

fn set_setting(p: &mut Palette, field: SettingField, v: f64) -> EditResult {
    let s = &mut p.settings;
    let nonneg = |v: f64| {
        if v.is_finite() && v >= 0.0 { Ok(v) } else { Err(EditError::NotNonNegative(v)) }
    };
    let ordered = |b: Bounds| if b.lower <= b.upper { Ok(b) } else { Err(EditError::Unordered) };
    match field {
        SettingField::ReflectanceLower => s.reflectance_bounds = ordered(Bounds::new(v, s.reflectance_bounds.upper))?,
        SettingField::ReflectanceUpper => s.reflectance_bounds = ordered(Bounds::new(s.reflectance_bounds.lower, v))?,
        SettingField::LightLower => s.light_bounds = ordered(Bounds::new(v, s.light_bounds.upper))?,
        SettingField::LightUpper => s.light_bounds = ordered(Bounds::new(s.light_bounds.lower, v))?,
        SettingField::Smoothness => s.smoothness = nonneg(v)?,
        SettingField::SubspaceError => s.subspace_error = nonneg(v)?,
        SettingField::BasisDimension => {
            if v.fract() != 0.0 || crate::basis::check_dimension(v as usize).is_err() {
                return Err(EditError::BasisDimension);
            }
            s.basis_dimension = v as usize;
        }
        SettingField::Bounds | SettingField::FitInSubspace => {}
    }
    Ok(())
}
