//! The one parse, on several threads. A palette of thousands of spectra is mostly a run of `[[lights]]`,
//! `[[reflectances]]` and `[[colours]]` tables, and `toml`'s parser runs on one thread: the text is cut
//! into pieces at such header lines, each piece is parsed by the same parser on its own thread, spans are
//! moved to count from the start of the whole text, and the arrays of tables are joined in order. A short
//! text is one piece. The tree is the one the whole text parses to, so the one walker ([`super::read`])
//! reads it.
//!
//! Cuts are only made where the whole-text parse would start a new table element: at a line that opens a
//! `[[name]]` header (a bare key, no dots) outside any string, comment or array, after the last header of
//! any other shape (so a later piece holds nothing but `[[name]]` tables, which can refer to no earlier
//! table). When a piece does not parse, or the join finds a key that the `[[name]]` tables of a later
//! piece cannot continue, the text is parsed as one piece, so errors (line, column, message) are exactly
//! those of the whole-text parse.

use super::doc::{Doc, Item, List};
use super::read;
use rayon::prelude::*;
use std::borrow::Cow;
use std::ops::Range;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// Texts shorter than this are one piece (a thread's start costs more than parsing them).
const MIN_PIECE: usize = 64 * 1024;

/// Why a text does not parse: a syntax error, or a number TOML cannot hold (span and reason).
pub(super) enum Failure {
    Syntax(toml::de::Error),
    Number(Range<usize>, &'static str),
}

/// Parse `text` (in pieces when it is long, cut at some of its `[[name]]` header lines `headers`, see
/// [`super::budget::Scan`]) and check its numbers ([`read::check_numbers`]).
pub(super) fn parse<'i>(text: &'i str, headers: &[usize]) -> Result<Spanned<DeTable<'i>>, Failure> {
    let starts = starts(text, headers);
    if starts.len() > 1
        && let Some(root) = parse_pieces(text, &starts)
    {
        return Ok(root);
    }
    parse_one(text)
}

/// Where the pieces of `text` start (the first at 0), at some of its `[[name]]` header lines `headers`: one
/// piece for a short text, else about one per [`MIN_PIECE`] bytes, at most four per thread.
pub(super) fn starts(text: &str, headers: &[usize]) -> Vec<usize> {
    let pieces = (text.len() / MIN_PIECE).min(4 * rayon::current_num_threads());
    cuts(text, pieces, headers)
}

/// The whole text as one piece.
fn parse_one(text: &str) -> Result<Spanned<DeTable<'_>>, Failure> {
    let root = DeTable::parse(text).map_err(Failure::Syntax)?;
    if let Some((span, message)) = root.get_ref().values().find_map(read::check_numbers) {
        return Err(Failure::Number(span, message));
    }
    Ok(root)
}

/// The pieces starting at `starts` (the first at 0), parsed and joined; `None` when a piece fails or the
/// join is not what the whole text says (the caller then parses it whole for the error).
fn parse_pieces<'i>(text: &'i str, starts: &[usize]) -> Option<Spanned<DeTable<'i>>> {
    let bounds: Vec<Range<usize>> =
        starts.iter().enumerate().map(|(i, &a)| a..starts.get(i + 1).copied().unwrap_or(text.len())).collect();
    let parsed: Vec<(Range<usize>, DeTable<'i>)> = bounds
        .par_iter()
        .map(|range| {
            let piece = text.get(range.clone())?;
            let root = DeTable::parse(piece).ok()?;
            let span = moved(root.span(), range.start);
            let root = root.into_inner();
            if root.values().any(|v| read::check_numbers(v).is_some()) {
                return None;
            }
            Some((span, if range.start == 0 { root } else { shift_table(root, range.start) }))
        })
        .collect::<Option<_>>()?;
    join(text, parsed)
}

/// The trees of the pieces of `text` (each with its root's span, spans counted from the start of `text`),
/// joined in order; `None` when the join is not what the whole text says.
pub(super) fn join<'i>(text: &'i str, parsed: Vec<(Range<usize>, DeTable<'i>)>) -> Option<Spanned<DeTable<'i>>> {
    let mut parsed = parsed.into_iter();
    let (span, mut root) = parsed.next()?;
    // Keys whose arrays are known to be made of `[[key]]` tables.
    let mut continued: Vec<String> = Vec::new();
    let headed = |items: &[Spanned<DeValue>]| {
        items.iter().all(|e| e.get_ref().is_table() && text.get(e.span()).is_some_and(|h| h.starts_with("[[")))
    };
    for (_, piece) in parsed {
        for (key, value) in piece {
            let span = value.span();
            let DeValue::Array(items) = value.into_inner() else { return None };
            if !headed(&items) {
                return None;
            }
            let name: &str = key.get_ref();
            match root.get_mut(name) {
                Some(existing) => {
                    let DeValue::Array(list) = existing.get_mut() else { return None };
                    if !continued.iter().any(|c| c == name) {
                        if !headed(list) {
                            return None;
                        }
                        continued.push(name.to_string());
                    }
                    for item in items {
                        list.push(item);
                    }
                }
                None => {
                    continued.push(name.to_string());
                    root.insert(key, Spanned::new(span, DeValue::Array(items)));
                }
            }
        }
    }
    Some(Spanned::new(span, root))
}

/// The documents of the pieces of a text read by the faster paths (each with its root's span, the first
/// piece's first), joined in order; `None` when the join is not what the whole text says: a later piece
/// (which starts at a `[[name]]` header) holds something besides `[[name]]` tables, or a list of such
/// tables continues a key of the first piece's tree.
pub(super) fn join_docs<'i>(pieces: Vec<(Range<usize>, Doc<'i>)>) -> Option<Doc<'i>> {
    let mut pieces = pieces.into_iter();
    let (span, mut doc) = pieces.next()?;
    doc.root = Spanned::new(span, doc.root.into_inner());
    let rest: Vec<Doc<'i>> = pieces.map(|(_, d)| d).collect();
    let mut list_of: std::collections::HashMap<Cow<'i, str>, usize, foldhash::fast::RandomState> =
        doc.lists.iter().enumerate().map(|(i, l)| (l.key.get_ref().clone(), i)).collect();
    // Each list's items reserved once (a batch's lists run through every piece).
    let mut more = vec![0; doc.lists.len()];
    for list in rest.iter().flat_map(|d| &d.lists) {
        if let Some(&i) = list_of.get(list.key.get_ref()) {
            more[i] += list.items.len();
        }
    }
    for (list, more) in doc.lists.iter_mut().zip(more) {
        list.items.reserve(more);
    }
    for later in rest {
        if !later.root.get_ref().is_empty() {
            return None;
        }
        let base = u32::try_from(doc.entries.len()).ok()?;
        doc.entries.extend(later.entries);
        for list in later.lists {
            let items = list.items.into_iter().map(|item| Item { piece: item.piece + base, ..item });
            match list_of.get(list.key.get_ref()) {
                Some(&i) => doc.lists[i].items.extend(items),
                None if doc.root.get_ref().contains_key(list.key.get_ref().as_ref()) => return None,
                None => {
                    list_of.insert(list.key.get_ref().clone(), doc.lists.len());
                    doc.lists.push(List { key: list.key, span: list.span, items: items.collect() });
                }
            }
        }
    }
    Some(doc)
}

/// Drop a document read by pieces: its tree as [`drop_tree`] does, its flat tables' entries a piece per
/// thread.
pub(super) fn drop_doc(doc: Doc<'_>) {
    let Doc { root, lists, entries } = doc;
    drop(lists);
    if entries.len() > 1 {
        entries.into_par_iter().for_each(drop);
    }
    drop_tree(root);
}

/// Drop a parsed tree, its long arrays (a long file's `[[…]]` tables, a value per sample) on the pool's
/// threads: freeing the tree of a palette of thousands of spectra one value at a time took as long as a
/// tenth of its parse.
pub(super) fn drop_tree(tree: Spanned<DeTable<'_>>) {
    for (_, value) in tree.into_inner() {
        if let DeValue::Array(items) = value.into_inner()
            && items.len() >= 64
        {
            items.into_par_iter().for_each(drop);
        }
    }
}

fn moved(span: Range<usize>, by: usize) -> Range<usize> {
    span.start + by..span.end + by
}

/// A piece's table with its spans counted from `by` bytes earlier.
fn shift_table(table: DeTable<'_>, by: usize) -> DeTable<'_> {
    table.into_iter().map(|(k, v)| (Spanned::new(moved(k.span(), by), k.into_inner()), shift(v, by))).collect()
}

pub(super) fn shift(value: Spanned<DeValue<'_>>, by: usize) -> Spanned<DeValue<'_>> {
    let span = moved(value.span(), by);
    let inner = match value.into_inner() {
        DeValue::Array(mut items) => {
            for item in items.iter_mut() {
                let v = std::mem::replace(item, Spanned::new(0..0, DeValue::Boolean(false)));
                *item = shift(v, by);
            }
            DeValue::Array(items)
        }
        DeValue::Table(t) => DeValue::Table(shift_table(t, by)),
        other => other,
    };
    Spanned::new(span, inner)
}

/// Where the pieces start (the first at 0): about `len / pieces` apart, at the `[[name]]` header lines
/// `headers` (from [`super::budget::scan`]: outside strings, comments and arrays, after the last header of
/// another shape).
fn cuts(text: &str, pieces: usize, headers: &[usize]) -> Vec<usize> {
    let mut out = vec![0];
    if pieces < 2 {
        return out;
    }
    let step = text.len() / pieces;
    let mut next = step;
    for &at in headers {
        if at >= next {
            out.push(at);
            next = at + step;
        }
    }
    out
}

#[cfg(test)]
mod tests;
