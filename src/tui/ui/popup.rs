//! Popups over the main screen: the help listing every key, text prompts, the add lists, the
//! light-or-reflectance choice, the quit confirmation and the outside-change conflict.

use crate::tui::app::{Popup, State};
use crate::tui::keymap::{self, TABLES};
use crate::tui::ui::{fit, put};
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};
use ratatui::widgets::{Block, Clear, Widget};

/// The open popup of a state.
pub(crate) struct PopupView<'a>(pub &'a State);

/// A rectangle of at most `width`×`height` centred in `area`.
fn centred(area: Rect, width: u16, height: u16) -> Rect {
    let w = width.min(area.width);
    let h = height.min(area.height);
    Rect { x: area.x + (area.width - w) / 2, y: area.y + (area.height - h) / 2, width: w, height: h }
}

fn frame(area: Rect, buf: &mut Buffer, title: &str) -> Rect {
    Clear.render(area, buf);
    let block = Block::bordered()
        .title(format!(" {title} "))
        .title_bottom(" Esc closes ")
        .border_style(Style::new().fg(Color::LightCyan));
    let inner = block.inner(area);
    block.render(area, buf);
    inner
}

/// `text` in lines of at most `width` characters, broken between words (a longer word is cut).
fn wrap(text: &str, width: usize) -> Vec<String> {
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

/// One row of the help.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum HelpRow {
    Heading(&'static str),
    /// Up to two (keys, what they do) pairs side by side.
    Keys(Vec<(String, &'static str)>),
    /// A popup's keys on one line.
    Popup(&'static str, String),
}

/// The help's rows for a popup `width` wide: every binding of the main screen (two columns when wide),
/// then each popup's keys on one line (`TABLES[0]` is the main screen's).
pub(crate) fn help_rows(width: u16) -> Vec<HelpRow> {
    let columns = if width >= 90 { 2 } else { 1 };
    let mut rows = Vec::new();
    // The main screen's and the light dial's keys in columns; `TABLES[0..2]` are these two.
    for (title, table) in [("main screen", keymap::MAIN), ("light dial (g; Esc leaves)", keymap::DIAL)] {
        let keys: Vec<(String, &'static str)> = table.iter().map(|b| (keymap::keys_label(b), b.help)).collect();
        let per_column = keys.len().div_ceil(columns);
        rows.push(HelpRow::Heading(title));
        for r in 0..per_column {
            rows.push(HelpRow::Keys((0..columns).filter_map(|c| keys.get(c * per_column + r).cloned()).collect()));
        }
    }
    rows.push(HelpRow::Heading("popups and prompts"));
    for (title, table) in TABLES.iter().skip(2) {
        let keys: Vec<String> = table.iter().map(|b| format!("{} {}", keymap::keys_label(b), b.help)).collect();
        rows.push(HelpRow::Popup(title, keys.join(" · ")));
    }
    rows
}

impl Widget for PopupView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        let Some(popup) = &state.ui.popup else { return };
        let bold = Style::new().add_modifier(Modifier::BOLD);
        let grey = Style::new().fg(Color::Gray);
        match popup {
            Popup::Help { scroll } => {
                let r = centred(area, area.width.saturating_sub(2), area.height.saturating_sub(2));
                let inner = frame(r, buf, "keys (↑↓ scroll)");
                let rows = help_rows(inner.width);
                let height = usize::from(inner.height);
                let scroll = usize::from(*scroll).min(rows.len().saturating_sub(height));
                let col_width = inner.width / 2;
                for (y, row) in rows.iter().skip(scroll).take(height).enumerate() {
                    let y = y as u16;
                    match row {
                        HelpRow::Heading(text) => {
                            put(buf, inner, 1, y, text, bold.fg(Color::LightCyan));
                        }
                        HelpRow::Keys(pairs) => {
                            for (c, (keys, help)) in pairs.iter().enumerate() {
                                let x = 1 + c as u16 * col_width;
                                put(buf, inner, x, y, &fit(keys, 11), bold);
                                put(buf, inner, x + 12, y, help, Style::new());
                            }
                        }
                        HelpRow::Popup(title, keys) => {
                            let x = put(buf, inner, 1, y, &format!("{title}: "), bold);
                            put(buf, inner, x, y, keys, Style::new());
                        }
                    }
                }
            }
            Popup::Diagnostics { scroll } => {
                let r = centred(area, area.width.saturating_sub(4), area.height.saturating_sub(4));
                let inner = frame(r, buf, "diagnostics of the latest solve (↑↓ scroll)");
                let width = usize::from(inner.width.saturating_sub(4)).max(10);
                let mut lines: Vec<String> = Vec::new();
                for d in state.diagnostics() {
                    let mut line = String::from("•");
                    for w in d.message.split_whitespace() {
                        if line.chars().count() + w.chars().count() + 1 > width && line.chars().count() > 2 {
                            lines.push(std::mem::replace(&mut line, String::from(" ")));
                        }
                        line.push(' ');
                        line.push_str(w);
                    }
                    lines.push(line);
                }
                let rows = usize::from(inner.height);
                let scroll = usize::from(*scroll).min(lines.len().saturating_sub(rows));
                for (y, line) in lines.iter().skip(scroll).take(rows).enumerate() {
                    put(buf, inner, 1, y as u16, line, Style::new().fg(Color::Yellow));
                }
            }
            Popup::Prompt(p) => {
                let r = centred(area, 64, 6);
                let inner = frame(r, buf, &p.title);
                put(buf, inner, 1, 0, &p.hint, grey);
                let w = usize::from(inner.width.saturating_sub(4));
                let chars: Vec<char> = p.input.chars().collect();
                let shown: String = chars[chars.len().saturating_sub(w)..].iter().collect();
                let x = put(buf, inner, 1, 1, "› ", bold);
                let x = put(buf, inner, x, 1, &shown, Style::new().fg(Color::White));
                put(buf, inner, x, 1, "▏", Style::new().fg(Color::LightGreen));
                match &p.error {
                    Some(e) => put(
                        buf,
                        inner,
                        1,
                        2,
                        &fit(&crate::fsio::escape(&e.0.to_string()), usize::from(inner.width.saturating_sub(2))),
                        Style::new().fg(Color::LightRed),
                    ),
                    None => put(buf, inner, 1, 2, "Enter accepts", grey),
                };
            }
            Popup::ChooseSpectrum { op, light, reflectance } => {
                let r = centred(area, 60, 5);
                let inner = frame(r, buf, op.label());
                let l = state.doc.palette.lights.get(*light).map_or("", |e| e.name.as_str());
                let rf = state.doc.palette.reflectances.get(*reflectance).map_or("", |e| e.name.as_str());
                put(buf, inner, 1, 0, &format!("l  the light {l}"), Style::new());
                put(buf, inner, 1, 1, &format!("r  the reflectance {rf}"), Style::new());
            }
            Popup::Pick { kind, items, selected } => {
                let h = (items.len() as u16 + 2).min(area.height.saturating_sub(2)).max(3);
                let r = centred(area, 50, h);
                let inner = frame(r, buf, &format!("add a {} (↑↓ Enter)", kind.as_str()));
                let rows = usize::from(inner.height).max(1);
                let first = if *selected >= rows { selected + 1 - rows } else { 0 };
                for (y, (k, item)) in items.iter().enumerate().skip(first).take(rows).enumerate() {
                    let style =
                        if k == *selected { Style::new().fg(Color::Black).bg(Color::LightGreen) } else { Style::new() };
                    put(buf, inner, 0, y as u16, &format!(" {:<46}", item.label()), style);
                }
            }
            Popup::ConfirmQuit => {
                let r = centred(area, 56, 6);
                let inner = frame(r, buf, "unsaved changes");
                let name = state.path().display().to_string();
                put(buf, inner, 1, 0, &fit(&format!("{name} has unsaved changes."), 52), bold);
                put(buf, inner, 1, 1, "s  save, then quit", Style::new());
                put(buf, inner, 1, 2, "y  quit without saving", Style::new());
                put(buf, inner, 1, 3, "n  stay", Style::new());
            }
            Popup::Conflict { text } => {
                let width = 70u16.min(area.width.saturating_sub(2)).max(20);
                let lines = wrap(&crate::fsio::escape(text), usize::from(width.saturating_sub(4)));
                let r = centred(area, width, lines.len() as u16 + 7);
                let inner = frame(r, buf, "the file changed on disk");
                for (y, line) in lines.iter().enumerate() {
                    put(buf, inner, 1, y as u16, line, bold);
                }
                let y = lines.len() as u16 + 1;
                for (k, b) in keymap::CONFLICT.iter().enumerate() {
                    put(
                        buf,
                        inner,
                        1,
                        y + k as u16,
                        &format!("{:<10} {}", keymap::keys_label(b), b.help),
                        Style::new(),
                    );
                }
            }
        }
    }
}
