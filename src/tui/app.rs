//! The designer's state: the four sub-models of [`crate::tui::model`] (document, solve, preview,
//! interface) and the types they share (selection, focus, popups). Everything the view draws is read from
//! here; only [`crate::tui::update`] changes it.

use crate::colorimetry::Colorimetry;
use crate::palette::Kind;
use crate::palette::PaletteFile;
use crate::tui::colour::ColourMode;
use crate::tui::model::{Document, PreviewState, SolveState, UiState};
use std::path::{Path, PathBuf};

pub(crate) use crate::tui::basics::VisibleText;
pub use crate::tui::basics::{PromptText, Renamed, Selection};
pub(crate) use crate::tui::model::{EditKey, Import};

/// Which panel takes the arrow keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Focus {
    Matrix,
    Sliders,
    Settings,
}

/// What the selection points at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Target {
    /// The cell of light `light` on reflectance `reflectance` (whether or not it has a colour criterion).
    Cell { light: usize, reflectance: usize },
    /// A light's swatch across the top.
    Light(usize),
    /// A reflectance's swatch down the left.
    Reflectance(usize),
    /// The palette has no lights and no reflectances.
    Nothing,
}

/// The sliders of the selected cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Slider {
    Red,
    Green,
    Blue,
    Weight,
}

impl Slider {
    pub(crate) const ALL: [Slider; 4] = [Slider::Red, Slider::Green, Slider::Blue, Slider::Weight];
}

/// The fields of the settings row, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SettingField {
    Bounds,
    ReflectanceLower,
    ReflectanceUpper,
    LightLower,
    LightUpper,
    Smoothness,
    SubspaceError,
    FitInSubspace,
    BasisDimension,
}

impl SettingField {
    pub(crate) const ALL: [SettingField; 9] = [
        SettingField::Bounds,
        SettingField::ReflectanceLower,
        SettingField::ReflectanceUpper,
        SettingField::LightLower,
        SettingField::LightUpper,
        SettingField::Smoothness,
        SettingField::SubspaceError,
        SettingField::FitInSubspace,
        SettingField::BasisDimension,
    ];
}

/// An operation on one spectrum (a light or a reflectance).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumOp {
    ToggleDesign,
    NormaliseLuminance,
    NormaliseL2,
    Scale,
    Planck,
    Remove,
    /// Rename the light or the reflectance (or the cell's free-colour group).
    Rename,
}

impl SpectrumOp {
    pub fn label(self) -> &'static str {
        match self {
            SpectrumOp::ToggleDesign => "toggle design",
            SpectrumOp::NormaliseLuminance => "normalise to luminance 1",
            SpectrumOp::NormaliseL2 => "normalise to L2 norm 1",
            SpectrumOp::Scale => "scale",
            SpectrumOp::Planck => "make Planck",
            SpectrumOp::Remove => "remove",
            SpectrumOp::Rename => "rename",
        }
    }
}

/// What a text prompt's answer is for.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum PromptPurpose {
    /// `#rrggbb` target of the cell at (light, reflectance), created if absent.
    Hex { light: usize, reflectance: usize },
    /// Weight of a cell.
    Weight { light: usize, reflectance: usize },
    /// Free-colour group name of a cell (empty = none).
    FreeGroup { light: usize, reflectance: usize },
    /// Bounds of free group `group`.
    FreeBounds { group: usize },
    /// Planck temperature of light `light`.
    Planck { light: usize },
    /// Scale factor of a spectrum.
    Scale { kind: Kind, index: usize },
    /// A numeric setting.
    Setting(SettingField),
    /// Path of a CSV file to import as a new light or reflectance.
    CsvPath(Kind),
    /// Temperature of a new Planck light.
    NewPlanck,
    /// The path to save the palette to (save as).
    SaveAs,
    /// The new name of a light, reflectance or free-colour group.
    Rename(Renamed),
    /// A value of a mixture or path of the dial list.
    Dial(crate::tui::dial_list::DialPrompt),
}

/// A one-line text prompt.
#[derive(Clone, Debug, PartialEq)]
pub struct Prompt {
    pub title: String,
    pub(crate) hint: String,
    pub(crate) input: PromptText,
    pub(crate) purpose: PromptPurpose,
    /// Why the last answer was refused (rendered by the view).
    pub error: Option<crate::tui::edits::Refusal>,
    /// Where ↑/↓ stand in the answers given to this kind of prompt ([`crate::tui::prompt_memory`]).
    pub(crate) recall: Option<crate::tui::prompt_memory::Recall>,
}

/// One entry of an "add" list.
#[derive(Clone, Debug, PartialEq)]
pub enum PickItem {
    Illuminant(&'static str),
    ColorChecker(&'static str),
    Flat(f64),
    Planck,
    Csv,
}

impl PickItem {
    pub fn label(&self) -> String {
        match self {
            PickItem::Illuminant(n) => format!("illuminant {n}"),
            PickItem::ColorChecker(n) => format!("ColorChecker {n}"),
            PickItem::Flat(v) => format!("flat {v}"),
            PickItem::Planck => "Planck black body… (temperature)".to_string(),
            PickItem::Csv => "import CSV file… (path)".to_string(),
        }
    }
}

/// A popup over the main screen. `Esc` closes any of them.
#[derive(Clone, Debug, PartialEq)]
pub enum Popup {
    /// Every key (`?`).
    Help {
        scroll: u16,
    },
    /// The latest solve's diagnostics (`!`).
    Diagnostics {
        scroll: u16,
    },
    /// `/` search or `:` command palette ([`crate::tui::finder`]).
    Find(crate::tui::finder::Finder),
    /// The criteria along the light dial (`M`; [`crate::tui::dial_list`]).
    DialList(crate::tui::dial_list::DialList),
    /// What the marks mean (`i`; [`crate::tui::legend`]).
    Legend {
        scroll: u16,
    },
    Prompt(Prompt),
    /// The dial's keyframes (`f` with the dial keys; [`crate::tui::keyframe_list`]).
    Keyframes(crate::tui::keyframe_list::KeyframeList),
    /// Choose the light or the reflectance of the selected cell for a spectrum operation.
    ChooseSpectrum {
        op: SpectrumOp,
        light: usize,
        reflectance: usize,
    },
    /// Choose what to add.
    Pick {
        kind: Kind,
        items: Vec<PickItem>,
        selected: usize,
    },
    /// `q` with unsaved changes.
    ConfirmQuit,
    /// A recovery copy of an interrupted session's unsaved work is beside the palette (on opening): restore
    /// it here, or keep the file as it is.
    Recovery {
        path: std::path::PathBuf,
    },
    /// Another program changed the palette file: overwrite it, reload it or save as another file. `text`
    /// says what happened (and where the designer's version was saved aside).
    Conflict {
        text: String,
    },
}

/// A short message in the bottom line until the next key.
#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    pub text: String,
    pub is_error: bool,
}

impl Message {
    /// A message (control characters escaped).
    pub(crate) fn info(text: impl Into<String>) -> Message {
        Message { text: crate::fsio::escape(&text.into()).into_owned(), is_error: false }
    }

    /// An error (control characters escaped).
    pub(crate) fn error(text: impl Into<String>) -> Message {
        Message { text: crate::fsio::escape(&text.into()).into_owned(), is_error: true }
    }
}

/// The whole model of the designer: one of each sub-model.
#[derive(Debug)]
pub struct State {
    /// The palette file, the palette being edited, its history.
    pub doc: Document,
    /// The solutions, the basis and the colours derived from them.
    pub solve: SolveState,
    /// The scene preview and its light dial.
    pub preview: PreviewState,
    /// Selection, focus, popup, message line.
    pub ui: UiState,
    pub colorimetry: Colorimetry,
}

impl State {
    /// A designer on `palette`, as if read from `path` (tests; the file's document is built from the
    /// palette).
    pub fn new(path: PathBuf, palette: crate::palette::Palette, colour_mode: ColourMode) -> State {
        let mut file = PaletteFile::from_palette(&palette);
        file.path = Some(path);
        State::with_file(file, colour_mode)
    }

    /// A designer on the palette of `file`.
    pub fn with_file(file: PaletteFile, colour_mode: ColourMode) -> State {
        let mut state = State {
            doc: Document::new(file),
            solve: SolveState { trains_bases: true, ..SolveState::default() },
            preview: PreviewState::default(),
            ui: UiState::new(colour_mode),
            colorimetry: Colorimetry::default(),
        };
        state.ui.clamp_selection(&state.doc.palette);
        state.refresh();
        state
    }

    /// True while something runs off the UI thread whose outcome will come back as a message: a solve, a
    /// basis training, a raycast, a CSV import, a file operation, the terminal's graphics probe.
    pub fn busy(&self) -> bool {
        self.solve.running.is_some()
            || self.solve.training
            || self.preview.pending.is_some()
            || self.preview.saving
            || self.preview.probing
            || self.doc.import.is_some()
            || self.doc.file_busy
            || self.ui.completing
    }

    /// The palette file's path.
    pub fn path(&self) -> &Path {
        self.doc.path()
    }

    /// True when the palette differs from the file.
    pub fn is_dirty(&self) -> bool {
        self.doc.is_dirty()
    }

    /// Derive the colours the view shows from the palette, the solution and the basis, and relight the
    /// preview with them (the update step does this after a message that changed one of them; a new
    /// designer does it once).
    pub fn refresh(&mut self) {
        self.solve.derive(&self.doc.palette, &self.colorimetry);
        self.relight();
    }

    /// Relight the scene preview with the current spectra at the current dial position.
    pub fn relight(&mut self) {
        self.preview.relight(&self.doc.palette, &self.solve);
    }

    /// Attach a scene preview and show it.
    pub fn set_preview(&mut self, preview: crate::tui::preview::Preview) {
        self.preview.attach(preview);
        self.relight();
    }

    /// Attach a scene whose raycast runs off the UI thread (the event loop starts it at the panel's size).
    pub fn set_preview_scene(&mut self, scene: crate::render::Scene) {
        self.preview.attach_scene(scene);
    }

    /// What the selection points at.
    pub(crate) fn target(&self) -> Target {
        self.ui.target(&self.doc.palette)
    }

    /// The light and reflectance whose spectra the plot shows: the selected cell's, or the selected swatch.
    pub(crate) fn plotted(&self) -> (Option<usize>, Option<usize>) {
        match self.target() {
            Target::Cell { light, reflectance } => (Some(light), Some(reflectance)),
            Target::Light(l) => (Some(l), None),
            Target::Reflectance(r) => (None, Some(r)),
            Target::Nothing => (None, None),
        }
    }

    /// Show a message until the next key.
    pub(crate) fn say(&mut self, text: impl Into<String>) {
        self.ui.say(text);
    }

    /// The latest solution's diagnostics (of the current palette, else the last one solved).
    pub fn diagnostics(&self) -> &[crate::design::Diagnostic] {
        self.solve.diagnostics()
    }

    /// The cell whose mismatch region the overlay wants: the selected cell, when the overlay is on.
    pub(crate) fn feasibility_cell(&self) -> Option<usize> {
        feasibility_cell(&self.ui, &self.doc)
    }
}

/// The cell whose mismatch region the overlay wants: the selected cell, when the overlay is on.
pub(crate) fn feasibility_cell(ui: &UiState, doc: &Document) -> Option<usize> {
    match (ui.show_feasibility, ui.target(&doc.palette)) {
        (true, Target::Cell { light, reflectance }) => doc.cell_index(light, reflectance),
        _ => None,
    }
}

#[cfg(test)]
mod prompt_text_tests {
    use super::PromptText;
    use tui_input::InputRequest;
    use unicode_width::UnicodeWidthStr;

    /// At every cursor position of a line with wide characters, in fields of several widths, the field
    /// shows the character under the cursor (none past the end) with the text just before and after it,
    /// and no more than fits.
    #[test]
    fn the_visible_part_keeps_the_cursor_in_view_and_fits_the_field() {
        let line = "ab日本cd語efgh";
        let chars: Vec<char> = line.chars().collect();
        for width in [3, 4, 5, 8, 40] {
            let mut p = PromptText::new(line.to_string());
            for back in 0..=chars.len() {
                let at = chars.len() - back;
                let v = p.visible(width);
                assert_eq!(v.under, chars.get(at).copied(), "cursor {at}, width {width}: {v:?}");
                let before: String = chars[..at].iter().collect();
                let after: String = chars.get(at + 1..).unwrap_or_default().iter().collect();
                assert!(before.ends_with(&v.before) && after.starts_with(&v.after), "{v:?}");
                let shown = v.before.width() + v.under.map_or(1, |c| c.to_string().width()) + v.after.width();
                assert!(shown <= width.max(2), "cursor {at}, width {width}: {v:?} is {shown} wide");
                if width > line.width() {
                    assert_eq!((v.before, v.after), (before, after));
                }
                p.edit(InputRequest::GoToPrevChar);
            }
        }
    }
}
