//! The designer's state: the palette being edited, the selection, popups, undo history and the latest
//! solve. Everything the view draws is read from here; only [`crate::tui::update`] changes it.

use crate::colorimetry::Colorimetry;
use crate::design::{DesignError, Solution};
use crate::palette::file::PaletteFile;
use crate::palette::{Bounds, Kind, Palette};
use crate::tui::colour::ColourMode;
use crate::tui::derived::Derived;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

/// Which panel takes the arrow keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Focus {
    Matrix,
    Sliders,
    Settings,
}

/// The selection in the design matrix. Column 0 is the reflectance column down the left, row 0 the light
/// row across the top; column `j + 1` is light `j`, row `i + 1` is reflectance `i`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Selection {
    pub col: usize,
    pub row: usize,
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
}

/// A one-line text prompt.
#[derive(Clone, Debug, PartialEq)]
pub struct Prompt {
    pub title: String,
    pub(crate) hint: String,
    pub(crate) input: String,
    pub(crate) purpose: PromptPurpose,
    /// Why the last answer was refused (rendered by the view).
    pub error: Option<crate::tui::edits::Refusal>,
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
    Prompt(Prompt),
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

/// The latest solve, as far as the view is concerned.
#[derive(Clone, Debug, Default)]
pub struct SolveStatus {
    /// Generation of the palette: bumped by every edit. A reply for an older generation is stale.
    pub generation: u64,
    /// The generation now being solved, if any.
    pub running: Option<u64>,
    /// Solve requests sent so far (the ticket of the newest); only the newest one's reply counts.
    pub(crate) tickets: u64,
    /// When the newest solve was asked for (the progress line's clock).
    pub(crate) started: Option<std::time::Instant>,
    /// The key of the newest basis asked for (the same spectra are not asked for twice).
    pub(crate) basis_asked: Option<String>,
    /// How long the running solve has been going (updated on ticks; shown as progress).
    pub(crate) running_for: Duration,
    /// The latest solution and the generation it belongs to.
    pub solution: Option<(u64, Arc<Solution>)>,
    /// The latest solve's failure, if it failed.
    pub error: Option<DesignError>,
    /// Wall-clock time of the latest finished solve.
    pub(crate) last_time: Option<Duration>,
    /// A basis is being trained.
    pub(crate) training: bool,
    /// Generation of the palette the shown basis was trained for.
    pub(crate) basis_generation: u64,
    /// Why the basis could not be trained.
    pub(crate) basis_error: Option<String>,
    /// The factor model's mean ΔE00 on the shown spectra's own pairs, when it is poor (above
    /// [`crate::basis::POOR_MODEL_MEAN_DE00`], [`crate::basis::Report::poor_model`]).
    pub basis_poor: Option<f64>,
}

impl SolveStatus {
    /// The solution of the current palette, if solved.
    pub fn current(&self) -> Option<&Solution> {
        self.solution.as_ref().filter(|(g, _)| *g == self.generation).map(|(_, s)| s.as_ref())
    }
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

/// The whole model of the designer.
#[derive(Debug)]
pub struct State {
    /// The palette file as last loaded or saved: its path (shown in the title; saved to), its palette (the
    /// `●` marker shows when `palette` differs) and its document (comments, key order, unknown keys, which a
    /// save keeps). The one owner of these: a save hands a copy to the loop and gets the new file back.
    pub file: PaletteFile,
    /// The palette being edited.
    pub palette: Palette,
    /// The outside change was shown and the user may now overwrite it (the next save does).
    pub(crate) overwrite_armed: bool,
    pub colorimetry: Colorimetry,
    /// The CSV import being read, if any (Esc cancels it).
    pub import: Option<Import>,
    /// The worker trains bases (off: `--no-basis`).
    pub trains_bases: bool,
    /// Imports started so far (the id of the newest).
    pub imports: u64,
    /// A save, save-as, reload or recovery copy is under way (its outcome comes back as a message).
    pub(crate) file_busy: bool,
    /// The terminal's size in cells (the preview is raycast at its panel's pixel size).
    pub(crate) screen: (u16, u16),
    /// The preview size being raycast, if any.
    pub(crate) preview_pending: Option<(usize, usize)>,
    /// The spectral factor basis for subspace colours and the key of the spectra it is for (the derived
    /// colours use it only while the shown spectra have that key).
    pub basis: Option<(String, crate::basis::policy::Resolved)>,
    pub selection: Selection,
    pub focus: Focus,
    pub slider: usize,
    pub(crate) setting: usize,
    pub popup: Option<Popup>,
    pub history: History,
    pub solve: SolveStatus,
    pub colour_mode: ColourMode,
    /// Replay runs hide wall-clock times so their screens are reproducible.
    pub hide_times: bool,
    pub message: Option<Message>,
    /// Bounds to restore when bounds are switched back on.
    pub remembered_bounds: (Bounds, Bounds),
    /// Colours and errors derived from the palette and the latest solution (recomputed on change).
    pub derived: Derived,
    pub quit: bool,
    /// The designer was ended by SIGTERM/SIGHUP: where unsaved work was written (`Some(None)` when there was
    /// none to write, or it could not be written).
    pub(crate) terminated: Option<Option<std::path::PathBuf>>,
    /// Frames drawn so far (spinner phase).
    pub ticks: u64,
    /// The scene preview (`--scene`), its dial position in [0, 1], whether it is shown, and its pixels
    /// under the current spectra (sRGB, 3 bytes per pixel at the preview's size; recomputed with the
    /// derived colours and on every dial change).
    pub preview: Option<crate::tui::preview::Preview>,
    pub(crate) dial: f64,
    pub(crate) show_preview: bool,
    pub preview_frame: Vec<u8>,
    /// A scene waiting for its first raycast (off the UI thread); the progress line says so.
    pub(crate) preview_scene: Option<Arc<crate::render::scene::Scene>>,
    /// What the preview is being raycast at, for the progress line.
    pub(crate) preview_loading: Option<String>,
    /// How the preview reaches the terminal: half blocks, or a graphics protocol at real pixels.
    pub graphics: crate::tui::graphics::Graphics,
    /// The live light dial (lights, vertices, on/off, intensities, slider) the preview is lit by.
    pub dial_state: Option<crate::render::dial::DialState>,
    /// The dial panel has the keys ([`crate::tui::keymap::DIAL`]).
    pub dial_keys: bool,
    /// What the dial keys move: the slider (`None`) or light i's vertex.
    pub(crate) dial_selected: Option<usize>,
    /// Keyframes added this session (written into the scene by the dial's save).
    pub keyframes: Vec<crate::render::dial::DialState>,
    /// The mismatch-region overlay of the selected cell is shown (`m`).
    pub(crate) show_feasibility: bool,
    /// The latest region computed by the worker for the overlay.
    pub(crate) feasibility: Option<FeasibilityView>,
}

/// A mismatch region computed off the UI thread, for the palette of `generation`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FeasibilityView {
    pub(crate) generation: u64,
    /// Index into `palette.colours`.
    pub(crate) cell: usize,
    pub(crate) result: Result<Arc<crate::design::feasibility::Panel>, String>,
}

impl State {
    /// A designer on `palette`, as if read from `path` (tests; the file's document is built from the
    /// palette).
    pub fn new(path: PathBuf, palette: Palette, colour_mode: ColourMode) -> State {
        let mut file = PaletteFile::from_palette(&palette);
        file.path = Some(path);
        State::with_file(file, colour_mode)
    }

    /// A designer on the palette of `file`.
    pub fn with_file(file: PaletteFile, colour_mode: ColourMode) -> State {
        let colorimetry = Colorimetry::default();
        let mut state = State {
            palette: file.palette.clone(),
            file,
            overwrite_armed: false,
            colorimetry,
            import: None,
            imports: 0,
            trains_bases: true,
            file_busy: false,
            screen: (0, 0),
            preview_pending: None,
            basis: None,
            selection: Selection { col: 1, row: 1 },
            focus: Focus::Matrix,
            slider: 0,
            setting: 0,
            popup: None,
            history: History::default(),
            solve: SolveStatus::default(),
            colour_mode,
            hide_times: false,
            message: None,
            remembered_bounds: (Bounds::new(0.0, 1.0), Bounds::new(0.0, f64::INFINITY)),
            derived: Derived::default(),
            quit: false,
            terminated: None,
            ticks: 0,
            preview: None,
            dial: 0.0,
            show_preview: false,
            preview_frame: Vec::new(),
            show_feasibility: false,
            feasibility: None,
            preview_scene: None,
            preview_loading: None,
            graphics: crate::tui::graphics::Graphics::default(),
            dial_state: None,
            dial_keys: false,
            dial_selected: None,
            keyframes: Vec::new(),
        };
        state.clamp_selection();
        state.refresh();
        state
    }

    /// True while something runs off the UI thread whose outcome will come back as a message: a solve, a
    /// basis training, a raycast, a CSV import, a file operation.
    pub fn busy(&self) -> bool {
        self.solve.running.is_some()
            || self.solve.training
            || self.preview_pending.is_some()
            || self.import.is_some()
            || self.file_busy
    }

    /// The palette file's path.
    pub fn path(&self) -> &Path {
        self.file.path.as_deref().unwrap_or(Path::new("palette.toml"))
    }

    /// True when the palette differs from the file.
    pub fn is_dirty(&self) -> bool {
        self.palette != self.file.palette
    }

    /// Recompute the derived colours (after any change of palette or solution).
    pub fn refresh(&mut self) {
        self.derived = Derived::compute(
            &self.palette,
            self.solve.current().or(self.solve.solution.as_ref().map(|(_, s)| s.as_ref())),
            &self.colorimetry,
            self.basis.as_ref().map(|(k, r)| (k.as_str(), &r.0)),
        );
        self.relight();
    }

    /// Relight the scene preview with the current spectra at the current dial position.
    pub fn relight(&mut self) {
        let lut = crate::tui::preview::lut();
        // The basis of the spectra shown, once trained, is the one `metamer render` would use for them.
        if let (Some(p), Some((key, resolved))) = (&mut self.preview, &self.basis)
            && self.derived.basis_key.as_deref() == Some(key.as_str())
        {
            p.follow_basis(&self.palette, key, &resolved.0);
        }
        self.preview_frame = match (&mut self.preview, &self.dial_state) {
            (Some(p), Some(d)) => p.frame(&self.palette, &self.derived, d, lut),
            _ => Vec::new(),
        };
        let size = self.preview.as_ref().map_or((0, 0), |p| p.size());
        self.graphics.encode(&self.preview_frame, size);
    }

    /// Attach a scene preview and show it.
    pub fn set_preview(&mut self, preview: crate::tui::preview::Preview) {
        if self.dial_state.is_none() {
            self.dial_state = Some(preview.scene.dial.state_at(self.dial));
        }
        self.preview = Some(preview);
        self.preview_scene = None;
        self.preview_loading = None;
        self.show_preview = true;
        self.relight();
    }

    /// Attach a scene whose raycast runs off the UI thread (the event loop starts it at the panel's size).
    pub fn set_preview_scene(&mut self, scene: crate::render::scene::Scene) {
        self.dial_state = Some(scene.dial.state_at(self.dial));
        self.preview_scene = Some(Arc::new(scene));
        self.show_preview = true;
    }

    /// The scene of the preview (attached or on its way).
    pub(crate) fn scene(&self) -> Option<&crate::render::scene::Scene> {
        self.preview.as_ref().map(|p| p.scene.as_ref()).or(self.preview_scene.as_deref())
    }

    /// True when a scene preview is attached or on its way.
    pub(crate) fn has_scene(&self) -> bool {
        self.preview.is_some() || self.preview_scene.is_some()
    }

    /// What the selection points at.
    pub(crate) fn target(&self) -> Target {
        let (nl, nr) = (self.palette.lights.len(), self.palette.reflectances.len());
        let Selection { col, row } = self.selection;
        match (col, row) {
            (0, 0) => Target::Nothing,
            (0, r) if r <= nr => Target::Reflectance(r - 1),
            (c, 0) if c <= nl => Target::Light(c - 1),
            (c, r) if c <= nl && r <= nr => Target::Cell { light: c - 1, reflectance: r - 1 },
            _ => Target::Nothing,
        }
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

    /// Keep the selection inside the matrix (after removing a spectrum, or on an empty palette).
    pub(crate) fn clamp_selection(&mut self) {
        let (nl, nr) = (self.palette.lights.len(), self.palette.reflectances.len());
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

    /// Record the palette before an edit so it can be undone. Consecutive edits with the same
    /// slider key coalesce into one step.
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

    /// Show a message until the next key.
    pub(crate) fn say(&mut self, text: impl Into<String>) {
        self.message = Some(Message { text: crate::fsio::escape(&text.into()).into_owned(), is_error: false });
    }

    /// Show an error until the next key.
    pub(crate) fn complain(&mut self, text: impl Into<String>) {
        self.message = Some(Message { text: crate::fsio::escape(&text.into()).into_owned(), is_error: true });
    }

    /// The palette file's folder (CSV paths are relative to it).
    pub(crate) fn base_dir(&self) -> PathBuf {
        crate::fsio::folder_of(self.path())
    }

    /// The latest solution's diagnostics (of the current palette, else the last one solved).
    pub fn diagnostics(&self) -> &[crate::design::Diagnostic] {
        self.solve
            .current()
            .or(self.solve.solution.as_ref().map(|(_, s)| s.as_ref()))
            .map_or(&[], |s| s.diagnostics.as_slice())
    }

    /// The cell whose mismatch region the overlay wants: the selected cell, when the overlay is on.
    pub(crate) fn feasibility_cell(&self) -> Option<usize> {
        match (self.show_feasibility, self.target()) {
            (true, Target::Cell { light, reflectance }) => self.cell_index(light, reflectance),
            _ => None,
        }
    }

    /// The index into `palette.colours` of the cell at (light, reflectance).
    pub(crate) fn cell_index(&self, light: usize, reflectance: usize) -> Option<usize> {
        self.palette.colours.iter().position(|c| c.light == light && c.reflectance == reflectance)
    }
}
