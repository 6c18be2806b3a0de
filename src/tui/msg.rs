//! The designer's messages and effects (the Elm architecture's `Msg` and `Cmd`).
//!
//! Everything that can change the [`crate::tui::State`] arrives as one [`Msg`] on the event loop's one
//! channel: keys and resizes from the input thread, worker replies (solves, bases), finished raycasts,
//! finished CSV imports, the outcome of saves, reloads and scene writes, the clock, the end signals and
//! the spinner's ticks. [`crate::tui::update::update`] handles each and returns the [`Effect`]s to run, as
//! data — the one kind of request there is: every file read or write, thread and clock reading is one —
//! and the loop runs them; their results come back as messages. Nothing else changes the state.

use crate::basis::TrainingSet;
use crate::colorimetry::Colorimetry;
use crate::palette::PaletteFile;
use crate::palette::{Kind, Palette};
use crate::render::ColourModel;
use crate::render::DialState;
use crate::render::Scene;
use crate::tui::action::Action;
use crate::tui::edits::{EditError, FileError};
use crate::tui::preview::Loaded;
use crate::tui::worker::Reply;
use ratatui::crossterm::event::KeyEvent;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// A save that went through.
#[derive(Clone, Debug)]
pub struct Saved {
    /// What the status line says (where it went).
    pub text: String,
    /// The palette file as written (its path: the new one after a save-as).
    pub file: PaletteFile,
}

/// Which file operation a [`Msg::File`] answers. (One per file operation, moved once: the size of the
/// save's variant does not matter.)
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
pub enum FileOutcome {
    /// `Effect::Save` or `Effect::SaveAs` (`save_as`: the path typed): the file as written (or why not), and
    /// whether to quit now.
    Saved {
        /// The palette on screen when the save was asked for.
        before: Palette,
        result: Result<Saved, FileError>,
        quit_after: bool,
        save_as: Option<PathBuf>,
    },
    /// `Effect::Reload`: the file read again.
    Reloaded(Result<PaletteFile, FileError>),
    /// `Effect::Restore`: the recovery copy's palette (or why not), and where it is.
    Restored { path: PathBuf, result: Result<Palette, FileError> },
    /// `Effect::Recover`: where the recovery copy went.
    Recovered(Result<PathBuf, FileError>),
}

/// Keyframes written into the scene file, and the scene read back.
#[derive(Clone, Debug)]
pub struct SavedScene {
    /// What the status line says (how many keyframes went where).
    pub text: String,
    /// How many keyframes were written (the first ones of the dial's list).
    pub count: usize,
    /// The scene as saved (its exposure is the one `metamer render` now uses), or why it does not load.
    pub reloaded: Result<Scene, String>,
}

/// One message to the designer. (A few per key or reply, each moved once through the channel: the
/// variants' sizes do not matter, so the large ones are not boxed.)
#[allow(clippy::large_enum_variant)]
pub enum Msg {
    /// The loop starts on a terminal of this size (columns, rows); `trains_bases`: the worker trains bases.
    Start { width: u16, height: u16, trains_bases: bool },
    /// A key from the terminal or a script (turned into an [`Action`] by the keymap).
    Key(KeyEvent),
    /// A mouse event from the terminal (a click or drag; [`crate::tui::mouse`]).
    Mouse(ratatui::crossterm::event::MouseEvent),
    /// A user action as such (tests; the keymap's output).
    Action(Action),
    /// The terminal answered the graphics probe (or its deadline passed): how the preview is drawn, and a
    /// warning when it had to guess.
    Graphics { graphics: crate::tui::graphics::Graphics, warning: Option<String> },
    /// The terminal changed size.
    Resize { width: u16, height: u16 },
    /// The solve or basis worker finished something.
    Worker(Reply),
    /// A preview raycast finished.
    Preview(Loaded),
    /// A CSV import (number `id`) finished: the palette with the spectrum added, or why not.
    Imported { id: u64, result: Result<Palette, EditError> },
    /// A save, reload or recovery copy finished.
    File(FileOutcome),
    /// The dial's keyframes were written into the scene file (and the scene read back), or why not.
    SceneSaved(Result<SavedScene, String>),
    /// The loop's clock when it handed solve `ticket` to the worker (the progress line counts from it).
    SolveStarted { ticket: u64, at: Instant },
    /// The names in the folder a path prompt's `typed` text names (Tab completion).
    Completed { typed: String, entries: Vec<String> },
    /// The spinner's clock (sent only while something is under way).
    Tick(Instant),
    /// A script asks to wait for the running solve (every step waits anyway; kept for old scripts).
    WaitSolve,
    /// The process was told to end (SIGTERM, SIGHUP, SIGINT): write a recovery copy of unsaved work and stop.
    Terminated,
    /// No more input: stop.
    End,
}

impl Msg {
    /// A short name of the message (logs and tests).
    pub fn label(&self) -> String {
        match self {
            Msg::Start { .. } => "start".into(),
            Msg::Key(k) => format!("key {:?}", k.code),
            Msg::Action(a) => format!("action {a:?}"),
            Msg::Mouse(m) => format!("mouse {:?} {},{}", m.kind, m.column, m.row),
            Msg::Resize { .. } => "resize".into(),
            Msg::Graphics { graphics, .. } => format!("graphics {}", graphics.name()),
            Msg::Worker(Reply::Solved(s)) => format!("solved {}", s.generation),
            Msg::Worker(Reply::Trained(_)) => "trained".into(),
            Msg::Preview(_) => "preview".into(),
            Msg::Imported { .. } => "imported".into(),
            Msg::File(_) => "file".into(),
            Msg::SceneSaved(_) => "scene saved".into(),
            Msg::SolveStarted { ticket, .. } => format!("solve started {ticket}"),
            Msg::Completed { .. } => "completed".into(),
            Msg::Tick(_) => "tick".into(),
            Msg::WaitSolve => "wait-solve".into(),
            Msg::Terminated => "terminated".into(),
            Msg::End => "end".into(),
        }
    }
}

/// A side effect [`crate::tui::update::update`] asks the loop to run; its result comes back as a [`Msg`].
#[allow(clippy::large_enum_variant)]
pub enum Effect {
    /// Solve `palette` (cancelling the running solve); the replies are a [`Msg::SolveStarted`] (the clock)
    /// and a `Reply::Solved` with `ticket`.
    Solve { ticket: u64, generation: u64, palette: Palette, feasibility: Option<usize> },
    /// Train (or look up) the basis of these spectra; the reply is a `Reply::Trained` with `key`.
    TrainBasis { generation: u64, key: crate::tui::model::BasisKey, set: TrainingSet, m: usize },
    /// Raycast the scene preview at `size` pixels; the reply is a [`Msg::Preview`].
    Raycast { scene: Arc<Scene>, model: Option<ColourModel>, size: (usize, usize), colorimetry: Colorimetry },
    /// Read a CSV spectrum into `palette` off the UI thread; the reply is a [`Msg::Imported`].
    Import {
        id: u64,
        kind: Kind,
        name: String,
        path: String,
        base_dir: PathBuf,
        palette: Palette,
        colorimetry: Colorimetry,
    },
    /// Save `palette` into `file` (`before`: the palette on screen, handed back with the outcome;
    /// `overwrite`: even when the file changed on disk).
    Save { file: PaletteFile, palette: Palette, before: Palette, quit_after: bool, overwrite: bool },
    /// Save `palette` into `file` at `path`, which becomes the palette file (`replace`: even when another
    /// file is there; the user was asked).
    SaveAs { file: PaletteFile, palette: Palette, before: Palette, path: PathBuf, replace: bool },
    /// Read the palette file again.
    Reload { file: PaletteFile },
    /// Read the recovery copy at `path`; the reply is a [`FileOutcome::Restored`].
    Restore { path: PathBuf },
    /// Write a recovery copy of `palette` beside `file`.
    Recover { file: PaletteFile, palette: Palette },
    /// List `folder` for the path prompt's Tab completion of `typed`; the reply is a [`Msg::Completed`].
    Complete { folder: PathBuf, typed: String },
    /// Append `keyframes` to the scene file at `path` and read the scene back; the reply is a
    /// [`Msg::SceneSaved`].
    SaveKeyframes { path: PathBuf, keyframes: Vec<DialState> },
}
