//! Headless replay: a key script run against ratatui's off-screen `TestBackend`, writing the final
//! screen (or every frame) as text. Solves are waited for between keys, so screens are reproducible.
//!
//! Script format, one step per line:
//!
//! ```text
//! # a comment (a line that is exactly `#` is the `#` key)
//! Down                 a named key: Up Down Left Right Enter Esc Tab BackTab Backspace Delete
//!                      Home End PageUp PageDown Space Hash F1…F12
//! Right *3             any step repeated 3 times
//! Ctrl-s               modifiers: Ctrl- Alt- Shift-
//! q                    a single character is that key
//! "#ff8800"            text in double quotes types each character (\" and \\ escape)
//! wait-solve           wait for the running solve (done after every key anyway)
//! click 12 5           the left mouse button pressed at column 12, row 5 (0-based)
//! drag 20 5            moved to column 20, row 5 with the button held
//! release 20 5         released there
//! ```

use crate::palette::Palette;
use crate::palette::PaletteFile;
use crate::tui::app::State;
use crate::tui::edits::FileError;
use crate::tui::event_loop::{self, Events, Io, Saver};
use crate::tui::msg::{Msg, Saved};
use crate::tui::ui;
use crate::tui::worker::WorkerConfig;
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers, MouseButton, MouseEvent, MouseEventKind};
use std::io;

/// Why a script line cannot be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("line {line}: {reason}")]
pub struct ScriptError {
    pub line: usize,
    pub(crate) reason: String,
}

/// One step of a script.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Step {
    Key(KeyEvent),
    WaitSolve,
    Mouse(MouseEvent),
}

/// A mouse step such as `click 12 5`, `drag 20 5` or `release 20 5` (left button, column and row from 0).
fn parse_mouse(body: &str) -> Option<Result<MouseEvent, String>> {
    let mut words = body.split_whitespace();
    let kind = match words.next()?.to_ascii_lowercase().as_str() {
        "click" => MouseEventKind::Down(MouseButton::Left),
        "drag" => MouseEventKind::Drag(MouseButton::Left),
        "release" => MouseEventKind::Up(MouseButton::Left),
        _ => return None,
    };
    let mut number = || words.next().and_then(|w| w.parse::<u16>().ok());
    let (Some(column), Some(row)) = (number(), number()) else {
        return Some(Err(format!("'{body}': a mouse step is `click|drag|release COLUMN ROW`")));
    };
    if words.next().is_some() {
        return Some(Err(format!("'{body}': a mouse step is `click|drag|release COLUMN ROW`")));
    }
    Some(Ok(MouseEvent { kind, column, row, modifiers: KeyModifiers::NONE }))
}

fn named_key(name: &str) -> Option<KeyCode> {
    let lower = name.to_ascii_lowercase();
    Some(match lower.as_str() {
        "up" => KeyCode::Up,
        "down" => KeyCode::Down,
        "left" => KeyCode::Left,
        "right" => KeyCode::Right,
        "enter" | "return" => KeyCode::Enter,
        "esc" | "escape" => KeyCode::Esc,
        "tab" => KeyCode::Tab,
        "backtab" => KeyCode::BackTab,
        "backspace" => KeyCode::Backspace,
        "delete" | "del" => KeyCode::Delete,
        "home" => KeyCode::Home,
        "end" => KeyCode::End,
        "pageup" | "pgup" => KeyCode::PageUp,
        "pagedown" | "pgdn" => KeyCode::PageDown,
        "space" => KeyCode::Char(' '),
        "hash" => KeyCode::Char('#'),
        _ => {
            if let Some(n) = lower.strip_prefix('f').and_then(|n| n.parse::<u8>().ok()).filter(|n| (1..=12).contains(n))
            {
                return Some(KeyCode::F(n));
            }
            let mut chars = name.chars();
            match (chars.next(), chars.next()) {
                (Some(c), None) => KeyCode::Char(c),
                _ => return None,
            }
        }
    })
}

/// Parse one key such as `Down`, `Ctrl-s`, `Shift-Tab`, `q`.
pub fn parse_key(text: &str) -> Option<KeyEvent> {
    let mut modifiers = KeyModifiers::NONE;
    let mut rest = text;
    loop {
        let lower = rest.to_ascii_lowercase();
        let (m, len) = if lower.starts_with("ctrl-") {
            (KeyModifiers::CONTROL, 5)
        } else if lower.starts_with("alt-") {
            (KeyModifiers::ALT, 4)
        } else if lower.starts_with("shift-") {
            (KeyModifiers::SHIFT, 6)
        } else {
            break;
        };
        if rest.len() == len {
            break; // "ctrl-" alone: not a modifier
        }
        modifiers |= m;
        rest = &rest[len..];
    }
    let mut code = named_key(rest)?;
    if modifiers.contains(KeyModifiers::SHIFT) {
        match code {
            KeyCode::Tab => {
                code = KeyCode::BackTab;
            }
            KeyCode::Char(c) => code = KeyCode::Char(c.to_ascii_uppercase()),
            _ => {}
        }
    }
    Some(KeyEvent::new(code, modifiers))
}

/// The characters a quoted text types, unescaped (kept as characters, not expanded into key steps).
fn parse_text(body: &str, line: usize) -> Result<Vec<char>, ScriptError> {
    let mut typed = Vec::new();
    let mut chars = body.chars();
    while let Some(c) = chars.next() {
        let c = if c == '\\' {
            chars.next().ok_or(ScriptError { line, reason: "a text ends with a lone backslash".into() })?
        } else {
            c
        };
        typed.push(c);
    }
    Ok(typed)
}

/// One script line's steps, before its repeat.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Line {
    Step(Step),
    /// A quoted text: one key per character.
    Text(Vec<char>),
}

impl Line {
    fn len(&self) -> usize {
        match self {
            Line::Step(_) => 1,
            Line::Text(t) => t.len(),
        }
    }

    fn steps(&self) -> impl Iterator<Item = Step> + '_ {
        let (one, text) = match self {
            Line::Step(s) => (Some(s.clone()), &[][..]),
            Line::Text(t) => (None, &t[..]),
        };
        one.into_iter().chain(text.iter().map(|c| Step::Key(KeyEvent::new(KeyCode::Char(*c), KeyModifiers::NONE))))
    }
}

/// The most steps a script may expand to (keys after repeats and typed texts): each step draws a frame
/// and may wait for a solve, so a million is minutes of work; more is refused before anything runs.
pub const MAX_STEPS: u64 = 1_000_000;

/// A parsed script: each line's steps once, with its repeat count. The steps are streamed from here
/// ([`Script::steps`]), never expanded in memory, and their total is bounded by [`MAX_STEPS`] at parse time.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Script {
    lines: Vec<(Line, usize)>,
    total: u64,
}

impl Script {
    /// How many steps the script runs.
    pub fn len(&self) -> u64 {
        self.total
    }

    /// True when the script has no step.
    pub fn is_empty(&self) -> bool {
        self.total == 0
    }

    /// Every step in order, repeats included, streamed.
    pub fn steps(&self) -> impl Iterator<Item = Step> + '_ {
        self.lines.iter().flat_map(|(line, repeat)| std::iter::repeat_n(line, *repeat).flat_map(Line::steps))
    }
}

/// Parse a whole script. Refused, naming the line, when a line cannot be read or when the steps would
/// exceed [`MAX_STEPS`] (the count is checked as the lines are read, before any step runs).
pub fn parse_script(text: &str) -> Result<Script, ScriptError> {
    let mut script = Script::default();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let trimmed = raw.trim();
        if trimmed.is_empty() || (trimmed.starts_with('#') && trimmed != "#") {
            continue;
        }
        // Optional repeat suffix ` *N` (a lone `*` is the key).
        let (body, repeat) = match trimmed.rsplit_once('*') {
            Some((b, n)) if !b.trim().is_empty() && !n.is_empty() && n.chars().all(|c| c.is_ascii_digit()) => {
                let n: usize =
                    n.parse().map_err(|_| ScriptError { line, reason: format!("'{n}' is not a repeat count") })?;
                if n > 10_000 {
                    return Err(ScriptError { line, reason: format!("repeat count {n} is above 10000") });
                }
                (b.trim(), n)
            }
            _ => (trimmed, 1),
        };
        let one = if body.len() >= 2 && body.starts_with('"') && body.ends_with('"') {
            Line::Text(parse_text(&body[1..body.len() - 1], line)?)
        } else if body.eq_ignore_ascii_case("wait-solve") {
            Line::Step(Step::WaitSolve)
        } else if let Some(mouse) = parse_mouse(body) {
            Line::Step(Step::Mouse(mouse.map_err(|reason| ScriptError { line, reason })?))
        } else {
            Line::Step(Step::Key(
                parse_key(body)
                    .ok_or(ScriptError { line, reason: format!("'{body}' is not a key, a \"text\" or wait-solve") })?,
            ))
        };
        let here = (one.len() as u64).saturating_mul(repeat as u64);
        script.total = script.total.saturating_add(here);
        if script.total > MAX_STEPS {
            return Err(ScriptError {
                line,
                reason: format!(
                    "the script reaches {} steps here ({} step{} × {repeat}), above the limit of {MAX_STEPS}",
                    script.total,
                    one.len(),
                    if one.len() == 1 { "" } else { "s" }
                ),
            });
        }
        script.lines.push((one, repeat));
    }
    Ok(script)
}

/// A script as an input source: every step in order, then the end; solves are synchronous.
pub(crate) struct ScriptEvents<'a> {
    steps: Box<dyn Iterator<Item = Step> + 'a>,
}

impl<'a> ScriptEvents<'a> {
    pub fn new(script: &'a Script) -> ScriptEvents<'a> {
        ScriptEvents { steps: Box::new(script.steps()) }
    }
}

impl Events for ScriptEvents<'_> {
    fn next_step(&mut self) -> Msg {
        match self.steps.next() {
            Some(Step::Key(k)) => Msg::Key(k),
            Some(Step::WaitSolve) => Msg::WaitSolve,
            Some(Step::Mouse(m)) => Msg::Mouse(m),
            None => Msg::End,
        }
    }

    fn synchronous(&self) -> bool {
        true
    }
}

/// A saver that keeps the palettes it was given (tests, and replays that must not touch the file).
#[derive(Debug, Default)]
pub struct MemorySaver {
    pub saved: Vec<Palette>,
}

impl Saver for MemorySaver {
    fn save(&mut self, file: &PaletteFile, palette: &Palette, _overwrite: bool) -> Result<Saved, FileError> {
        self.saved.push(palette.clone());
        let mut file = file.clone();
        file.palette = palette.clone();
        Ok(Saved { text: "saved (in memory)".into(), file })
    }
}

/// Run `steps` on `state` in a `width`×`height` off-screen terminal. Returns the frames drawn (all of
/// them when `every_frame`, else only the last) as text, and the final buffer.
pub fn run(
    state: &mut State,
    steps: Script,
    width: u16,
    height: u16,
    every_frame: bool,
    saver: &mut dyn Saver,
    worker: WorkerConfig,
) -> io::Result<(Vec<String>, ratatui::buffer::Buffer)> {
    state.ui.hide_times = true;
    let mut terminal = Terminal::new(TestBackend::new(width, height)).map_err(io::Error::other)?;
    let mut events = ScriptEvents::new(&steps);
    let mut frames = Vec::new();
    let mut last = String::new();
    let mut on_frame = |buf: &ratatui::buffer::Buffer| {
        let text = ui::buffer_text(buf);
        if every_frame {
            frames.push(text);
        } else {
            last = text;
        }
    };
    event_loop::run_main_loop(
        &mut terminal,
        state,
        Io { events: &mut events, saver, on_frame: Some(&mut on_frame), on_msg: None, worker, tick: None },
    )?;
    if !every_frame {
        frames.push(last);
    }
    Ok((frames, terminal.backend().buffer().clone()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_texts_repeats_and_comments() {
        let s =
            parse_script("# comment\nDown\nRight *2\nCtrl-s\n#\n\"#a\\\"\"\nwait-solve\nShift-Tab\nF1\n*\n").unwrap();
        let k = |c, m| Step::Key(KeyEvent::new(c, m));
        let n = KeyModifiers::NONE;
        assert_eq!(s.len(), 12);
        assert_eq!(
            s.steps().collect::<Vec<_>>(),
            vec![
                k(KeyCode::Down, n),
                k(KeyCode::Right, n),
                k(KeyCode::Right, n),
                k(KeyCode::Char('s'), KeyModifiers::CONTROL),
                k(KeyCode::Char('#'), n),
                k(KeyCode::Char('#'), n),
                k(KeyCode::Char('a'), n),
                k(KeyCode::Char('"'), n),
                Step::WaitSolve,
                k(KeyCode::BackTab, KeyModifiers::SHIFT),
                k(KeyCode::F(1), n),
                k(KeyCode::Char('*'), n),
            ]
        );
    }

    #[test]
    fn bad_lines_name_their_number() {
        let e = parse_script("Down\nbogus-key\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(parse_script("Down *99999").is_err());
    }

    #[test]
    fn total_work_is_bounded_before_anything_runs() {
        // A 4 Mi-character text repeated 10000 times: 4·10¹⁰ steps, refused while parsing, naming the line.
        let big = format!("Down\n\"{}\" *10000\n", "a".repeat(4 << 20));
        let e = parse_script(&big).unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.reason.contains("41943040001 steps") && e.reason.contains("limit of 1000000"), "{e}");
        // Exactly at the limit is fine and is streamed, not expanded.
        let at = parse_script("\"ab\" *10000\nx *10000\n".repeat(33).as_str()).unwrap();
        assert_eq!(at.len(), 33 * 30_000);
        assert_eq!(at.steps().count() as u64, at.len());
        let over = "\"ab\" *10000\nx *10000\n".repeat(34);
        assert!(parse_script(&over).is_err());
        // Many small lines add up to the same limit.
        assert!(parse_script(&"x *10000\n".repeat(200)).is_err());
    }
}
