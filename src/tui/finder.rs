//! `/` search and `:` command palette: a line to type in over a list filtered as you type (every word
//! typed must appear in an entry, case ignored), ↑/↓ to choose, Enter to jump to the light, reflectance
//! or cell (search) or to run the action (commands: every action of the main keymap, by what the help
//! calls it). A popup component: state ([`Finder`]), update ([`on_action`], taking the sub-models it
//! needs) and view ([`draw`]).

use crate::palette::Palette;
use crate::tui::action::{Action, Direction};
use crate::tui::app::{PromptText, Selection};
use crate::tui::keymap;
use crate::tui::ui::{fit, put};
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};

/// Search the palette or the commands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FinderKind {
    Search,
    Commands,
}

/// The open finder: what is typed and which entry of the filtered list is chosen.
#[derive(Clone, Debug, PartialEq)]
pub struct Finder {
    pub kind: FinderKind,
    pub(crate) input: PromptText,
    pub(crate) selected: usize,
}

/// Where an entry leads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Goal {
    Select(Selection),
    Run(Action),
}

impl Finder {
    pub(crate) fn new(kind: FinderKind) -> Finder {
        Finder { kind, input: PromptText::default(), selected: 0 }
    }

    /// Every entry (label, goal) before filtering.
    fn entries(&self, palette: &Palette) -> Vec<(String, Goal)> {
        match self.kind {
            FinderKind::Search => {
                let mut out = Vec::new();
                for (j, l) in palette.lights.iter().enumerate() {
                    out.push((format!("light {}", l.name), Goal::Select(Selection { col: j + 1, row: 0 })));
                }
                for (i, r) in palette.reflectances.iter().enumerate() {
                    out.push((format!("reflectance {}", r.name), Goal::Select(Selection { col: 0, row: i + 1 })));
                }
                for (i, r) in palette.reflectances.iter().enumerate() {
                    for (j, l) in palette.lights.iter().enumerate() {
                        let label = format!("cell {} × {}", l.name, r.name);
                        out.push((label, Goal::Select(Selection { col: j + 1, row: i + 1 })));
                    }
                }
                out
            }
            FinderKind::Commands => keymap::MAIN
                .iter()
                .map(|b| (format!("{}  ({})", b.help, keymap::keys_label(b)), Goal::Run(b.action)))
                .collect(),
        }
    }

    /// The entries whose label holds every word typed (case ignored), in their order.
    pub(crate) fn matches(&self, palette: &Palette) -> Vec<(String, Goal)> {
        let typed = self.input.as_str().to_lowercase();
        let words: Vec<&str> = typed.split_whitespace().collect();
        self.entries(palette)
            .into_iter()
            .filter(|(label, _)| {
                let label = label.to_lowercase();
                words.iter().all(|w| label.contains(w))
            })
            .collect()
    }
}

/// A key while the finder is open: `Ok(None)` keeps it open (or closed it, on Esc), `Ok(Some(goal))`
/// closes it with where to go; the finder comes back in `Err` when it stays open.
pub(crate) fn on_action(mut finder: Finder, action: Action, palette: &Palette) -> Result<Option<Goal>, Finder> {
    let count = finder.matches(palette).len();
    let last = count.saturating_sub(1);
    match action {
        Action::Back => return Ok(None),
        Action::Submit => {
            return match finder.matches(palette).get(finder.selected) {
                Some((_, goal)) => Ok(Some(*goal)),
                None => Err(finder),
            };
        }
        Action::Move(Direction::Up) => finder.selected = finder.selected.saturating_sub(1),
        Action::Move(Direction::Down) => finder.selected = (finder.selected + 1).min(last),
        Action::Edit(request) if finder.input.edit(request) => finder.selected = 0,
        _ => {}
    }
    Err(finder)
}

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
