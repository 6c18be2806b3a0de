//! What is under a screen cell: the same layout functions the view draws with ([`super::areas`],
//! [`super::matrix::geometry`], [`super::preview_areas`], [`super::preview::dial_canvas`]) read back for a
//! mouse click, so a click lands on what is drawn there. Pure: it reads the state, changes nothing.

use super::{areas, matrix, preview_areas};
use crate::tui::app::{Selection, State};
use ratatui::layout::{Position, Rect};
use ratatui::widgets::{Block, Borders};

/// What a screen cell shows that a click can act on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hit {
    /// A cell of the matrix, or a light's or reflectance's swatch.
    Matrix(Selection),
    /// Slider `slider` (R, G, B, weight) of the selected cell at `fraction` (0–1) of its bar.
    Slider { slider: usize, fraction: f64 },
    /// Slider `slider` of the one-line sliders (no bar: the keys change it).
    SliderName(usize),
    /// The light dial's canvas at this dial point.
    Dial([f64; 2]),
}

/// What is at column `x`, row `y` of the screen the state was last laid out on (`ui.screen`).
pub fn hit(state: &State, x: u16, y: u16) -> Option<Hit> {
    let (width, height) = state.ui.screen;
    let screen = Rect::new(0, 0, width, height);
    let at = Position { x, y };
    if !screen.contains(at) {
        return None;
    }
    let a = areas(state, Block::bordered().inner(screen));
    if a.matrix.contains(at) {
        return matrix_hit(state, a.matrix, x - a.matrix.x, y - a.matrix.y).map(Hit::Matrix);
    }
    if !a.sliders_compact && a.sliders.contains(at) {
        return slider_hit(Block::new().borders(Borders::LEFT).inner(a.sliders), at);
    }
    if a.sliders_compact && a.sliders.contains(at) {
        return compact_hit(state, x - a.sliders.x);
    }
    let p = preview_areas(state, screen)?;
    let dial = state.preview.dial_state()?;
    let d = super::preview::dial_canvas(p.dial, dial);
    d.canvas.contains(at).then(|| Hit::Dial(d.point_at(x, y)))
}

/// The matrix cell or swatch at (`dx`, `dy`) inside the matrix panel.
fn matrix_hit(state: &State, area: Rect, dx: u16, dy: u16) -> Option<Selection> {
    let p = &state.doc.palette;
    let g = matrix::geometry(state, area);
    let (dx, dy) = (usize::from(dx), usize::from(dy));
    let col = if dx < g.left_width {
        0
    } else {
        g.columns.iter().find(|(_, x, w)| (*x..x + w).contains(&dx)).map(|(j, _, _)| j + 1)?
    };
    let row = if dy < 2 {
        0
    } else {
        let i = g.first_reflectance + (dy - 2) / g.row_height.max(1);
        if (dy - 2) / g.row_height.max(1) >= g.visible_reflectances || i >= p.reflectances.len() {
            return None;
        }
        i + 1
    };
    let inside = (col, row) != (0, 0) && col <= p.lights.len() && row <= p.reflectances.len();
    inside.then_some(Selection { col, row })
}

/// The one-line slider whose text is at column `dx` of the line (a free cell's line has none).
fn compact_hit(state: &State, dx: u16) -> Option<Hit> {
    let crate::tui::app::Target::Cell { light, reflectance } = state.target() else { return None };
    if state.doc.palette.cell(light, reflectance).is_some_and(|c| c.free.is_some()) {
        return None;
    }
    let mut x = 0usize;
    for (k, text) in super::sliders::compact_texts(state, light, reflectance).iter().enumerate() {
        let width = text.chars().count();
        if (x..x + width).contains(&usize::from(dx)) {
            return Some(Hit::SliderName(k));
        }
        x += width + 2;
    }
    None
}

/// The slider bar at `at` inside the full sliders panel `inner` (rows 1–4, as `ui/sliders.rs` draws
/// them).
fn slider_hit(inner: Rect, at: Position) -> Option<Hit> {
    let row = at.y.checked_sub(inner.y)?;
    if !(1..=4).contains(&row) {
        return None;
    }
    Some(Hit::Slider { slider: usize::from(row - 1), fraction: bar_fraction(inner, at.x) })
}

/// Where column `x` falls along the sliders' bars in the full sliders panel `inner`: 0 at the bar's
/// first character (and left of it), 1 at its last (and right of it). The bar starts at column 3 and is
/// `inner.width − 12` wide (at least 4), as `ui/sliders.rs` draws it.
fn bar_fraction(inner: Rect, x: u16) -> f64 {
    let bar_x = f64::from(inner.x + 3);
    let bar_width = usize::from(inner.width).saturating_sub(12).max(4) as f64;
    ((f64::from(x) - bar_x) / (bar_width - 1.0)).clamp(0.0, 1.0)
}

/// Where column `x` falls along the sliders' bars (a drag that left the bar's row), when the full
/// sliders panel is shown.
pub fn slider_fraction(state: &State, x: u16) -> Option<f64> {
    let (width, height) = state.ui.screen;
    let a = areas(state, Block::bordered().inner(Rect::new(0, 0, width, height)));
    (!a.sliders_compact).then(|| bar_fraction(Block::new().borders(Borders::LEFT).inner(a.sliders), x))
}

/// The dial point under column `x`, row `y` (a drag that left the canvas: the point beyond its edge),
/// when the dial is shown.
pub fn dial_point(state: &State, x: u16, y: u16) -> Option<[f64; 2]> {
    let (width, height) = state.ui.screen;
    let p = preview_areas(state, Rect::new(0, 0, width, height))?;
    let dial = state.preview.dial_state()?;
    let d = super::preview::dial_canvas(p.dial, dial);
    (d.canvas.width > 0 && d.canvas.height > 0).then(|| d.point_at(x, y))
}
