//! The terminal graphics probe (`--preview auto`, and the font size for a forced protocol), read by the
//! input thread itself so that no key is lost.
//!
//! The question (ratatui-image's: kitty graphics, device attributes for sixel, the cell size in pixels, and
//! a device status report that every terminal answers) is written once the first screen is drawn; the
//! answers arrive on standard input mixed with whatever the user types. The input thread reads the raw
//! bytes until the status answer (or a deadline), and [`ProbeReader`] splits them: the answers go to
//! ratatui-image's parser, every other byte is a key, decoded here in the order typed and queued before
//! the keys crossterm reads afterwards. (Crossterm's own byte parser is private, and a reader that
//! keeps reading after its deadline — ratatui-image's probe thread — takes the next key typed; hence
//! this small decoder of the key sequences a terminal sends.)

use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui_image::picker::cap_parser::{Parser, Response};

const ESC: u8 = 0x1b;

/// Splits the bytes read during the probe into the terminal's answers and the keys typed.
#[derive(Default)]
pub(crate) struct ProbeReader {
    /// Bytes not yet split (an escape sequence may be incomplete).
    pending: Vec<u8>,
    /// The answers, interpreted.
    pub(crate) responses: Vec<Response>,
    /// The keys typed, in order.
    pub(crate) keys: Vec<KeyEvent>,
    /// The status answer arrived: the terminal has answered everything it will.
    pub(crate) done: bool,
}

/// What one complete piece of input is.
enum Piece {
    /// An answer to the probe (the bytes, escape included).
    Answer(usize),
    /// A key, `len` bytes long (`None`: bytes that are no key, dropped).
    Key(Option<KeyEvent>, usize),
    /// The piece is not complete yet.
    Incomplete,
}

impl ProbeReader {
    /// Take bytes read from the terminal.
    pub(crate) fn push(&mut self, bytes: &[u8]) {
        self.pending.extend_from_slice(bytes);
        self.split(false);
    }

    /// The deadline passed (or the input ended): whatever is left is keys (a lone Esc is the Esc key).
    pub(crate) fn finish(&mut self) {
        self.split(true);
    }

    fn split(&mut self, at_end: bool) {
        let mut at = 0;
        while at < self.pending.len() {
            match piece(&self.pending[at..], at_end) {
                Piece::Answer(len) => {
                    let text = String::from_utf8_lossy(&self.pending[at..at + len]).into_owned();
                    let mut parser = Parser::new();
                    for c in text.chars() {
                        for r in parser.push(c) {
                            if r == Response::Status {
                                self.done = true;
                            } else {
                                self.responses.push(r);
                            }
                        }
                    }
                    at += len;
                }
                Piece::Key(key, len) => {
                    self.keys.extend(key);
                    at += len;
                }
                Piece::Incomplete => break,
            }
        }
        self.pending.drain(..at);
    }
}

/// The first piece of `bytes` (not empty).
fn piece(bytes: &[u8], at_end: bool) -> Piece {
    let incomplete = |len: usize| if at_end { Piece::Key(None, len) } else { Piece::Incomplete };
    if bytes[0] != ESC {
        return match char_key(bytes) {
            Some((key, len)) => Piece::Key(Some(key), len),
            None if at_end || bytes.len() >= 4 => Piece::Key(None, 1),
            None => Piece::Incomplete,
        };
    }
    let Some(&next) = bytes.get(1) else {
        return if at_end {
            Piece::Key(Some(KeyEvent::new(KeyCode::Esc, KeyModifiers::NONE)), 1)
        } else {
            Piece::Incomplete
        };
    };
    match next {
        // APC (kitty's answer) and OSC: up to the string terminator (or BEL for OSC).
        b'_' | b']' => {
            let end = (2..bytes.len()).find_map(|i| match bytes[i] {
                0x07 if next == b']' => Some(i + 1),
                b'\\' if bytes[i - 1] == ESC => Some(i + 1),
                _ => None,
            });
            match end {
                Some(len) => Piece::Answer(len),
                None => incomplete(bytes.len()),
            }
        }
        b'[' => {
            // Parameters 0x30–0x3f, intermediates 0x20–0x2f, one final byte 0x40–0x7e.
            let Some(end) = (2..bytes.len()).find(|&i| (0x40..=0x7e).contains(&bytes[i])) else {
                return incomplete(bytes.len());
            };
            let params = &bytes[2..end];
            if params.iter().any(|b| !(0x20..=0x3f).contains(b)) {
                // Not a CSI sequence after all: Alt-[ and what follows.
                return Piece::Key(Some(KeyEvent::new(KeyCode::Char('['), KeyModifiers::ALT)), 2);
            }
            let fin = bytes[end];
            let answer =
                (fin == b'c' && params.first() == Some(&b'?')) || fin == b't' || (fin == b'n' && params == b"0");
            if answer { Piece::Answer(end + 1) } else { Piece::Key(csi_key(params, fin), end + 1) }
        }
        b'O' => match bytes.get(2) {
            Some(&fin) => Piece::Key(ss3_key(fin), 3),
            None => incomplete(2),
        },
        ESC => Piece::Key(Some(KeyEvent::new(KeyCode::Esc, KeyModifiers::NONE)), 1),
        _ => match char_key(&bytes[1..]) {
            Some((mut key, len)) => {
                key.modifiers |= KeyModifiers::ALT;
                Piece::Key(Some(key), len + 1)
            }
            None => incomplete(bytes.len()),
        },
    }
}

/// One character (UTF-8) or control byte, as crossterm reports it.
fn char_key(bytes: &[u8]) -> Option<(KeyEvent, usize)> {
    let none = KeyModifiers::NONE;
    let key = |code, m| Some((KeyEvent::new(code, m), 1));
    match bytes[0] {
        b'\r' | b'\n' => key(KeyCode::Enter, none),
        b'\t' => key(KeyCode::Tab, none),
        0x7f => key(KeyCode::Backspace, none),
        0 => key(KeyCode::Char(' '), KeyModifiers::CONTROL),
        c @ 0x01..=0x1a => key(KeyCode::Char(char::from(c - 1 + b'a')), KeyModifiers::CONTROL),
        c @ 0x1c..=0x1f => key(KeyCode::Char(char::from(c - 0x1c + b'4')), KeyModifiers::CONTROL),
        _ => {
            let len = match bytes[0] {
                0x00..=0x7f => 1,
                0xc0..=0xdf => 2,
                0xe0..=0xef => 3,
                _ => 4,
            };
            let c = std::str::from_utf8(bytes.get(..len)?).ok()?.chars().next()?;
            let m = if c.is_uppercase() { KeyModifiers::SHIFT } else { none };
            Some((KeyEvent::new(KeyCode::Char(c), m), len))
        }
    }
}

/// xterm's modifier parameter (1 + shift 1, alt 2, ctrl 4).
fn modifiers(param: Option<&str>) -> KeyModifiers {
    let bits = param.and_then(|p| p.parse::<u8>().ok()).map_or(0, |m| m.saturating_sub(1));
    let mut m = KeyModifiers::NONE;
    if bits & 1 != 0 {
        m |= KeyModifiers::SHIFT;
    }
    if bits & 2 != 0 {
        m |= KeyModifiers::ALT;
    }
    if bits & 4 != 0 {
        m |= KeyModifiers::CONTROL;
    }
    m
}

fn csi_key(params: &[u8], fin: u8) -> Option<KeyEvent> {
    let text = std::str::from_utf8(params).ok()?;
    let mut parts = text.split(';');
    let first = parts.next().filter(|p| !p.is_empty());
    let m = modifiers(parts.next());
    let code = match fin {
        b'Z' => return Some(KeyEvent::new(KeyCode::BackTab, KeyModifiers::SHIFT)),
        b'~' => match first?.parse::<u8>().ok()? {
            1 | 7 => KeyCode::Home,
            2 => KeyCode::Insert,
            3 => KeyCode::Delete,
            4 | 8 => KeyCode::End,
            5 => KeyCode::PageUp,
            6 => KeyCode::PageDown,
            n @ 11..=15 => KeyCode::F(n - 10),
            n @ 17..=21 => KeyCode::F(n - 11),
            n @ 23..=24 => KeyCode::F(n - 12),
            _ => return None,
        },
        other => return ss3_key(other).map(|k| KeyEvent::new(k.code, m)),
    };
    Some(KeyEvent::new(code, m))
}

fn ss3_key(fin: u8) -> Option<KeyEvent> {
    let code = match fin {
        b'A' => KeyCode::Up,
        b'B' => KeyCode::Down,
        b'C' => KeyCode::Right,
        b'D' => KeyCode::Left,
        b'H' => KeyCode::Home,
        b'F' => KeyCode::End,
        b'P' => KeyCode::F(1),
        b'Q' => KeyCode::F(2),
        b'R' => KeyCode::F(3),
        b'S' => KeyCode::F(4),
        _ => return None,
    };
    Some(KeyEvent::new(code, KeyModifiers::NONE))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn k(code: KeyCode) -> KeyEvent {
        KeyEvent::new(code, KeyModifiers::NONE)
    }

    #[test]
    fn keys_typed_around_the_answers_are_kept_in_order() {
        let mut r = ProbeReader::default();
        // Keys before the answers, between them, split across reads, and after the status answer.
        r.push(b"j\x1b[Bx");
        r.push(b"\x1b_Gi=31;OK\x1b\\\x1b[?62;4c\x1b[");
        assert!(!r.done);
        r.push(b"6;20;10tk\x1b[1;5C\x1b[0n");
        assert!(r.done);
        r.push(b"\x1b[5~q");
        r.finish();
        let want = vec![
            k(KeyCode::Char('j')),
            k(KeyCode::Down),
            k(KeyCode::Char('x')),
            k(KeyCode::Char('k')),
            KeyEvent::new(KeyCode::Right, KeyModifiers::CONTROL),
            k(KeyCode::PageUp),
            k(KeyCode::Char('q')),
        ];
        assert_eq!(r.keys, want);
        assert_eq!(r.responses, vec![Response::Kitty, Response::Sixel, Response::CellSize(Some((10, 20)))]);
    }

    #[test]
    fn at_the_deadline_what_is_left_is_keys() {
        let mut r = ProbeReader::default();
        r.push(b"\x1b");
        assert!(r.keys.is_empty(), "a lone Esc may start a sequence");
        r.finish();
        assert_eq!(r.keys, vec![k(KeyCode::Esc)]);
        assert!(!r.done);
        let mut r = ProbeReader::default();
        r.push("é\x1bOA\t\r\x7f\x13Z\x1b[Z".as_bytes());
        r.finish();
        let want = vec![
            k(KeyCode::Char('é')),
            k(KeyCode::Up),
            k(KeyCode::Tab),
            k(KeyCode::Enter),
            k(KeyCode::Backspace),
            KeyEvent::new(KeyCode::Char('s'), KeyModifiers::CONTROL),
            KeyEvent::new(KeyCode::Char('Z'), KeyModifiers::SHIFT),
            KeyEvent::new(KeyCode::BackTab, KeyModifiers::SHIFT),
        ];
        assert_eq!(r.keys, want);
    }
}
