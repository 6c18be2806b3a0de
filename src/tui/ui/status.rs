//! The title line (file, unsaved marker, colour mode; objective, worst ΔE00, solve time or progress) and
//! the bottom line (a message, else the main keys).

use crate::tui::app::State;
use crate::tui::colour::ColourMode;
use crate::tui::ui::{fit, num};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};

const SPINNER: [&str; 8] = ["⠋", "⠙", "⠹", "⠸", "⠼", "⠴", "⠦", "⠧"];

/// `metamer ─ palettes/x.toml ●` (and `256 colours` without truecolor).
pub fn title_left(state: &State) -> Line<'static> {
    let mut spans = vec![
        Span::styled(" metamer ", Style::new().add_modifier(Modifier::BOLD)),
        Span::raw(format!("─ {} ", state.path.display())),
    ];
    if state.is_dirty() {
        spans.push(Span::styled("● ", Style::new().fg(Color::Yellow).add_modifier(Modifier::BOLD)));
    }
    if state.colour_mode == ColourMode::Indexed256 {
        spans.push(Span::styled("· 256 colours ", Style::new().fg(Color::DarkGray)));
    }
    Line::from(spans)
}

fn time_text(seconds: f64) -> String {
    if seconds < 1.0 { format!("{:.1} ms", seconds * 1e3) } else { format!("{seconds:.2} s") }
}

/// The live objective, worst ΔE00 and solve time, or the solve's progress or failure.
pub fn title_right(state: &State) -> Line<'static> {
    let s = &state.solve;
    if s.running.is_some() {
        let spin = SPINNER[(state.ticks as usize) % SPINNER.len()];
        let t = if state.hide_times { String::new() } else { format!(" {}", time_text(s.running_for.as_secs_f64())) };
        return Line::from(Span::styled(format!(" {spin} solving…{t} "), Style::new().fg(Color::Yellow)));
    }
    if let Some(sol) = s.current() {
        let worst = state.derived.worst_delta_e.map_or("–".to_string(), |d| format!("{d:.2}"));
        let t = if state.hide_times {
            "time hidden".to_string()
        } else {
            time_text(s.last_time.map_or(sol.seconds, |d| d.as_secs_f64()))
        };
        let mut spans = vec![Span::raw(format!(" objective {} · worst ΔE00 {worst} · {t} ", num(sol.objective)))];
        if !sol.diagnostics.is_empty() {
            spans.push(Span::styled(
                format!("⚠ {} ", sol.diagnostics.len()),
                Style::new().fg(Color::Yellow).add_modifier(Modifier::BOLD),
            ));
        }
        return Line::from(spans);
    }
    if let Some(e) = &s.error {
        return Line::from(Span::styled(format!(" solver: {e} "), Style::new().fg(Color::LightRed)));
    }
    Line::from(" not solved yet ")
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

/// A message when there is one, else the key hints that fit in `width`.
pub fn bottom_line(state: &State, width: u16) -> Line<'static> {
    let width = usize::from(width);
    if let Some(m) = &state.message {
        let style = if m.is_error { Style::new().fg(Color::LightRed) } else { Style::new().fg(Color::LightGreen) };
        return Line::from(Span::styled(format!(" {} ", fit(&m.text, width.saturating_sub(2))), style));
    }
    let room = width.saturating_sub(ALWAYS.chars().count() + 2);
    let mut text = String::new();
    for h in HINTS {
        let add = h.chars().count() + 3;
        if text.chars().count() + add > room {
            break;
        }
        text.push_str(h);
        text.push_str(" · ");
    }
    Line::from(Span::styled(format!(" {text}{ALWAYS} "), Style::new().fg(Color::Gray)))
}
