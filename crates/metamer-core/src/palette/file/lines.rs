//! The read of a palette written in its plainest lines, in one pass over the text.
//!
//! Why this exists: measured on a palette of 1200 designed reflectances (`metamer solve`, whole process,
//! callgrind), reading walked the text four times before the model was read: the parse budget's scan
//! ([`super::budget`]), the hand-read arrays' search ([`super::numbers::arrays_in`]), the copy of each piece
//! with those arrays blanked, and `toml_parser`'s lexer and parser ([`super::events`]), about 60 M
//! instructions of reading's 100 M. A palette as `metamer` writes it (and as most people write one) is a
//! run of lines of a few shapes, which this module reads in one pass, a line at a time, on the pieces the
//! text is cut into, in parallel:
//!
//! - blank lines and comments (`# …`, no control character but a tab, as TOML allows);
//! - `[name]` and `[[name]]` headers with a bare key and nothing inside the brackets but the key;
//! - `key = value` with a bare key, blanks around `=`, and an optional comment after the value, where the
//!   value is a basic string without escapes (`"…"`), a literal string (`'…'`), `true` or `false`, a
//!   decimal number as [`super::numbers`] reads it, or an array of such numbers (the `samples` and `target`
//!   arrays read into `f64`s, others given to `toml`'s own value parser).
//!
//! How it stays exact: a line of any other shape (escapes, multi-line strings, dotted or quoted keys, inline
//! tables, dates, `inf`, a carriage return anywhere, …) makes this path give `None`, and the caller reads the
//! text as before ([`super::events`], then the `toml` crate's whole parse), so every error is theirs. The tree
//! is built by the same code as the events' path ([`super::events::Tree`]: the same keys, values and spans,
//! the `[[name]]` tables in flat lists, [`super::doc`]; a number is parsed by `toml`'s own value parser at
//! its place), and tests compare it with the `toml` crate's tree of the same text. The parse budget is kept: the pass counts tables, arrays and values as
//! [`super::budget::scan`] counts them (the same counts, tested), adds them as it goes to a total shared by
//! the pieces (each piece adds its share every [`FLUSH`] bytes of estimate) and stops once the total is over
//! [`super::budget::budget`] (the caller's scan then refuses the text as before), so what is built stays
//! within the budget and [`FLUSH`] a piece, as the budget estimates it.

use super::budget::{self, Counts};
use super::doc::Doc;
use super::events::Tree;
use super::{numbers, pieces, read};
use rayon::prelude::*;
use std::borrow::Cow;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use toml::Spanned;
use toml::de::{DeArray, DeValue};

/// Texts shorter than this are read in one piece (a thread's start costs more than reading them).
const MIN_PIECE: usize = 64 * 1024;

/// A piece's estimated parse memory is added to the shared total once it has grown by this many bytes.
const FLUSH: u64 = 1 << 20;

/// What the pass found: the tree, the arrays read by hand, and the budget's counts.
pub(super) struct Lines<'i> {
    pub(super) tree: Doc<'i>,
    pub(super) read: numbers::Read,
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) counts: Counts,
}

/// The tree of `text` with the `samples` and `target` arrays read by hand, when every line has one of the
/// shapes this module reads and the parse stays within the budget; `None` otherwise.
pub(super) fn parse(text: &str) -> Option<Lines<'_>> {
    let limit = budget::budget(text.len());
    let spent = AtomicU64::new(0);
    let ranges = cuts(text);
    let parsed: Vec<Piece<'_>> =
        ranges.par_iter().map(|range| piece(text, range.clone(), &spent, limit)).collect::<Option<_>>()?;
    let mut counts = Counts::default();
    let mut read = Vec::with_capacity(parsed.len());
    let mut docs = Vec::with_capacity(parsed.len());
    for (Piece { doc, arrays, values, counts: c }, range) in parsed.into_iter().zip(&ranges) {
        counts.tables += c.tables;
        counts.arrays += c.arrays;
        counts.values += c.values;
        read.push((arrays, values));
        let span = if range.start == 0 { 0..0 } else { range.clone() };
        docs.push((span, doc));
    }
    if counts.cost() > limit {
        return None;
    }
    let tree = pieces::join_docs(docs)?;
    Some(Lines { tree, read: numbers::Read::pieces(read), counts })
}

/// A piece as read: its table, the arrays read by hand (their spans in the whole text, and where their
/// numbers sit in `values`), and its counts.
struct Piece<'i> {
    doc: Doc<'i>,
    arrays: Vec<(Range<usize>, Range<usize>)>,
    values: Vec<f64>,
    counts: Counts,
}

/// Where the pieces are (the first at 0): about one per [`MIN_PIECE`] bytes, at most four per thread, each
/// starting at a line that opens with `[[`. A cut inside something this pass does not read (a multi-line
/// string or array) makes a piece start with a line it refuses.
fn cuts(text: &str) -> Vec<Range<usize>> {
    let b = text.as_bytes();
    let pieces = (b.len() / MIN_PIECE).min(4 * rayon::current_num_threads());
    let mut starts = vec![0];
    for k in 1..pieces.max(1) {
        let from = (k * b.len() / pieces).max(starts[starts.len() - 1]);
        if let Some(p) = b[from..].windows(3).position(|w| w == b"\n[[") {
            let at = from + p + 1;
            if at > starts[starts.len() - 1] {
                starts.push(at);
            }
        }
    }
    starts.iter().enumerate().map(|(i, &a)| a..starts.get(i + 1).copied().unwrap_or(b.len())).collect()
}

/// Bytes of a bare key.
fn bare(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_' || c == b'-'
}

/// A byte TOML does not allow in a comment or a single-line string: a control character other than a tab.
fn control(c: u8) -> bool {
    (c < 0x20 && c != b'\t') || c == 0x7f
}

/// The piece `text[range]` as read; `None` at a line this pass does not read, or once the pieces' total
/// `spent` is over `limit`.
fn piece<'i>(text: &'i str, range: Range<usize>, spent: &AtomicU64, limit: u64) -> Option<Piece<'i>> {
    // Nothing past the piece is read (spans still count from the start of the text).
    let t = text.get(..range.end)?;
    let b = t.as_bytes();
    // Room for what a piece of a palette's usual lines holds (batches of designs hold a key and value every
    // 44 bytes, an array every 148, a number every 5 to 20), so that the vectors seldom grow by copying:
    // what is reserved and not written is never touched.
    let len = range.len();
    let mut tree = Tree::with_capacity(len / 32);
    let mut arrays = Vec::with_capacity(len / 128);
    let mut values = Vec::with_capacity(len / 5);
    let mut counts = Counts::default();
    let mut pending = Counts::default();
    let mut i = range.start;
    let blanks = |mut i: usize| {
        while matches!(b.get(i), Some(b' ' | b'\t')) {
            i += 1;
        }
        i
    };
    // After a header or a value: blanks, an optional comment, then the line's end.
    let end_of_line = |i: usize| -> Option<usize> {
        let mut i = blanks(i);
        if b.get(i) == Some(&b'#') {
            while i < b.len() && b[i] != b'\n' {
                if control(b[i]) {
                    return None;
                }
                i += 1;
            }
        }
        match b.get(i) {
            None => Some(i),
            Some(b'\n') => Some(i + 1),
            Some(_) => None,
        }
    };
    let key_at = |i: usize| -> Option<(Spanned<Cow<'i, str>>, usize)> {
        let mut j = i;
        while b.get(j).is_some_and(|&c| bare(c)) {
            j += 1;
        }
        (j > i).then(|| (Spanned::new(i..j, Cow::Borrowed(&t[i..j])), j))
    };
    while i < b.len() {
        i = blanks(i);
        let Some(&c) = b.get(i) else { break };
        match c {
            b'\n' => i += 1,
            b'#' => i = end_of_line(i)?,
            b'[' => {
                let is_array = b.get(i + 1) == Some(&b'[');
                let (key, after) = key_at(i + 1 + usize::from(is_array))?;
                let close: &[u8] = if is_array { b"]]" } else { b"]" };
                if !b[after..].starts_with(close) {
                    return None;
                }
                let end = after + close.len();
                tree.open(is_array, key, i..end)?;
                pending.tables += 1;
                i = end_of_line(end)?;
            }
            c if bare(c) => {
                let (key, after) = key_at(i)?;
                let eq = blanks(after);
                if b.get(eq) != Some(&b'=') {
                    return None;
                }
                pending.values += 1;
                let v = blanks(eq + 1);
                let (value, end) = match b.get(v)? {
                    &q @ (b'"' | b'\'') => {
                        // A single-line string without escapes (an empty `""` is one; `"""` opens a
                        // multi-line string).
                        let mut j = v + 1;
                        while j < b.len() && b[j] != q {
                            if control(b[j]) || (q == b'"' && b[j] == b'\\') {
                                return None;
                            }
                            j += 1;
                        }
                        if j >= b.len() || (j == v + 1 && b.get(j + 1) == Some(&q)) {
                            return None;
                        }
                        (DeValue::String(Cow::Borrowed(&t[v + 1..j])), j + 1)
                    }
                    b't' | b'f' => {
                        let (word, value): (&[u8], bool) =
                            if b[v] == b't' { (b"true", true) } else { (b"false", false) };
                        if !b[v..].starts_with(word) {
                            return None;
                        }
                        (DeValue::Boolean(value), v + word.len())
                    }
                    b'[' => {
                        let from = values.len();
                        let end = numbers::array_into(t, v, &mut values)?;
                        pending.arrays += 1;
                        pending.values += b[v..end].iter().filter(|&&c| c == b',').count() as u64;
                        if numbers::KEYS.contains(&key.get_ref().as_ref()) {
                            arrays.push((v..end, from..values.len()));
                            (DeValue::Array(DeArray::new()), end)
                        } else {
                            values.truncate(from);
                            (parsed(t, v..end)?, end)
                        }
                    }
                    _ => {
                        let (end, _) = numbers::number(t, v)?;
                        (parsed(t, v..end)?, end)
                    }
                };
                tree.insert(key, Spanned::new(v..end, value))?;
                i = end_of_line(end)?;
            }
            _ => return None,
        }
        if pending.cost() >= FLUSH {
            let cost = pending.cost();
            add(&mut counts, &mut pending);
            if spent.fetch_add(cost, Ordering::Relaxed) + cost > limit {
                return None;
            }
        }
    }
    add(&mut counts, &mut pending);
    Some(Piece { doc: tree.done()?, arrays, values, counts })
}

/// The value written at `text[range]`, parsed by `toml`'s own value parser and moved to its place; `None`
/// for a number TOML cannot hold (the whole parse reports it).
fn parsed<'i>(text: &'i str, range: Range<usize>) -> Option<DeValue<'i>> {
    let value = pieces::shift(DeValue::parse(text.get(range.clone())?).ok()?, range.start);
    if read::check_numbers(&value).is_some() {
        return None;
    }
    Some(value.into_inner())
}

/// Moves the counts `pending` into `total`.
fn add(total: &mut Counts, pending: &mut Counts) {
    total.tables += pending.tables;
    total.arrays += pending.arrays;
    total.values += pending.values;
    *pending = Counts::default();
}

#[cfg(test)]
mod tests;
