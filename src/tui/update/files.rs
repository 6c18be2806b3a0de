//! What comes back from the file work off the update step — CSV imports, saves, save-as, reloads,
//! recovery copies — and the end signals. (Solves, bases, raycasts and the dial's scene are the solve's
//! and the preview's own messages: [`crate::tui::model`].)

use super::edit::{changed, edit, palette_to_save, save_as_prompt, select_newest};
use crate::palette::Palette;
use crate::tui::app::{EditKey, Popup, State};
use crate::tui::edits::{EditError, FileError};
use crate::tui::msg::{Effect, FileOutcome};

/// The reply of CSV import `id`: the spectrum is added unless the import was cancelled, failed, or the
/// palette changed meanwhile.
pub(super) fn imported(state: &mut State, id: u64, result: Result<Palette, EditError>) {
    if state.doc.import.as_ref().is_none_or(|i| i.id != id) {
        // Cancelled (Esc) or replaced: the reply is dropped.
        return;
    }
    let Some(import) = state.doc.import.take() else { return };
    let shown = crate::fsio::escape(&import.path).into_owned();
    match result {
        Err(reason) => state.complain(format!("not imported: {shown}: {reason}")),
        Ok(_) if state.doc.palette != import.before => {
            state.complain(format!("not imported: the palette changed while {shown} was read; import it again"))
        }
        Ok(next) => {
            let added = edit(state, EditKey::Other, |p, _| {
                *p = next;
                Ok(())
            });
            if added {
                state.say(format!("added {} from {shown}", import.kind.as_str()));
                select_newest(state, import.kind);
            }
        }
    }
}

/// A save, save-as, reload or recovery copy finished.
pub(super) fn file(state: &mut State, outcome: FileOutcome) {
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
                    // The palette on screen becomes the one written, whose designed spectra are the
                    // solution's: the solution the user saw is its solution, kept as it is (no new solve,
                    // which could move a joint design from its new start): saving changes no result.
                    state.doc.palette = written.clone();
                    state.solve.carry_to_next_generation();
                    state.clamp_selection();
                    state.refresh();
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
            changed(state);
            state.say("reloaded from disk (z undoes the reload)");
        }
        FileOutcome::Reloaded(Err(e)) => state.complain(format!("not reloaded: {e}")),
        FileOutcome::Restored { path, result } => {
            let shown = crate::fsio::show(&path);
            match result {
                Ok(palette) => {
                    // An edit like any other: unsaved until saved into the palette file, `z` undoes it.
                    edit(state, EditKey::Other, |p, _| {
                        *p = palette;
                        Ok(())
                    });
                    state.say(format!(
                        "restored the unsaved work from {shown}: Ctrl-s saves it into {}, z undoes it (delete \
                         the copy when done)",
                        crate::fsio::show(state.path())
                    ));
                }
                Err(e) => state.complain(format!("not restored from {shown}: {e}")),
            }
        }
        FileOutcome::Recovered(result) => {
            state.ui.terminated = Some(result.ok());
            state.ui.quit = true;
        }
    }
}

/// SIGTERM or SIGHUP: write unsaved work as a recovery copy (offered on the next open), then stop.
pub(super) fn terminated(state: &mut State) -> Vec<Effect> {
    if state.is_dirty() {
        state.doc.file_busy = true;
        vec![Effect::Recover { file: state.doc.file.clone(), palette: palette_to_save(state) }]
    } else {
        state.ui.terminated = Some(None);
        state.ui.quit = true;
        Vec::new()
    }
}
