//! The view of the `/` search and `:` command palette (`crate::tui::finder`): the line typed, then the
//! matches, the chosen one highlighted.

use super::{fit, put};
use crate::palette::Palette;
use crate::tui::finder::{Finder, FinderKind};
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};

/// Draw the finder over `area`: the line typed, then the matches (the chosen one highlighted).
pub(crate) fn draw(finder: &Finder, palette: &Palette, area: Rect, buf: &mut Buffer) {
    let matches = finder.matches(palette);
    let width = 70u16.min(area.width);
    let height = (matches.len() as u16 + 4).clamp(5, area.height.saturating_sub(2).max(5)).min(area.height);
    let r = Rect { x: area.x + (area.width - width) / 2, y: area.y + (area.height - height) / 2, width, height };
    ratatui::widgets::Widget::render(ratatui::widgets::Clear, r, buf);
    let title = match finder.kind {
        FinderKind::Search => " / jump to a light, reflectance or cell ",
        FinderKind::Commands => " : run a command ",
    };
    let block = ratatui::widgets::Block::bordered()
        .title(title)
        .title_bottom(format!(
            " {} of {} · ↑↓ choose · Enter · Esc ",
            matches.len().min(finder.selected + 1),
            matches.len()
        ))
        .border_style(Style::new().fg(Color::LightCyan));
    let inner = block.inner(r);
    ratatui::widgets::Widget::render(block, r, buf);
    let typed = finder.input.visible(usize::from(inner.width.saturating_sub(4)));
    let x = put(buf, inner, 1, 0, "› ", Style::new().add_modifier(Modifier::BOLD));
    let x = put(buf, inner, x, 0, &typed.before, Style::new().fg(Color::White));
    let x = match typed.under {
        Some(c) => put(buf, inner, x, 0, &c.to_string(), Style::new().fg(Color::Black).bg(Color::LightGreen)),
        None => put(buf, inner, x, 0, "▏", Style::new().fg(Color::LightGreen)),
    };
    put(buf, inner, x, 0, &typed.after, Style::new().fg(Color::White));
    let rows = usize::from(inner.height.saturating_sub(1)).max(1);
    let first = (finder.selected + 1).saturating_sub(rows);
    if matches.is_empty() {
        put(buf, inner, 1, 1, "nothing matches", Style::new().fg(Color::Gray));
    }
    for (y, (k, (label, _))) in matches.iter().enumerate().skip(first).take(rows).enumerate() {
        let style =
            if k == finder.selected { Style::new().fg(Color::Black).bg(Color::LightGreen) } else { Style::new() };
        let text = fit(label, usize::from(inner.width.saturating_sub(2)));
        put(
            buf,
            inner,
            0,
            1 + y as u16,
            &format!(" {text:<w$}", w = usize::from(inner.width.saturating_sub(1))),
            style,
        );
    }
}
