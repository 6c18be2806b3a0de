//! The dial's keyframes listed (`f` with the dial keys): the keyframes added this session (`a`), each with
//! its slider's point, the vertex it sits on and the lights off there, then the scene file's own
//! keyframes. ↑/↓ choose, Enter sets the dial to the chosen keyframe (and closes the list), `d` or Delete removes a keyframe
//! added this session. A popup component: state ([`KeyframeList`]), update ([`on_action`], taking the
//! preview it lists) and rows for its view (`ui/keyframe_list.rs`).
//!
//! Keyframes are the preview's, not the palette's: they are not in the undo history, so a deletion
//! cannot be undone with `z` (the message says so). A keyframe in the scene file is removed by editing
//! the file; the list says so and `d` refuses it.

use crate::render::{DialState, Sweep};
use crate::tui::action::{Action, Direction};
use crate::tui::app::Message;
use crate::tui::model::PreviewState;

/// The open list: which entry is chosen (the session's keyframes first, then the scene's).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct KeyframeList {
    pub selected: usize,
}

/// Where a listed keyframe lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// Added this session (number `i` of the preview's keyframes): deletable.
    New(usize),
    /// The scene file's keyframe `i` (removed by editing the file).
    Scene(usize),
}

/// One row of the list: where the keyframe lives and what it is.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub origin: Origin,
    /// The slider's point, the vertex it sits on, the lights off: `(0.25, 0.50) on hide · off: split`.
    pub text: String,
}

/// A keyframe as a line: the slider's point (the vertex it sits on) and the lights off there.
pub fn describe(k: &DialState) -> String {
    let [x, y] = k.slider;
    let mut text = format!("({x:.2}, {y:.2})");
    let on_vertex = k.lights.iter().find(|l| (l.position[0] - x).hypot(l.position[1] - y) < 1e-9);
    if let Some(l) = on_vertex {
        text.push_str(&format!(" on {}", l.name));
    }
    let off: Vec<&str> = k.lights.iter().filter(|l| !l.on).map(|l| l.name.as_str()).collect();
    text.push_str(&if off.is_empty() {
        " · all lights on".to_string()
    } else {
        format!(" · off: {}", off.join(", "))
    });
    crate::fsio::escape(&text).into_owned()
}

/// Every keyframe the list shows: the session's, then the scene file's.
pub fn rows(preview: &PreviewState) -> Vec<Row> {
    let mut rows: Vec<Row> =
        preview.keyframes.iter().enumerate().map(|(i, k)| Row { origin: Origin::New(i), text: describe(k) }).collect();
    if let Some(scene) = preview.scene()
        && let Sweep::Keyframes(k) = &scene.dial.sweep
    {
        rows.extend(k.iter().enumerate().map(|(i, k)| Row { origin: Origin::Scene(i), text: describe(k) }));
    }
    rows
}

/// A key while the list is open: the list to keep open (`None`: closed), and a line for the message area.
pub(crate) fn on_action(
    mut list: KeyframeList,
    action: Action,
    preview: &mut PreviewState,
) -> (Option<KeyframeList>, Option<Message>) {
    let all = rows(preview);
    let last = all.len().saturating_sub(1);
    list.selected = list.selected.min(last);
    let chosen = all.get(list.selected).map(|r| r.origin);
    let message = match action {
        Action::Back => return (None, None),
        Action::Move(Direction::Up) => {
            list.selected = list.selected.saturating_sub(1);
            None
        }
        Action::Move(Direction::Down) => {
            list.selected = (list.selected + 1).min(last);
            None
        }
        Action::ListEnd { last: to_last } => {
            list.selected = if to_last { last } else { 0 };
            None
        }
        Action::Submit => {
            let state = match chosen {
                Some(Origin::New(i)) => preview.keyframes.get(i).cloned(),
                Some(Origin::Scene(i)) => preview.scene().and_then(|s| match &s.dial.sweep {
                    Sweep::Keyframes(k) => k.get(i).cloned(),
                    Sweep::Path(_) => None,
                }),
                None => None,
            };
            match (state, preview.dial.as_mut()) {
                (Some(k), Some(live)) => {
                    let text = format!("the dial set to keyframe {}: {}", list.selected + 1, describe(&k));
                    live.state = k;
                    preview.stale = true;
                    // Closed, so the dial and the preview show it.
                    return (None, Some(Message::info(text)));
                }
                _ => Some(Message::error("no keyframe to show")),
            }
        }
        Action::Remove => match chosen {
            None => Some(Message::error("no keyframes yet: `a` with the dial keys adds one")),
            Some(Origin::Scene(i)) => Some(Message::error(format!(
                "this is the scene file's keyframe {}: remove its [[dial.keyframes]] table from the file",
                i + 1
            ))),
            Some(Origin::New(_)) if preview.saving => {
                Some(Message::error("the keyframes are being written into the scene: delete once it is done"))
            }
            Some(Origin::New(i)) => {
                let gone = preview.keyframes.remove(i);
                list.selected = list.selected.min(rows(preview).len().saturating_sub(1));
                Some(Message::info(format!(
                    "keyframe {} deleted: {} (not undoable: keyframes are not in the undo history)",
                    i + 1,
                    describe(&gone)
                )))
            }
        },
        _ => None,
    };
    (Some(list), message)
}
