//! The update step: the one place the designer's [`State`] changes. [`update`] takes one [`Msg`] — a key,
//! a worker reply, a finished raycast, import or save, a tick, a signal — changes the state and returns
//! the [`Effect`]s the event loop must run (as data). Nothing here draws, blocks or starts a thread.
//!
//! - [`keys`]: the main screen's actions, one handler per group of keys;
//! - [`popups`]: each popup's own key handler;
//! - [`prompt`]: a submitted prompt;
//! - [`replies`]: what comes back from off the UI thread (solves, bases, raycasts, imports, files).

mod keys;
mod popups;
mod prompt;
mod replies;

pub use keys::Wants;
pub use popups::start_import;
pub use replies::palette_to_save;

use crate::tui::action::Action;
use crate::tui::app::State;
use crate::tui::keymap;
use crate::tui::msg::{Effect, Msg};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

/// Handle one message: change the state, return the effects to run.
pub fn update(state: &mut State, msg: Msg) -> Vec<Effect> {
    let mut effects = Vec::new();
    match msg {
        Msg::Start { width, height, trains_bases } => {
            state.ui.screen = (width, height);
            state.solve.trains_bases = trains_bases;
            replies::submit(state, &mut effects);
        }
        Msg::Resize { width, height } => state.ui.screen = (width, height),
        Msg::Key(key) => {
            // Each key is looked up in the keymap in force after the one before it acted.
            for key in keys_for(state, key) {
                if let Some(action) = keymap::action_for(state, key) {
                    let wants = on_action(state, action);
                    replies::run(state, wants, &mut effects);
                }
            }
        }
        Msg::Action(action) => {
            let wants = on_action(state, action);
            replies::run(state, wants, &mut effects);
        }
        Msg::Worker(reply) => replies::worker(state, reply, &mut effects),
        Msg::Preview(loaded) => replies::preview(state, loaded),
        Msg::Imported { id, result } => {
            let wants = replies::imported(state, id, result);
            replies::run(state, wants, &mut effects);
        }
        Msg::File(outcome) => replies::file(state, outcome, &mut effects),
        Msg::Tick(now) => {
            state.ui.ticks += 1;
            if let Some(started) = state.solve.started
                && (state.solve.running.is_some() || state.solve.training)
            {
                state.solve.running_for = now.saturating_duration_since(started);
            }
        }
        Msg::Terminated => replies::terminated(state, &mut effects),
        Msg::WaitSolve | Msg::End => {}
    }
    replies::want_preview(state, &mut effects);
    effects
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

/// One user action: the focused popup's handler or the main screen's; the mismatch-region overlay follows
/// the selection (a new cell needs its region computed).
fn on_action(state: &mut State, action: Action) -> Wants {
    state.ui.message = None;
    let wanted = state.feasibility_cell();
    let mut wants = match state.ui.popup.take() {
        Some(popup) => popups::update_popup(state, popup, action),
        None => keys::update_main(state, action),
    };
    let now = state.feasibility_cell();
    if now.is_some() && now != wanted {
        wants.solve = true;
    }
    wants
}
