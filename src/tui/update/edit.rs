//! What the handlers share: edits (each an undo step; the update step then solves the new generation),
//! prompts, spectrum operations, the file requests. Imports none of its sibling modules, so `update/` has
//! no circle: `mod` → `keys`, `popups`, `prompt`, `files` → `edit`.

use crate::colorimetry::Colorimetry;
use crate::palette::{Kind, Palette, Source};
use crate::spectrum::Normalize;
use crate::tui::app::{EditKey, Import, Prompt, PromptPurpose, PromptText, SpectrumOp};
use crate::tui::edits::{self, EditError, EditResult};
use crate::tui::model::{Document, SolveState, UiState};
use crate::tui::msg::Effect;
use nalgebra::Vector3;

/// Make an edit of the document (an undo step when it changed something; the update step then solves,
/// derives and relights). A refused edit is shown in the message line. True when the palette changed.
pub(super) fn edit(
    doc: &mut Document,
    ui: &mut UiState,
    colorimetry: &Colorimetry,
    key: EditKey,
    f: impl FnOnce(&mut Palette, &Colorimetry) -> EditResult,
) -> bool {
    doc.edit(key, colorimetry, f).unwrap_or_else(|reason| {
        ui.complain(reason.to_string());
        false
    })
}

/// The colour the cell has now (solved where solved), for fit colour and new criteria.
pub(super) fn current_colour(solve: &SolveState, light: usize, reflectance: usize) -> Vector3<f64> {
    solve.derived.cell(light, reflectance).map(|c| c.full).unwrap_or_default()
}

/// A number as prompts prefill it (shortest round-trip form).
pub(super) fn num_text(v: f64) -> String {
    format!("{v}")
}

/// The save-as prompt, with `input` typed and the reason the last answer was refused; paths are relative
/// to `folder` (the palette's, as the CSV import's are).
pub(super) fn save_as_prompt(input: String, error: Option<EditError>, folder: &std::path::Path) -> Prompt {
    Prompt {
        title: "save as".into(),
        hint: format!("a path relative to the palette's folder {} · Tab completes · ↑ earlier", show_folder(folder)),
        input: PromptText::new(input),
        purpose: PromptPurpose::SaveAs,
        error: error.map(Into::into),
        recall: None,
    }
}

/// A folder as the prompts name it (`./` for the folder the designer started in).
pub(super) fn show_folder(folder: &std::path::Path) -> String {
    let shown = crate::fsio::show(folder);
    if shown.is_empty() || shown == "." { "./".to_string() } else { format!("{}/", shown.trim_end_matches('/')) }
}

/// Add a built-in spectrum of `kind` named after `base` and select it.
pub(super) fn add_spectrum(
    doc: &mut Document,
    ui: &mut UiState,
    colorimetry: &Colorimetry,
    kind: Kind,
    base: &str,
    source: Source,
) {
    let name = edits::unique_name(&doc.palette, kind, base);
    let base_dir = doc.base_dir();
    if edit(doc, ui, colorimetry, EditKey::Other, |p, c| edits::add(p, kind, &name, source, &base_dir, c)) {
        ui.say(format!("added {} {name}", kind.as_str()));
        ui.select_newest(&doc.palette, kind);
    }
}

/// Start importing the CSV file `path` as a new spectrum of `kind` off the UI thread: the UI stays
/// responsive, Esc cancels (the reply is dropped), the update step applies the reply.
pub(super) fn start_import(
    doc: &mut Document,
    ui: &mut UiState,
    colorimetry: &Colorimetry,
    kind: Kind,
    path: &str,
) -> Vec<Effect> {
    let base = std::path::Path::new(path)
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "imported".into());
    let name = edits::unique_name(&doc.palette, kind, &base);
    ui.say(format!("reading {}… (Esc cancels)", crate::fsio::escape(path)));
    doc.imports += 1;
    let import = Import { id: doc.imports, path: path.to_string(), kind, name, before: doc.palette.clone() };
    let effect = Effect::Import {
        id: import.id,
        kind,
        name: import.name.clone(),
        path: import.path.clone(),
        base_dir: doc.base_dir(),
        palette: import.before.clone(),
        colorimetry: colorimetry.clone(),
    };
    doc.import = Some(import);
    vec![effect]
}

/// A spectrum operation on light or reflectance `index` (from a swatch, or the choice popup of a cell).
pub(super) fn apply_spectrum_op(
    doc: &mut Document,
    ui: &mut UiState,
    colorimetry: &Colorimetry,
    op: SpectrumOp,
    kind: Kind,
    index: usize,
) {
    let Some(name) = doc.palette.entries(kind).get(index).map(|e| e.name.clone()) else {
        return;
    };
    let c = colorimetry;
    match op {
        SpectrumOp::ToggleDesign => {
            edit(doc, ui, c, EditKey::Other, |p, _| edits::toggle_design(p, kind, index));
        }
        SpectrumOp::NormaliseLuminance | SpectrumOp::NormaliseL2 if kind == Kind::Reflectance => {
            ui.complain("reflectances are never normalised; scale them instead (s)");
        }
        SpectrumOp::NormaliseLuminance => {
            edit(doc, ui, c, EditKey::Other, |p, c| edits::normalise(p, index, Normalize::Luminance, c));
        }
        SpectrumOp::NormaliseL2 => {
            edit(doc, ui, c, EditKey::Other, |p, c| edits::normalise(p, index, Normalize::L2, c));
        }
        SpectrumOp::Planck if kind == Kind::Reflectance => {
            ui.complain("Planck black bodies are lights: select a light");
        }
        SpectrumOp::Planck => {
            let t = match doc.palette.lights[index].source {
                Source::Planck(t) => t,
                _ => 6500.0,
            };
            let title = format!("make {name} a Planck black body");
            ui.open_prompt(&title, "temperature in kelvin", format!("{t}"), PromptPurpose::Planck { light: index })
        }
        SpectrumOp::Scale => {
            let title = format!("scale of {name}");
            let now = num_text(doc.palette.entries(kind)[index].scale);
            let hint = if kind == Kind::Light {
                "spectrum = normalised source × scale"
            } else {
                "spectrum = source × scale"
            };
            ui.open_prompt(&title, hint, now, PromptPurpose::Scale { kind, index })
        }
        SpectrumOp::Rename => {
            crate::tui::rename::open(ui, &doc.palette, crate::tui::rename::Renamed::Spectrum(kind, index))
        }
        SpectrumOp::Remove => {
            if edit(doc, ui, c, EditKey::Other, |p, _| edits::remove(p, kind, index)) {
                ui.say(format!("removed {} {name} (z undoes)", kind.as_str()));
            }
        }
    }
}
