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
pub(crate) struct Matrix<'a>(pub &'a State);

/// Width of a matrix column: `[`, four cell characters, `]`, the marker, a gap.
pub(crate) const MIN_COLUMN: usize = 8;
/// Columns and the name column grow to show whole names up to these widths, space permitting.
const MAX_COLUMN: usize = 25;
const MIN_NAME: usize = 5;
const MAX_NAME: usize = 24;

/// The reflectance-name width that shows every name whole (within limits).
fn ideal_name_width(state: &State) -> usize {
    state.doc.palette.reflectances.iter().map(|r| r.name.chars().count()).max().unwrap_or(0).clamp(MIN_NAME, MAX_NAME)
}

/// The width of light `j`'s column: its whole name and a gap (within limits).
fn column_width(state: &State, j: usize) -> usize {
    state.doc.palette.lights.get(j).map_or(0, |l| l.name.chars().count() + 1).clamp(MIN_COLUMN, MAX_COLUMN)
}

/// Rows the matrix needs with two rows per reflectance (`compact`: one).
pub(crate) fn rows_needed(state: &State, compact: bool) -> u16 {
    let n = state.doc.palette.reflectances.len() as u16;
    2 + if compact { n } else { 2 * n }
}

/// Columns the whole matrix needs to show every light with its whole name.
pub(crate) fn width_needed(state: &State) -> u16 {
    let columns: usize = (0..state.doc.palette.lights.len()).map(|j| column_width(state, j)).sum();
    (ideal_name_width(state) + 6 + columns) as u16
}

/// Where the matrix's columns and rows fall, scrolled so the selection is visible.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Geometry {
    /// Width of the reflectance-name part of the left column.
    pub name_width: usize,
    /// Width of the whole left column (name, swatch, marker).
    pub(crate) left_width: usize,
    /// The lights shown: (light index, x offset in the panel, column width).
    pub(crate) columns: Vec<(usize, usize, usize)>,
    /// First reflectance shown and how many rows fit.
    pub(crate) first_reflectance: usize,
    pub(crate) visible_reflectances: usize,
    /// Screen rows per reflectance: 2 (square-ish cells), or 1 when that shows more names.
    pub row_height: usize,
}

impl Geometry {
    /// The x offset of light `j`'s column, when shown.
    pub fn column_x(&self, j: usize) -> Option<usize> {
        self.columns.iter().find(|(l, _, _)| *l == j).map(|(_, x, _)| *x)
    }
}

/// Lay the matrix out in `area`: every light column as wide as its name (names are cut only when even one
/// column would not fit), scrolled sideways and down so the selection is visible.
pub fn geometry(state: &State, area: Rect) -> Geometry {
    let width = usize::from(area.width);
    let name_width = ideal_name_width(state).min(width.saturating_sub(6 + MIN_COLUMN)).max(MIN_NAME);
    let left_width = name_width + 6;
    let room = width.saturating_sub(left_width);
    let n = state.doc.palette.lights.len();
    let widths: Vec<usize> = (0..n).map(|j| column_width(state, j).min(room.max(MIN_COLUMN))).collect();
    let selected = state.ui.selection.col.saturating_sub(1).min(n.saturating_sub(1));
    // First column: 0 when the selection fits from there, else the leftmost that keeps it in view.
    let mut first = 0;
    while first < selected && widths[first..=selected].iter().sum::<usize>() > room {
        first += 1;
    }
    let mut columns = Vec::new();
    let mut x = left_width;
    for (j, w) in widths.iter().enumerate().skip(first) {
        if x + w > width && !columns.is_empty() {
            break;
        }
        columns.push((j, x, *w));
        x += w;
    }
    let rows = usize::from(area.height).saturating_sub(2);
    let row_height = if rows >= 2 * state.doc.palette.reflectances.len() { 2 } else { 1 };
    let visible_reflectances = (rows / row_height).max(1);
    let sel_reflectance = state.ui.selection.row.saturating_sub(1);
    let first_reflectance =
        if sel_reflectance >= visible_reflectances { sel_reflectance + 1 - visible_reflectances } else { 0 };
    Geometry { name_width, left_width, columns, first_reflectance, visible_reflectances, row_height }
}

/// The style of a cell's three colours.
fn cell_styles(state: &State, cell: &CellView) -> (Style, Style) {
    let mode = state.ui.colour_mode;
    let full = mode.linear(&cell.full);
    // While the basis of the shown spectra is being trained the lower half is grey, never a stale colour.
    let pending = state.solve.derived.subspace_pending && state.solve.basis_error.is_none();
    let sub = match &cell.subspace {
        Some(s) => mode.linear(s),
        None if pending => Color::DarkGray,
        None => full,
    };
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
        let p = &state.doc.palette;
        let d = &state.solve.derived;
        if area.height == 0 || area.width == 0 {
            return;
        }
        if p.lights.is_empty() && p.reflectances.is_empty() {
            put(buf, area, 1, 0, "empty palette: L adds a light, R a reflectance", Style::new().fg(Color::Gray));
            return;
        }
        let g = geometry(state, area);
        let target = state.target();
        let sel = if state.ui.focus == Focus::Matrix {
            selected_style()
        } else {
            selected_style().remove_modifier(Modifier::BOLD).fg(Color::Green)
        };
        let head = Style::new().add_modifier(Modifier::BOLD);
        put(buf, area, 0, 0, "matrix", Style::new().fg(Color::Gray));
        // Lights across the top.
        for &(j, x, width) in &g.columns {
            let x = x as u16;
            let entry = &p.lights[j];
            let name_style =
                if matches!(target, Target::Light(l) if l == j) { head.fg(Color::LightGreen) } else { head };
            put(buf, area, x + 1, 0, &fit(&entry.name, width - 1), name_style);
            if let Some(rgb) = d.light_swatches.get(j) {
                put(buf, area, x + 1, 1, "████", swatch(state.ui.colour_mode, rgb));
            }
            if entry.design {
                put(buf, area, x + 6, 1, "D", design_style());
            }
            if matches!(target, Target::Light(l) if l == j) {
                put(buf, area, x, 1, "[", sel);
                put(buf, area, x + 5, 1, "]", sel);
            }
        }
        let shown_first = g.columns.first().map_or(0, |c| c.0);
        let shown_end = g.columns.last().map_or(0, |c| c.0 + 1);
        if shown_first > 0 {
            put(buf, area, (g.left_width - 2) as u16, 0, &format!("◂{shown_first}"), Style::new().fg(Color::Yellow));
        }
        if shown_end < p.lights.len() {
            let x = g.columns.last().map_or(g.left_width, |(_, x, w)| x + w) as u16;
            let more = format!("▸{}", p.lights.len() - shown_end);
            put(buf, area, x.min(area.width.saturating_sub(3)), 0, &more, Style::new().fg(Color::Yellow));
        }
        // Reflectances down the left, and the cells.
        let rows = g.first_reflectance..(g.first_reflectance + g.visible_reflectances).min(p.reflectances.len());
        for (k, i) in rows.clone().enumerate() {
            let y = (2 + g.row_height * k) as u16;
            let height = g.row_height as u16;
            let entry = &p.reflectances[i];
            let selected_row = matches!(target, Target::Reflectance(r) if r == i);
            let name_style = if selected_row { head.fg(Color::LightGreen) } else { head };
            put(buf, area, 0, y, &fit(&entry.name, g.name_width), name_style);
            let sx = (g.name_width + 2) as u16;
            if let Some(rgb) = d.reflectance_swatches.get(i) {
                for dy in 0..height {
                    put(buf, area, sx, y + dy, "██", swatch(state.ui.colour_mode, rgb));
                }
            }
            if selected_row {
                for dy in 0..height {
                    put(buf, area, sx - 1, y + dy, "[", sel);
                    put(buf, area, sx + 2, y + dy, "]", sel);
                }
            }
            if entry.design {
                put(buf, area, sx + 3, y, "D", design_style());
            }
            for &(j, x, _) in &g.columns {
                let x = x as u16;
                let Some(cell) = d.cell(j, i) else { continue };
                let (desired, model) = cell_styles(state, cell);
                let left = if cell.desired.is_some() { "▌" } else { "·" };
                for dy in 0..height {
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
                        super::legend::group_style()
                    } else {
                        super::legend::criterion_style()
                    };
                    put(buf, area, x + 6, y, &marker, style);
                }
                if matches!(target, Target::Cell { light, reflectance } if light == j && reflectance == i) {
                    for dy in 0..height {
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
