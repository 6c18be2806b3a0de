//! The popups as components: each has its own key handler ([`on_help`], [`on_prompt`], …); a popup is
//! taken out of the state while its handler runs and put back unless the key closed it.

use super::keys::{Wants, edit, open_prompt, update_main};
use super::prompt::submit_prompt;
use crate::palette::{Kind, Source};
use crate::tui::action::{Action, Direction};
use crate::tui::app::{EditKey, Import, PickItem, Popup, Prompt, PromptPurpose, Selection, SpectrumOp, State};
use crate::tui::edits;

/// An action while `popup` is open: handed to that popup's own handler.
pub(super) fn update_popup(state: &mut State, popup: Popup, action: Action) -> Wants {
    match popup {
        Popup::Help { scroll } => on_scroll(state, action, scroll, 200, |scroll| Popup::Help { scroll }),
        Popup::Diagnostics { scroll } => on_scroll(state, action, scroll, 500, |scroll| Popup::Diagnostics { scroll }),
        Popup::Prompt(prompt) => on_prompt(state, prompt, action),
        Popup::ChooseSpectrum { op, light, reflectance } => on_choose(state, action, op, light, reflectance),
        Popup::Pick { kind, items, selected } => on_pick(state, action, kind, items, selected),
        Popup::ConfirmQuit => on_confirm_quit(state, action),
        Popup::Conflict { text } => on_conflict(state, action, text),
    }
}

/// Help and diagnostics: arrows scroll, Esc closes, any other key closes and acts on the main screen.
fn on_scroll(state: &mut State, action: Action, scroll: u16, max: u16, popup: impl Fn(u16) -> Popup) -> Wants {
    state.ui.popup = match action {
        Action::Back => None,
        Action::Move(Direction::Up) => Some(popup(scroll.saturating_sub(1))),
        Action::Move(Direction::Down) => Some(popup(scroll.saturating_add(1).min(max))),
        other => return update_main(state, other),
    };
    Wants::NONE
}

/// A one-line prompt: typing edits the text, Enter submits, Esc cancels.
fn on_prompt(state: &mut State, mut prompt: Prompt, action: Action) -> Wants {
    match action {
        Action::Back => return Wants::NONE,
        Action::Submit => return submit_prompt(state, prompt),
        Action::Input(c) => {
            if prompt.input.chars().count() < 400 {
                prompt.input.push(c);
            }
            prompt.error = None;
        }
        Action::Backspace => {
            prompt.input.pop();
            prompt.error = None;
        }
        Action::ClearInput => prompt.input.clear(),
        _ => {}
    }
    state.ui.popup = Some(Popup::Prompt(prompt));
    Wants::NONE
}

/// Light or reflectance of the selected cell.
fn on_choose(state: &mut State, action: Action, op: SpectrumOp, light: usize, reflectance: usize) -> Wants {
    match action {
        Action::ChooseLight => super::keys::apply_spectrum_op(state, op, Kind::Light, light),
        Action::ChooseReflectance => super::keys::apply_spectrum_op(state, op, Kind::Reflectance, reflectance),
        Action::Back => Wants::NONE,
        _ => {
            state.ui.popup = Some(Popup::ChooseSpectrum { op, light, reflectance });
            Wants::NONE
        }
    }
}

/// A list to add from.
fn on_pick(state: &mut State, action: Action, kind: Kind, items: Vec<PickItem>, selected: usize) -> Wants {
    let last = items.len().saturating_sub(1);
    let selected = match action {
        Action::Back => return Wants::NONE,
        Action::Submit => return pick(state, kind, items.get(selected).cloned()),
        Action::Move(Direction::Up) => selected.saturating_sub(1),
        Action::Move(Direction::Down) => (selected + 1).min(last),
        Action::BigStep { up: true } => selected.saturating_sub(10),
        Action::BigStep { up: false } => (selected + 10).min(last),
        _ => selected,
    };
    state.ui.popup = Some(Popup::Pick { kind, items, selected });
    Wants::NONE
}

/// `q` with unsaved changes: save and quit, quit, or stay.
fn on_confirm_quit(state: &mut State, action: Action) -> Wants {
    match action {
        Action::Discard => {
            state.ui.quit = true;
            Wants::NONE
        }
        Action::SaveAndQuit => Wants { save: true, quit_after_save: true, ..Wants::NONE },
        Action::Back => Wants::NONE,
        _ => {
            state.ui.popup = Some(Popup::ConfirmQuit);
            Wants::NONE
        }
    }
}

/// The file changed on disk: overwrite it (the next save does), reload it, save as another file, or keep
/// editing (Esc).
fn on_conflict(state: &mut State, action: Action, text: String) -> Wants {
    match action {
        Action::Save | Action::Reload | Action::SaveAs => update_main(state, action),
        Action::Back => Wants::NONE,
        _ => {
            state.ui.popup = Some(Popup::Conflict { text });
            Wants::NONE
        }
    }
}

fn pick(state: &mut State, kind: Kind, item: Option<PickItem>) -> Wants {
    let (base, source) = match item {
        None => return Wants::NONE,
        Some(PickItem::Illuminant(n)) => (n.to_string(), Source::Illuminant(n.to_string())),
        Some(PickItem::ColorChecker(n)) => (n.to_string(), Source::ColorChecker(n.to_string())),
        Some(PickItem::Flat(v)) => {
            (if kind == Kind::Light { "flat".into() } else { format!("flat_{v}") }, Source::Flat(v))
        }
        Some(PickItem::Planck) => {
            return open_prompt(
                state,
                "new Planck light",
                "temperature in kelvin",
                "6500".into(),
                PromptPurpose::NewPlanck,
            );
        }
        Some(PickItem::Csv) => {
            let title = format!("import a {} from CSV", kind.as_str());
            return open_prompt(
                state,
                &title,
                "path relative to the palette: rows of nm,value over 400–700 nm",
                String::new(),
                PromptPurpose::CsvPath(kind),
            );
        }
    };
    add_spectrum(state, kind, &base, source)
}

pub(super) fn add_spectrum(state: &mut State, kind: Kind, base: &str, source: Source) -> Wants {
    let name = edits::unique_name(&state.doc.palette, kind, base);
    let base_dir = state.doc.base_dir();
    let effects = edit(state, EditKey::Other, |p, c| edits::add(p, kind, &name, source, &base_dir, c));
    if effects.solve {
        state.say(format!("added {} {name}", kind.as_str()));
        select_newest(state, kind);
    }
    effects
}

/// Start importing the CSV file `path` as a new spectrum of `kind` off the UI thread: the UI stays
/// responsive, Esc cancels (the reply is dropped), [`super::replies::imported`] applies the reply.
pub fn start_import(state: &mut State, kind: Kind, path: &str) -> Wants {
    let base = std::path::Path::new(path)
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "imported".into());
    let name = edits::unique_name(&state.doc.palette, kind, &base);
    state.say(format!("reading {}… (Esc cancels)", crate::fsio::escape(path)));
    state.doc.imports += 1;
    state.doc.import =
        Some(Import { id: state.doc.imports, path: path.to_string(), kind, name, before: state.doc.palette.clone() });
    Wants { import: true, ..Wants::NONE }
}

/// Select the swatch of the newest light or reflectance.
pub(super) fn select_newest(state: &mut State, kind: Kind) {
    state.ui.selection = match kind {
        Kind::Light => Selection { col: state.doc.palette.lights.len(), row: 0 },
        Kind::Reflectance => Selection { col: 0, row: state.doc.palette.reflectances.len() },
    };
    state.clamp_selection();
}
