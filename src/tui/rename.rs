//! Renaming a light, a reflectance or a free-colour group (`r`): what can be renamed from the selection,
//! the prompt that asks for the new name and the edit it makes. The palette model refers to entries by
//! index, so cells, groups, mixtures and paths follow a rename; saving writes the new name wherever the
//! file named the old one (`palette/file/write.rs`). The handlers take the sub-models they read, not the
//! whole state.

use crate::palette::{Kind, Palette};
use crate::tui::app::{Popup, Prompt, PromptPurpose, PromptText, SpectrumOp, Target};
pub use crate::tui::basics::Renamed;
use crate::tui::edits::{EditError, EditResult};
use crate::tui::model::UiState;

/// `r` on the main screen: a swatch is renamed at once (the prompt opens); a cell asks which of its light,
/// reflectance (or free-colour group, when it has one) to rename.
pub(crate) fn start(ui: &mut UiState, palette: &Palette, target: Target) {
    match target {
        Target::Light(l) => open(ui, palette, Renamed::Spectrum(Kind::Light, l)),
        Target::Reflectance(r) => open(ui, palette, Renamed::Spectrum(Kind::Reflectance, r)),
        Target::Cell { light, reflectance } => {
            ui.popup = Some(Popup::ChooseSpectrum { op: SpectrumOp::Rename, light, reflectance })
        }
        Target::Nothing => ui.complain("the palette is empty: add a light (L) or a reflectance (R)"),
    }
}

/// The free-colour group of the cell at (light, reflectance), if it is in one.
pub(crate) fn group_of(palette: &Palette, light: usize, reflectance: usize) -> Option<usize> {
    palette.cell(light, reflectance).and_then(|c| c.free)
}

/// Open the prompt for the new name of `what`, its current name typed in.
pub(crate) fn open(ui: &mut UiState, palette: &Palette, what: Renamed) {
    let Some(name) = what.name(palette) else { return };
    ui.popup = Some(Popup::Prompt(Prompt {
        title: format!("rename {}", what.describe(palette)),
        hint: "the new name (unique on its side; cells, groups, mixtures and paths follow)".into(),
        input: PromptText::new(name.to_string()),
        purpose: PromptPurpose::Rename(what),
        error: None,
        recall: None,
    }));
}

/// Carry out a rename on `palette` (refused: a name empty, taken, or with a quote or control character).
pub(crate) fn rename(palette: &mut Palette, what: Renamed, name: &str) -> EditResult {
    let name = name.trim();
    if name.chars().any(|c| c.is_control() || c == '"') {
        return Err(EditError::BadName(name.to_string()));
    }
    match what {
        Renamed::Spectrum(kind, i) => palette.rename_spectrum(kind, i, name)?,
        Renamed::Group(g) => {
            if name.chars().any(char::is_whitespace) {
                return Err(EditError::GroupName(name.to_string()));
            }
            palette.rename_free_group(g, name)?
        }
    }
    Ok(())
}

/// What the message line says after a rename; `scene_names` are the reflectance names the scene preview's
/// materials use, which a renamed reflectance no longer matches.
pub(crate) fn done_message(old: &str, new: &str, what: Renamed, scene_names: &[String]) -> String {
    let mut text = format!("renamed {old} to {new} (z undoes)");
    if matches!(what, Renamed::Spectrum(Kind::Reflectance, _)) && scene_names.iter().any(|n| n == old) {
        text.push_str(&format!(
            "; the scene's material `{old}` now shows the scene's own spectrum (the scene names the old reflectance)"
        ));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::Colorimetry;
    use crate::palette::Source;

    #[test]
    fn renames_are_checked() {
        let c = Colorimetry::default();
        let mut p = Palette::default();
        p.add_spectrum(Kind::Light, "d65", Source::Illuminant("D65".into()), &c).unwrap();
        p.add_spectrum(Kind::Light, "a", Source::Illuminant("A".into()), &c).unwrap();
        p.add_free_group("A", nalgebra::Vector3::zeros(), nalgebra::Vector3::repeat(1.0)).unwrap();
        assert!(rename(&mut p, Renamed::Spectrum(Kind::Light, 0), "a").is_err());
        assert!(rename(&mut p, Renamed::Spectrum(Kind::Light, 0), "say \"hi\"").is_err());
        assert!(rename(&mut p, Renamed::Group(0), "two words").is_err());
        rename(&mut p, Renamed::Spectrum(Kind::Light, 0), "  noon sun ").unwrap();
        assert_eq!(p.lights[0].name, "noon sun");
        rename(&mut p, Renamed::Group(0), "warm").unwrap();
        assert_eq!(p.free[0].name, "warm");
        assert!(done_message("x", "y", Renamed::Spectrum(Kind::Reflectance, 0), &["x".into()]).contains("scene"));
        assert!(!done_message("x", "y", Renamed::Spectrum(Kind::Light, 0), &["x".into()]).contains("scene"));
    }
}
