//! The popups as components: each has its own key handler ([`on_scroll`], [`on_prompt`], …); a popup is
//! taken out of the state while its handler runs and put back unless the key closed it. A handler does
//! not call the main screen's: it hands the action back ([`PopupOutcome::Main`]) and the update step
//! routes it.

use super::edit::{add_spectrum, apply_spectrum_op};
use super::prompt::submit_prompt;
use crate::colorimetry::Colorimetry;
use crate::palette::{Kind, Source};
use crate::tui::action::{Action, Direction};
use crate::tui::app::{PickItem, Popup, Prompt, PromptPurpose, SpectrumOp};
use crate::tui::model::{Document, PreviewState, SolveState, UiState};
use crate::tui::msg::Effect;

/// What a popup's handler did with an action.
pub(super) enum PopupOutcome {
    /// Handled here, with these effects.
    Done(Vec<Effect>),
    /// Not the popup's: the main screen acts on it (the popup is closed, or stays when it put itself
    /// back).
    Main(Action),
}

use PopupOutcome::{Done, Main};

/// An action while `popup` (taken out of `ui`) is open: handed to that popup's own handler.
pub(super) fn update_popup(
    doc: &mut Document,
    ui: &mut UiState,
    solve: &SolveState,
    preview: &mut PreviewState,
    c: &Colorimetry,
    popup: Popup,
    action: Action,
) -> PopupOutcome {
    match popup {
        Popup::Help { scroll } => on_scroll(ui, action, scroll, 200, |scroll| Popup::Help { scroll }),
        Popup::Diagnostics { scroll } => on_scroll(ui, action, scroll, 500, |scroll| Popup::Diagnostics { scroll }),
        Popup::Find(finder) => match crate::tui::finder::on_action(finder, action, &doc.palette) {
            Err(open) => {
                ui.popup = Some(Popup::Find(open));
                Done(Vec::new())
            }
            Ok(Some(crate::tui::finder::Goal::Select(at))) => {
                ui.selection = at;
                ui.focus = crate::tui::app::Focus::Matrix;
                Done(Vec::new())
            }
            Ok(Some(crate::tui::finder::Goal::Run(action))) => Main(action),
            Ok(None) => Done(Vec::new()),
        },
        Popup::Legend { scroll } => on_scroll(ui, action, scroll, 50, |scroll| Popup::Legend { scroll }),
        Popup::DialList(list) => match crate::tui::dial_list::on_action(doc, ui, solve, c, list, action) {
            crate::tui::dial_list::Outcome::Done => Done(Vec::new()),
            crate::tui::dial_list::Outcome::Main(action) => Main(action),
        },
        Popup::Keyframes(list) => {
            let (open, message) = crate::tui::keyframe_list::on_action(list, action, preview);
            ui.popup = open.map(Popup::Keyframes);
            ui.message = message.or(ui.message.take());
            Done(Vec::new())
        }
        Popup::Prompt(prompt) => Done(on_prompt(doc, ui, solve, preview, c, prompt, action)),
        Popup::ChooseSpectrum { op, light, reflectance } => {
            on_choose(doc, ui, c, action, op, light, reflectance);
            Done(Vec::new())
        }
        Popup::Pick { kind, items, selected } => {
            on_pick(doc, ui, c, action, kind, items, selected);
            Done(Vec::new())
        }
        Popup::ConfirmQuit => Done(on_confirm_quit(doc, ui, solve, action)),
        Popup::Conflict { text } => on_conflict(ui, action, text),
        Popup::Recovery { path } => Done(on_recovery(doc, ui, action, path)),
    }
}

/// Help and diagnostics: arrows scroll, Esc closes, any other key closes and acts on the main screen.
fn on_scroll(ui: &mut UiState, action: Action, scroll: u16, max: u16, popup: impl Fn(u16) -> Popup) -> PopupOutcome {
    ui.popup = match action {
        Action::Back => None,
        Action::Move(Direction::Up) => Some(popup(scroll.saturating_sub(1))),
        Action::Move(Direction::Down) => Some(popup(scroll.saturating_add(1).min(max))),
        other => return Main(other),
    };
    Done(Vec::new())
}

/// A one-line prompt: typing edits the text, Enter submits, Esc cancels.
fn on_prompt(
    doc: &mut Document,
    ui: &mut UiState,
    solve: &SolveState,
    preview: &PreviewState,
    c: &Colorimetry,
    mut prompt: Prompt,
    action: Action,
) -> Vec<Effect> {
    use crate::tui::prompt_memory::{is_path, kind, split};
    match action {
        Action::Back => return Vec::new(),
        Action::Submit => {
            ui.history.record(kind(&prompt.purpose), prompt.input.as_str());
            return submit_prompt(doc, ui, solve, preview, c, prompt);
        }
        Action::Move(crate::tui::action::Direction::Up) if !ui.history.browse(&mut prompt, true) => {
            ui.say("no earlier answer to this prompt");
        }
        Action::Move(crate::tui::action::Direction::Down) => {
            ui.history.browse(&mut prompt, false);
        }
        Action::Complete if is_path(&prompt.purpose) => {
            let typed = prompt.input.as_str().to_string();
            let folder = doc.base_dir().join(split(&typed).0);
            ui.completing = true;
            ui.popup = Some(Popup::Prompt(prompt));
            return vec![Effect::Complete { folder, typed }];
        }
        // An edit that changes the text clears the last refusal; a cursor move keeps it.
        Action::Edit(request) if prompt.input.edit(request) => prompt.error = None,
        _ => {}
    }
    ui.popup = Some(Popup::Prompt(prompt));
    Vec::new()
}

/// Light or reflectance of the selected cell.
fn on_choose(
    doc: &mut Document,
    ui: &mut UiState,
    c: &Colorimetry,
    action: Action,
    op: SpectrumOp,
    light: usize,
    reflectance: usize,
) {
    match action {
        Action::ChooseLight => apply_spectrum_op(doc, ui, c, op, Kind::Light, light),
        Action::ChooseReflectance => apply_spectrum_op(doc, ui, c, op, Kind::Reflectance, reflectance),
        Action::ChooseGroup if op == SpectrumOp::Rename => {
            match crate::tui::rename::group_of(&doc.palette, light, reflectance) {
                Some(g) => crate::tui::rename::open(ui, &doc.palette, crate::tui::rename::Renamed::Group(g)),
                None => {
                    ui.popup = Some(Popup::ChooseSpectrum { op, light, reflectance });
                    ui.complain("this cell is in no free-colour group: l renames its light, r its reflectance");
                }
            }
        }
        Action::Back => {}
        _ => ui.popup = Some(Popup::ChooseSpectrum { op, light, reflectance }),
    }
}

/// A list to add from.
fn on_pick(
    doc: &mut Document,
    ui: &mut UiState,
    c: &Colorimetry,
    action: Action,
    kind: Kind,
    items: Vec<PickItem>,
    selected: usize,
) {
    let last = items.len().saturating_sub(1);
    let selected = match action {
        Action::Back => return,
        Action::Submit => return pick(doc, ui, c, kind, items.get(selected).cloned()),
        Action::Move(Direction::Up) => selected.saturating_sub(1),
        Action::Move(Direction::Down) => (selected + 1).min(last),
        Action::BigStep { up: true } => selected.saturating_sub(10),
        Action::BigStep { up: false } => (selected + 10).min(last),
        Action::ListEnd { last: false } => 0,
        Action::ListEnd { last: true } => last,
        _ => selected,
    };
    ui.popup = Some(Popup::Pick { kind, items, selected });
}

/// `q` with unsaved changes: save and quit, quit, or stay.
fn on_confirm_quit(doc: &mut Document, ui: &mut UiState, solve: &SolveState, action: Action) -> Vec<Effect> {
    match action {
        Action::Discard => ui.quit = true,
        Action::SaveAndQuit => return doc.save(solve.current(), true),
        Action::Back => {}
        _ => ui.popup = Some(Popup::ConfirmQuit),
    }
    Vec::new()
}

/// The file changed on disk: overwrite it (the next save does), reload it, save as another file, or keep
/// editing (Esc).
fn on_conflict(ui: &mut UiState, action: Action, text: String) -> PopupOutcome {
    match action {
        Action::Save | Action::Reload | Action::SaveAs => return Main(action),
        Action::Back => {}
        _ => ui.popup = Some(Popup::Conflict { text }),
    }
    Done(Vec::new())
}

/// A recovery copy found on opening: restore it (read by the loop), or keep the file as it is.
fn on_recovery(doc: &mut Document, ui: &mut UiState, action: Action, path: std::path::PathBuf) -> Vec<Effect> {
    match action {
        Action::Restore => {
            doc.file_busy = true;
            return vec![Effect::Restore { path }];
        }
        Action::Back => {
            ui.say(format!("the recovery copy stays in {} (delete it when done)", crate::fsio::show(&path)))
        }
        _ => ui.popup = Some(Popup::Recovery { path }),
    }
    Vec::new()
}

fn pick(doc: &mut Document, ui: &mut UiState, c: &Colorimetry, kind: Kind, item: Option<PickItem>) {
    let (base, source) = match item {
        None => return,
        Some(PickItem::Illuminant(n)) => (n.to_string(), Source::Illuminant(n.to_string())),
        Some(PickItem::ColorChecker(n)) => (n.to_string(), Source::ColorChecker(n.to_string())),
        Some(PickItem::Flat(v)) => {
            (if kind == Kind::Light { "flat".into() } else { format!("flat_{v}") }, Source::Flat(v))
        }
        Some(PickItem::Planck) => {
            return ui.open_prompt(
                "new Planck light",
                "temperature in kelvin",
                "6500".into(),
                PromptPurpose::NewPlanck,
            );
        }
        Some(PickItem::Csv) => {
            let title = format!("import a {} from CSV", kind.as_str());
            let hint = format!(
                "a path relative to the palette's folder {}: rows of nm,value over 400–700 nm · Tab completes · ↑ earlier",
                super::edit::show_folder(&doc.base_dir())
            );
            return ui.open_prompt(&title, &hint, String::new(), PromptPurpose::CsvPath(kind));
        }
    };
    add_spectrum(doc, ui, c, kind, &base, source);
}
