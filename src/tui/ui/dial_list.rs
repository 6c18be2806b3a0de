//! The view of the mixtures and paths list (`M`, [`crate::tui::dial_list`]): per entry its name, its
//! colours drawn as the matrix draws a cell (`▌` the target, `▀` the full colour over the factor-model
//! colour; a path's at its worst position along the dense check), then target, colours and ΔE00 as
//! `metamer solve` prints them, weight, group and status; under the list, the solve's remark on the
//! selected entry.

use super::{put, selected_style, wrap};
use crate::colorimetry::linear_to_hex;
use crate::design::Criterion;
use crate::palette::DialEntry;
use crate::tui::app::State;
use crate::tui::dial_list::{DialList, label};
use nalgebra::Vector3;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};

/// How an entry stands after the solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Status {
    NotUsed,
    Met,
    Unmet,
    /// No solution of the palette on screen yet.
    Solving,
}

impl Status {
    /// A solved entry's status: not used, else met or unmet as the solve says.
    fn of(active: bool, unmet: bool) -> Status {
        if !active {
            Status::NotUsed
        } else if unmet {
            Status::Unmet
        } else {
            Status::Met
        }
    }

    fn text(self) -> &'static str {
        match self {
            Status::NotUsed => "not used",
            Status::Met => "met",
            Status::Unmet => "UNMET",
            Status::Solving => "solving…",
        }
    }

    fn style(self) -> Style {
        match self {
            Status::NotUsed | Status::Solving => Style::new().fg(Color::Gray),
            Status::Met => Style::new().fg(Color::LightGreen),
            Status::Unmet => Style::new().fg(Color::Yellow).add_modifier(Modifier::BOLD),
        }
    }
}

/// One entry as drawn: its colours (target, full, factor model) and the line of numbers.
pub(crate) struct Row {
    pub(crate) entry: DialEntry,
    pub(crate) name: String,
    pub(crate) target: Option<Vector3<f64>>,
    pub(crate) full: Option<Vector3<f64>>,
    pub(crate) subspace: Option<Vector3<f64>>,
    pub(crate) numbers: String,
    pub(crate) status: Status,
    pub(crate) active: bool,
}

fn de(v: f64) -> String {
    if v == f64::MAX { "-".into() } else { format!("{v:.2}") }
}

/// The rows of the palette's mixtures and paths with the solve's numbers.
pub(crate) fn rows(state: &State) -> Vec<Row> {
    let p = &state.doc.palette;
    let r = &state.solve.dial;
    let group = |g: Option<usize>| g.and_then(|g| p.free.get(g)).map(|g| format!("  free {}", g.name));
    p.dial_entries()
        .into_iter()
        .map(|entry| {
            let name = label(p, entry);
            match entry {
                DialEntry::Mixture(k) => {
                    let m = &p.mixtures[k];
                    let g = group(m.free).unwrap_or_default();
                    match r.mixtures.get(k) {
                        Some(c) => {
                            let vm = match (c.rgb_subspace, c.delta_e_subspace) {
                                (Some(s), Some(d)) => format!("  Vm {} ΔE {}", linear_to_hex(&s), de(d)),
                                _ => String::new(),
                            };
                            let status = Status::of(m.is_active(), r.unmet_mixtures.get(k).copied().unwrap_or(false));
                            Row {
                                entry,
                                name,
                                target: Some(c.target),
                                full: Some(c.rgb_full),
                                subspace: c.rgb_subspace,
                                numbers: format!(
                                    "target {}  full {} ΔE {}{vm}  w {}{g}",
                                    linear_to_hex(&c.target),
                                    linear_to_hex(&c.rgb_full),
                                    de(c.delta_e_full),
                                    super::num(m.weight)
                                ),
                                status,
                                active: m.is_active(),
                            }
                        }
                        None => unsolved(entry, name, m.free.is_none().then_some(m.target), m.weight, g, m.is_active()),
                    }
                }
                DialEntry::Path(k) => {
                    let q = &p.paths[k];
                    let g = group(q.free).unwrap_or_default();
                    match r.paths.get(k) {
                        Some(c) => {
                            let vm = c.worst_delta_e_subspace.map(|d| format!("  Vm {}", de(d))).unwrap_or_default();
                            let status = Status::of(q.is_active(), c.is_unmet());
                            Row {
                                entry,
                                name,
                                target: Some(c.target),
                                full: Some(c.worst_rgb),
                                subspace: None,
                                numbers: format!(
                                    "target {}  worst ΔE {} at t {:.3} of {}{vm}  w {}{g}",
                                    linear_to_hex(&c.target),
                                    de(c.worst_delta_e),
                                    c.worst_t,
                                    c.checked,
                                    super::num(q.weight)
                                ),
                                status,
                                active: q.is_active(),
                            }
                        }
                        None => unsolved(entry, name, q.free.is_none().then_some(q.target), q.weight, g, q.is_active()),
                    }
                }
            }
        })
        .collect()
}

fn unsolved(
    entry: DialEntry,
    name: String,
    target: Option<Vector3<f64>>,
    weight: f64,
    group: String,
    active: bool,
) -> Row {
    let t = target.map_or_else(|| "free".to_string(), |t| linear_to_hex(&t));
    Row {
        entry,
        name,
        target,
        full: None,
        subspace: None,
        numbers: format!("target {t}  w {}{group}", super::num(weight)),
        status: Status::Solving,
        active,
    }
}

/// Draw the list into `inner` (inside its frame).
pub(crate) fn draw(state: &State, list: &DialList, inner: Rect, buf: &mut Buffer) {
    let rows = rows(state);
    let grey = Style::new().fg(Color::Gray);
    if rows.is_empty() {
        let text = "no [[mixtures]] or [[paths]]: in the light dial (g, with --scene), m adds a target for the \
                    selected reflectance at the slider";
        for (y, line) in wrap(text, usize::from(inner.width.saturating_sub(2))).iter().enumerate() {
            put(buf, inner, 1, y as u16, line, grey);
        }
        return;
    }
    let selected = list.selected.min(rows.len() - 1);
    // The keys on the last line, the selected entry's remark above it, the list in the rest.
    let keys = "# target · F fit · w weight · u use · f group · n samples · t tol · x del";
    let keys_y = inner.height.saturating_sub(1);
    put(buf, inner, 1, keys_y, keys, grey);
    let remark = remark(state, rows[selected].entry);
    let remark_lines = remark.map(|r| wrap(&r, usize::from(inner.width.saturating_sub(2)))).unwrap_or_default();
    let remark_rows = (remark_lines.len() as u16).min(3);
    let list_rows = inner.height.saturating_sub(1 + remark_rows + u16::from(remark_rows > 0));
    for (k, line) in remark_lines.iter().take(usize::from(remark_rows)).enumerate() {
        put(buf, inner, 1, list_rows + 1 + k as u16, line, Style::new().fg(Color::Yellow));
    }
    let visible = usize::from(list_rows / 2).max(1);
    let first = (selected + 1).saturating_sub(visible);
    let mode = state.ui.colour_mode;
    let pending = state.solve.derived.subspace_pending && state.solve.basis_error.is_none();
    for (i, row) in rows.iter().enumerate().skip(first).take(visible) {
        let y = ((i - first) * 2) as u16;
        if i == selected {
            put(buf, inner, 0, y, "›", selected_style());
        }
        let dim = |s: Style| if row.active { s } else { s.add_modifier(Modifier::DIM) };
        let desired = row.target.map_or(Style::new().fg(Color::DarkGray), |t| Style::new().fg(mode.linear(&t)));
        put(buf, inner, 2, y, "▌", dim(desired));
        let model = match row.full {
            Some(f) => {
                let full = mode.linear(&f);
                let sub = match (row.subspace, row.entry) {
                    (Some(s), _) => mode.linear(&s),
                    (None, DialEntry::Mixture(_)) if pending => Color::DarkGray,
                    _ => full,
                };
                Style::new().fg(full).bg(sub)
            }
            None => Style::new().fg(Color::DarkGray),
        };
        put(buf, inner, 3, y, "▀▀▀", dim(model));
        let status = row.status.text();
        let room = usize::from(inner.width).saturating_sub(8 + status.chars().count() + 1);
        let name_style = if i == selected { Style::new().add_modifier(Modifier::BOLD) } else { Style::new() };
        put(buf, inner, 7, y, &super::fit(&row.name, room), name_style);
        let x = inner.width.saturating_sub(status.chars().count() as u16 + 1);
        put(buf, inner, x, y, status, row.status.style());
        put(buf, inner, 7, y + 1, &row.numbers, grey);
    }
}

/// The solve's sentence on `entry` (why it is unmet), when there is one.
fn remark(state: &State, entry: DialEntry) -> Option<String> {
    let want = match entry {
        DialEntry::Mixture(k) => Criterion::Mixture(k),
        DialEntry::Path(k) => Criterion::Path(k),
    };
    state.solve.dial.remarks.iter().find(|(c, _)| *c == want).map(|(_, m)| m.clone())
}
