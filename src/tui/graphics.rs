//! How the scene preview reaches the terminal: half blocks (two pixels per character cell, any truecolor
//! or 256-colour terminal), or the relit image at its real pixel size through a terminal graphics protocol
//! — kitty (kitty, WezTerm, Ghostty), sixel (foot, xterm with sixel, WezTerm) or iTerm2 (iTerm2, WezTerm) —
//! encoded by `ratatui-image`. These protocols travel in the terminal stream, so they work over SSH.
//!
//! `--preview auto` asks the terminal (ratatui-image's picker queries it for kitty and sixel support and
//! for its font size in pixels) and falls back to half blocks when it answers nothing useful.

use ratatui::buffer::Buffer;
use ratatui::layout::{Rect, Size};
use ratatui_image::picker::cap_parser::{Parser, QueryStdioOptions, Response};
use ratatui_image::picker::{Picker, ProtocolType};
use ratatui_image::protocol::Protocol;
use ratatui_image::protocol::iterm2::Iterm2;
use ratatui_image::protocol::kitty::Kitty;
use ratatui_image::protocol::sixel::Sixel;

/// The `--preview` choice.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PreviewMode {
    /// Ask the terminal; half blocks when it supports no graphics protocol.
    #[default]
    Auto,
    Halfblocks,
    Kitty,
    Sixel,
    Iterm2,
}

impl PreviewMode {
    pub(crate) fn parse(text: &str) -> Option<PreviewMode> {
        Some(match text {
            "auto" => PreviewMode::Auto,
            "halfblocks" | "half-blocks" => PreviewMode::Halfblocks,
            "kitty" => PreviewMode::Kitty,
            "sixel" => PreviewMode::Sixel,
            "iterm2" => PreviewMode::Iterm2,
            _ => return None,
        })
    }

    fn protocol(self) -> Option<ProtocolType> {
        match self {
            PreviewMode::Auto | PreviewMode::Halfblocks => None,
            PreviewMode::Kitty => Some(ProtocolType::Kitty),
            PreviewMode::Sixel => Some(ProtocolType::Sixel),
            PreviewMode::Iterm2 => Some(ProtocolType::Iterm2),
        }
    }
}

/// A question asked of the terminal, waiting for its answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Probe {
    pub(crate) mode: PreviewMode,
}

/// The kitty image id of the preview: every relit frame replaces the same image in the terminal.
const KITTY_ID: u32 = 0x4d45_5441;

/// The preview's way to the terminal and its last encoded frame.
#[derive(Default)]
pub struct Graphics {
    /// The protocol and the terminal's cell size in pixels; `None` = half blocks.
    picker: Option<Picker>,
    /// The last frame, encoded, with its size in cells.
    encoded: Option<Protocol>,
}

impl std::fmt::Debug for Graphics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Graphics").field("protocol", &self.name()).finish()
    }
}

impl Graphics {
    /// Half blocks.
    pub fn halfblocks() -> Graphics {
        Graphics::default()
    }

    /// A graphics protocol over a terminal with `font` = (width, height) pixels per cell, without asking the
    /// terminal (tests, and `--preview kitty|sixel|iterm2` when the terminal does not answer).
    pub fn forced(mode: PreviewMode, font: (u16, u16)) -> Graphics {
        match mode.protocol() {
            None => Graphics::halfblocks(),
            Some(p) => {
                #[allow(deprecated)] // the one constructor that takes a font size without querying
                let mut picker = Picker::from_fontsize(ratatui_image::FontSize::new(font.0.max(1), font.1.max(1)));
                picker.set_protocol_type(p);
                Graphics { picker: Some(picker), encoded: None }
            }
        }
    }

    /// Write the probe's question to the terminal (once the first screen is drawn; the input thread
    /// reads the answers, [`crate::tui::probe::ProbeReader`]). `None` for half blocks: nothing to ask.
    pub(crate) fn ask_terminal(mode: PreviewMode) -> std::io::Result<Option<Probe>> {
        use std::io::Write;
        if mode == PreviewMode::Halfblocks {
            return Ok(None);
        }
        // ratatui-image's detection of tmux (which also switches tmux's passthrough on) and its question.
        let is_tmux = Picker::halfblocks().tmux_detected();
        let mut options = QueryStdioOptions::default();
        let env = |name: &str| std::env::var(name).is_ok_and(|s| !s.is_empty());
        if env("WEZTERM_EXECUTABLE") || env("KONSOLE_VERSION") {
            // As ratatui-image: their kitty and sixel support is not usable for this; iTerm2 is.
            options.blacklist_protocols = vec![ProtocolType::Kitty, ProtocolType::Sixel];
        }
        let mut out = std::io::stdout().lock();
        out.write_all(Parser::query(is_tmux, options).as_bytes())?;
        out.flush()?;
        Ok(Some(Probe { mode }))
    }

    /// The graphics for the terminal's answers to the probe (`answered`: the status answer came before the
    /// deadline; `responses`: what it said). `auto` takes kitty, else sixel, else what the environment
    /// says (iTerm2), else half blocks; a forced protocol takes the cell size, assuming 10×20 pixels
    /// when the terminal reports none.
    pub(crate) fn from_answers(probe: &Probe, responses: &[Response], answered: bool) -> (Graphics, Option<String>) {
        let mut proto = None;
        let mut font = None;
        for r in responses {
            match r {
                Response::Kitty => proto = Some(ProtocolType::Kitty),
                Response::Sixel if proto.is_none() => proto = Some(ProtocolType::Sixel),
                Response::CellSize(Some((w, h))) => font = Some((*w, *h)),
                _ => {}
            }
        }
        // No cell size answered: the window's size in pixels over its size in cells, when the terminal
        // tells the kernel.
        let font = font.or_else(|| {
            let w = ratatui::crossterm::terminal::window_size().ok()?;
            (w.width > 0 && w.height > 0 && w.columns > 0 && w.rows > 0)
                .then(|| (w.width / w.columns, w.height / w.rows))
        });
        let Some(font) = font else {
            return match probe.mode.protocol() {
                None => (Graphics::halfblocks(), None),
                Some(_) => {
                    let why = if answered { "did not report its font size" } else { "did not answer in time" };
                    (
                        Graphics::forced(probe.mode, (10, 20)),
                        Some(format!("the terminal {why}; assuming 10×20 pixels per cell")),
                    )
                }
            };
        };
        #[allow(deprecated)] // the one constructor that takes a font size without querying
        let mut picker = Picker::from_fontsize(ratatui_image::FontSize::new(font.0.max(1), font.1.max(1)));
        let chosen = match probe.mode.protocol() {
            Some(forced) => forced,
            None => match proto.or(Some(picker.protocol_type()).filter(|p| *p != ProtocolType::Halfblocks)) {
                Some(p) => p,
                None => return (Graphics::halfblocks(), None),
            },
        };
        picker.set_protocol_type(chosen);
        (Graphics { picker: Some(picker), encoded: None }, None)
    }

    /// True for half blocks.
    pub(crate) fn is_halfblocks(&self) -> bool {
        self.picker.is_none()
    }

    /// The protocol's name, for the panel title.
    pub fn name(&self) -> &'static str {
        match self.picker.as_ref().map(Picker::protocol_type) {
            None | Some(ProtocolType::Halfblocks) => "half blocks",
            Some(ProtocolType::Kitty) => "kitty",
            Some(ProtocolType::Sixel) => "sixel",
            Some(ProtocolType::Iterm2) => "iTerm2",
        }
    }

    /// Pixels per cell (half blocks: 1 × 2).
    pub(crate) fn cell_pixels(&self) -> (usize, usize) {
        match &self.picker {
            None => (1, 2),
            Some(p) => {
                let f = p.font_size();
                (usize::from(f.width.max(1)), usize::from(f.height.max(1)))
            }
        }
    }

    /// The side of the square raycast that fits a panel of `area` cells.
    pub fn pixels_for(&self, area: Rect, max_edge: usize) -> usize {
        let (cw, ch) = self.cell_pixels();
        let w = usize::from(area.width) * cw;
        let h = usize::from(area.height) * ch;
        w.min(h).min(max_edge)
    }

    /// Encode a relit frame (3 bytes per pixel, `size` pixels) for the protocol (half blocks: nothing).
    pub(crate) fn encode(&mut self, rgb: &[u8], size: (usize, usize)) {
        self.encoded = None;
        let Some(picker) = &self.picker else { return };
        let (w, h) = size;
        if w == 0 || h == 0 || rgb.len() != w * h * 3 {
            return;
        }
        let Some(img) = image::RgbImage::from_raw(w as u32, h as u32, rgb.to_vec()) else { return };
        let img = image::DynamicImage::ImageRgb8(img);
        let (cw, ch) = self.cell_pixels();
        let cells = Size::new(w.div_ceil(cw).min(usize::from(u16::MAX)) as u16, h.div_ceil(ch).min(65535) as u16);
        let tmux = picker.tmux_detected();
        self.encoded = match picker.protocol_type() {
            ProtocolType::Halfblocks => None,
            ProtocolType::Kitty => Kitty::new(img, cells, KITTY_ID, tmux, false).ok().map(Protocol::Kitty),
            ProtocolType::Sixel => Sixel::new(img, cells, tmux).ok().map(Protocol::Sixel),
            ProtocolType::Iterm2 => Iterm2::new(img, cells, tmux).ok().map(Protocol::ITerm2),
        };
    }

    /// The encoded frame's size in cells, if there is one.
    pub(crate) fn encoded_cells(&self) -> Option<Size> {
        self.encoded.as_ref().map(Protocol::size)
    }

    /// Draw the encoded frame at the top left of `area` (false when there is none or it does not fit).
    pub(crate) fn render(&self, area: Rect, buf: &mut Buffer) -> bool {
        match &self.encoded {
            Some(p) => {
                let s = p.size();
                if s.width > area.width || s.height > area.height {
                    return false;
                }
                ratatui::widgets::Widget::render(ratatui_image::Image::new(p), area, buf);
                true
            }
            None => false,
        }
    }
}
