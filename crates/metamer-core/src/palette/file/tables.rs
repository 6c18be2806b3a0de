//! Saving table by table. A save that only changes how spectra are given (a designed spectrum's new
//! `samples`, its `normalize` or `scale`), which is what a solve does, needs no document of the whole
//! file: each changed `[[lights]]` / `[[reflectances]]` table's text (from its header to the next
//! top-level header) is parsed as a `toml_edit` document of its own, updated by the one writer
//! ([`super::write::sync_spectrum`]), printed and put back in its place; the rest of the text is not
//! touched. The entry each new table reads as is resolved as the reader resolves it; debug builds (the
//! tests) read the whole new text back and compare.
//!
//! That is the document writer's own output (the same code writes the same keys with the same decor), at
//! the cost of the changed tables only (building and printing the document of a palette of thousands of
//! spectra dominated such a save). Anything else (renames, added or removed entries, settings, cells, a
//! CSV path to rebase, a table whose text holds another header or an inline table) is written through the
//! whole document.
//!
//! A source value the writer replaces (a solve's old samples, most of a designed table's text) is not
//! parsed: the table is parsed with a placeholder in its place, at the span the reader saw.

use super::doc::{Doc, TableRef};
use super::write::{SaveContext, Written, source_text, sync_spectrum, written_source};
use crate::palette::{Kind, Palette, Source, SpectrumEntry};
use rayon::prelude::*;
use std::ops::Range;
use toml::de::DeValue;
use toml_edit::DocumentMut;

/// Where one spectrum's table sits in the text.
#[derive(Clone, Debug)]
pub(super) struct TableSpan {
    /// From the header to the next top-level header (or the end of the text).
    range: Range<usize>,
    /// Where its source value sits, from the table's start, as read (`None` once the table is rewritten).
    source_value: Option<Range<usize>>,
}

/// Spans are equal when they cover the same text (the source value's place is only known as read).
impl PartialEq for TableSpan {
    fn eq(&self, other: &TableSpan) -> bool {
        self.range == other.range
    }
}

/// Where each light's and reflectance's table sits in the text, in model order.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Tables {
    lights: Vec<TableSpan>,
    reflectances: Vec<TableSpan>,
}

impl Tables {
    /// The tables of a parsed text the reader accepted (`None` when its lists are not all `[[…]]` tables,
    /// e.g. inline arrays, which then save through the whole document).
    pub(super) fn of(doc: &Doc, text: &str) -> Option<Tables> {
        let root = doc.root.get_ref();
        // Every top-level header, sorted: a table ends where the next one starts.
        let mut starts: Vec<usize> = Vec::with_capacity(
            doc.lists.iter().map(|l| l.items.len()).sum::<usize>()
                + root.values().map(|v| v.get_ref().as_array().map_or(1, |a| a.len())).sum::<usize>(),
        );
        for list in &doc.lists {
            starts.extend(list.items.iter().map(|i| i.span.start));
        }
        for value in root.values() {
            match value.get_ref() {
                DeValue::Array(items) => starts.extend(
                    items
                        .iter()
                        .map(|i| i.span().start)
                        .filter(|&s| text.get(s..).is_some_and(|t| t.starts_with("[["))),
                ),
                DeValue::Table(_) if text.get(value.span()).is_some_and(|h| h.starts_with('[')) => {
                    starts.push(value.span().start)
                }
                _ => {}
            }
        }
        // In text order within each list: the stable sort merges the runs.
        starts.sort();
        starts.dedup();
        let end_of = |start: usize| {
            let i = starts.partition_point(|&s| s <= start);
            starts.get(i).copied().unwrap_or(text.len())
        };
        // One walk of a table's keys (not a lookup of each source key).
        let span = |start: usize, table: TableRef| -> Option<TableSpan> {
            if !text.get(start..)?.starts_with("[[") {
                return None;
            }
            let range = start..end_of(start);
            let mut sources = table.iter().filter(|(k, _)| Source::KEYS.contains(k)).map(|(_, v)| v);
            let source_value = match (sources.next(), sources.next()) {
                (Some(v), None) if range.start <= v.span().start && v.span().end <= range.end => {
                    Some(v.span().start - start..v.span().end - start)
                }
                _ => None,
            };
            Some(TableSpan { range, source_value })
        };
        let list = |key: &str| -> Option<Vec<TableSpan>> {
            let mut out = Vec::new();
            if let Some(list) = doc.list(key) {
                out.reserve_exact(list.items.len());
                for item in &list.items {
                    out.push(span(item.span.start, doc.table(item))?);
                }
            } else if let Some(v) = root.get(key) {
                let items = v.get_ref().as_array()?;
                out.reserve_exact(items.len());
                for item in items {
                    out.push(span(item.span().start, TableRef::Tree(item.get_ref().as_table()?))?);
                }
            }
            Some(out)
        };
        Some(Tables { lights: list("lights")?, reflectances: list("reflectances")? })
    }

    fn list(&self, kind: Kind) -> &[TableSpan] {
        if kind == Kind::Light { &self.lights } else { &self.reflectances }
    }
}

/// A save written table by table: the new text, in pieces, and what the file then says.
pub(super) struct Saved {
    /// The new text: these pieces one after another (each a run of rewritten tables and the text between
    /// them, formatted on a thread of the pool; written to the file in turn, joined only when the file
    /// keeps its text, [`Saved::text`]).
    pub(crate) pieces: Vec<String>,
    /// The entries the rewritten tables read as, by list and place (every other entry is the old one);
    /// none when the save was made without them ([`save`]'s `keep_entries`).
    entries: Vec<(Kind, usize, SpectrumEntry)>,
    pub(crate) tables: Tables,
}

impl Saved {
    /// The whole new text.
    pub(crate) fn text(&self) -> String {
        self.pieces.concat()
    }

    /// What the new text says, `old` being what the text saved over said (a save made with its entries).
    pub(crate) fn palette(&self, old: &Palette) -> Palette {
        let mut palette = old.clone();
        for (kind, i, entry) in &self.entries {
            let list = if *kind == Kind::Light { &mut palette.lights } else { &mut palette.reflectances };
            list[*i] = entry.clone();
        }
        palette
    }
}

/// What the file as read says, and how it is laid out.
pub(super) struct Layout<'a> {
    pub(crate) text: &'a str,
    pub(crate) tables: &'a Tables,
    pub(crate) crlf: bool,
    /// Some lines end in CRLF and some in LF (the whole document's print changes some of them).
    pub(crate) mixed_newlines: bool,
    pub(crate) no_final_newline: bool,
}

/// Entries of the two palettes that only differ in how their spectrum is given.
fn same_but_spectrum(a: &SpectrumEntry, b: &SpectrumEntry) -> bool {
    a.name == b.name && a.kind == b.kind && a.design == b.design && a.bounds == b.bounds && a.dial == b.dial
}

/// Rewritten tables a piece of the new text: a piece is formatted on one thread into one string sized up
/// front, instead of a string per table (and another for its samples) copied into a string of the whole.
const TABLES_A_PIECE: usize = 48;

/// The text of saving `new` to `path` over the file `layout` (which says `old`), or `None` when the change
/// is more than rewriting some spectrum tables. With `keep_entries`, also what each rewritten table reads as
/// ([`Saved::palette`]); a command that ends once the save is in place never asks for it, and without it
/// no entry is built or copied (the same text, the same `None`s).
pub(super) fn save(
    layout: &Layout,
    old: &Palette,
    new: &Palette,
    ctx: &SaveContext,
    keep_entries: bool,
) -> Option<Saved> {
    let tables = layout.tables;
    let same_shape = old.name == new.name
        && old.settings == new.settings
        && old.colours == new.colours
        && old.mixtures == new.mixtures
        && old.paths == new.paths
        && old.free == new.free
        && old.lights.len() == new.lights.len()
        && old.reflectances.len() == new.reflectances.len()
        && tables.lights.len() == old.lights.len()
        && tables.reflectances.len() == old.reflectances.len()
        && old.lights.iter().zip(&new.lights).all(|(a, b)| same_but_spectrum(a, b))
        && old.reflectances.iter().zip(&new.reflectances).all(|(a, b)| same_but_spectrum(a, b));
    // A CSV source saved into another folder gets a rebased path in every table that has one.
    let moves_csv = || {
        let same_dir = ctx.old_base.is_some_and(|b| super::write::same_dir(b, ctx.new_base));
        !same_dir && new.lights.iter().chain(&new.reflectances).any(|e| matches!(e.source, Source::Csv(_)))
    };
    if !same_shape || layout.mixed_newlines || moves_csv() {
        return None;
    }
    // The changed entries with their tables, in the text's order.
    let mut changed: Vec<(usize, &SpectrumEntry, &SpectrumEntry, &TableSpan)> = [Kind::Light, Kind::Reflectance]
        .into_iter()
        .flat_map(|kind| {
            let (o, n) =
                if kind == Kind::Light { (&old.lights, &new.lights) } else { (&old.reflectances, &new.reflectances) };
            o.iter().zip(n).enumerate().filter(|(_, (o, n))| o != n).map(move |(i, (o, n))| (i, o, n))
        })
        .map(|(i, o, n)| Some((i, o, n, tables.list(o.kind).get(i)?)))
        .collect::<Option<_>>()?;
    changed.sort_by_key(|c| c.3.range.start);
    if changed.windows(2).any(|w| w[0].3.range.end > w[1].3.range.start) {
        return None;
    }
    // Each piece runs from the end of the previous piece's last table (the text's start for the first) to
    // the end of its own last table (the text's end for the last).
    let runs: Vec<_> = changed.chunks(TABLES_A_PIECE).collect();
    let count = runs.len();
    type Piece = (String, Vec<(Range<usize>, isize)>, Vec<(Kind, usize, SpectrumEntry)>);
    let pieces: Vec<Piece> = runs
        .par_iter()
        .enumerate()
        .map(|(k, run)| {
            let from = match k {
                0 => 0,
                _ => runs[k - 1].last()?.3.range.end,
            };
            let to = if k + 1 == count { layout.text.len() } else { run.last()?.3.range.end };
            // The old text's bytes and each table's samples at their usual size.
            let samples: usize = run
                .iter()
                .map(|c| match &c.2.source {
                    Source::Samples(v) => super::write::samples_text_bytes(v.len()),
                    _ => super::write::samples_text_bytes(crate::spectrum::SAMPLES),
                })
                .sum();
            let mut out = String::with_capacity(to.saturating_sub(from) + samples);
            let mut edits = Vec::with_capacity(run.len());
            let mut entries = Vec::with_capacity(if keep_entries { run.len() } else { 0 });
            let mut at = from;
            for &(i, o, n, span) in run.iter() {
                out.push_str(layout.text.get(at..span.range.start)?);
                let before = out.len();
                if let Some(entry) = rewrite_into(&mut out, layout, span, o, n, ctx, keep_entries)? {
                    entries.push((o.kind, i, entry));
                }
                edits.push((span.range.clone(), (out.len() - before) as isize - span.range.len() as isize));
                at = span.range.end;
            }
            out.push_str(layout.text.get(at..to)?);
            Some((out, edits, entries))
        })
        .collect::<Option<_>>()?;
    let mut texts = Vec::with_capacity(pieces.len());
    let mut edits: Vec<(Range<usize>, isize)> = Vec::with_capacity(changed.len());
    let mut entries = Vec::with_capacity(changed.len());
    for (text, e, n) in pieces {
        texts.push(text);
        edits.extend(e);
        entries.extend(n);
    }
    if texts.is_empty() {
        // Nothing changed: the text as it is.
        texts.push(layout.text.to_string());
    }
    // The tables after the rewrite: each start moves by the growth of the tables before it.
    // Edits are disjoint and sorted: what the tables before a start grew by is a prefix sum.
    let mut grown = Vec::with_capacity(edits.len() + 1);
    grown.push(0isize);
    for (_, d) in &edits {
        grown.push(grown[grown.len() - 1] + d);
    }
    let shift = |t: &TableSpan| -> TableSpan {
        let r = &t.range;
        let before = grown[edits.partition_point(|(e, _)| e.end <= r.start)];
        let own = edits
            .binary_search_by_key(&r.start, |(e, _)| e.start)
            .ok()
            .and_then(|k| (edits[k].0 == *r).then_some(edits[k].1));
        let start = (r.start as isize + before) as usize;
        let range = start..(r.end as isize + before + own.unwrap_or(0)) as usize;
        TableSpan { range, source_value: if own.is_some() { None } else { t.source_value.clone() } }
    };
    let new_tables = Tables {
        lights: tables.lights.iter().map(shift).collect(),
        reflectances: tables.reflectances.iter().map(shift).collect(),
    };
    Some(Saved { pieces: texts, entries, tables: new_tables })
}

/// The new text of the table at `span` (which says `old`) saying `new`, appended to `out`, and with `keep`
/// the entry it then reads as (`Some(None)` without it; `None` when the table cannot be rewritten).
fn rewrite_into(
    out: &mut String,
    layout: &Layout,
    span: &TableSpan,
    old: &SpectrumEntry,
    new: &SpectrumEntry,
    ctx: &SaveContext,
    keep: bool,
) -> Option<Option<SpectrumEntry>> {
    let range = span.range.clone();
    let piece = layout.text.get(range.clone())?;
    // Its own header only: no other table, no inline table (which the cut could split).
    if tables_in(piece, span, old)? != 1 {
        return None;
    }
    let Written { source: written, normalize, scale, resolved } = written_source(new, ctx);
    let source: &Source = &written;
    match &span.source_value {
        // Only the source's value changes (a solve's new samples): what `sync_spectrum` does to the
        // document is to replace that value, keeping the key and the text around it, so the writer's value
        // ([`source_text`]) goes in at the span the reader saw and no document of the table is built.
        Some(v) if only_the_value_changes(old, new, source, normalize, scale) => {
            out.push_str(piece.get(..v.start)?);
            match source {
                Source::Samples(values) => {
                    super::write::push_samples_text(out, values, if layout.crlf { "\r\n" } else { "\n" })
                }
                other => {
                    let value = source_text(other);
                    out.push_str(&if layout.crlf { value.replace('\n', "\r\n") } else { value });
                }
            }
            out.push_str(piece.get(v.end..)?);
        }
        _ => out.push_str(&rewrite_document(layout, span, old, new, ctx, source)?),
    }
    // The entry as reading the new table gives it: the written source, resolved as the reader resolves
    // it (debug builds read the whole text back and compare). When that is the resolve `written_source`
    // made (the entry's own source, normalisation and scale), its spectrum; else resolved here, also when
    // the entry is not kept: a source that does not resolve makes no save by tables.
    let normalize = if new.kind == Kind::Light { normalize } else { crate::spectrum::Normalize::default() };
    let spectrum = match resolved {
        Some(spectrum) if normalize == new.normalize && scale == new.scale => spectrum,
        _ => ctx.resolve(source, new.kind, normalize, scale)?,
    };
    if !keep {
        return Some(None);
    }
    Some(Some(SpectrumEntry {
        name: new.name.clone(),
        kind: new.kind,
        source: written.into_owned(),
        normalize,
        scale,
        design: new.design,
        bounds: new.bounds,
        dial: new.dial,
        spectrum,
    }))
}

/// The tables (headers and inline tables, [`super::budget::count`]) in `piece`, the text of the table at
/// `span` which says `old`. A `samples` value as read is an array of numbers, which holds none: only the
/// text around it is scanned (the array was nine tenths of a designed spectrum's table, and scanning it
/// a tenth of a solve's save).
fn tables_in(piece: &str, span: &TableSpan, old: &SpectrumEntry) -> Option<u64> {
    let count = |text: &str| super::budget::count(text).tables;
    Some(match &span.source_value {
        Some(v) if matches!(old.source, Source::Samples(_)) => {
            count(piece.get(..v.start)?) + count(piece.get(v.end..)?)
        }
        _ => count(piece),
    })
}

/// True when `sync_spectrum` would change nothing in the table of `old` but its source's value: the same
/// source key, name, normalisation and scale (the other keys are the same, see [`same_but_spectrum`]).
fn only_the_value_changes(
    old: &SpectrumEntry,
    new: &SpectrumEntry,
    source: &Source,
    normalize: crate::spectrum::Normalize,
    scale: f64,
) -> bool {
    old.source != *source
        && old.source.key() == source.key()
        && old.name == new.name
        && (old.kind != Kind::Light || old.normalize == normalize)
        && old.scale == scale
        && same_but_spectrum(old, new)
}

/// The new text of the table at `span` through a `toml_edit` document of it, updated by `sync_spectrum`
/// (line endings as the whole document is printed).
fn rewrite_document(
    layout: &Layout,
    span: &TableSpan,
    old: &SpectrumEntry,
    new: &SpectrumEntry,
    ctx: &SaveContext,
    source: &Source,
) -> Option<String> {
    let piece = layout.text.get(span.range.clone())?;
    // A source the writer replaces need not be parsed: its value (a solve's old samples, most of the
    // table's text) is read as a placeholder; the key and the text around the value are kept.
    let placeholder;
    let piece = match &span.source_value {
        Some(v) if old.source != *source => {
            placeholder = format!("{}0{}", piece.get(..v.start)?, piece.get(v.end..)?);
            placeholder.as_str()
        }
        _ => piece,
    };
    let list = if old.kind == Kind::Light { "lights" } else { "reflectances" };
    let mut document: DocumentMut = piece.parse().ok()?;
    if document.len() != 1 {
        return None;
    }
    let aot = document.get_mut(list)?.as_array_of_tables_mut()?;
    if aot.len() != 1 {
        return None;
    }
    sync_spectrum(aot.get_mut(0)?, Some(old), new, ctx);
    // As the whole document is printed: the file's final newline (or none) and line endings.
    let mut text = document.to_string();
    if span.range.end == layout.text.len() && layout.no_final_newline && text.ends_with('\n') {
        text.pop();
    }
    Some(if layout.crlf { text.replace("\r\n", "\n").replace('\n', "\r\n") } else { text })
}

#[cfg(test)]
mod tests;
