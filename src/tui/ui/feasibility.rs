//! The mismatch-region overlay (`m`): the selected cell's region of reachable colours, sliced through
//! CIELAB at the target's L* (a*–b* plane, braille canvas) with the target (`×`) and the colour now (`○`)
//! marked, its L* range and the a*, b* ranges the canvas spans: the inner region (reachable with the other cells held, cyan) inside the outer one
//! (what the ΔE00 τ criterion could accept at most, grey). The region is computed by the worker after each solve
//! ([`crate::design::feasibility::panel`]); this only draws it.

use crate::design::feasibility::{Panel, Placement};
use crate::tui::app::State;
use crate::tui::ui::{fit, put, wrap};
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};
use ratatui::symbols::Marker;
use ratatui::widgets::canvas::{Canvas, Line as CanvasLine};
use ratatui::widgets::{Block, Clear, Widget};

/// Width and height of the overlay (clipped to the screen).
pub(crate) const WIDTH: u16 = 46;
pub(crate) const HEIGHT: u16 = 18;

/// The overlay, drawn in the bottom-right corner of `area` (over the spectra panel), or in the bottom-left
/// one when the right would cover the selected cell's column.
pub(crate) struct FeasibilityOverlay<'a>(pub &'a State);

impl Widget for FeasibilityOverlay<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        let w = WIDTH.min(area.width);
        let h = HEIGHT.min(area.height);
        if w < 20 || h < 6 {
            return;
        }
        let rect = Rect::new(place_x(state, area, w), area.y + area.height - h, w, h);
        Clear.render(rect, buf);
        let cell = state.feasibility_cell();
        let view = state.solve.feasibility.as_ref().filter(|v| Some(v.cell) == cell);
        let title = match view.and_then(|v| v.result.as_ref().ok()) {
            Some(p) => format!(" reachable · {} ", p.label),
            None => " reachable colours ".to_string(),
        };
        let block = Block::bordered().title(fit(&title, usize::from(w.saturating_sub(2)))).title_bottom(" m close ");
        let inner = block.inner(rect);
        block.render(rect, buf);
        let dim = Style::new().fg(Color::Gray);
        let width = usize::from(inner.width);
        let Some(view) = view else {
            let text = if cell.is_none() { "select a cell with a colour criterion" } else { "computing…" };
            put(buf, inner, 0, 0, &fit(text, width), dim);
            return;
        };
        let panel = match &view.result {
            Ok(p) => p,
            Err(e) => {
                // The reason, wrapped between words over the overlay's lines.
                for (i, line) in wrap(e, width).iter().take(usize::from(inner.height)).enumerate() {
                    put(buf, inner, 0, i as u16, line, dim);
                }
                return;
            }
        };
        let stale = view.generation != state.solve.generation;
        // The summary wrapped between words under the canvas (as many rows as it needs).
        let lines: Vec<String> = summary(panel, stale).iter().flat_map(|l| wrap(l, width)).collect();
        let text_rows = (lines.len() as u16).min(inner.height);
        let canvas_area = Rect::new(inner.x, inner.y, inner.width, inner.height.saturating_sub(text_rows));
        draw_slice(panel, canvas_area, buf);
        for (i, line) in lines.iter().take(usize::from(text_rows)).enumerate() {
            let y = inner.height.saturating_sub(text_rows) + i as u16;
            put(buf, inner, 0, y, line, Style::new());
        }
    }
}

/// The overlay's left edge in `area` for a width `w`: the right side, unless that covers the columns of
/// the selected cell (or light) in the matrix and the left side covers less of them.
fn place_x(state: &State, area: Rect, w: u16) -> u16 {
    let right = area.x + area.width - w;
    let crate::tui::app::Target::Cell { light, .. } = state.target() else { return right };
    let matrix = super::areas(state, area).matrix;
    let g = super::matrix::geometry(state, matrix);
    let Some(&(_, x, width)) = g.columns.iter().find(|c| c.0 == light) else { return right };
    let (c0, c1) = (matrix.x + x as u16, matrix.x + (x + width) as u16);
    let covered = |x0: u16| c1.min(x0 + w).saturating_sub(c0.max(x0));
    if covered(right) > 0 && covered(area.x) < covered(right) { area.x } else { right }
}

/// The lines under the canvas: the L* range, where the target is, the axes' ranges, what is held.
pub(crate) fn summary(panel: &Panel, stale: bool) -> Vec<String> {
    let (lo, hi) = panel.l_range;
    let range = format!("L* {:.1}…{:.1}, slice at target L* {:.1}", lo, hi, panel.target_lab[0]);
    let place = match panel.placement {
        Placement::Inside => format!("× inside: ΔE00 {:.2} from the edge", -panel.signed_delta_e),
        Placement::On => "× on the edge".to_string(),
        Placement::Undecided => format!("× undecided: ΔE00 {:.2} past the inner edge", panel.signed_delta_e),
        Placement::Outside => format!("× outside: ΔE00 {:.2} away", panel.signed_delta_e),
    };
    let held = format!(
        "{} other cell{} held within ΔE {}{}",
        panel.held,
        if panel.held == 1 { "" } else { "s" },
        panel.tolerance,
        if stale { " · updating…" } else { "" }
    );
    // The axes, named with the ranges the canvas spans (issue 30, defect 7: the plot had no a*/b* labels).
    let axes =
        canvas_bounds(panel).map(|([x0, x1], [y0, y1])| format!("a* {x0:.0}…{x1:.0} across · b* {y0:.0}…{y1:.0} up"));
    // With no region at the target's L* the canvas holds only the two marks: say why (never over them).
    let no_slice = panel.slice.as_ref().is_none_or(|s| s.lab.is_empty()).then(|| {
        let side = if panel.target_lab[0] > hi {
            "above"
        } else if panel.target_lab[0] < lo {
            "below"
        } else {
            "at"
        };
        format!("no region at the target's L* ({side} the reachable L*): the marks only")
    });
    [Some(range), no_slice, Some(format!("{place} · ○ now")), axes, Some(held)].into_iter().flatten().collect()
}

/// The inner and the outer slice polygons in the a*–b* plane.
fn slice_polygons(panel: &Panel) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let ab = |s: &Option<_>| -> Vec<[f64; 2]> {
        s.as_ref()
            .map(|s: &crate::design::feasibility::Slice| s.lab.iter().map(|l| [l[1], l[2]]).collect())
            .unwrap_or_default()
    };
    (ab(&panel.slice), ab(&panel.outer_slice))
}

/// The a* and b* ranges the canvas shows: the polygons and both marks, each axis padded by a tenth (at least
/// one unit); none when nothing is finite.
fn canvas_bounds(panel: &Panel) -> Option<([f64; 2], [f64; 2])> {
    let (poly, outer) = slice_polygons(panel);
    let marks = [[panel.target_lab[1], panel.target_lab[2]], [panel.achieved_lab[1], panel.achieved_lab[2]]];
    let all = poly.iter().chain(&outer).chain(&marks);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for p in all.filter(|p| p[0].is_finite() && p[1].is_finite()) {
        x0 = x0.min(p[0]);
        x1 = x1.max(p[0]);
        y0 = y0.min(p[1]);
        y1 = y1.max(p[1]);
    }
    if !(x0.is_finite() && y0.is_finite()) {
        return None;
    }
    // Equal scales would waste the wide canvas; pad each axis by a tenth (at least one unit).
    let pad = |a: f64, b: f64| ((b - a) * 0.1).max(1.0);
    let (px, py) = (pad(x0, x1), pad(y0, y1));
    Some(([x0 - px, x1 + px], [y0 - py, y1 + py]))
}

/// The slice polygon and the two marks on a braille canvas, a* across, b* up (the ranges are in the summary).
fn draw_slice(panel: &Panel, area: Rect, buf: &mut Buffer) {
    if area.height < 2 {
        return;
    }
    let (poly, outer) = slice_polygons(panel);
    let marks = [[panel.target_lab[1], panel.target_lab[2]], [panel.achieved_lab[1], panel.achieved_lab[2]]];
    let Some(([x0, x1], [y0, y1])) = canvas_bounds(panel) else { return };
    let region = Color::LightCyan;
    let canvas = Canvas::default().marker(Marker::Braille).x_bounds([x0, x1]).y_bounds([y0, y1]).paint(|ctx| {
        // The outer boundary first (dimmer), the inner one over it.
        for (k, a) in outer.iter().enumerate() {
            let b = outer[(k + 1) % outer.len()];
            ctx.draw(&CanvasLine { x1: a[0], y1: a[1], x2: b[0], y2: b[1], color: Color::DarkGray });
        }
        for (k, a) in poly.iter().enumerate() {
            let b = poly[(k + 1) % poly.len()];
            ctx.draw(&CanvasLine { x1: a[0], y1: a[1], x2: b[0], y2: b[1], color: region });
        }
        ctx.layer();
        let bold = Style::new().add_modifier(Modifier::BOLD);
        ctx.print(marks[1][0], marks[1][1], ratatui::text::Line::styled("○", bold.fg(Color::LightGreen)));
        ctx.print(marks[0][0], marks[0][1], ratatui::text::Line::styled("×", bold.fg(Color::LightRed)));
    });
    canvas.render(area, buf);
}
