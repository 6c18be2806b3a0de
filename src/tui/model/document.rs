//! The document: the palette file, the palette being edited and its undo history, and the file work
//! (save, save as, reload, CSV import) under way. The one owner of the palette.

use crate::colorimetry::Colorimetry;
use crate::design::Solution;
use crate::palette::PaletteFile;
use crate::palette::{Bounds, Kind, Palette};
use crate::tui::edits::{EditError, EditResult};
use crate::tui::msg::Effect;
use std::path::{Path, PathBuf};

/// How the palette changed since the update step last looked: it then starts a new generation (solved
/// anew), keeps the selection inside the matrix, derives the colours again and relights.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum PaletteChange {
    /// Unchanged.
    #[default]
    None,
    /// Edited (an edit, undo, redo, reload, restore, import): a new generation, solved anew.
    Edited,
    /// Replaced by the palette the current solution already describes (its designed spectra written by a
    /// save): a new generation that keeps the solution, so nothing is solved again.
    Carried,
}

/// Groups consecutive edits of one slider of one cell into one undo step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum EditKey {
    Slider { light: usize, reflectance: usize, slider: usize },
    Other,
}

/// Undo / redo as whole palette snapshots (palettes are small).
#[derive(Clone, Debug, Default)]
pub struct History {
    pub undo: Vec<Palette>,
    pub(crate) redo: Vec<Palette>,
    pub(crate) last_edit: Option<EditKey>,
}

impl History {
    /// Most undo steps kept.
    pub(crate) const LIMIT: usize = 500;
}

/// A CSV import running off the UI thread (the read is bounded by `crate::fsio`, so the thread ends).
#[derive(Clone, Debug, PartialEq)]
pub struct Import {
    /// Which import this is (a reply to an older, cancelled one is dropped).
    pub(crate) id: u64,
    /// The path as typed.
    pub(crate) path: String,
    pub(crate) kind: Kind,
    /// The name the new spectrum gets.
    pub(crate) name: String,
    /// The palette the import was started from (a reply for another palette is dropped).
    pub(crate) before: Palette,
}

/// The palette file, the palette being edited, its history and the file work under way.
#[derive(Debug)]
pub struct Document {
    /// The palette file as last loaded or saved: its path (shown in the title; saved to), its palette (the
    /// `●` marker shows when `palette` differs) and its document (comments, key order, unknown keys, which a
    /// save keeps). The one owner of these: a save hands a copy to the loop and gets the new file back.
    pub file: PaletteFile,
    /// The palette being edited.
    pub palette: Palette,
    pub history: History,
    /// The outside change was shown and the user may now overwrite it (the next save does).
    pub(crate) overwrite_armed: bool,
    /// A save, save-as, reload or recovery copy is under way (its outcome comes back as a message).
    pub(crate) file_busy: bool,
    /// The CSV import being read, if any (Esc cancels it).
    pub import: Option<Import>,
    /// Imports started so far (the id of the newest).
    pub imports: u64,
    /// Bounds to restore when bounds are switched back on.
    pub remembered_bounds: (Bounds, Bounds),
    /// How the palette changed while the update step handled the current message.
    pub(crate) change: PaletteChange,
}

impl Document {
    /// The document of `file`, its palette unedited.
    pub fn new(file: PaletteFile) -> Document {
        Document {
            palette: file.palette.clone(),
            file,
            history: History::default(),
            overwrite_armed: false,
            file_busy: false,
            import: None,
            imports: 0,
            remembered_bounds: (Bounds::new(0.0, 1.0), Bounds::new(0.0, f64::INFINITY)),
            change: PaletteChange::None,
        }
    }

    /// Make an edit on a copy of the palette; keep it (with an undo step) when it succeeds and changed
    /// something. A refused edit leaves the palette as it was. True when the palette changed.
    pub(crate) fn edit(
        &mut self,
        key: EditKey,
        colorimetry: &Colorimetry,
        f: impl FnOnce(&mut Palette, &Colorimetry) -> EditResult,
    ) -> Result<bool, EditError> {
        let mut next = self.palette.clone();
        f(&mut next, colorimetry)?;
        if next == self.palette {
            return Ok(false);
        }
        self.remember(key);
        self.palette = next;
        self.touch(PaletteChange::Edited);
        Ok(true)
    }

    /// Step back (`undo`) or forward through the history; false when there is nothing to step to.
    pub(crate) fn step_history(&mut self, undo: bool) -> bool {
        let (from, to) = if undo {
            (&mut self.history.undo, &mut self.history.redo)
        } else {
            (&mut self.history.redo, &mut self.history.undo)
        };
        let Some(other) = from.pop() else { return false };
        to.push(std::mem::replace(&mut self.palette, other));
        self.history.last_edit = None;
        self.touch(PaletteChange::Edited);
        true
    }

    /// The palette file read again: the palette on screen is kept in the undo history (`z` brings it back).
    pub(crate) fn reloaded(&mut self, file: PaletteFile) {
        let mine = std::mem::replace(&mut self.palette, file.palette.clone());
        self.history.undo.push(mine);
        self.history.redo.clear();
        self.history.last_edit = None;
        self.file = file;
        self.overwrite_armed = false;
        self.touch(PaletteChange::Edited);
    }

    /// A save went through: `file` is the palette file as written. The palette on screen becomes the
    /// file's as written (read back), so the `●` marker compares with what is on disk, when it is still
    /// the one the save started from (`before`); keys that came while the file was written are kept. The
    /// written palette's designed spectra are the solution's: the solution the user saw stays its
    /// solution ([`PaletteChange::Carried`]: no new solve, which could move a joint design from its new
    /// start), so saving changes no result.
    pub(crate) fn saved(&mut self, file: PaletteFile, before: &Palette) {
        self.file = file;
        self.overwrite_armed = false;
        if self.palette == *before && self.file.palette != self.palette {
            self.palette = self.file.palette.clone();
            self.touch(PaletteChange::Carried);
        }
    }

    /// The palette to write: designed spectra replaced by `solution`'s, the solution of the palette
    /// ([`Solution::apply_to`]).
    pub(crate) fn palette_to_save(&self, solution: Option<&Solution>) -> Palette {
        match solution {
            Some(solution) => solution.apply_to(&self.palette),
            None => self.palette.clone(),
        }
    }

    /// Save the palette (with `solution`'s designed spectra) to its file, then quit when `quit_after`.
    pub(crate) fn save(&mut self, solution: Option<&Solution>, quit_after: bool) -> Vec<Effect> {
        self.file_busy = true;
        vec![Effect::Save {
            file: self.file.clone(),
            palette: self.palette_to_save(solution),
            before: self.palette.clone(),
            quit_after,
            overwrite: std::mem::take(&mut self.overwrite_armed),
        }]
    }

    /// Save the palette to `path`, which becomes the palette file (`replace`: the user was asked).
    pub(crate) fn save_as(&mut self, solution: Option<&Solution>, path: PathBuf, replace: bool) -> Vec<Effect> {
        self.file_busy = true;
        let (palette, before) = (self.palette_to_save(solution), self.palette.clone());
        vec![Effect::SaveAs { file: self.file.clone(), palette, before, path, replace }]
    }

    /// Read the palette file again.
    pub(crate) fn reload(&mut self) -> Vec<Effect> {
        self.file_busy = true;
        vec![Effect::Reload { file: self.file.clone() }]
    }

    /// Write a recovery copy of unsaved work (with `solution`'s designed spectra) beside the file.
    pub(crate) fn recover(&mut self, solution: Option<&Solution>) -> Vec<Effect> {
        self.file_busy = true;
        vec![Effect::Recover { file: self.file.clone(), palette: self.palette_to_save(solution) }]
    }

    /// Note a change of the palette (an edit outranks a carried solution).
    fn touch(&mut self, change: PaletteChange) {
        if self.change != PaletteChange::Edited {
            self.change = change;
        }
    }

    /// How the palette changed since the last call.
    pub(crate) fn take_change(&mut self) -> PaletteChange {
        std::mem::take(&mut self.change)
    }

    /// The palette file's path.
    pub fn path(&self) -> &Path {
        self.file.path.as_deref().unwrap_or(Path::new("palette.toml"))
    }

    /// True when the palette differs from the file.
    pub fn is_dirty(&self) -> bool {
        self.palette != self.file.palette
    }

    /// The palette file's folder (CSV paths are relative to it).
    pub(crate) fn base_dir(&self) -> PathBuf {
        crate::fsio::folder_of(self.path())
    }

    /// Record the palette before an edit so it can be undone. Consecutive edits with the same slider key
    /// coalesce into one step.
    pub(crate) fn remember(&mut self, key: EditKey) {
        let coalesce = key != EditKey::Other && self.history.last_edit == Some(key);
        if !coalesce {
            self.history.undo.push(self.palette.clone());
            if self.history.undo.len() > History::LIMIT {
                self.history.undo.remove(0);
            }
        }
        self.history.redo.clear();
        self.history.last_edit = Some(key);
    }

    /// The index into `palette.colours` of the cell at (light, reflectance).
    pub(crate) fn cell_index(&self, light: usize, reflectance: usize) -> Option<usize> {
        self.palette.colours.iter().position(|c| c.light == light && c.reflectance == reflectance)
    }
}
