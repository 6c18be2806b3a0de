//! The parse of a palette's usual shapes straight from `toml_parser`'s events, without the `toml` crate's
//! document layer.
//!
//! Why this exists: measured on a palette of 1200 designed reflectances (`metamer solve`, whole process),
//! the `toml` crate's parse of the text builds its events into a tree through a general document builder
//! (dotted keys, implicit tables, key paths), and the pieces' trees were then walked again to move their
//! spans. A palette is mostly `[[name]]` tables of `key = "string"`, `key = true` and number arrays (read by
//! hand, [`super::numbers`]). This module takes the events of the same lexer and parser the `toml` crate
//! uses (`toml_parser`, its lower layer, same maintainers), and builds the same tree (the same keys, values
//! and spans) for those shapes directly, on the pieces the text is cut into, in parallel, each piece's
//! hand-read arrays blanked in a copy of that piece only.
//!
//! How it stays exact: it takes top-level keys, `[name]` and `[[name]]` headers with a single key, and
//! `key = value` with a single key; a string or boolean is decoded by `toml_parser`'s own decoder, an empty
//! array is built as it stands, and any other value (numbers, date-times, non-empty arrays, inline tables)
//! is parsed by `toml`'s own value parser on its text and moved to its place. Anything else (a dotted key,
//! a key or table given twice, an array of tables that is not one, any error the parser reports, a number
//! TOML cannot hold) gives `None`: the caller then parses the whole text as before, so every error, its
//! line, column and message are the `toml` crate's. Tests compare the tree with the `toml` crate's on the
//! same text, and the palettes both paths read.

use super::doc::{Doc, Entry, Item, List};
use super::{numbers, pieces, read};
use rayon::prelude::*;
use std::borrow::Cow;
use std::ops::Range;
use toml::Spanned;
use toml::de::{DeArray, DeTable, DeValue};
use toml_parser::parser::{Event, EventKind, RecursionGuard, ValidateWhitespace};
use toml_parser::{ParseError, Source};

/// The deepest nesting the parser takes (the `toml` crate's own limit).
const DEPTH: u32 = 80;

/// The tree of `text` (cut at some of its `[[name]]` header lines `headers`, see [`pieces::starts`]) with
/// the number arrays read by hand at their spans, or `None` when the text holds something this path leaves
/// to the whole parse.
pub(super) fn parse<'i>(text: &'i str, headers: &[usize]) -> Option<(Doc<'i>, numbers::Read)> {
    let starts = pieces::starts(text, headers);
    let bounds: Vec<Range<usize>> =
        starts.iter().enumerate().map(|(i, &a)| a..starts.get(i + 1).copied().unwrap_or(text.len())).collect();
    type Piece<'i> = (Range<usize>, Doc<'i>, Vec<(Range<usize>, Vec<f64>)>);
    let parsed: Vec<Piece<'i>> = bounds
        .par_iter()
        .map(|range| {
            let arrays = numbers::arrays_in(text, range.clone());
            let doc = piece(text, range.clone(), &arrays)?;
            if doc.values().any(|v| read::check_numbers(v).is_some()) {
                return None;
            }
            let span = if range.start == 0 { 0..0 } else { range.clone() };
            Some((span, doc, arrays))
        })
        .collect::<Option<_>>()?;
    let mut arrays = Vec::new();
    let mut docs = Vec::with_capacity(parsed.len());
    for (span, doc, found) in parsed {
        arrays.extend(found);
        docs.push((span, doc));
    }
    let doc = pieces::join_docs(docs)?;
    Some((doc, numbers::Read::new(arrays)))
}

/// The table of `text[range]`, its `arrays` (read by hand) parsed as blank arrays.
fn piece<'i>(text: &'i str, range: Range<usize>, arrays: &[(Range<usize>, Vec<f64>)]) -> Option<Doc<'i>> {
    let original = text.get(range.clone())?;
    let blanked = numbers::blank(original, range.start, arrays)?;
    let lexed = Source::new(&blanked);
    let tokens = lexed.lex().into_vec();
    let mut events = Vec::with_capacity(tokens.len());
    let mut error: Option<ParseError> = None;
    {
        let mut validate = ValidateWhitespace::new(&mut events, lexed);
        let mut guard = RecursionGuard::new(&mut validate, DEPTH);
        toml_parser::parser::parse_document(&tokens, &mut guard, &mut error);
    }
    if error.is_some() {
        return None;
    }
    // Strings and keys are decoded from the original text: it is the blanked text outside the arrays read.
    let builder = Builder {
        source: Source::new(original),
        text: original,
        offset: range.start,
        events: &events,
        at: 0,
        tree: Tree::with_capacity(range.len() / 32),
    };
    builder.document()
}

/// Builds a piece's tree from its events, as the `toml` crate's document builder does for the shapes taken.
struct Builder<'e, 'i> {
    source: Source<'i>,
    text: &'i str,
    /// Where the piece starts in the whole text (spans count from there).
    offset: usize,
    events: &'e [Event],
    at: usize,
    tree: Tree<'i>,
}

/// A flat table holding more keys than this checks a new key against a set of its keys, not each key.
const FEW_KEYS: usize = 8;

/// A hash set of a table's keys (no input chooses them to collide with a seed it cannot know).
type KeySet<'i> = std::collections::HashSet<Cow<'i, str>, foldhash::fast::RandomState>;

/// The table being read.
#[derive(Default)]
enum Current<'i> {
    /// None yet: the top-level keys.
    #[default]
    Root,
    /// A `[name]` table: its key, its header's span and its keys.
    Table(Spanned<Cow<'i, str>>, Range<usize>, DeTable<'i>),
    /// A `[[name]]` table: its list, its header's span and where its entries start.
    Item(usize, Range<usize>, usize),
}

/// A piece's document as it is built, header by header (shared with the line reader, [`super::lines`]):
/// the top-level keys and `[name]` tables in a tree, the `[[name]]` tables in flat lists ([`super::doc`]).
#[derive(Default)]
pub(super) struct Tree<'i> {
    root: DeTable<'i>,
    current: Current<'i>,
    lists: Vec<List<'i>>,
    /// The lists by key.
    list_of: std::collections::HashMap<Cow<'i, str>, usize, foldhash::fast::RandomState>,
    entries: Vec<Entry<'i>>,
    /// The keys of the `[[name]]` table being read once it holds more than [`FEW_KEYS`].
    keys: Option<KeySet<'i>>,
}

impl<'i> Tree<'i> {
    /// A tree with room for `entries` keys and values of `[[name]]` tables.
    pub(super) fn with_capacity(entries: usize) -> Tree<'i> {
        Tree { entries: Vec::with_capacity(entries), ..Tree::default() }
    }

    /// `key = value` in the table being read (the root before any header); `None` for a key given twice.
    pub(super) fn insert(&mut self, key: Spanned<Cow<'i, str>>, value: Spanned<DeValue<'i>>) -> Option<()> {
        let table = match &mut self.current {
            Current::Root => &mut self.root,
            Current::Table(_, _, table) => table,
            Current::Item(_, _, from) => {
                let name: &str = key.get_ref();
                let entries = &self.entries[*from..];
                let twice = match &mut self.keys {
                    None if entries.len() < FEW_KEYS => entries.iter().any(|e| e.key.get_ref() == name),
                    None => {
                        let mut keys: KeySet<'i> = entries.iter().map(|e| e.key.get_ref().clone()).collect();
                        let twice = !keys.insert(key.get_ref().clone());
                        self.keys = Some(keys);
                        twice
                    }
                    Some(keys) => !keys.insert(key.get_ref().clone()),
                };
                if twice {
                    return None;
                }
                self.entries.push(Entry { key, value });
                return Some(());
            }
        };
        // A key given twice gives `None` (the tree is dropped).
        table.insert(key, value).is_none().then_some(())
    }

    /// A `[name]` (or `[[name]]` when `is_array`) header at `span`: the table before it put in its place.
    pub(super) fn open(&mut self, is_array: bool, key: Spanned<Cow<'i, str>>, span: Range<usize>) -> Option<()> {
        self.finish()?;
        self.current = if is_array {
            let name: &str = key.get_ref();
            let list = match self.list_of.get(name) {
                Some(&list) => list,
                // A key of the tree (a value or a `[name]` table) cannot take `[[name]]` tables.
                None if self.root.contains_key(name) => return None,
                None => {
                    self.list_of.insert(key.get_ref().clone(), self.lists.len());
                    self.lists.push(List { key, span: span.clone(), items: Vec::new() });
                    self.lists.len() - 1
                }
            };
            Current::Item(list, span, self.entries.len())
        } else {
            Current::Table(key, span, DeTable::new())
        };
        Some(())
    }

    /// Put the table being read in its place.
    fn finish(&mut self) -> Option<()> {
        match std::mem::take(&mut self.current) {
            Current::Root => {}
            Current::Table(key, span, table) => {
                let name: &str = key.get_ref();
                if self.list_of.contains_key(name) || self.root.contains_key(name) {
                    return None;
                }
                self.root.insert(key, Spanned::new(span, DeValue::Table(table)));
            }
            Current::Item(list, span, from) => {
                let entries = u32::try_from(from).ok()?..u32::try_from(self.entries.len()).ok()?;
                self.lists[list].items.push(Item { span, piece: 0, entries });
                self.keys = None;
            }
        }
        Some(())
    }

    /// The piece's document (its root's span empty), once every table is in its place.
    pub(super) fn done(mut self) -> Option<Doc<'i>> {
        self.finish()?;
        Some(Doc { root: Spanned::new(0..0, self.root), lists: self.lists, entries: vec![self.entries] })
    }
}

impl<'i> Builder<'_, 'i> {
    fn next(&mut self) -> Option<Event> {
        let e = self.events.get(self.at).copied();
        self.at += 1;
        e
    }

    /// The next event that is not a blank.
    fn next_solid(&mut self) -> Option<Event> {
        loop {
            let e = self.next()?;
            if e.kind() != EventKind::Whitespace {
                return Some(e);
            }
        }
    }

    fn span(&self, e: &Event) -> Range<usize> {
        self.offset + e.span().start()..self.offset + e.span().end()
    }

    fn document(mut self) -> Option<Doc<'i>> {
        while let Some(e) = self.next() {
            match e.kind() {
                EventKind::Whitespace | EventKind::Newline | EventKind::Comment => {}
                EventKind::StdTableOpen | EventKind::ArrayTableOpen => self.header(e)?,
                EventKind::SimpleKey => {
                    let key = self.key(&e)?;
                    if self.next_solid()?.kind() != EventKind::KeyValSep {
                        return None;
                    }
                    let value = self.value()?;
                    self.tree.insert(key, value)?;
                }
                _ => return None,
            }
        }
        self.tree.done()
    }

    /// A single key, decoded (a dotted key is left to the whole parse).
    fn key(&self, e: &Event) -> Option<Spanned<Cow<'i, str>>> {
        let raw = self.source.get(e)?;
        let mut decoded = Cow::Borrowed("");
        let mut error: Option<ParseError> = None;
        raw.decode_key(&mut decoded, &mut error);
        error.is_none().then(|| Spanned::new(self.span(e), decoded))
    }

    /// A `[name]` or `[[name]]` header with a single key.
    fn header(&mut self, open: Event) -> Option<()> {
        let is_array = open.kind() == EventKind::ArrayTableOpen;
        let key_event = self.next_solid()?;
        if key_event.kind() != EventKind::SimpleKey {
            return None;
        }
        let key = self.key(&key_event)?;
        let close = self.next_solid()?;
        let expected = if is_array { EventKind::ArrayTableClose } else { EventKind::StdTableClose };
        if close.kind() != expected {
            return None;
        }
        let span = self.offset + open.span().start()..self.offset + close.span().end();
        self.tree.open(is_array, key, span)
    }

    /// The value after `key =`.
    fn value(&mut self) -> Option<Spanned<DeValue<'i>>> {
        let e = self.next_solid()?;
        match e.kind() {
            EventKind::Scalar => {
                let raw = self.source.get(e)?;
                let mut decoded = Cow::Borrowed("");
                let mut error: Option<ParseError> = None;
                let kind = raw.decode_scalar(&mut decoded, &mut error);
                if error.is_some() {
                    return None;
                }
                match kind {
                    toml_parser::decoder::ScalarKind::String => {
                        Some(Spanned::new(self.span(&e), DeValue::String(decoded)))
                    }
                    toml_parser::decoder::ScalarKind::Boolean(b) => {
                        Some(Spanned::new(self.span(&e), DeValue::Boolean(b)))
                    }
                    _ => self.parsed(e.span().start()..e.span().end()),
                }
            }
            EventKind::ArrayOpen | EventKind::InlineTableOpen => {
                let start = e.span().start();
                let mut depth = 1usize;
                let mut blank = e.kind() == EventKind::ArrayOpen;
                let close = loop {
                    let inner = self.next()?;
                    match inner.kind() {
                        EventKind::ArrayOpen | EventKind::InlineTableOpen => depth += 1,
                        EventKind::ArrayClose | EventKind::InlineTableClose => {
                            depth -= 1;
                            if depth == 0 {
                                break inner;
                            }
                        }
                        EventKind::Whitespace | EventKind::Newline => continue,
                        _ => {}
                    }
                    blank = false;
                };
                if blank {
                    // An empty array (a hand-read one, blanked): as the parser builds it.
                    let span = self.offset + start..self.offset + close.span().end();
                    return Some(Spanned::new(span, DeValue::Array(DeArray::new())));
                }
                self.parsed(start..close.span().end())
            }
            _ => None,
        }
    }

    /// The value written at `range` of the piece, parsed by `toml`'s own value parser and moved to its place.
    fn parsed(&self, range: Range<usize>) -> Option<Spanned<DeValue<'i>>> {
        let value = DeValue::parse(self.text.get(range.clone())?).ok()?;
        Some(pieces::shift(value, self.offset + range.start))
    }
}

#[cfg(test)]
pub(super) mod tests;
