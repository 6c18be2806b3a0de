//! The interface: the selection, the focused panel, the popup, the message line, the terminal's size and
//! colours, and whether the designer is to quit.

use crate::tui::app::{Focus, Message, Popup, Selection};
use crate::tui::colour::ColourMode;

/// What the user is looking at and pointing at.
#[derive(Debug)]
pub struct UiState {
    pub selection: Selection,
    pub focus: Focus,
    /// The focused slider of the selected cell.
    pub slider: usize,
    /// The focused field of the settings row.
    pub(crate) setting: usize,
    pub popup: Option<Popup>,
    pub message: Option<Message>,
    /// The mismatch-region overlay of the selected cell is shown (`m`).
    pub(crate) show_feasibility: bool,
    /// The terminal's size in cells (the preview is raycast at its panel's pixel size).
    pub(crate) screen: (u16, u16),
    pub colour_mode: ColourMode,
    /// Replay runs hide wall-clock times so their screens are reproducible.
    pub hide_times: bool,
    /// Frames drawn so far (spinner phase).
    pub ticks: u64,
    pub quit: bool,
    /// The designer was ended by SIGTERM/SIGHUP: where unsaved work was written (`Some(None)` when there was
    /// none to write, or it could not be written).
    pub(crate) terminated: Option<Option<std::path::PathBuf>>,
}

impl UiState {
    pub(crate) fn new(colour_mode: ColourMode) -> UiState {
        UiState {
            selection: Selection { col: 1, row: 1 },
            focus: Focus::Matrix,
            slider: 0,
            setting: 0,
            popup: None,
            message: None,
            show_feasibility: false,
            screen: (0, 0),
            colour_mode,
            hide_times: false,
            ticks: 0,
            quit: false,
            terminated: None,
        }
    }

    /// Show a message until the next key.
    pub(crate) fn say(&mut self, text: impl Into<String>) {
        self.message = Some(Message { text: crate::fsio::escape(&text.into()).into_owned(), is_error: false });
    }

    /// Show an error until the next key.
    pub(crate) fn complain(&mut self, text: impl Into<String>) {
        self.message = Some(Message { text: crate::fsio::escape(&text.into()).into_owned(), is_error: true });
    }
}
