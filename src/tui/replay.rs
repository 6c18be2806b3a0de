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
//! ```

use crate::palette::Palette;
use crate::palette::file::PaletteFile;
use crate::tui::app::State;
use crate::tui::edits::FileError;
use crate::tui::event_loop::{self, Events, Io, Saver};
use crate::tui::msg::{Msg, Saved};
use crate::tui::ui;
use crate::tui::worker::WorkerConfig;
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
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

fn parse_text(body: &str, line: usize) -> Result<Vec<Step>, ScriptError> {
    let mut steps = Vec::new();
    let mut chars = body.chars();
    while let Some(c) = chars.next() {
        let c = if c == '\\' {
            chars.next().ok_or(ScriptError { line, reason: "a text ends with a lone backslash".into() })?
        } else {
            c
        };
        steps.push(Step::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE)));
    }
    Ok(steps)
}

/// Parse a whole script.
pub fn parse_script(text: &str) -> Result<Vec<Step>, ScriptError> {
    let mut steps = Vec::new();
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
        let one: Vec<Step> = if body.len() >= 2 && body.starts_with('"') && body.ends_with('"') {
            parse_text(&body[1..body.len() - 1], line)?
        } else if body.eq_ignore_ascii_case("wait-solve") {
            vec![Step::WaitSolve]
        } else {
            vec![Step::Key(
                parse_key(body)
                    .ok_or(ScriptError { line, reason: format!("'{body}' is not a key, a \"text\" or wait-solve") })?,
            )]
        };
        for _ in 0..repeat {
            steps.extend(one.iter().cloned());
        }
    }
    Ok(steps)
}

/// A script as an input source: every step in order, then the end; solves are synchronous.
pub(crate) struct ScriptEvents {
    steps: std::vec::IntoIter<Step>,
}

impl ScriptEvents {
    pub fn new(steps: Vec<Step>) -> ScriptEvents {
        ScriptEvents { steps: steps.into_iter() }
    }
}

impl Events for ScriptEvents {
    fn next_step(&mut self) -> Msg {
        match self.steps.next() {
            Some(Step::Key(k)) => Msg::Key(k),
            Some(Step::WaitSolve) => Msg::WaitSolve,
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
    steps: Vec<Step>,
    width: u16,
    height: u16,
    every_frame: bool,
    saver: &mut dyn Saver,
    worker: WorkerConfig,
) -> io::Result<(Vec<String>, ratatui::buffer::Buffer)> {
    state.ui.hide_times = true;
    let mut terminal = Terminal::new(TestBackend::new(width, height)).map_err(io::Error::other)?;
    let mut events = ScriptEvents::new(steps);
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
        assert_eq!(
            s,
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
}
