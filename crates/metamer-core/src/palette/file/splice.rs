//! Saving by splicing: when a save changes only how spectra are given (a designed spectrum's new `samples`,
//! its `normalize` or `scale`) — what a solve does — the new values are written into the text as read, at
//! the byte ranges the parser reported for the old ones. Everything else stays byte-identical, as the
//! document-based writer ([`super::write`]) would leave it, without building and printing a whole
//! `toml_edit` document (which dominates saving a palette of thousands of spectra).
//!
//! The splice writes exactly what [`super::write::update_document`] writes for those keys (same sources
//! chosen by [`written_source`], same float and string notation, same samples layout, the key's place and
//! the text around it kept); `tests/palette_file.rs` checks the two agree. Anything else (renames, added or
//! removed entries, settings, cells, a CSV path to rebase, a key that must be added) goes to that writer.

use super::write::{SaveContext, samples_text, string_text, written_source};
use crate::palette::{Kind, Palette, Source, SpectrumEntry};
use crate::spectrum::Normalize;
use rayon::prelude::*;
use std::ops::Range;
use toml::de::{DeTable, DeValue};

/// Where one spectrum's keys sit in the text.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct EntrySpans {
    /// The source key (`samples`, `flat`, …) and its value.
    source_key: Range<usize>,
    source_value: Range<usize>,
    /// The source key is `samples` (the value alone is replaced).
    samples: bool,
    /// Values of `normalize` and `scale`, when the table has them.
    normalize: Option<Range<usize>>,
    scale: Option<Range<usize>>,
}

/// The spans of every light and reflectance, in model order.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Spans {
    lights: Vec<EntrySpans>,
    reflectances: Vec<EntrySpans>,
}

impl Spans {
    /// The spans of a parsed document the reader accepted (`None` when its lists are not shaped as
    /// expected, which then saves through the document writer).
    pub(super) fn of(root: &DeTable) -> Option<Spans> {
        Spans::of_piece(root, 0)
    }

    /// The spans of a piece of a document that starts at byte `offset` of the text (its spans count from
    /// the piece's start).
    pub(super) fn of_piece(root: &DeTable, offset: usize) -> Option<Spans> {
        Some(Spans {
            lights: list_spans(root, "lights", offset)?,
            reflectances: list_spans(root, "reflectances", offset)?,
        })
    }

    /// These spans followed by those of the next piece.
    pub(super) fn extend(&mut self, next: Spans) {
        self.lights.extend(next.lights);
        self.reflectances.extend(next.reflectances);
    }

    /// The spans after `edits` (sorted, non-overlapping; each replaces exactly one tracked span or none).
    fn shifted(&self, edits: &[Edit]) -> Spans {
        let map = |r: &Range<usize>| -> Range<usize> {
            let before: isize = edits.iter().take_while(|e| e.range.end <= r.start).map(Edit::delta).sum();
            let start = (r.start as isize + before) as usize;
            match edits.iter().find(|e| e.range == *r) {
                Some(e) => start..start + e.text.len(),
                None => start..start + r.len(),
            }
        };
        let entry = |e: &EntrySpans| EntrySpans {
            source_key: map(&e.source_key),
            source_value: map(&e.source_value),
            samples: e.samples,
            normalize: e.normalize.as_ref().map(map),
            scale: e.scale.as_ref().map(map),
        };
        Spans {
            lights: self.lights.iter().map(entry).collect(),
            reflectances: self.reflectances.iter().map(entry).collect(),
        }
    }

    /// After a splice that renamed a source key to `samples`.
    fn mark_samples(&mut self, kind: Kind, index: usize) {
        let list = if kind == Kind::Light { &mut self.lights } else { &mut self.reflectances };
        if let Some(e) = list.get_mut(index) {
            e.samples = true;
        }
    }
}

fn list_spans(root: &DeTable, list: &str, offset: usize) -> Option<Vec<EntrySpans>> {
    let Some(v) = root.get(list) else { return Some(Vec::new()) };
    let items = v.get_ref().as_array()?;
    items.iter().map(|item| entry_spans(item.get_ref().as_table()?, offset)).collect()
}

fn entry_spans(t: &DeTable, offset: usize) -> Option<EntrySpans> {
    let at = |r: Range<usize>| r.start + offset..r.end + offset;
    let mut present = Source::KEYS.iter().filter_map(|k| t.get_key_value(*k).map(|kv| (*k, kv)));
    let (name, (key, value)) = present.next()?;
    if present.next().is_some() {
        return None;
    }
    let value_span = |k: &str| t.get(k).map(|v| at(v.span()));
    Some(EntrySpans {
        source_key: at(key.span()),
        source_value: at(value.span()),
        samples: name == "samples",
        normalize: value_span("normalize"),
        scale: value_span("scale"),
    })
}

/// Replace `range` of the text by `text`.
#[derive(Clone, Debug)]
struct Edit {
    range: Range<usize>,
    text: String,
    /// What the new text must read as (checked after writing it).
    expect: Expect,
}

#[derive(Clone, Debug)]
enum Expect {
    Key,
    Samples(Vec<f64>),
    Float(f64),
    String(&'static str),
}

impl Edit {
    fn delta(&self) -> isize {
        self.text.len() as isize - self.range.len() as isize
    }

    /// The new text reads back as intended. Samples are checked number by number (each parses back to the
    /// same bits; the brackets and commas around them are `samples_text`'s); other values by the TOML parser.
    fn check(&self) -> bool {
        match &self.expect {
            Expect::Key => return self.text == "samples",
            Expect::Samples(want) => {
                let Some(inner) = self.text.strip_prefix('[').and_then(|t| t.strip_suffix(']')) else { return false };
                let mut numbers = inner.split(',').map(str::trim).filter(|t| !t.is_empty());
                return want.iter().all(|w| {
                    numbers.next().and_then(|t| t.parse::<f64>().ok()).is_some_and(|x| x.to_bits() == w.to_bits())
                }) && numbers.next().is_none();
            }
            _ => {}
        }
        let Ok(v) = DeValue::parse(&self.text) else { return false };
        let float = |v: &DeValue| v.as_float().and_then(|f| f.as_str().parse::<f64>().ok());
        match (&self.expect, v.get_ref()) {
            (Expect::Float(want), x) => float(x).is_some_and(|x| x.to_bits() == want.to_bits()),
            (Expect::String(want), DeValue::String(s)) => s == want,
            _ => false,
        }
    }
}

/// A splice that worked: the new text and what the file now says.
pub(super) struct Spliced {
    pub text: String,
    pub palette: Palette,
    pub spans: Spans,
}

/// Entries of the two palettes that only differ in how their spectrum is given.
fn same_but_spectrum(a: &SpectrumEntry, b: &SpectrumEntry) -> bool {
    a.name == b.name && a.kind == b.kind && a.design == b.design && a.bounds == b.bounds && a.dial == b.dial
}

/// The text of saving `new` over the file `text` (which says `old`, with `spans`), or `None` when the change
/// is more than splicing can write.
pub(super) fn splice(
    text: &str,
    spans: &Spans,
    old: &Palette,
    new: &Palette,
    ctx: &SaveContext,
    crlf: bool,
) -> Option<Spliced> {
    let same_shape = old.name == new.name
        && old.settings == new.settings
        && old.colours == new.colours
        && old.free == new.free
        && old.lights.len() == new.lights.len()
        && old.reflectances.len() == new.reflectances.len()
        && spans.lights.len() == old.lights.len()
        && spans.reflectances.len() == old.reflectances.len()
        && old.lights.iter().zip(&new.lights).all(|(a, b)| same_but_spectrum(a, b))
        && old.reflectances.iter().zip(&new.reflectances).all(|(a, b)| same_but_spectrum(a, b));
    // A CSV source saved into another folder gets a rebased path: the document writer does that.
    let moves_csv = || {
        let same_dir = ctx.old_base.is_some_and(|b| super::write::same_dir(b, ctx.new_base));
        !same_dir && new.lights.iter().chain(&new.reflectances).any(|e| matches!(e.source, Source::Csv(_)))
    };
    if !same_shape || moves_csv() {
        return None;
    }
    let newline = if crlf { "\r\n" } else { "\n" };
    let pairs = old.lights.iter().zip(&new.lights).zip(&spans.lights).enumerate();
    let pairs = pairs.chain(old.reflectances.iter().zip(&new.reflectances).zip(&spans.reflectances).enumerate());
    let changed: Vec<(usize, &SpectrumEntry, &SpectrumEntry, &EntrySpans)> =
        pairs.filter(|(_, ((o, n), _))| o != n).map(|(i, ((o, n), s))| (i, o, n, s)).collect();
    // Per changed entry: its edits and the entry as the file will then read, or None when it cannot splice.
    let planned: Option<Vec<(Vec<Edit>, SpectrumEntry)>> =
        changed.par_iter().map(|(_, o, n, s)| plan_entry(o, n, s, ctx, newline)).collect();
    let planned = planned?;
    let mut edits: Vec<Edit> = planned.iter().flat_map(|(e, _)| e.iter().cloned()).collect();
    edits.sort_by_key(|e| e.range.start);
    if edits.windows(2).any(|w| w[0].range.end > w[1].range.start) || edits.iter().any(|e| e.range.end > text.len()) {
        return None;
    }
    if !edits.par_iter().all(Edit::check) {
        return None;
    }
    let growth: isize = edits.iter().map(Edit::delta).sum();
    let mut out = String::with_capacity((text.len() as isize + growth.max(0)) as usize);
    let mut at = 0;
    for e in &edits {
        out.push_str(text.get(at..e.range.start)?);
        out.push_str(&e.text);
        at = e.range.end;
    }
    out.push_str(text.get(at..)?);
    let mut palette = old.clone();
    let mut new_spans = spans.shifted(&edits);
    for ((i, o, _, _), (_, entry)) in changed.iter().zip(planned) {
        let list = if o.kind == Kind::Light { &mut palette.lights } else { &mut palette.reflectances };
        if matches!(entry.source, Source::Samples(_)) {
            new_spans.mark_samples(o.kind, *i);
        }
        list[*i] = entry;
    }
    Some(Spliced { text: out, palette, spans: new_spans })
}

/// The edits that make the table of `old` say `new`, and the entry as the file will then read.
fn plan_entry(
    old: &SpectrumEntry,
    new: &SpectrumEntry,
    spans: &EntrySpans,
    ctx: &SaveContext,
    newline: &str,
) -> Option<(Vec<Edit>, SpectrumEntry)> {
    let (source, normalize, scale) = written_source(new, ctx);
    let mut edits = Vec::new();
    if old.source != source {
        let Source::Samples(values) = &source else { return None };
        if !spans.samples {
            edits.push(Edit { range: spans.source_key.clone(), text: "samples".into(), expect: Expect::Key });
        }
        edits.push(Edit {
            range: spans.source_value.clone(),
            text: samples_text(values, newline),
            expect: Expect::Samples(values.clone()),
        });
    }
    // As `sync_value`: a changed value is written over the old one; a default need not be added.
    if new.kind == Kind::Light && old.normalize != normalize {
        match &spans.normalize {
            Some(r) => edits.push(Edit {
                range: r.clone(),
                text: string_text(normalize.as_str()),
                expect: Expect::String(normalize.as_str()),
            }),
            None if normalize == Normalize::default() => {}
            None => return None,
        }
    }
    if old.scale != scale {
        match &spans.scale {
            Some(r) => edits.push(Edit {
                range: r.clone(),
                text: super::write::float_text(scale),
                expect: Expect::Float(scale),
            }),
            None if scale == 1.0 => {}
            None => return None,
        }
    }
    // What reading the new text gives: the written source, resolved as the reader resolves it.
    let raw = match &source {
        Source::Csv(file) => ctx.csv_raw.get(file).copied().or_else(|| source.raw_spectrum(ctx.old_base).ok())?,
        other => other.raw_spectrum(None).ok()?,
    };
    let normalize = if new.kind == Kind::Light { normalize } else { Normalize::default() };
    let spectrum = crate::palette::source::finish(&raw, new.kind, normalize, scale, &ctx.luminance).ok()?;
    Some((edits, SpectrumEntry { source, normalize, scale, spectrum, ..new.clone() }))
}

#[cfg(test)]
mod tests {
    use super::super::PaletteFile;
    use crate::palette::{Palette, Source};
    use crate::spectrum::{Normalize, SAMPLES, Spectrum};
    use std::path::{Path, PathBuf};

    /// What a solve does to the designed spectra (and, here, to every other spectrum in `every`).
    fn solved(p: &Palette, every: usize) -> Palette {
        let mut p = p.clone();
        let mut k = 0;
        for e in p.lights.iter_mut().chain(p.reflectances.iter_mut()) {
            k += 1;
            if e.design || k % every == 0 {
                let s = Spectrum(crate::spectrum::Samples::from_fn(|i, _| {
                    0.01 + (i as f64 * 0.37 + k as f64).sin().abs() / (1.0 + i as f64) * 0.9
                }));
                e.spectrum = s;
                e.source = Source::Samples(s.to_vec());
                e.normalize = Normalize::None;
                e.scale = 1.0;
            }
        }
        p
    }

    /// The texts the tests splice into: the example palettes, the fuzz findings and some awkward layouts.
    fn texts() -> Vec<(PathBuf, String)> {
        // The repository root: this crate lives in crates/metamer-core.
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut out = Vec::new();
        for dir in [root.join("palettes"), root.join("tests/data/fuzz")] {
            for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
                let path = entry.path();
                if path.extension().is_some_and(|e| e == "toml") {
                    out.push((path.clone(), std::fs::read_to_string(&path).unwrap_or_default()));
                }
            }
        }
        assert!(out.len() >= 3, "the example palettes were not found under {}", root.display());
        let samples = (0..SAMPLES).map(|i| format!("{}", 0.5 + i as f64 / 100.0)).collect::<Vec<_>>().join(", ");
        let awkward = [
            // Comments after values, a quoted source key, scale and normalize keys, CRLF and a BOM.
            format!(
                "\u{feff}name = \"a\"\r\n\r\n[[lights]]\r\nname = \"e\" # the light\r\n\"samples\" = [{samples}] # measured\r\nnormalize = \"luminance\"\r\nscale = 2.0\r\ndesign = true\r\n\r\n[[reflectances]]\r\nname = \"r\"\r\nflat = 0.5   # grey\r\ndesign = true\r\n\r\n[[colours]]\r\nlight = \"e\"\r\nreflectance = \"r\"\r\ntarget = \"#808080\"\r\n"
            ),
            // Inline tables, no final newline.
            format!(
                "lights = [{{ name = \"e\", illuminant = \"D65\", normalize = \"none\", design = true }}]\nreflectances = [\n  {{ name = \"r\", samples = [{samples}], design = true }},\n  {{ name = \"s\", colorchecker = \"dark_skin\" }},\n]\ncolours = [{{ light = \"e\", reflectance = \"r\", target = [0.1, 0.2, 0.3] }}]"
            ),
        ];
        for (i, text) in awkward.into_iter().enumerate() {
            out.push((PathBuf::from(format!("awkward{i}.toml")), text));
        }
        out
    }

    #[test]
    fn splicing_writes_what_the_document_writer_writes() {
        let mut spliced = 0;
        for (path, text) in texts() {
            let Ok(file) = PaletteFile::parse(&text, &path) else { continue };
            for every in [1, 2, 1000] {
                let p = solved(&file.palette, every);
                let Some(s) = file.splice(&p, &path) else { continue };
                spliced += 1;
                let (document, reread) = file.render(&p, &path).unwrap();
                assert_eq!(s.text, file.text_of(&document), "{} (every {every})", path.display());
                assert_eq!(s.palette, reread.palette, "{}", path.display());
                assert_eq!(Some(&s.spans), reread.spans.as_ref(), "{}", path.display());
            }
        }
        assert!(spliced >= 8, "only {spliced} palettes were spliced");
    }

    #[test]
    fn changes_beyond_values_go_to_the_document_writer() {
        let (path, text) = texts().pop().unwrap();
        let file = PaletteFile::parse(&text, &path).unwrap();
        let p = solved(&file.palette, 1);
        assert!(file.splice(&p, &path).is_some());
        let mut renamed = p.clone();
        renamed.reflectances[0].name = "renamed".into();
        assert!(file.splice(&renamed, &path).is_none());
        let mut reweighted = p.clone();
        reweighted.colours[0].weight = 3.0;
        assert!(file.splice(&reweighted, &path).is_none());
        // A designed light saved as samples must now say `normalize = "none"`, a key its table lacks.
        let text = "[[lights]]\nname = \"e\"\nilluminant = \"D65\"\ndesign = true\n\n[[reflectances]]\nname = \"r\"\nflat = 0.5\n";
        let file = PaletteFile::parse(text, &path).unwrap();
        assert!(file.splice(&solved(&file.palette, 1000), &path).is_none());
    }

    #[test]
    fn repeated_splices_keep_their_places() {
        let (path, text) = texts().remove(texts().len() - 2);
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("p.toml");
        let mut file = PaletteFile::parse(&text, &path).unwrap();
        for every in [1, 2, 3] {
            let p = solved(&file.palette, every);
            assert!(file.splice(&p, &target).is_some());
            file.save_as(&p, &target).unwrap();
            let reread = PaletteFile::load(&target).unwrap();
            assert_eq!(reread.palette, file.palette);
            assert_eq!(reread.spans, file.spans);
        }
    }
}
