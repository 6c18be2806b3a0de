//! Popups over the main screen: the help listing every key, text prompts, the add lists, the
//! light-or-reflectance choice, the quit confirmation and the outside-change conflict.

use crate::tui::app::{Popup, State};
use crate::tui::keymap::{self, TABLES};
use crate::tui::ui::{fit, put, wrap};
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

/// One row of the help.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum HelpRow {
    Heading(&'static str),
    /// Up to two (keys, what they do) pairs side by side (keys empty: the line goes on).
    Keys(Vec<(String, String)>),
    /// A popup's keys (title on the first line only; the keys wrapped between words).
    Popup(Option<&'static str>, String),
}

/// Columns the keys take in the help (the description starts after them).
const KEYS_COLS: u16 = 12;

/// The help's rows for a popup `width` wide (inside its border): every binding of the main screen and
/// the light dial (two columns when every description fits in half the width), then each popup's keys,
/// every description wrapped between words so that no line is cut.
pub(crate) fn help_rows(width: u16) -> Vec<HelpRow> {
    let longest = TABLES.iter().take(2).flat_map(|(_, t)| t.iter()).map(|b| b.help.chars().count()).max().unwrap_or(0);
    let two = width >= 90 && usize::from(width / 2) >= usize::from(KEYS_COLS) + 1 + longest;
    let columns = if two { 2 } else { 1 };
    let room = usize::from((width / columns).saturating_sub(KEYS_COLS + 1)).max(8);
    let mut rows = Vec::new();
    // The main screen's and the light dial's keys in columns; `TABLES[0..2]` are these two.
    for (title, table) in [("main screen", keymap::MAIN), ("light dial (g; Esc leaves)", keymap::DIAL)] {
        // One (keys, line) per row of a column: a description longer than its room goes on below.
        let mut lines: Vec<(String, String)> = Vec::new();
        for b in table {
            for (k, line) in wrap(b.help, room).into_iter().enumerate() {
                lines.push((if k == 0 { keymap::keys_label(b) } else { String::new() }, line));
            }
        }
        let per_column = lines.len().div_ceil(usize::from(columns));
        rows.push(HelpRow::Heading(title));
        for r in 0..per_column {
            rows.push(HelpRow::Keys(
                (0..usize::from(columns)).filter_map(|c| lines.get(c * per_column + r).cloned()).collect(),
            ));
        }
    }
    rows.push(HelpRow::Heading("popups and prompts"));
    for (title, table) in TABLES.iter().skip(2) {
        let keys: Vec<String> = table.iter().map(|b| format!("{} {}", keymap::keys_label(b), b.help)).collect();
        let text = format!("{title}: {}", keys.join(" · "));
        for (k, line) in wrap(&text, usize::from(width.saturating_sub(4)).max(8)).into_iter().enumerate() {
            match k {
                0 => {
                    let rest = line.strip_prefix(&format!("{title}:")).unwrap_or(&line).trim_start().to_string();
                    rows.push(HelpRow::Popup(Some(title), rest));
                }
                _ => rows.push(HelpRow::Popup(None, line)),
            }
        }
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
                                put(buf, inner, x, y, &fit(keys, usize::from(KEYS_COLS - 1)), bold);
                                put(buf, inner, x + KEYS_COLS, y, help, Style::new());
                            }
                        }
                        HelpRow::Popup(Some(title), keys) => {
                            let x = put(buf, inner, 1, y, &format!("{title}: "), bold);
                            put(buf, inner, x, y, keys, Style::new());
                        }
                        HelpRow::Popup(None, keys) => {
                            put(buf, inner, 3, y, keys, Style::new());
                        }
                    }
                }
            }
            Popup::Find(finder) => super::finder::draw(finder, &state.doc.palette, area, buf),
            Popup::DialList(list) => {
                let r = centred(area, area.width.saturating_sub(2), area.height.saturating_sub(2));
                let inner = frame(r, buf, "mixtures and paths along the dial");
                super::dial_list::draw(state, list, inner, buf);
            }
            Popup::Keyframes(list) => super::keyframe_list::draw(list, &state.preview, area, buf),
            Popup::Legend { scroll } => {
                let width = 76u16.min(area.width);
                let lines = super::legend::lines(width.saturating_sub(2)).len() as u16;
                let r = centred(area, width, lines + 2);
                let inner = frame(r, buf, "what the marks mean (↑↓ scroll)");
                super::legend::draw(inner, buf, *scroll);
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
                // The hint and the refusal wrapped, the popup as tall as they need: nothing cut.
                let width = 64u16.min(area.width);
                let text_width = usize::from(width.saturating_sub(4));
                let hint = wrap(&p.hint, text_width);
                let (below, below_style) = match &p.error {
                    Some(e) => {
                        (wrap(&crate::fsio::escape(&e.0.to_string()), text_width), Style::new().fg(Color::LightRed))
                    }
                    None => (vec!["Enter accepts".to_string()], grey),
                };
                let r = centred(area, width, (hint.len() + below.len()) as u16 + 3);
                let inner = frame(r, buf, &p.title);
                for (y, line) in hint.iter().enumerate() {
                    put(buf, inner, 1, y as u16, line, grey);
                }
                let row = hint.len() as u16;
                let w = usize::from(inner.width.saturating_sub(4));
                // The line scrolls so that the cursor stays in view; the character under it is highlighted, and
                // a cursor past the end is a bar.
                let crate::tui::app::VisibleText { before, under, after } = p.input.visible(w);
                let text = Style::new().fg(Color::White);
                let x = put(buf, inner, 1, row, "› ", bold);
                let x = put(buf, inner, x, row, &before, text);
                match under {
                    Some(c) => {
                        let x = put(
                            buf,
                            inner,
                            x,
                            row,
                            &c.to_string(),
                            Style::new().fg(Color::Black).bg(Color::LightGreen),
                        );
                        put(buf, inner, x, row, &after, text);
                    }
                    None => {
                        put(buf, inner, x, row, "▏", Style::new().fg(Color::LightGreen));
                    }
                }
                for (y, line) in below.iter().enumerate() {
                    put(buf, inner, 1, row + 1 + y as u16, line, below_style);
                }
            }
            Popup::ChooseSpectrum { op, light, reflectance } => {
                let p = &state.doc.palette;
                let group = (*op == crate::tui::app::SpectrumOp::Rename)
                    .then(|| crate::tui::rename::group_of(p, *light, *reflectance))
                    .flatten()
                    .and_then(|g| p.free.get(g));
                let r = centred(area, 60, 5 + u16::from(group.is_some()));
                let inner = frame(r, buf, op.label());
                let l = p.lights.get(*light).map_or("", |e| e.name.as_str());
                let rf = p.reflectances.get(*reflectance).map_or("", |e| e.name.as_str());
                put(buf, inner, 1, 0, &format!("l  the light {l}"), Style::new());
                put(buf, inner, 1, 1, &format!("r  the reflectance {rf}"), Style::new());
                if let Some(g) = group {
                    put(buf, inner, 1, 2, &format!("g  the free-colour group {}", g.name), Style::new());
                }
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
                let width = 56u16.min(area.width);
                let name = state.path().display().to_string();
                let lines = wrap(&format!("{name} has unsaved changes."), usize::from(width.saturating_sub(4)));
                let r = centred(area, width, lines.len() as u16 + 5);
                let inner = frame(r, buf, "unsaved changes");
                for (y, line) in lines.iter().enumerate() {
                    put(buf, inner, 1, y as u16, line, bold);
                }
                let y = lines.len() as u16;
                put(buf, inner, 1, y, "s  save, then quit", Style::new());
                put(buf, inner, 1, y + 1, "y  quit without saving", Style::new());
                put(buf, inner, 1, y + 2, "n  stay", Style::new());
            }
            Popup::Recovery { path } => {
                let width = 70u16.min(area.width.saturating_sub(2)).max(20);
                let text = format!(
                    "unsaved work from an interrupted session is in {}, beside the palette file.",
                    crate::fsio::show(path)
                );
                let lines = wrap(&text, usize::from(width.saturating_sub(4)));
                // Each key with its description, wrapped beside it.
                let keys: Vec<String> = keymap::RECOVERY
                    .iter()
                    .flat_map(|b| {
                        let label = keymap::keys_label(b);
                        wrap(b.help, usize::from(width.saturating_sub(13)))
                            .into_iter()
                            .enumerate()
                            .map(move |(k, l)| format!("{:<8} {l}", if k == 0 { label.as_str() } else { "" }))
                            .collect::<Vec<_>>()
                    })
                    .collect();
                let r = centred(area, width, (lines.len() + keys.len()) as u16 + 3);
                let inner = frame(r, buf, "recovery copy found");
                for (y, line) in lines.iter().enumerate() {
                    put(buf, inner, 1, y as u16, line, bold);
                }
                for (k, line) in keys.iter().enumerate() {
                    put(buf, inner, 1, (lines.len() + 1 + k) as u16, line, Style::new());
                }
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
