//! The scene preview panel: the relit raycast image — at real pixels through a terminal graphics
//! protocol ([`crate::tui::graphics`]) or in half blocks (two square pixels per character) — centred in
//! the panel, and a progress line while the raycast runs.

use crate::tui::app::State;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style};
use ratatui::widgets::Widget;

/// The panel's title: where the dial is, the keys, the protocol.
pub fn title(state: &State) -> String {
    let caption = match &state.preview {
        Some(p) => p.caption(state.dial),
        None => "raycasting…".to_string(),
    };
    format!(" light dial: {caption} · [ ] move · v spectra · {} ", state.graphics.name())
}

/// The preview image of a state (a progress line while it is raycast).
pub struct PreviewPanel<'a>(pub &'a State);

impl Widget for PreviewPanel<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        if area.width == 0 || area.height == 0 {
            return;
        }
        if let Some(text) = &state.preview_loading {
            let style = Style::new().fg(Color::Yellow);
            buf.set_stringn(area.x, area.y, text, usize::from(area.width), style);
        }
        let Some(preview) = &state.preview else { return };
        let (pw, ph) = preview.size();
        let pixels = &state.preview_frame;
        if pw == 0 || ph == 0 || pixels.len() != pw * ph * 3 {
            return;
        }
        let first = if state.preview_loading.is_some() { 1 } else { 0 };
        let area = Rect { y: area.y + first, height: area.height - first, ..area };
        if !state.graphics.is_halfblocks() {
            if let Some(cells) = state.graphics.encoded_cells() {
                let x = area.x + area.width.saturating_sub(cells.width) / 2;
                let y = area.y + area.height.saturating_sub(cells.height) / 2;
                let at = Rect { x, y, width: area.width - (x - area.x), height: area.height - (y - area.y) };
                if state.graphics.render(at, buf) {
                    return;
                }
            }
        }
        // Fit pw × ph into width × 2·height pixels, keeping the aspect ratio.
        let (aw, ah) = (usize::from(area.width), 2 * usize::from(area.height));
        if ah < 2 {
            return;
        }
        let scale = (aw as f64 / pw as f64).min(ah as f64 / ph as f64);
        let w = ((pw as f64 * scale).round() as usize).clamp(1, aw);
        let h = ((ph as f64 * scale).round() as usize).clamp(2, ah) & !1;
        let x0 = area.x + ((aw - w) / 2) as u16;
        let y0 = area.y + ((ah - h) / 4) as u16;
        let sample = |x: usize, y: usize| {
            let sx = (x * pw / w).min(pw - 1);
            let sy = (y * ph / h).min(ph - 1);
            let i = 3 * (sy * pw + sx);
            [pixels[i], pixels[i + 1], pixels[i + 2]]
        };
        for cy in 0..h / 2 {
            for x in 0..w {
                let top = state.colour_mode.color(sample(x, 2 * cy));
                let bottom = state.colour_mode.color(sample(x, 2 * cy + 1));
                if let Some(cell) = buf.cell_mut((x0 + x as u16, y0 + cy as u16)) {
                    cell.set_symbol("▀").set_style(Style::new().fg(top).bg(bottom));
                }
            }
        }
    }
}

/// The light dial beside the preview image.
pub struct DialPanel<'a>(pub &'a State);

impl Widget for DialPanel<'_> {
    fn render(self, _area: Rect, _buf: &mut Buffer) {}
}
