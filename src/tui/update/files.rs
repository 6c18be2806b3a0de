//! What comes back from the file work off the update step — CSV imports, saves, save-as, reloads,
//! recovery copies — and the end signals. (Solves, bases, raycasts and the dial's scene are the solve's
//! and the preview's own messages: [`crate::tui::model`].)

use super::edit::{edit, save_as_prompt};
use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use crate::tui::app::{EditKey, Popup};
use crate::tui::edits::{EditError, FileError};
use crate::tui::model::{Document, SolveState, UiState};
use crate::tui::msg::{Effect, FileOutcome};

/// The reply of CSV import `id`: the spectrum is added unless the import was cancelled, failed, or the
/// palette changed meanwhile.
pub(super) fn imported(
    doc: &mut Document,
    ui: &mut UiState,
    c: &Colorimetry,
    id: u64,
    result: Result<Palette, EditError>,
) {
    if doc.import.as_ref().is_none_or(|i| i.id != id) {
        // Cancelled (Esc) or replaced: the reply is dropped.
        return;
    }
    let Some(import) = doc.import.take() else { return };
    let shown = crate::fsio::escape(&import.path).into_owned();
    match result {
        Err(reason) => ui.complain(format!("not imported: {shown}: {reason}")),
        Ok(_) if doc.palette != import.before => {
            ui.complain(format!("not imported: the palette changed while {shown} was read; import it again"))
        }
        Ok(next) => {
            let added = edit(doc, ui, c, EditKey::Other, |p, _| {
                *p = next;
                Ok(())
            });
            if added {
                ui.say(format!("added {} from {shown}", import.kind.as_str()));
                ui.select_newest(&doc.palette, import.kind);
            }
        }
    }
}

/// A save, save-as, reload or recovery copy finished.
pub(super) fn file(doc: &mut Document, ui: &mut UiState, solve: &SolveState, c: &Colorimetry, outcome: FileOutcome) {
    doc.file_busy = false;
    match outcome {
        FileOutcome::Saved { before, result, quit_after, save_as } => match result {
            Ok(saved) => {
                let solved = solve.current().is_some();
                doc.saved(saved.file, &before);
                if solved {
                    ui.say(saved.text);
                } else {
                    ui.say(format!("{} (not solved yet: designed spectra kept as they were)", saved.text));
                }
                if quit_after {
                    ui.quit = true;
                }
            }
            Err(e @ FileError::Conflict { .. }) => {
                // The user has seen it: the next save overwrites.
                doc.overwrite_armed = true;
                ui.complain("not saved: the file changed on disk");
                ui.popup = Some(Popup::Conflict { text: e.to_string() });
            }
            Err(e) => match save_as {
                // The save-as prompt comes back with the reason; nothing was written.
                Some(path) => {
                    // Typed relative to the palette's folder: shown so again.
                    let folder = doc.base_dir();
                    let typed = path.strip_prefix(&folder).unwrap_or(&path).display().to_string();
                    ui.popup = Some(Popup::Prompt(save_as_prompt(typed, Some(EditError::File(e)), &folder)));
                }
                None => ui.complain(format!("not saved: {e}")),
            },
        },
        FileOutcome::Reloaded(Ok(file)) => {
            doc.reloaded(file);
            ui.say("reloaded from disk (z undoes the reload)");
        }
        FileOutcome::Reloaded(Err(e)) => ui.complain(format!("not reloaded: {e}")),
        FileOutcome::Restored { path, result } => {
            let shown = crate::fsio::show(&path);
            match result {
                Ok(palette) => {
                    // An edit like any other: unsaved until saved into the palette file, `z` undoes it.
                    edit(doc, ui, c, EditKey::Other, |p, _| {
                        *p = palette;
                        Ok(())
                    });
                    ui.say(format!(
                        "restored the unsaved work from {shown}: Ctrl-s saves it into {}, z undoes it (delete \
                         the copy when done)",
                        crate::fsio::show(doc.path())
                    ));
                }
                Err(e) => ui.complain(format!("not restored from {shown}: {e}")),
            }
        }
        FileOutcome::Recovered(result) => {
            ui.terminated = Some(result.ok());
            ui.quit = true;
        }
    }
}

/// SIGTERM or SIGHUP: write unsaved work as a recovery copy (offered on the next open), then stop.
pub(super) fn terminated(doc: &mut Document, ui: &mut UiState, solve: &SolveState) -> Vec<Effect> {
    if doc.is_dirty() {
        doc.recover(solve.current())
    } else {
        ui.terminated = Some(None);
        ui.quit = true;
        Vec::new()
    }
}
