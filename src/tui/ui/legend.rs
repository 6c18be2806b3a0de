//! The legend of the marks (`i`): every mark the matrix and the title line draw, drawn in the style the
//! matrix draws it in, with what it means. A popup component: its rows here, its keys in
//! [`crate::tui::keymap::LEGEND`], its update the scrolling the help shares, its view [`draw`].

use super::{design_style, put, selected_style, wrap};
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};

/// One mark: what is drawn, its style, what it means.
pub(crate) struct Mark {
    pub(crate) symbol: &'static str,
    pub(crate) style: Style,
    pub(crate) meaning: &'static str,
}

/// The style of a free-colour group's initial on its cells (the matrix draws it so).
pub(crate) fn group_style() -> Style {
    Style::new().fg(Color::LightMagenta).add_modifier(Modifier::BOLD)
}

/// The style of the `•` / `○` criterion marks.
pub(crate) fn criterion_style() -> Style {
    Style::new().fg(Color::Gray)
}

/// Every mark, in the order the legend lists them.
pub(crate) fn marks() -> Vec<Mark> {
    let yellow = Style::new().fg(Color::Yellow);
    let mark = |symbol, style, meaning| Mark { symbol, style, meaning };
    vec![
        mark("[ ]", selected_style(), "the selection (dim green: another panel has the keys)"),
        mark("D", design_style(), "open to design: the solver sets this spectrum's samples"),
        mark("▌", Style::new(), "a cell's left column: its target colour"),
        mark("▀", Style::new(), "top: full-spectrum colour; bottom: subspace-model (Vm) colour"),
        mark(
            "▀",
            Style::new().fg(Color::Gray).bg(Color::DarkGray),
            "grey bottom half: the model's basis is being trained",
        ),
        mark("·", Style::new().fg(Color::DarkGray), "no target: the cell has no colour criterion"),
        mark("•", criterion_style(), "the cell's colour criterion is in use"),
        mark("○", criterion_style(), "the criterion is kept but not in use (u); the cell is dimmed"),
        mark("A", group_style(), "free-colour group (its initial): the solver picks its colour"),
        mark("◂ ▸ ▴ ▾", yellow, "N more lights or reflectances off screen that way"),
        mark("●", yellow.add_modifier(Modifier::BOLD), "title: unsaved changes"),
        mark("⚠N", yellow.add_modifier(Modifier::BOLD), "title: the latest solve has N diagnostics (! lists them)"),
        mark("⚠ Vm poor", yellow, "title: the m-dimensional basis models these spectra poorly"),
        mark("256c", Style::new().fg(Color::Gray), "title: 256 colours (no truecolor); nearest by ΔE*ab"),
    ]
}

/// Columns the symbols take (the meanings start after them).
const SYMBOL_COLS: u16 = 11;

/// The legend's lines for `width` columns: (symbol on the mark's first line, meaning wrapped between words).
pub(crate) fn lines(width: u16) -> Vec<(Option<&'static str>, Style, String)> {
    let room = usize::from(width.saturating_sub(SYMBOL_COLS + 1)).max(8);
    let mut out = Vec::new();
    for m in marks() {
        for (k, line) in wrap(m.meaning, room).into_iter().enumerate() {
            out.push(((k == 0).then_some(m.symbol), m.style, line));
        }
    }
    out
}

/// Draw the legend into `inner` (inside its frame), scrolled by `scroll` lines.
pub(crate) fn draw(inner: Rect, buf: &mut Buffer, scroll: u16) {
    let lines = lines(inner.width);
    let height = usize::from(inner.height);
    let scroll = usize::from(scroll).min(lines.len().saturating_sub(height));
    for (y, (symbol, style, meaning)) in lines.iter().skip(scroll).take(height).enumerate() {
        if let Some(symbol) = symbol {
            put(buf, inner, 1, y as u16, symbol, *style);
        }
        put(buf, inner, SYMBOL_COLS, y as u16, meaning, Style::new());
    }
}
