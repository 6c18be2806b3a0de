//! The update step: the one place the designer's [`State`] changes. [`update`] takes one [`Msg`] — a key,
//! a worker reply, a finished raycast, import or save, the clock, a signal — hands it to the sub-model it
//! is for, and returns the [`Effect`]s the event loop must run (as data). Nothing here draws, blocks,
//! reads a file or the clock, or starts a thread.
//!
//! - the solve's and the preview's messages go to their own `update` ([`crate::tui::model::SolveState`],
//!   [`crate::tui::model::PreviewState`]);
//! - [`keys`]: the main screen's actions, one handler per group of keys;
//! - [`popups`]: each popup's own key handler (a popup hands keys that are not its own back here);
//! - [`prompt`]: a submitted prompt;
//! - [`files`]: what comes back from file work (imports, saves, reloads, recovery copies);
//! - [`edit`]: what they share (edits, prompts, file requests); it imports none of them, so the modules
//!   form no circle.
//!
//! After every message two rules of the model ask for what is missing: a palette generation (or a
//! mismatch-region cell) not asked for yet is solved, and a scene preview not raycast at its panel's size
//! is raycast.

mod edit;
mod files;
mod keys;
mod popups;
mod prompt;

pub use edit::{palette_to_save, start_import};

use crate::tui::action::Action;
use crate::tui::app::State;
use crate::tui::keymap;
use crate::tui::model::{PreviewMsg, SolveMsg, is_dial_action};
use crate::tui::msg::{Effect, Msg};
use crate::tui::preview::{MAX_PREVIEW_EDGE, Preview};
use popups::PopupOutcome;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::layout::Rect;

/// Handle one message: change the state, return the effects to run.
pub fn update(state: &mut State, msg: Msg) -> Vec<Effect> {
    let mut effects = match msg {
        Msg::Start { width, height, trains_bases } => {
            state.ui.screen = (width, height);
            state.solve.trains_bases = trains_bases;
            Vec::new()
        }
        Msg::Resize { width, height } => {
            state.ui.screen = (width, height);
            Vec::new()
        }
        Msg::Graphics { graphics, warning } => {
            state.preview.graphics = graphics;
            state.preview.probing = false;
            if let Some(w) = warning {
                state.complain(w);
            }
            // The frame encoded for the new protocol (the raycast follows at the panel's new pixel size).
            state.relight();
            Vec::new()
        }
        Msg::Key(key) => {
            // Each key is looked up in the keymap in force after the one before it acted.
            let mut effects = Vec::new();
            for key in keys_for(state, key) {
                if let Some(action) = keymap::action_for(state, key) {
                    effects.extend(on_action(state, action));
                }
            }
            effects
        }
        Msg::Action(action) => on_action(state, action),
        Msg::Worker(reply) => solve(state, SolveMsg::Worker(reply)),
        Msg::SolveStarted { ticket, at } => solve(state, SolveMsg::Started { ticket, at }),
        Msg::Tick(now) => {
            state.ui.ticks += 1;
            solve(state, SolveMsg::Tick(now))
        }
        Msg::Preview(loaded) => preview(state, PreviewMsg::Raycast(loaded)),
        Msg::SceneSaved(result) => preview(state, PreviewMsg::SceneSaved(result)),
        Msg::Imported { id, result } => {
            files::imported(state, id, result);
            Vec::new()
        }
        Msg::File(outcome) => {
            files::file(state, outcome);
            Vec::new()
        }
        Msg::Terminated => files::terminated(state),
        Msg::WaitSolve | Msg::End => Vec::new(),
    };
    want_solve(state, &mut effects);
    want_preview(state, &mut effects);
    effects
}

/// A message for the solve; the preview relights when the derived colours changed.
fn solve(state: &mut State, msg: SolveMsg) -> Vec<Effect> {
    let update = state.solve.update(msg, &state.doc.palette, &state.colorimetry);
    if update.derived {
        state.relight();
    }
    update.effects
}

/// A message for the preview; its line goes to the message area.
fn preview(state: &mut State, msg: PreviewMsg) -> Vec<Effect> {
    let update = state.preview.update(msg, &state.colorimetry);
    if let Some(message) = update.message {
        state.ui.message = Some(message);
    }
    if update.relight {
        state.relight();
    }
    update.effects
}

/// The keys a key event stands for. Esc followed at once by a key reaches us as Alt+key (the terminal
/// cannot tell them apart); nothing is bound to Alt, so take it as Esc, then the key.
fn keys_for(state: &State, key: KeyEvent) -> Vec<KeyEvent> {
    match keymap::action_for(state, key) {
        None if key.modifiers.contains(KeyModifiers::ALT) => {
            let mut plain = key;
            plain.modifiers.remove(KeyModifiers::ALT);
            vec![KeyEvent::new(KeyCode::Esc, KeyModifiers::NONE), plain]
        }
        _ => vec![key],
    }
}

/// One user action: the open popup's handler, or the main screen's.
fn on_action(state: &mut State, action: Action) -> Vec<Effect> {
    state.ui.message = None;
    match state.ui.popup.take() {
        Some(popup) => match popups::update_popup(state, popup, action) {
            PopupOutcome::Done(effects) => effects,
            PopupOutcome::Main(action) => main_screen(state, action),
        },
        None => main_screen(state, action),
    }
}

/// An action on the main screen: the dial's keys are the preview's, the others the main screen's.
fn main_screen(state: &mut State, action: Action) -> Vec<Effect> {
    if is_dial_action(action) {
        state.doc.history.last_edit = None;
        return preview(state, PreviewMsg::Dial(action));
    }
    keys::update_main(state, action)
}

/// Solve the palette when its generation, or the mismatch region the overlay wants, was not asked for
/// yet (not while quitting).
fn want_solve(state: &mut State, effects: &mut Vec<Effect>) {
    let feasibility = state.feasibility_cell();
    if state.ui.quit || !state.solve.wants_solve(feasibility) {
        return;
    }
    let update = state.solve.submit(&state.doc.palette, feasibility, &state.colorimetry);
    if update.derived {
        state.relight();
    }
    effects.extend(update.effects);
}

/// Keep the scene preview at its panel's pixel size: ask for a raycast when the scene is new or the panel
/// changed size.
pub(super) fn want_preview(state: &mut State, effects: &mut Vec<Effect>) {
    // While the terminal is asked for its graphics, the panel's pixel size is not known yet.
    if !state.preview.has_scene() || state.preview.probing {
        return;
    }
    let (width, height) = state.ui.screen;
    let Some(areas) = crate::tui::ui::preview_areas(state, Rect::new(0, 0, width, height)) else { return };
    let side = state.preview.graphics.pixels_for(areas.image, MAX_PREVIEW_EDGE).max(2);
    let want = (side, side);
    let have = state.preview.ready.as_ref().map(Preview::size);
    if have == Some(want) || state.preview.pending == Some(want) {
        return;
    }
    let scene = state.preview.ready.as_ref().map(|p| p.scene.clone()).or_else(|| state.preview.waiting.clone());
    if let Some(scene) = scene {
        let model = state.preview.ready.as_ref().map(|p| p.model.clone());
        effects.push(Effect::Raycast { scene, model, size: want, colorimetry: state.colorimetry.clone() });
        state.preview.pending = Some(want);
    }
}
