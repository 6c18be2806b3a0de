//! The update step: the one place the designer's [`State`] changes. [`update`] takes one [`Msg`] — a key,
//! a worker reply, a finished raycast, import or save, the clock, a signal — hands it to the sub-model it
//! is for, and returns the [`Effect`]s the event loop must run (as data). Nothing here draws, blocks,
//! reads a file or the clock, or starts a thread.
//!
//! The state is taken apart into its sub-models once, here; no handler sees the whole [`State`]:
//!
//! - the interface's, the solve's and the preview's own messages go to their `update`
//!   ([`crate::tui::model::UiState::update`], [`crate::tui::model::SolveState::update`],
//!   [`crate::tui::model::PreviewState::update`]);
//! - a key becomes an action through the [`keymap`] (which reads the open popup and whether the dial has
//!   the keys); the open popup's handler gets it ([`popups`]), else the dial's keys go to the preview and
//!   the main screen's to [`keys`], one handler per group of keys;
//! - [`prompt`]: a submitted prompt; [`files`]: what comes back from file work (imports, saves, reloads,
//!   recovery copies);
//! - [`edit`]: what they share (edits, prompts, file requests); it imports none of them, so the modules
//!   form no circle.
//!
//! A handler takes the sub-models it needs: the [`Document`] it edits, the [`UiState`] it selects,
//! prompts and speaks in, the [`SolveState`] it reads the solved colours from. An edit only changes the
//! document (which notes the change); after every message [`settle`] does what follows from the changes,
//! once: a changed palette starts a new generation, keeps the selection inside the matrix and derives the
//! colours again; a palette generation (or a mismatch-region cell) not asked for yet is solved; a stale
//! preview is relit; a scene preview not raycast at its panel's size is raycast.

mod edit;
mod files;
mod keys;
mod popups;
mod prompt;

use crate::colorimetry::Colorimetry;
use crate::tui::action::Action;
use crate::tui::app::{State, feasibility_cell};
use crate::tui::keymap;
use crate::tui::model::{
    Document, PaletteChange, PreviewMsg, PreviewState, SolveMsg, SolveState, UiMsg, UiState, is_dial_action,
};
use crate::tui::msg::{Effect, Msg};
use crate::tui::preview::{MAX_PREVIEW_EDGE, Preview};
use popups::PopupOutcome;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::layout::Rect;

/// Handle one message: change the state, return the effects to run.
pub fn update(state: &mut State, msg: Msg) -> Vec<Effect> {
    // What the pointer is on, read with the view's layout before the state is taken apart.
    let located = match &msg {
        Msg::Mouse(event) => crate::tui::mouse::locate(state, event),
        _ => Default::default(),
    };
    let State { doc, solve, preview, ui, colorimetry } = state;
    let mut effects = match msg {
        Msg::Start { width, height, trains_bases } => {
            solve.trains_bases = trains_bases;
            ui.update(UiMsg::Screen { width, height });
            Vec::new()
        }
        Msg::Resize { width, height } => {
            ui.update(UiMsg::Screen { width, height });
            Vec::new()
        }
        Msg::Tick(now) => {
            ui.update(UiMsg::Tick);
            on_solve(solve, preview, &doc.palette, colorimetry, SolveMsg::Tick(now))
        }
        Msg::Graphics { graphics, warning } => {
            on_preview(preview, ui, PreviewMsg::Graphics { graphics, warning }, colorimetry)
        }
        Msg::Key(key) => {
            // Each key is looked up in the keymap in force after the one before it acted.
            let mut effects = Vec::new();
            for key in keys_for(ui, preview, key) {
                if let Some(action) = keymap::action_for(ui.popup.as_ref(), preview.keys, key) {
                    effects.extend(on_action(doc, ui, solve, preview, colorimetry, action));
                }
            }
            effects
        }
        Msg::Action(action) => on_action(doc, ui, solve, preview, colorimetry, action),
        Msg::Mouse(event) => {
            crate::tui::mouse::on_mouse(doc, ui, solve, preview, colorimetry, event, located);
            Vec::new()
        }
        Msg::Worker(reply) => on_solve(solve, preview, &doc.palette, colorimetry, SolveMsg::Worker(reply)),
        Msg::SolveStarted { ticket, at } => {
            on_solve(solve, preview, &doc.palette, colorimetry, SolveMsg::Started { ticket, at })
        }
        Msg::Preview(loaded) => on_preview(preview, ui, PreviewMsg::Raycast(loaded), colorimetry),
        Msg::SceneSaved(result) => on_preview(preview, ui, PreviewMsg::SceneSaved(result), colorimetry),
        Msg::Imported { id, result } => {
            files::imported(doc, ui, colorimetry, id, result);
            Vec::new()
        }
        Msg::File(outcome) => {
            files::file(doc, ui, solve, colorimetry, outcome);
            Vec::new()
        }
        Msg::Terminated => files::terminated(doc, ui, solve),
        Msg::Completed { typed, entries } => {
            crate::tui::prompt_memory::completed(ui, &typed, &entries);
            Vec::new()
        }
        Msg::WaitSolve | Msg::End => Vec::new(),
    };
    settle(state, &mut effects);
    effects
}

/// A message for the solve; the preview is stale when the derived colours changed.
fn on_solve(
    solve: &mut SolveState,
    preview: &mut PreviewState,
    palette: &crate::palette::Palette,
    colorimetry: &Colorimetry,
    msg: SolveMsg,
) -> Vec<Effect> {
    let update = solve.update(msg, palette, colorimetry);
    preview.stale |= update.derived;
    update.effects
}

/// A message for the preview; its line goes to the message area.
fn on_preview(preview: &mut PreviewState, ui: &mut UiState, msg: PreviewMsg, colorimetry: &Colorimetry) -> Vec<Effect> {
    let update = preview.update(msg, colorimetry);
    if let Some(message) = update.message {
        ui.message = Some(message);
    }
    update.effects
}

/// The keys a key event stands for. Esc followed at once by a key reaches us as Alt+key (the terminal
/// cannot tell them apart); nothing is bound to Alt, so take it as Esc, then the key.
fn keys_for(ui: &UiState, preview: &PreviewState, key: KeyEvent) -> Vec<KeyEvent> {
    match keymap::action_for(ui.popup.as_ref(), preview.keys, key) {
        None if key.modifiers.contains(KeyModifiers::ALT) => {
            let mut plain = key;
            plain.modifiers.remove(KeyModifiers::ALT);
            vec![KeyEvent::new(KeyCode::Esc, KeyModifiers::NONE), plain]
        }
        _ => vec![key],
    }
}

/// One user action: the open popup's handler, or the main screen's.
fn on_action(
    doc: &mut Document,
    ui: &mut UiState,
    solve: &SolveState,
    preview: &mut PreviewState,
    colorimetry: &Colorimetry,
    action: Action,
) -> Vec<Effect> {
    ui.message = None;
    let action = match ui.popup.take() {
        Some(popup) => match popups::update_popup(doc, ui, solve, preview, colorimetry, popup, action) {
            PopupOutcome::Done(effects) => return effects,
            PopupOutcome::Main(action) => action,
        },
        None => action,
    };
    // Over the whole terminal, Esc (and leaving the dial) returns to the panels first.
    if preview.full && matches!(action, Action::Back | Action::DialLeave) {
        preview.full = false;
        return Vec::new();
    }
    // A target at the slider changes the document: the dial list's, not the preview's.
    if action == Action::DialAddMixture {
        doc.history.last_edit = None;
        crate::tui::dial_list::add_at_slider(doc, ui, solve, preview, colorimetry);
        return Vec::new();
    }
    // On the main screen the dial's keys are the preview's, the others the main screen's.
    if is_dial_action(action) {
        doc.history.last_edit = None;
        return on_preview(preview, ui, PreviewMsg::Dial(action), colorimetry);
    }
    keys::update_main(doc, ui, solve, preview, colorimetry, action)
}

/// What follows from the message's changes, once: a changed palette starts a new generation (or carries
/// the solution to it), keeps the selection inside the matrix and derives the colours again; a palette
/// generation or a mismatch-region cell not asked for yet is solved (not while quitting); a stale preview
/// is relit; a scene preview not raycast at its panel's size is raycast.
fn settle(state: &mut State, effects: &mut Vec<Effect>) {
    let State { doc, solve, preview, ui, colorimetry } = state;
    let change = doc.take_change();
    if change != PaletteChange::None {
        if change == PaletteChange::Carried {
            solve.carry_to_next_generation();
        } else {
            solve.generation += 1;
        }
        ui.clamp_selection(&doc.palette);
        solve.derive(&doc.palette, colorimetry);
        preview.stale = true;
    }
    let feasibility = feasibility_cell(ui, doc);
    if !ui.quit && solve.wants_solve(feasibility) {
        effects.extend(solve.submit(&doc.palette, feasibility));
    }
    if preview.stale {
        preview.relight(&doc.palette, solve);
    }
    want_preview(state, effects);
}

/// Keep the scene preview at its panel's pixel size: ask for a raycast when the scene is new or the panel
/// changed size.
fn want_preview(state: &mut State, effects: &mut Vec<Effect>) {
    // While the terminal is asked for its graphics, the panel's pixel size is not known yet.
    if !state.preview.has_scene() || state.preview.probing {
        return;
    }
    let (width, height) = state.ui.screen;
    let Some(areas) = crate::tui::ui::preview_areas(state, Rect::new(0, 0, width, height)) else { return };
    let side = state.preview.graphics.pixels_for(areas.image, MAX_PREVIEW_EDGE).max(2);
    let want = (side, side);
    let preview = &mut state.preview;
    let have = preview.ready.as_ref().map(Preview::size);
    if have == Some(want) || preview.pending == Some(want) {
        return;
    }
    if let Some(scene) = preview.scene() {
        let model = preview.ready.as_ref().map(|p| p.model.clone());
        effects.push(Effect::Raycast { scene, model, size: want, colorimetry: state.colorimetry.clone() });
        preview.pending = Some(want);
    }
}
