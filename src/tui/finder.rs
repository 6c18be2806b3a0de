//! `/` search and `:` command palette: a line to type in over a list filtered as you type (every word
//! typed must appear in an entry, case ignored), ↑/↓ to choose, Enter to jump to the light, reflectance
//! or cell (search) or to run the action (commands: every action of the main keymap, by what the help
//! calls it). A popup component: state ([`Finder`]) and update ([`on_action`], taking what it needs); its
//! view is `ui/finder.rs`. It imports nothing of the keymap or the view: the caller hands it the commands.

use crate::palette::Palette;
use crate::tui::action::{Action, Direction};
use crate::tui::basics::{PromptText, Selection};

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
    /// The commands a `:` palette offers (label, action), from the keymap; empty for a search.
    commands: Vec<(String, Action)>,
}

/// Where an entry leads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Goal {
    Select(Selection),
    Run(Action),
}

impl Finder {
    /// A search over the palette.
    pub(crate) fn search() -> Finder {
        Finder { kind: FinderKind::Search, input: PromptText::default(), selected: 0, commands: Vec::new() }
    }

    /// A command palette over `commands` (label, action).
    pub(crate) fn commands(commands: Vec<(String, Action)>) -> Finder {
        Finder { kind: FinderKind::Commands, input: PromptText::default(), selected: 0, commands }
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
            FinderKind::Commands => self.commands.iter().map(|(label, a)| (label.clone(), Goal::Run(*a))).collect(),
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
