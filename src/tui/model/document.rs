//! The document: the palette file, the palette being edited and its undo history, and the file work
//! (save, save as, reload, CSV import) under way. The one owner of the palette.

use crate::palette::PaletteFile;
use crate::palette::{Bounds, Kind, Palette};
use std::path::{Path, PathBuf};

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
        }
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
