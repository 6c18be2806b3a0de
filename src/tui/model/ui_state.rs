//! The interface: the selection, the focused panel, the popup, the message line, the terminal's size and
//! colours, and whether the designer is to quit.

use crate::palette::{Kind, Palette};
use crate::tui::app::{Focus, Message, Popup, Prompt, PromptPurpose, PromptText, Selection, Target};
use crate::tui::colour::ColourMode;

/// A message for the interface alone. (The keys are the interface's too, but most act on the document
/// as well: [`crate::tui::update`] hands them to handlers that take both.)
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum UiMsg {
    /// The terminal's size in cells.
    Screen { width: u16, height: u16 },
    /// A tick of the spinner's clock.
    Tick,
}

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
    /// The answers given to each kind of prompt this session (↑/↓ in a prompt recall them).
    pub history: crate::tui::prompt_memory::PromptHistory,
    /// A path prompt's Tab completion is being read (the folder listing comes back as a message).
    pub(crate) completing: bool,
    /// What the held mouse button went down on (a drag acts on it).
    pub drag: Option<crate::tui::mouse::Drag>,
    /// The designer was ended by SIGTERM, SIGHUP or SIGINT: where unsaved work was written (`Some(None)` when there was
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
            drag: None,
            history: Default::default(),
            completing: false,
            terminated: None,
        }
    }

    /// Handle one message of the interface: the terminal's size, a tick of the spinner.
    pub(crate) fn update(&mut self, msg: UiMsg) {
        match msg {
            UiMsg::Screen { width, height } => self.screen = (width, height),
            UiMsg::Tick => self.ticks += 1,
        }
    }

    /// Show a message until the next key.
    pub(crate) fn say(&mut self, text: impl Into<String>) {
        self.message = Some(Message::info(text));
    }

    /// Show an error until the next key.
    pub(crate) fn complain(&mut self, text: impl Into<String>) {
        self.message = Some(Message::error(text));
    }

    /// What the selection points at in `palette`.
    pub(crate) fn target(&self, palette: &Palette) -> Target {
        let (nl, nr) = (palette.lights.len(), palette.reflectances.len());
        let Selection { col, row } = self.selection;
        match (col, row) {
            (0, 0) => Target::Nothing,
            (0, r) if r <= nr => Target::Reflectance(r - 1),
            (c, 0) if c <= nl => Target::Light(c - 1),
            (c, r) if c <= nl && r <= nr => Target::Cell { light: c - 1, reflectance: r - 1 },
            _ => Target::Nothing,
        }
    }

    /// The selected cell (light, reflectance) of `palette`, or `None` having said that a cell must be
    /// selected.
    pub(crate) fn selected_cell(&mut self, palette: &Palette) -> Option<(usize, usize)> {
        match self.target(palette) {
            Target::Cell { light, reflectance } => Some((light, reflectance)),
            _ => {
                self.complain("select a cell of the matrix first");
                None
            }
        }
    }

    /// Open a one-line prompt.
    pub(crate) fn open_prompt(&mut self, title: &str, hint: &str, input: String, purpose: PromptPurpose) {
        self.popup = Some(Popup::Prompt(Prompt {
            title: title.to_string(),
            hint: hint.to_string(),
            input: PromptText::new(input),
            purpose,
            error: None,
            recall: None,
        }));
    }

    /// Keep the selection inside `palette`'s matrix (after removing a spectrum, or on an empty palette).
    pub(crate) fn clamp_selection(&mut self, palette: &Palette) {
        let (nl, nr) = (palette.lights.len(), palette.reflectances.len());
        let s = &mut self.selection;
        s.col = s.col.min(nl);
        s.row = s.row.min(nr);
        if s.col == 0 && s.row == 0 {
            if nl > 0 {
                s.col = 1;
            } else if nr > 0 {
                s.row = 1;
            }
        }
    }

    /// Select the swatch of `palette`'s newest light or reflectance.
    pub(crate) fn select_newest(&mut self, palette: &Palette, kind: Kind) {
        self.selection = match kind {
            Kind::Light => Selection { col: palette.lights.len(), row: 0 },
            Kind::Reflectance => Selection { col: 0, row: palette.reflectances.len() },
        };
        self.clamp_selection(palette);
    }
}
