//! How the scene preview reaches the terminal: half blocks (two pixels per character cell, any truecolor
//! or 256-colour terminal), or the relit image at its real pixel size through a terminal graphics protocol
//! — kitty (kitty, WezTerm, Ghostty), sixel (foot, xterm with sixel, WezTerm) or iTerm2 (iTerm2, WezTerm) —
//! encoded by `ratatui-image`. These protocols travel in the terminal stream, so they work over SSH.
//!
//! `--preview auto` asks the terminal (ratatui-image's picker queries it for kitty and sixel support and
//! for its font size in pixels) and falls back to half blocks when it answers nothing useful.

use ratatui::buffer::Buffer;
use ratatui::layout::{Rect, Size};
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

    /// Choose for a real terminal (call after entering the alternate screen, before reading events):
    /// `auto` queries it; a forced protocol still queries for the font size, assuming 10×20 when it
    /// does not answer.
    pub(crate) fn for_terminal(mode: PreviewMode) -> (Graphics, Option<String>) {
        if mode == PreviewMode::Halfblocks {
            return (Graphics::halfblocks(), None);
        }
        let queried = Picker::from_query_stdio();
        match (mode, queried) {
            (PreviewMode::Auto, Ok(picker)) if picker.protocol_type() != ProtocolType::Halfblocks => {
                (Graphics { picker: Some(picker), encoded: None }, None)
            }
            (PreviewMode::Auto, _) => (Graphics::halfblocks(), None),
            (forced, Ok(mut picker)) => {
                if let Some(p) = forced.protocol() {
                    picker.set_protocol_type(p);
                }
                (Graphics { picker: Some(picker), encoded: None }, None)
            }
            (forced, Err(e)) => (
                Graphics::forced(forced, (10, 20)),
                Some(format!("the terminal did not report its font size ({e}); assuming 10×20 pixels per cell")),
            ),
        }
    }

    /// True for half blocks.
    pub(crate) fn is_halfblocks(&self) -> bool {
        self.picker.is_none()
    }

    /// The protocol's name, for the panel title.
    pub(crate) fn name(&self) -> &'static str {
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
