//! The view of the dial's keyframes (`crate::tui::keyframe_list`): the keyframes added this session,
//! then the scene file's, the chosen one highlighted, and what the keys do.

use super::{fit, put};
use crate::tui::keyframe_list::{KeyframeList, Origin, rows};
use crate::tui::model::PreviewState;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style};
use ratatui::widgets::{Block, Clear, Widget};

/// Draw the list over `area`, centred.
pub(crate) fn draw(list: &KeyframeList, preview: &PreviewState, area: Rect, buf: &mut Buffer) {
    let all = rows(preview);
    let new = preview.keyframes.len();
    // One line per keyframe, a heading over each group, a line when there is none.
    let mut lines: Vec<(Option<usize>, String)> = Vec::new();
    lines.push((None, format!("added this session ({new}; d or Del deletes, not undoable):")));
    if new == 0 {
        lines.push((None, "  none yet: `a` adds the dial as it stands".to_string()));
    }
    for (k, row) in all.iter().enumerate() {
        if let Origin::Scene(0) = row.origin {
            lines.push((None, "in the scene file (edit the file to remove):".to_string()));
        }
        lines.push((Some(k), format!("{:>2}  {}", k + 1, row.text)));
    }
    let width = 70u16.min(area.width);
    let height = (lines.len() as u16 + 2).min(area.height);
    let r = Rect { x: area.x + (area.width - width) / 2, y: area.y + (area.height - height) / 2, width, height };
    Clear.render(r, buf);
    let block = Block::bordered()
        .title(" keyframes · ↑↓ choose · Enter set the dial · d delete ")
        .title_bottom(" Esc closes ")
        .border_style(Style::new().fg(Color::LightCyan));
    let inner = block.inner(r);
    block.render(r, buf);
    let rows_shown = usize::from(inner.height);
    // Keep the chosen line in view.
    let at = lines.iter().position(|(k, _)| *k == Some(list.selected)).unwrap_or(0);
    let first = (at + 1).saturating_sub(rows_shown);
    let text_width = usize::from(inner.width.saturating_sub(1));
    for (y, (k, text)) in lines.iter().skip(first).take(rows_shown).enumerate() {
        let style = match k {
            Some(k) if *k == list.selected => Style::new().fg(Color::Black).bg(Color::LightGreen),
            Some(_) => Style::new(),
            None => Style::new().fg(Color::Gray),
        };
        put(buf, inner, 0, y as u16, &format!(" {:<text_width$}", fit(text, text_width.saturating_sub(1))), style);
    }
}
