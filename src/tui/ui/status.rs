//! The title line (file, unsaved marker, colour mode; objective, worst ΔE00, solve time or progress) and
//! the bottom line (a message, else the main keys).

use crate::tui::app::State;
use crate::tui::colour::ColourMode;
use crate::tui::ui::{fit, sig4};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};

const SPINNER: [&str; 8] = ["⠋", "⠙", "⠹", "⠸", "⠼", "⠴", "⠦", "⠧"];

/// `metamer ─ palettes/x.toml ●` (and `256 colours` without truecolor); `compact` drops the program name,
/// `path_room` abbreviates the path to that many characters.
pub(crate) fn title_left(state: &State, compact: bool, path_room: Option<usize>) -> Line<'static> {
    let mut spans = Vec::new();
    if !compact {
        spans.push(Span::styled(" metamer ", Style::new().add_modifier(Modifier::BOLD)));
        spans.push(Span::raw("─ "));
    } else {
        spans.push(Span::raw(" "));
    }
    let path = state.path().display().to_string();
    let path = match path_room {
        Some(room) => crate::tui::ui::abbreviate_path(&path, room),
        None => path,
    };
    spans.push(Span::raw(format!("{path} ")));
    if state.is_dirty() {
        spans.push(Span::styled("● ", Style::new().fg(Color::Yellow).add_modifier(Modifier::BOLD)));
    }
    if state.ui.colour_mode == ColourMode::Indexed256 {
        let text = if compact { "256c " } else { "· 256 colours " };
        spans.push(Span::styled(text, Style::new().fg(Color::Gray)));
    }
    Line::from(spans)
}

fn time_text(seconds: f64) -> String {
    if seconds < 1.0 { format!("{:.1} ms", seconds * 1e3) } else { format!("{seconds:.2} s") }
}

/// The live objective, worst ΔE00 and solve time, or the solve's progress or failure; `compact` abbreviates.
pub(crate) fn title_right(state: &State, compact: bool) -> Line<'static> {
    let s = &state.solve;
    let spin = SPINNER[(state.ui.ticks as usize) % SPINNER.len()];
    let elapsed =
        if state.ui.hide_times { String::new() } else { format!(" {}", time_text(s.running_for.as_secs_f64())) };
    if s.running.is_some() {
        let what = if s.training && crate::basis::palette_uses_basis(&state.doc.palette) {
            "training basis, solving…"
        } else {
            "solving…"
        };
        return Line::from(Span::styled(format!(" {spin} {what}{elapsed} "), Style::new().fg(Color::Yellow)));
    }
    let mut spans = Vec::new();
    if let Some(sol) = s.current() {
        let worst = state.solve.derived.worst_delta_e.map_or("–".to_string(), |d| format!("{d:.2}"));
        let t = if state.ui.hide_times {
            "time hidden".to_string()
        } else {
            time_text(s.last_time.map_or(sol.seconds, |d| d.as_secs_f64()))
        };
        let text = if compact {
            format!(" obj {} · ΔE00 {worst} · {t} ", sig4(sol.objective))
        } else {
            format!(" objective {} · worst ΔE00 {worst} · {t} ", sig4(sol.objective))
        };
        spans.push(Span::raw(text));
        if !sol.diagnostics.is_empty() {
            spans.push(Span::styled(
                format!("⚠{} ", sol.diagnostics.len()),
                Style::new().fg(Color::Yellow).add_modifier(Modifier::BOLD),
            ));
        }
    } else if let Some(e) = &s.error {
        let text = fit(&format!("solver: {e}"), if compact { 40 } else { 70 });
        spans.push(Span::styled(format!(" {text} "), Style::new().fg(Color::LightRed)));
    } else {
        spans.push(Span::raw(" not solved yet "));
    }
    if s.training {
        spans.push(Span::styled(format!("{spin} basis "), Style::new().fg(Color::Yellow)));
    } else if s.basis_poor().is_some() {
        let m = state.doc.palette.settings.basis_dimension;
        spans.push(Span::styled(format!("⚠ V{m} poor "), Style::new().fg(Color::Yellow)));
    }
    Line::from(spans)
}

/// Draw the title row (over the top border of `area`): left and right parts, abbreviated to fit. The
/// path is abbreviated before anything else is cut, so the unsaved marker `●` always shows.
pub(crate) fn draw_title(state: &State, area: ratatui::layout::Rect, buf: &mut ratatui::buffer::Buffer) {
    let room = usize::from(area.width.saturating_sub(4));
    let fits = |l: &Line, r: &Line| l.width() + r.width() < room;
    let mut choice = None;
    for (lc, rc) in [(false, false), (false, true), (true, true)] {
        let (l, r) = (title_left(state, lc, None), title_right(state, rc));
        if fits(&l, &r) {
            choice = Some((l, r));
            break;
        }
    }
    let (left, right) = choice.unwrap_or_else(|| {
        let right = title_right(state, true);
        let path = state.path().display().to_string().chars().count();
        let others = title_left(state, true, None).width().saturating_sub(path);
        let path_room = room.saturating_sub(right.width() + others + 1).max(6);
        (title_left(state, true, Some(path_room)), right)
    });
    let right_width = right.width().min(room) as u16;
    let right_x = area.x + area.width.saturating_sub(2 + right_width);
    buf.set_line(right_x, area.y, &right, right_width);
    let left_room = right_x.saturating_sub(area.x + 2).saturating_sub(1);
    buf.set_line(area.x + 1, area.y, &left, left_room);
}

/// The main keys; the last three always show, the others as far as the width allows.
const HINTS: &[&str] = &[
    "←↑↓→ move",
    "enter edit",
    "tab panel",
    "d design",
    "u use",
    "f free",
    "F fit",
    "A fit all",
    "p Planck",
    "z undo",
];
const ALWAYS: &str = "^s save · ? help · q quit";

/// The light dial's keys (after `g`), in the same way.
const DIAL_HINTS: &[&str] = &[
    "←↑↓→ slider/vertex",
    "1…9 light on/off",
    "tab select",
    "+/- brighter/dimmer",
    "a keyframe",
    "f keyframes",
    "^s save scene",
];
const DIAL_ALWAYS: &str = "Esc leave · ? help · q quit";

/// A message's colour: red for errors, green otherwise.
pub(crate) fn message_style(m: &crate::tui::app::Message) -> Style {
    if m.is_error { Style::new().fg(Color::LightRed) } else { Style::new().fg(Color::LightGreen) }
}

/// The rows a message longer than the bottom line takes above it (the message area), wrapped between
/// words; none when it fits on the bottom line.
pub(crate) fn message_rows(state: &State, width: u16) -> Vec<String> {
    let width = usize::from(width);
    match &state.ui.message {
        Some(m) if m.text.chars().count() + 2 > width => crate::tui::ui::wrap(&m.text, width),
        _ => Vec::new(),
    }
}

/// A message when it fits on the line (a longer one is in the message area above), else the key hints
/// that fit in `width`.
pub(crate) fn bottom_line(state: &State, width: u16) -> Line<'static> {
    let width = usize::from(width);
    if let Some(m) = state.ui.message.as_ref().filter(|m| m.text.chars().count() + 2 <= width) {
        return Line::from(Span::styled(format!(" {} ", m.text), message_style(m)));
    }
    // The keys in force: the light dial's after `g`, else the main screen's.
    let (hints, always) = if state.preview.keys { (DIAL_HINTS, DIAL_ALWAYS) } else { (HINTS, ALWAYS) };
    let room = width.saturating_sub(always.chars().count() + 2);
    let mut text = String::new();
    for h in hints {
        let add = h.chars().count() + 3;
        if text.chars().count() + add > room {
            break;
        }
        text.push_str(h);
        text.push_str(" · ");
    }
    Line::from(Span::styled(format!(" {text}{always} "), Style::new().fg(Color::Gray)))
}
