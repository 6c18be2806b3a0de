//! The view: draws a [`State`] without changing it. `impl Widget for &State` lays out the screen after
//! the seed's Fig. 1 (matrix top left, sliders top right, settings in the middle, spectra at the bottom)
//! and hands each panel a borrowed view of the state.

pub(crate) mod dial_list;
pub mod feasibility;
pub(crate) mod finder;
pub mod hit;
pub(crate) mod keyframe_list;
pub mod legend;
pub mod matrix;
pub mod popup;
pub mod preview;
pub mod settings;
pub mod sliders;
pub mod spectra;
pub mod status;

use crate::tui::app::State;
use crate::tui::colour::ColourMode;
use ratatui::buffer::Buffer;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::Span;
use ratatui::widgets::{Block, Borders, Widget};

/// Rows the full sliders panel needs.
pub(crate) const SLIDERS_ROWS: u16 = 8;
/// Columns the full sliders panel needs; narrower screens get the one-line sliders.
pub(crate) const SLIDERS_COLS: u16 = 38;
/// Smallest spectra panel worth drawing (rows, with its top rule).
pub(crate) const SPECTRA_MIN: u16 = 5;

/// The panels' rectangles for a screen of `area`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Areas {
    pub matrix: Rect,
    /// Full sliders to the right of the matrix, or one line under it.
    pub(crate) sliders: Rect,
    pub(crate) sliders_compact: bool,
    pub(crate) settings: Rect,
    pub(crate) spectra: Rect,
}

/// Lay the panels out inside the outer border.
pub fn areas(state: &State, inner: Rect) -> Areas {
    let settings_rows = 2u16;
    let available = inner.height.saturating_sub(settings_rows);
    // Two rows per reflectance when they fit above a useful spectra panel, else one (same three colours).
    let matrix_rows = if matrix::rows_needed(state, false) + SPECTRA_MIN <= available {
        matrix::rows_needed(state, false)
    } else {
        matrix::rows_needed(state, true)
    };
    let compact_rows = 1;
    let fits_beside = inner.width >= matrix::width_needed(state) + SLIDERS_COLS;
    let want_top = if fits_beside { matrix_rows.max(SLIDERS_ROWS) } else { matrix_rows + compact_rows };
    let mut top = want_top.min(available.saturating_sub(SPECTRA_MIN)).max(available.min(4));
    if top > available {
        top = available;
    }
    let spectra = available - top;
    let [top_area, settings, spectra_area] =
        Layout::vertical([Constraint::Length(top), Constraint::Length(settings_rows), Constraint::Length(spectra)])
            .areas(inner);
    // Full sliders only when the whole matrix fits beside them; else they take one line under it.
    let compact = top < SLIDERS_ROWS || !fits_beside;
    let (matrix, sliders) = if !compact {
        let [m, s] = Layout::horizontal([Constraint::Min(20), Constraint::Length(SLIDERS_COLS)]).areas(top_area);
        (m, s)
    } else {
        let [m, s] = Layout::vertical([Constraint::Min(0), Constraint::Length(1)]).areas(top_area);
        (m, s)
    };
    Areas { matrix, sliders, sliders_compact: compact, settings, spectra: spectra_area }
}

/// Columns of the dial panel beside the preview image (when the panel is wide enough).
pub(crate) const DIAL_COLS: u16 = 34;

/// The preview panel's parts: the image and, to its right, the dial.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PreviewAreas {
    pub image: Rect,
    pub dial: Rect,
}

/// Where the scene preview goes on a screen of `screen`, when it is shown (the event loop raycasts at
/// this size).
pub fn preview_areas(state: &State, screen: Rect) -> Option<PreviewAreas> {
    if !(state.preview.shown && state.preview.has_scene()) {
        return None;
    }
    if state.preview.full {
        // The whole terminal but the caption line.
        let image = Rect { height: screen.height.saturating_sub(1), ..screen };
        return Some(PreviewAreas { image, dial: Rect { x: screen.x, y: image.bottom(), width: 0, height: 0 } });
    }
    let inner = Block::bordered().inner(screen);
    let spectra = areas(state, inner).spectra;
    if spectra.height < 3 {
        return None;
    }
    let panel = Block::new().borders(Borders::TOP).inner(spectra);
    let dial_cols = if panel.width >= DIAL_COLS + 24 { DIAL_COLS } else { 0 };
    let [image, dial] = Layout::horizontal([Constraint::Min(1), Constraint::Length(dial_cols)]).areas(panel);
    Some(PreviewAreas { image, dial })
}

impl Widget for &State {
    fn render(self, area: Rect, buf: &mut Buffer) {
        if let Some(p) = preview_areas(self, area).filter(|_| self.preview.full) {
            preview::full_screen(self, p.image, area, buf);
            if self.ui.popup.is_some() {
                popup::PopupView(self).render(area, buf);
            }
            return;
        }
        let outer = Block::bordered().title_bottom(status::bottom_line(self, area.width.saturating_sub(4)));
        let inner = outer.inner(area);
        let screen = inner;
        outer.render(area, buf);
        status::draw_title(self, area, buf);
        let a = areas(self, inner);
        matrix::Matrix(self).render(a.matrix, buf);
        if a.sliders_compact {
            sliders::CompactSliders(self).render(a.sliders, buf);
        } else {
            let block = Block::new().borders(Borders::LEFT);
            let inner = block.inner(a.sliders);
            block.render(a.sliders, buf);
            sliders::Sliders(self).render(inner, buf);
        }
        // Focused, the row's header says so in the focus colour and names its keys.
        let block = if self.ui.focus == crate::tui::app::Focus::Settings {
            Block::new().borders(Borders::TOP).title(Span::styled(
                " settings · ←/→ field · enter edit · ↑ back ",
                Style::new().fg(Color::LightGreen).add_modifier(Modifier::BOLD),
            ))
        } else {
            Block::new().borders(Borders::TOP).title(" settings ")
        };
        let inner = block.inner(a.settings);
        block.render(a.settings, buf);
        settings::SettingsRow(self).render(inner, buf);
        if a.spectra.height >= 3 {
            match preview_areas(self, area) {
                Some(p) => {
                    let block = Block::new().borders(Borders::TOP).title(preview::title(self));
                    block.render(a.spectra, buf);
                    preview::PreviewPanel(self).render(p.image, buf);
                    if p.dial.width > 0 {
                        preview::DialPanel(self).render(p.dial, buf);
                    }
                }
                None => {
                    let block = Block::new().borders(Borders::TOP).title(spectra::title(self, a.spectra.width));
                    let inner = block.inner(a.spectra);
                    block.render(a.spectra, buf);
                    spectra::SpectraPlot(self).render(inner, buf);
                }
            }
        }
        if self.ui.show_feasibility {
            feasibility::FeasibilityOverlay(self).render(Block::bordered().inner(area), buf);
        }
        message_area(self, screen, buf);
        if self.ui.popup.is_some() {
            popup::PopupView(self).render(area, buf);
        }
    }
}

/// A message longer than the bottom line, wrapped between words over the bottom rows of `inner` (under a
/// rule), so nothing of it is cut; the next key dismisses it as any message.
fn message_area(state: &State, inner: Rect, buf: &mut Buffer) {
    let rows = status::message_rows(state, inner.width.saturating_sub(2));
    let Some(m) = state.ui.message.as_ref().filter(|_| !rows.is_empty()) else { return };
    let height = (rows.len() as u16 + 1).min(inner.height);
    let rect = Rect { y: inner.bottom() - height, height, ..inner };
    ratatui::widgets::Clear.render(rect, buf);
    let block = Block::new().borders(Borders::TOP).title(if m.is_error { " error " } else { " message " });
    let text = block.inner(rect);
    block.render(rect, buf);
    for (y, line) in rows.iter().take(usize::from(text.height)).enumerate() {
        put(buf, text, 1, y as u16, line, status::message_style(m));
    }
}

/// A number as the screen shows it: short, `inf` for infinities.
pub(crate) fn num(v: f64) -> String {
    if v == f64::INFINITY {
        "inf".into()
    } else if v == f64::NEG_INFINITY {
        "-inf".into()
    } else if v != 0.0 && (v.abs() < 1e-3 || v.abs() >= 1e5) {
        format!("{v:.2e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s.is_empty() || s == "-0" { "0".into() } else { s.to_string() }
    }
}

/// A number to four significant digits (scientific below 1e-3 and from 1e5).
pub(crate) fn sig4(v: f64) -> String {
    if !v.is_finite() || v == 0.0 {
        return num(v);
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        return format!("{v:.3e}");
    }
    let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
    format!("{v:.decimals$}")
}

/// Style of the selection brackets (the seed's green border).
pub(crate) fn selected_style() -> Style {
    Style::new().fg(Color::LightGreen).add_modifier(Modifier::BOLD)
}

/// Style of a designed-spectrum marker (the seed's red border).
pub(crate) fn design_style() -> Style {
    Style::new().fg(Color::LightRed).add_modifier(Modifier::BOLD)
}

/// Foreground-only style of a colour swatch.
pub(crate) fn swatch(mode: ColourMode, rgb: &nalgebra::Vector3<f64>) -> Style {
    Style::new().fg(mode.linear(rgb))
}

/// Write `text` clipped to `area`'s row `dy`, starting at column `dx`; returns the column after it.
pub(crate) fn put(buf: &mut Buffer, area: Rect, dx: u16, dy: u16, text: &str, style: Style) -> u16 {
    if dy >= area.height || dx >= area.width {
        return dx;
    }
    let (x, _) = buf.set_stringn(area.x + dx, area.y + dy, text, usize::from(area.width - dx), style);
    x - area.x
}

/// Truncate `text` to `width` characters, marking a cut with `…`.
pub(crate) fn fit(text: &str, width: usize) -> String {
    if text.chars().count() <= width {
        text.to_string()
    } else if width == 0 {
        String::new()
    } else {
        let mut s: String = text.chars().take(width - 1).collect();
        s.push('…');
        s
    }
}

/// `text` in lines of at most `width` characters, broken between words (a longer word is cut).
pub(crate) fn wrap(text: &str, width: usize) -> Vec<String> {
    let width = width.max(1);
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        let (have, add) = (line.chars().count(), word.chars().count());
        if have > 0 && have + 1 + add > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
        while line.chars().count() > width {
            let rest: String = line.chars().skip(width).collect();
            lines.push(line.chars().take(width).collect());
            line = rest;
        }
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// `path` in at most `width` characters: whole when it fits, else its leading folders dropped (`…/name`),
/// else the file name cut in its middle, its extension kept (`fig6_en….toml`).
pub(crate) fn abbreviate_path(path: &str, width: usize) -> String {
    let count = |s: &str| s.chars().count();
    if count(path) <= width {
        return path.to_string();
    }
    let name = path.rsplit(['/', '\\']).next().unwrap_or(path);
    let short = format!("…/{name}");
    if count(&short) <= width && name != path {
        return short;
    }
    if count(name) <= width {
        return name.to_string();
    }
    // Keep the extension and as much of the start of the name as fits.
    let ext = name.rfind('.').filter(|&i| i > 0).map_or("", |i| &name[i..]);
    let keep = width.saturating_sub(count(ext) + 1);
    if keep == 0 {
        return fit(name, width);
    }
    format!("{}…{ext}", name.chars().take(keep).collect::<String>())
}

/// The screen as plain text, one line per row, trailing blanks trimmed (for `--screen`).
pub fn buffer_text(buf: &Buffer) -> String {
    let width = usize::from(buf.area.width.max(1));
    let mut out = String::with_capacity(buf.content.len() + usize::from(buf.area.height));
    for row in buf.content.chunks(width) {
        let mut line = String::with_capacity(width);
        let mut skip = 0usize;
        for cell in row {
            if skip > 0 {
                skip -= 1;
                continue;
            }
            line.push_str(cell.symbol());
            skip = ratatui::text::Span::raw(cell.symbol()).width().saturating_sub(1);
        }
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}
