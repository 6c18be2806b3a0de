//! What comes back from off the UI thread — solves, bases, raycasts, CSV imports, saves and reloads — and
//! the effects that ask for them: each reply is a message handled here, each request an [`Effect`] the
//! loop runs.

use super::keys::{Wants, edit};
use super::popups::select_newest;
use crate::palette::Palette;
use crate::tui::app::{EditKey, FeasibilityView, Popup, Prompt, PromptPurpose, State};
use crate::tui::edits::{EditError, FileError};
use crate::tui::model::ShownBasis;
use crate::tui::msg::{Effect, FileOutcome};
use crate::tui::preview::{Loaded, MAX_PREVIEW_EDGE, Preview};
use crate::tui::worker::Reply;
use ratatui::layout::Rect;
use std::time::{Duration, Instant};

/// Turn what an action wants into effects (solve first, then the file operations, as before).
pub(super) fn run(state: &mut State, wants: Wants, effects: &mut Vec<Effect>) {
    if wants.import
        && let Some(import) = &state.doc.import
    {
        effects.push(Effect::Import {
            id: import.id,
            kind: import.kind,
            name: import.name.clone(),
            path: import.path.clone(),
            base_dir: state.doc.base_dir(),
            palette: import.before.clone(),
            colorimetry: state.colorimetry.clone(),
        });
    }
    if wants.solve {
        submit(state, effects);
    }
    if wants.reload {
        state.doc.file_busy = true;
        effects.push(Effect::Reload { file: state.doc.file.clone() });
    }
    if wants.save {
        state.doc.file_busy = true;
        effects.push(Effect::Save {
            file: state.doc.file.clone(),
            palette: palette_to_save(state),
            before: state.doc.palette.clone(),
            quit_after: wants.quit_after_save,
            overwrite: std::mem::take(&mut state.doc.overwrite_armed),
        });
    }
    if let Some(path) = wants.save_as {
        state.doc.file_busy = true;
        let (palette, before) = (palette_to_save(state), state.doc.palette.clone());
        effects.push(Effect::SaveAs { file: state.doc.file.clone(), palette, before, path });
    }
}

/// The palette to write: designed spectra replaced by the current solution's ([`crate::design::Solution::apply_to`]).
pub fn palette_to_save(state: &State) -> Palette {
    match state.solve.current() {
        Some(solution) => solution.apply_to(&state.doc.palette),
        None => state.doc.palette.clone(),
    }
}

/// Solve the palette as it stands (the newest request cancels the running one).
pub(super) fn submit(state: &mut State, effects: &mut Vec<Effect>) {
    state.solve.tickets += 1;
    effects.push(Effect::Solve {
        ticket: state.solve.tickets,
        generation: state.solve.generation,
        palette: state.doc.palette.clone(),
        feasibility: state.feasibility_cell(),
    });
    state.solve.running = Some(state.solve.generation);
    state.solve.started = Some(Instant::now());
    state.solve.running_for = Duration::ZERO;
    ensure_basis(state, effects);
}

/// Have the basis of the spectra the matrix shows: at once from the basis memory, else asked of the worker
/// (the V7 half shows "updating" meanwhile). Nothing is asked while a solve of a palette with designed
/// spectra is under way (the shown spectra are about to change), nor for spectra asked for already.
fn ensure_basis(state: &mut State, effects: &mut Vec<Effect>) {
    let Some(key) = state.solve.derived.basis_key.clone() else { return };
    if state.solve.basis.as_ref().is_some_and(|b| b.key == key) {
        return;
    }
    if !state.solve.trains_bases {
        state.solve.basis_error = Some("basis training is off".into());
        return;
    }
    if let Some(hit) = crate::basis::policy::cached(key.as_str()) {
        state.solve.basis = Some(ShownBasis::new(key, hit));
        state.solve.basis_error = None;
        state.refresh();
        return;
    }
    let designs = state.doc.palette.lights.iter().chain(&state.doc.palette.reflectances).any(|e| e.design);
    if designs && state.solve.running.is_some() {
        return;
    }
    if state.solve.basis_asked.as_ref() == Some(&key) {
        return;
    }
    match crate::basis::train::TrainingSet::new(
        state.solve.derived.light_spectra.clone(),
        state.solve.derived.reflectance_spectra.clone(),
    ) {
        Ok(set) => {
            let m = state.doc.palette.settings.basis_dimension;
            effects.push(Effect::TrainBasis { generation: state.solve.generation, key: key.clone(), set, m });
            state.solve.basis_asked = Some(key);
            state.solve.training = true;
        }
        Err(e) => state.solve.basis_error = Some(format!("cannot train the basis: {e}")),
    }
}

/// A worker reply: a solve (only the newest request's counts) or a basis.
pub(super) fn worker(state: &mut State, reply: Reply, effects: &mut Vec<Effect>) {
    match reply {
        Reply::Trained(t) => {
            if state.solve.basis_asked.as_ref() == Some(&t.key) {
                state.solve.training = false;
            }
            if state.solve.derived.basis_key.as_ref() != Some(&t.key) {
                // For spectra no longer shown (it stays in the basis memory if they come back).
                ensure_basis(state, effects);
                return;
            }
            match t.result {
                Ok(resolved) => {
                    state.solve.basis = Some(ShownBasis::new(t.key, resolved));
                    state.solve.basis_error = None;
                }
                Err(e) => state.solve.basis_error = Some(e),
            }
        }
        Reply::Solved(s) => {
            if s.ticket != state.solve.tickets {
                // A request a newer one replaced (cancelled, or solved before the newer arrived).
                return;
            }
            state.solve.running = None;
            if s.generation != state.solve.generation {
                // Stale: the palette changed since (a newer solve is on its way).
                return;
            }
            state.solve.last_time = Some(s.elapsed);
            if let Some((cell, result)) = s.feasibility {
                state.solve.feasibility = Some(FeasibilityView { generation: s.generation, cell, result });
            }
            match s.result {
                Ok(solution) => {
                    state.solve.solution = Some((s.generation, solution));
                    state.solve.error = None;
                }
                Err(e) => state.solve.error = Some(e),
            }
        }
    }
    state.refresh();
    ensure_basis(state, effects);
}

/// A finished preview raycast.
pub(super) fn preview(state: &mut State, loaded: Loaded) {
    let size = (loaded.weights.width, loaded.weights.height);
    if state.preview.pending == Some(size) {
        state.preview.pending = None;
    }
    let same_scene = state.preview.ready.as_ref().is_some_and(|p| std::sync::Arc::ptr_eq(&p.scene, &loaded.scene));
    match &mut state.preview.ready {
        Some(p) if same_scene => {
            p.set_weights(loaded.weights);
            state.relight();
        }
        _ => {
            let preview = Preview::new(loaded.scene, loaded.model, loaded.weights, &state.colorimetry);
            let show = state.preview.shown;
            state.set_preview(preview);
            state.preview.shown = show;
        }
    }
}

/// Keep the scene preview at its panel's pixel size: ask for a raycast when the scene is new or the panel
/// changed size.
pub(super) fn want_preview(state: &mut State, effects: &mut Vec<Effect>) {
    if !state.preview.has_scene() {
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

/// The reply of CSV import `id`: the spectrum is added unless the import was cancelled, failed, or the
/// palette changed meanwhile.
pub(super) fn imported(state: &mut State, id: u64, result: Result<Palette, EditError>) -> Wants {
    if state.doc.import.as_ref().is_none_or(|i| i.id != id) {
        // Cancelled (Esc) or replaced: the reply is dropped.
        return Wants::NONE;
    }
    let Some(import) = state.doc.import.take() else { return Wants::NONE };
    let shown = crate::fsio::escape(&import.path).into_owned();
    match result {
        Err(reason) => {
            state.complain(format!("not imported: {shown}: {reason}"));
            Wants::NONE
        }
        Ok(_) if state.doc.palette != import.before => {
            state.complain(format!("not imported: the palette changed while {shown} was read; import it again"));
            Wants::NONE
        }
        Ok(next) => {
            let wants = edit(state, EditKey::Other, |p, _| {
                *p = next;
                Ok(())
            });
            if wants.solve {
                state.say(format!("added {} from {shown}", import.kind.as_str()));
                select_newest(state, import.kind);
            }
            wants
        }
    }
}

/// A save, save-as, reload or recovery copy finished.
pub(super) fn file(state: &mut State, outcome: FileOutcome, effects: &mut Vec<Effect>) {
    state.doc.file_busy = false;
    match outcome {
        FileOutcome::Saved { before, result, quit_after, save_as } => match result {
            Ok(saved) => {
                let solved = state.solve.current().is_some();
                state.doc.file = saved.file;
                state.doc.overwrite_armed = false;
                // The palette on screen becomes the file's as written (read back), so the `●` marker compares
                // with what is on disk. Keys that came while the file was written are kept: the palette is
                // replaced only when it is still the one the save started from.
                let written = &state.doc.file.palette;
                if state.doc.palette == before && *written != state.doc.palette {
                    state.doc.palette = written.clone();
                    // The palette now starts from its solution. Solve it again so the title shows exactly
                    // what the saved file solves to (the same optimum for designs with one side designed;
                    // a joint design may improve a little from its new start). The last solution stays on
                    // screen meanwhile.
                    state.solve.generation += 1;
                    state.refresh();
                    if !quit_after {
                        submit(state, effects);
                    }
                }
                if solved {
                    state.say(saved.text);
                } else {
                    state.say(format!("{} (not solved yet: designed spectra kept as they were)", saved.text));
                }
                if quit_after {
                    state.ui.quit = true;
                }
            }
            Err(e @ FileError::Conflict { .. }) => {
                // The user has seen it: the next save overwrites.
                state.doc.overwrite_armed = true;
                state.complain("not saved: the file changed on disk");
                state.ui.popup = Some(Popup::Conflict { text: e.to_string() });
            }
            Err(e) => match save_as {
                // The save-as prompt comes back with the reason; nothing was written.
                Some(path) => {
                    state.ui.popup =
                        Some(Popup::Prompt(save_as_prompt(path.display().to_string(), Some(EditError::File(e)))));
                }
                None => state.complain(format!("not saved: {e}")),
            },
        },
        FileOutcome::Reloaded(Ok(file)) => {
            // The palette on screen is kept in the undo history: `z` brings it back.
            let mine = std::mem::replace(&mut state.doc.palette, file.palette.clone());
            state.doc.history.undo.push(mine);
            state.doc.history.redo.clear();
            state.doc.history.last_edit = None;
            state.doc.file = file;
            state.doc.overwrite_armed = false;
            state.solve.generation += 1;
            state.clamp_selection();
            state.refresh();
            submit(state, effects);
            state.say("reloaded from disk (z undoes the reload)");
        }
        FileOutcome::Reloaded(Err(e)) => state.complain(format!("not reloaded: {e}")),
        FileOutcome::Recovered(result) => {
            state.ui.terminated = Some(result.ok());
            state.ui.quit = true;
        }
    }
}

/// The save-as prompt, with `input` typed and the reason the last answer was refused.
pub(super) fn save_as_prompt(input: String, error: Option<EditError>) -> Prompt {
    Prompt {
        title: "save as".into(),
        hint: "a path, relative to the folder the designer started in".into(),
        input,
        purpose: PromptPurpose::SaveAs,
        error: error.map(Into::into),
    }
}

/// SIGTERM or SIGHUP: write unsaved work as a recovery copy (offered on the next open), then stop.
pub(super) fn terminated(state: &mut State, effects: &mut Vec<Effect>) {
    if state.is_dirty() {
        state.doc.file_busy = true;
        effects.push(Effect::Recover { file: state.doc.file.clone(), palette: palette_to_save(state) });
    } else {
        state.ui.terminated = Some(None);
        state.ui.quit = true;
    }
}
