//! The scene preview panel: the relit raycast image in half blocks (two square-ish pixels per character),
//! fitted to the panel with its aspect ratio kept.

use crate::tui::app::State;
use crate::tui::preview::{PREVIEW_HEIGHT, PREVIEW_WIDTH};
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::widgets::Widget;

/// The preview of a state (draws nothing without one).
pub struct PreviewPanel<'a>(pub &'a State);

impl Widget for PreviewPanel<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        let pixels = &state.preview_frame;
        if pixels.len() != PREVIEW_WIDTH * PREVIEW_HEIGHT || area.width == 0 || area.height == 0 {
            return;
        }
        // Fit PREVIEW_WIDTH × PREVIEW_HEIGHT into width × 2·height pixels, keeping the aspect ratio.
        let (aw, ah) = (usize::from(area.width), 2 * usize::from(area.height));
        let scale = (aw as f64 / PREVIEW_WIDTH as f64).min(ah as f64 / PREVIEW_HEIGHT as f64);
        let w = ((PREVIEW_WIDTH as f64 * scale).floor() as usize).clamp(1, aw);
        let h = ((PREVIEW_HEIGHT as f64 * scale).floor() as usize).clamp(2, ah) & !1;
        let x0 = area.x + ((aw - w) / 2) as u16;
        let y0 = area.y + ((ah - h) / 4) as u16;
        let sample = |x: usize, y: usize| {
            let sx = (x * PREVIEW_WIDTH / w).min(PREVIEW_WIDTH - 1);
            let sy = (y * PREVIEW_HEIGHT / h).min(PREVIEW_HEIGHT - 1);
            pixels[sy * PREVIEW_WIDTH + sx]
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
