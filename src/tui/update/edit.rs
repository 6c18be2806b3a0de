//! What the handlers share: edits (each an undo step; the update step then solves the new generation),
//! prompts, spectrum operations, the file requests. Imports none of its sibling modules, so `update/` has
//! no circle: `mod` → `keys`, `popups`, `prompt`, `files` → `edit`.

use crate::colorimetry::Colorimetry;
use crate::palette::{Kind, Palette, Source};
use crate::spectrum::Normalize;
use crate::tui::app::{
    EditKey, Import, Popup, Prompt, PromptPurpose, PromptText, Selection, SpectrumOp, State, Target,
};
use crate::tui::edits::{self, EditError, EditResult};
use crate::tui::msg::Effect;
use nalgebra::Vector3;

/// Make an edit on a copy of the palette; keep it (with an undo step) when it succeeds and changed
/// something. A refused edit is shown in the message line. True when the palette changed.
pub(super) fn edit(state: &mut State, key: EditKey, f: impl FnOnce(&mut Palette, &Colorimetry) -> EditResult) -> bool {
    try_edit(state, key, f).unwrap_or_else(|reason| {
        state.complain(reason.to_string());
        false
    })
}

/// Like [`edit`], but a refused edit is returned (for a prompt to show) and the state is left as it was.
pub(super) fn try_edit(
    state: &mut State,
    key: EditKey,
    f: impl FnOnce(&mut Palette, &Colorimetry) -> EditResult,
) -> Result<bool, EditError> {
    let mut next = state.doc.palette.clone();
    f(&mut next, &state.colorimetry)?;
    if next == state.doc.palette {
        return Ok(false);
    }
    state.doc.remember(key);
    state.doc.palette = next;
    changed(state);
    Ok(true)
}

/// The palette changed (edit, undo, redo, reload, save): a new generation (which the update step then
/// solves) and a new derived view.
pub(super) fn changed(state: &mut State) {
    state.solve.generation += 1;
    state.clamp_selection();
    state.refresh();
}

/// The colour the cell has now (solved where solved), for fit colour and new criteria.
pub(super) fn current_colour(state: &State, light: usize, reflectance: usize) -> Vector3<f64> {
    state.solve.derived.cell(light, reflectance).map(|c| c.full).unwrap_or_default()
}

/// Run `f` on the selected cell, or say that a cell must be selected.
pub(super) fn with_cell(state: &mut State, f: impl FnOnce(&mut State, usize, usize)) {
    match state.target() {
        Target::Cell { light, reflectance } => f(state, light, reflectance),
        _ => state.complain("select a cell of the matrix first"),
    }
}

/// Open a one-line prompt.
pub(super) fn open_prompt(state: &mut State, title: &str, hint: &str, input: String, purpose: PromptPurpose) {
    state.ui.popup = Some(Popup::Prompt(Prompt {
        title: title.to_string(),
        hint: hint.to_string(),
        input: PromptText::new(input),
        purpose,
        error: None,
    }));
}

/// A number as prompts prefill it (shortest round-trip form).
pub(super) fn num_text(v: f64) -> String {
    format!("{v}")
}

/// The save-as prompt, with `input` typed and the reason the last answer was refused.
pub(super) fn save_as_prompt(input: String, error: Option<EditError>) -> Prompt {
    Prompt {
        title: "save as".into(),
        hint: "a path, relative to the folder the designer started in".into(),
        input: PromptText::new(input),
        purpose: PromptPurpose::SaveAs,
        error: error.map(Into::into),
    }
}

/// The palette to write: designed spectra replaced by the current solution's ([`crate::design::Solution::apply_to`]).
pub fn palette_to_save(state: &State) -> Palette {
    match state.solve.current() {
        Some(solution) => solution.apply_to(&state.doc.palette),
        None => state.doc.palette.clone(),
    }
}

/// Save the palette to its file (then quit, when `quit_after`).
pub(super) fn save(state: &mut State, quit_after: bool) -> Vec<Effect> {
    state.doc.file_busy = true;
    vec![Effect::Save {
        file: state.doc.file.clone(),
        palette: palette_to_save(state),
        before: state.doc.palette.clone(),
        quit_after,
        overwrite: std::mem::take(&mut state.doc.overwrite_armed),
    }]
}

/// Save the palette to `path`, which becomes the palette file (`replace`: the user was asked).
pub(super) fn save_as(state: &mut State, path: std::path::PathBuf, replace: bool) -> Vec<Effect> {
    state.doc.file_busy = true;
    let (palette, before) = (palette_to_save(state), state.doc.palette.clone());
    vec![Effect::SaveAs { file: state.doc.file.clone(), palette, before, path, replace }]
}

/// Read the palette file again.
pub(super) fn reload(state: &mut State) -> Vec<Effect> {
    state.doc.file_busy = true;
    vec![Effect::Reload { file: state.doc.file.clone() }]
}

/// Add a built-in spectrum of `kind` named after `base` and select it.
pub(super) fn add_spectrum(state: &mut State, kind: Kind, base: &str, source: Source) {
    let name = edits::unique_name(&state.doc.palette, kind, base);
    let base_dir = state.doc.base_dir();
    if edit(state, EditKey::Other, |p, c| edits::add(p, kind, &name, source, &base_dir, c)) {
        state.say(format!("added {} {name}", kind.as_str()));
        select_newest(state, kind);
    }
}

/// Start importing the CSV file `path` as a new spectrum of `kind` off the UI thread: the UI stays
/// responsive, Esc cancels (the reply is dropped), the update step applies the reply.
pub fn start_import(state: &mut State, kind: Kind, path: &str) -> Vec<Effect> {
    let base = std::path::Path::new(path)
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "imported".into());
    let name = edits::unique_name(&state.doc.palette, kind, &base);
    state.say(format!("reading {}… (Esc cancels)", crate::fsio::escape(path)));
    state.doc.imports += 1;
    let import =
        Import { id: state.doc.imports, path: path.to_string(), kind, name, before: state.doc.palette.clone() };
    let effect = Effect::Import {
        id: import.id,
        kind,
        name: import.name.clone(),
        path: import.path.clone(),
        base_dir: state.doc.base_dir(),
        palette: import.before.clone(),
        colorimetry: state.colorimetry.clone(),
    };
    state.doc.import = Some(import);
    vec![effect]
}

/// Select the swatch of the newest light or reflectance.
pub(super) fn select_newest(state: &mut State, kind: Kind) {
    state.ui.selection = match kind {
        Kind::Light => Selection { col: state.doc.palette.lights.len(), row: 0 },
        Kind::Reflectance => Selection { col: 0, row: state.doc.palette.reflectances.len() },
    };
    state.clamp_selection();
}

/// A spectrum operation on light or reflectance `index` (from a swatch, or the choice popup of a cell).
pub(super) fn apply_spectrum_op(state: &mut State, op: SpectrumOp, kind: Kind, index: usize) {
    let Some(name) = state.doc.palette.entries(kind).get(index).map(|e| e.name.clone()) else {
        return;
    };
    match op {
        SpectrumOp::ToggleDesign => {
            edit(state, EditKey::Other, |p, _| edits::toggle_design(p, kind, index));
        }
        SpectrumOp::NormaliseLuminance | SpectrumOp::NormaliseL2 if kind == Kind::Reflectance => {
            state.complain("reflectances are never normalised; scale them instead (s)");
        }
        SpectrumOp::NormaliseLuminance => {
            edit(state, EditKey::Other, |p, c| edits::normalise(p, index, Normalize::Luminance, c));
        }
        SpectrumOp::NormaliseL2 => {
            edit(state, EditKey::Other, |p, c| edits::normalise(p, index, Normalize::L2, c));
        }
        SpectrumOp::Planck if kind == Kind::Reflectance => {
            state.complain("Planck black bodies are lights: select a light");
        }
        SpectrumOp::Planck => {
            let t = match state.doc.palette.lights[index].source {
                Source::Planck(t) => t,
                _ => 6500.0,
            };
            let title = format!("make {name} a Planck black body");
            open_prompt(state, &title, "temperature in kelvin", format!("{t}"), PromptPurpose::Planck { light: index })
        }
        SpectrumOp::Scale => {
            let title = format!("scale of {name}");
            let now = num_text(state.doc.palette.entries(kind)[index].scale);
            let hint = if kind == Kind::Light {
                "spectrum = normalised source × scale"
            } else {
                "spectrum = source × scale"
            };
            open_prompt(state, &title, hint, now, PromptPurpose::Scale { kind, index })
        }
        SpectrumOp::Rename => crate::tui::rename::open(
            &mut state.ui,
            &state.doc.palette,
            crate::tui::rename::Renamed::Spectrum(kind, index),
        ),
        SpectrumOp::Remove => {
            if edit(state, EditKey::Other, |p, _| edits::remove(p, kind, index)) {
                state.say(format!("removed {} {name} (z undoes)", kind.as_str()));
            }
        }
    }
}
