//! The design matrix: lights across the top (each on flat white), reflectances down the left (each under
//! flat white), and per cell three colours in 4×2 characters — `▌` the desired colour, `▀` the full
//! 31-sample colour over the subspace-model colour. `[ ]` marks the selection, `D` a spectrum open to
//! design, a letter the free-colour group, `•` a cell in use; cells not in use are dimmed.

use crate::tui::app::{Focus, State, Target};
use crate::tui::derived::CellView;
use crate::tui::ui::{design_style, fit, put, selected_style, swatch};
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};
use ratatui::widgets::Widget;

/// The matrix panel of a state.
pub struct Matrix<'a>(pub &'a State);

/// Width of a matrix column: `[`, four cell characters, `]`, the marker, a gap.
pub const MIN_COLUMN: usize = 8;
const MAX_COLUMN: usize = 14;
const MIN_NAME: usize = 5;
const MAX_NAME: usize = 16;

/// Column geometry of the matrix for a state and width.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Geometry {
    /// Width of the reflectance-name part of the left column.
    pub name_width: usize,
    /// Width of the whole left column (name, swatch, marker).
    pub left_width: usize,
    pub column_width: usize,
    /// First light and reflectance shown (the matrix scrolls to keep the selection visible).
    pub first_light: usize,
    pub first_reflectance: usize,
    pub visible_lights: usize,
    pub visible_reflectances: usize,
}

/// Where the matrix's columns and rows fall, scrolled so the selection is visible.
pub fn geometry(state: &State, area: Rect) -> Geometry {
    let p = &state.palette;
    let name_width = p.reflectances.iter().map(|r| r.name.chars().count()).max().unwrap_or(0).clamp(MIN_NAME, MAX_NAME);
    let left_width = name_width + 6;
    let column_width =
        p.lights.iter().map(|l| l.name.chars().count() + 1).max().unwrap_or(0).clamp(MIN_COLUMN, MAX_COLUMN);
    let visible_lights = (usize::from(area.width).saturating_sub(left_width) / column_width).max(1);
    let visible_reflectances = (usize::from(area.height).saturating_sub(2) / 2).max(1);
    let first = |selected: usize, visible: usize| if selected >= visible { selected + 1 - visible } else { 0 };
    let sel_light = state.selection.col.saturating_sub(1);
    let sel_reflectance = state.selection.row.saturating_sub(1);
    Geometry {
        name_width,
        left_width,
        column_width,
        first_light: first(sel_light, visible_lights),
        first_reflectance: first(sel_reflectance, visible_reflectances),
        visible_lights,
        visible_reflectances,
    }
}

/// The style of a cell's three colours.
fn cell_styles(state: &State, cell: &CellView) -> (Style, Style) {
    let mode = state.colour_mode;
    let full = mode.linear(&cell.full);
    let sub = cell.subspace.as_ref().map_or(full, |s| mode.linear(s));
    let desired = match &cell.desired {
        Some(d) => Style::new().fg(mode.linear(d)),
        None => Style::new().fg(Color::DarkGray),
    };
    let mut model = Style::new().fg(full).bg(sub);
    let mut desired = desired;
    if !cell.active {
        model = model.add_modifier(Modifier::DIM);
        desired = desired.add_modifier(Modifier::DIM);
    }
    (desired, model)
}

impl Widget for Matrix<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        let p = &state.palette;
        let d = &state.derived;
        if area.height == 0 || area.width == 0 {
            return;
        }
        if p.lights.is_empty() && p.reflectances.is_empty() {
            put(buf, area, 1, 0, "empty palette: L adds a light, R a reflectance", Style::new().fg(Color::Gray));
            return;
        }
        let g = geometry(state, area);
        let target = state.target();
        let sel = if state.focus == Focus::Matrix {
            selected_style()
        } else {
            selected_style().remove_modifier(Modifier::BOLD).fg(Color::Green)
        };
        let head = Style::new().add_modifier(Modifier::BOLD);
        put(buf, area, 0, 0, "matrix", Style::new().fg(Color::Gray));
        // Lights across the top.
        let lights = g.first_light..(g.first_light + g.visible_lights).min(p.lights.len());
        for (k, j) in lights.clone().enumerate() {
            let x = (g.left_width + k * g.column_width) as u16;
            let entry = &p.lights[j];
            let name_style =
                if matches!(target, Target::Light(l) if l == j) { head.fg(Color::LightGreen) } else { head };
            put(buf, area, x + 1, 0, &fit(&entry.name, g.column_width - 1), name_style);
            if let Some(rgb) = d.light_swatches.get(j) {
                put(buf, area, x + 1, 1, "████", swatch(state.colour_mode, rgb));
            }
            if entry.design {
                put(buf, area, x + 6, 1, "D", design_style());
            }
            if matches!(target, Target::Light(l) if l == j) {
                put(buf, area, x, 1, "[", sel);
                put(buf, area, x + 5, 1, "]", sel);
            }
        }
        if lights.start > 0 {
            put(buf, area, (g.left_width - 2) as u16, 0, "◂", Style::new().fg(Color::Yellow));
        }
        if lights.end < p.lights.len() {
            let x = (g.left_width + g.visible_lights * g.column_width) as u16;
            let more = format!("▸{}", p.lights.len() - lights.end);
            put(buf, area, x.min(area.width.saturating_sub(3)), 0, &more, Style::new().fg(Color::Yellow));
        }
        // Reflectances down the left, and the cells.
        let rows = g.first_reflectance..(g.first_reflectance + g.visible_reflectances).min(p.reflectances.len());
        for (k, i) in rows.clone().enumerate() {
            let y = 2 + 2 * k as u16;
            let entry = &p.reflectances[i];
            let selected_row = matches!(target, Target::Reflectance(r) if r == i);
            let name_style = if selected_row { head.fg(Color::LightGreen) } else { head };
            put(buf, area, 0, y, &fit(&entry.name, g.name_width), name_style);
            let sx = (g.name_width + 2) as u16;
            if let Some(rgb) = d.reflectance_swatches.get(i) {
                for dy in 0..2 {
                    put(buf, area, sx, y + dy, "██", swatch(state.colour_mode, rgb));
                }
            }
            if selected_row {
                for dy in 0..2 {
                    put(buf, area, sx - 1, y + dy, "[", sel);
                    put(buf, area, sx + 2, y + dy, "]", sel);
                }
            }
            if entry.design {
                put(buf, area, sx + 3, y, "D", design_style());
            }
            for (kj, j) in lights.clone().enumerate() {
                let x = (g.left_width + kj * g.column_width) as u16;
                let Some(cell) = d.cell(j, i) else { continue };
                let (desired, model) = cell_styles(state, cell);
                let left = if cell.desired.is_some() { "▌" } else { "·" };
                for dy in 0..2 {
                    put(buf, area, x + 1, y + dy, left, desired);
                    put(buf, area, x + 2, y + dy, "▀▀▀", model);
                }
                let marker = match (cell.free, cell.has_criterion, cell.active) {
                    (Some(gi), _, _) => p.free.get(gi).and_then(|g| g.name.chars().next()).unwrap_or('?').to_string(),
                    (None, true, true) => "•".to_string(),
                    (None, true, false) => "○".to_string(),
                    _ => String::new(),
                };
                if !marker.is_empty() {
                    let style = if cell.free.is_some() {
                        Style::new().fg(Color::LightMagenta).add_modifier(Modifier::BOLD)
                    } else {
                        Style::new().fg(Color::Gray)
                    };
                    put(buf, area, x + 6, y, &marker, style);
                }
                if matches!(target, Target::Cell { light, reflectance } if light == j && reflectance == i) {
                    for dy in 0..2 {
                        put(buf, area, x, y + dy, "[", sel);
                        put(buf, area, x + 5, y + dy, "]", sel);
                    }
                }
            }
        }
        if rows.end < p.reflectances.len() && area.height > 0 {
            let more = format!("▾{}", p.reflectances.len() - rows.end);
            put(buf, area, (g.name_width + 2) as u16, area.height - 1, &more, Style::new().fg(Color::Yellow));
        }
        if rows.start > 0 {
            put(buf, area, (g.name_width + 2) as u16, 1, &format!("▴{}", rows.start), Style::new().fg(Color::Yellow));
        }
    }
}
