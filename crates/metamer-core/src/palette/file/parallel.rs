//! Parsing a long palette file in pieces on several threads. A palette of thousands of spectra is mostly a
//! run of `[[lights]]`, `[[reflectances]]` and `[[colours]]` tables; the text is cut at such header lines
//! into a few pieces, each piece is parsed on its own, and the arrays of tables are joined in order.
//!
//! The result is the document the whole-text parse gives, or `None` (the caller then parses the whole
//! text): a cut inside a string, array or inline table leaves the piece before it unterminated, so that
//! piece fails to parse; every piece after the first must consist of arrays of tables only (a `[table]`
//! header there, which could refer to an earlier piece, gives `None`); and a key the first piece defines
//! other than by `[[key]]` headers may not be continued by a later piece (the whole-text parse would
//! refuse that). Spans in the joined tree count from each piece's start; the splice spans are computed per
//! piece with its offset, and error messages (which need spans) come from the whole-text parse.

use super::read;
use super::splice::Spans;
use rayon::prelude::*;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// Texts shorter than this are parsed whole.
const MIN_PIECE: usize = 64 * 1024;

/// A document parsed in pieces (its numbers checked with [`read::check_numbers`]).
pub(super) struct Parsed<'i> {
    pub root: DeTable<'i>,
    pub spans: Option<Spans>,
}

/// Where the text is cut: starts of lines beginning with `[[`, about `len / pieces` apart.
fn cuts(text: &str, pieces: usize) -> Vec<usize> {
    let step = text.len() / pieces;
    let mut out = vec![0];
    let mut from = step;
    while from < text.len() {
        let Some(p) = text.get(from..).and_then(|t| t.find("\n[[")) else { break };
        let at = from + p + 1;
        out.push(at);
        from = at + step;
    }
    out
}

/// Is every element of `items` a table opened by a `[[…]]` header in `piece`?
fn headed_tables(piece: &str, items: &[Spanned<DeValue>]) -> bool {
    items.iter().all(|e| e.get_ref().is_table() && piece.get(e.span()).is_some_and(|h| h.starts_with("[[")))
}

/// Parse `text` in pieces when it is long and shaped for it (see the module docs).
pub(super) fn parse(text: &str) -> Option<Parsed<'_>> {
    let pieces = (text.len() / MIN_PIECE).min(4 * rayon::current_num_threads());
    if pieces < 2 {
        return None;
    }
    let cuts = cuts(text, pieces);
    if cuts.len() < 2 {
        return None;
    }
    let bounds: Vec<(usize, usize)> =
        cuts.iter().enumerate().map(|(i, &a)| (a, cuts.get(i + 1).copied().unwrap_or(text.len()))).collect();
    let parsed: Vec<(Spanned<DeTable>, Option<Spans>)> = bounds
        .par_iter()
        .map(|&(a, b)| {
            let piece = text.get(a..b)?;
            let root = DeTable::parse(piece).ok()?;
            // A number TOML cannot hold is an error, reported by the whole-text parse.
            if root.get_ref().values().any(|v| read::check_numbers(v).is_some()) {
                return None;
            }
            let spans = Spans::of_piece(root.get_ref(), a);
            Some((root, spans))
        })
        .collect::<Option<_>>()?;
    let mut parsed = parsed.into_iter().zip(&bounds);
    let ((first, mut spans), &(a0, b0)) = parsed.next()?;
    let first_text = text.get(a0..b0)?;
    let mut root = first.into_inner();
    // Keys whose arrays are known to be made of `[[key]]` tables.
    let mut continued: Vec<String> = Vec::new();
    for ((piece, piece_spans), &(a, b)) in parsed {
        let piece_text = text.get(a..b)?;
        match (&mut spans, piece_spans) {
            (Some(s), Some(p)) => s.extend(p),
            (s, _) => *s = None,
        }
        for (key, value) in piece.into_inner() {
            let span = value.span();
            let DeValue::Array(items) = value.into_inner() else { return None };
            if !headed_tables(piece_text, &items) {
                return None;
            }
            let name: &str = key.get_ref();
            match root.get_mut(name) {
                Some(existing) => {
                    let DeValue::Array(list) = existing.get_mut() else { return None };
                    // An array of the first piece must have been opened by `[[name]]` headers too.
                    if !continued.iter().any(|c| c == name) {
                        if !headed_tables(first_text, list) {
                            return None;
                        }
                        continued.push(name.to_string());
                    }
                    for item in items {
                        list.push(item);
                    }
                }
                None => {
                    // Opened by a later piece: already checked.
                    continued.push(name.to_string());
                    root.insert(key, Spanned::new(span, DeValue::Array(items)));
                }
            }
        }
    }
    Some(Parsed { root, spans })
}

#[cfg(test)]
mod tests {
    use super::super::read::Reader;
    use super::*;
    use crate::colorimetry::Colorimetry;
    use std::path::Path;

    /// A long palette: `n` designed reflectances under two lights, with comments and a multi-line string.
    fn long_palette(n: usize) -> String {
        let samples = (0..31).map(|i| format!("{}", 0.25 + i as f64 / 64.0)).collect::<Vec<_>>().join(", ");
        let mut t = String::from("name = \"long\"\n[settings]\nreflectance_bounds = [0.0, 1.0]\n\n");
        for l in ["a", "b"] {
            t += &format!("[[lights]]\nname = \"{l}\"\nsamples = [{samples}]\nnormalize = \"none\"\n\n");
        }
        for i in 0..n {
            t += &format!(
                "# reflectance {i}\n[[reflectances]]\nname = \"r{i}\"\nsamples = [\n    {samples},\n]\ndesign = true\n\n"
            );
        }
        for i in 0..n {
            for l in ["a", "b"] {
                t += &format!("[[colours]]\nlight = \"{l}\"\nreflectance = \"r{i}\"\ntarget = [0.1, 0.2, 0.3]\n\n");
            }
        }
        t
    }

    fn read(root: &DeTable) -> crate::palette::Palette {
        let reader = Reader::new(Path::new("long.toml"), Colorimetry::default().luminance());
        reader.read(root).map(|o| o.palette).unwrap()
    }

    #[test]
    fn pieces_give_the_whole_document() {
        let text = long_palette(1500);
        let whole = DeTable::parse(&text).unwrap();
        let parsed = parse(&text).expect("a long regular palette is parsed in pieces");
        assert_eq!(read(&parsed.root), read(whole.get_ref()));
        assert_eq!(parsed.spans, Spans::of(whole.get_ref()));
        assert!(parsed.spans.is_some());
    }

    #[test]
    fn unusual_shapes_are_left_to_the_whole_text_parse() {
        let text = long_palette(1500);
        let mid = text.len() / 2 + text[text.len() / 2..].find("\n[[").unwrap() + 1;
        // A table header after the first piece (it could refer to an array of an earlier piece).
        let header = format!("{}[lights.extra]\nx = 1\n{}", &text[..mid], &text[mid..]);
        assert!(parse(&header).is_none());
        // A static array in the first piece continued by `[[colours]]` headers: the whole parse refuses it.
        let fixed = text.replacen("[settings]", "colours = [{ light = \"a\", reflectance = \"r0\" }]\n[settings]", 1);
        assert!(parse(&fixed).is_none());
        assert!(DeTable::parse(&fixed).is_err());
        // A number TOML cannot hold, late in the file: the whole-text path reports it.
        let overflow = format!("{}{}", &text[..mid], text[mid..].replacen("0.1, 0.2", "1e400, 0.2", 1));
        assert!(parse(&overflow).is_none());
        // A multi-line string over the would-be cuts of the first half.
        let opened = text[..mid].replacen("name = \"long\"", "name = \"long\"\nnote = \"\"\"", 1);
        let string = format!("{opened}\"\"\"\n");
        assert!(DeTable::parse(&string).is_ok());
        assert!(parse(&string).is_none());
    }

    /// Differential check: snippets that open or close strings, arrays and tables, duplicate keys or add
    /// headers, inserted at random line starts of a long palette. Whenever the pieces give a document, the
    /// whole text must parse and the reader must see the same palette (or fail on both).
    #[test]
    fn random_insertions_never_make_the_pieces_disagree_with_the_whole_text() {
        let base = long_palette(1500);
        let lines: Vec<usize> = std::iter::once(0)
            .chain(base.match_indices('\n').map(|(i, _)| i + 1))
            .filter(|&i| i < base.len())
            .collect();
        let snippets = [
            "\"\"\"\n",
            "'''\n",
            "samples = [\n",
            "]\n",
            "]]\n",
            "[extra]\n",
            "[[lights]]\n",
            "[[colours]]\nlight = \"a\"\n",
            "name = \"dup\"\n",
            "x = 1\n",
            "# [[reflectances]]\n",
            "note = \"\"\"\n[[reflectances]]\n\"\"\"\n",
            "t = { a = [\n",
        ];
        let mut seed = 0x5eed_u64;
        let mut next = |n: usize| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 33) as usize) % n
        };
        let reader = || Reader::new(Path::new("long.toml"), Colorimetry::default().luminance());
        let (mut in_pieces, mut cases) = (0, 0);
        for _ in 0..24 {
            let mut text = base.clone();
            let mut at: Vec<usize> = (0..1 + next(3)).map(|_| lines[next(lines.len())]).collect();
            at.sort_unstable_by(|a, b| b.cmp(a));
            for p in at {
                text.insert_str(p, snippets[next(snippets.len())]);
            }
            cases += 1;
            let Some(parsed) = parse(&text) else { continue };
            in_pieces += 1;
            let whole = DeTable::parse(&text).expect("the pieces parsed, so the whole text must");
            let a = reader().read(&parsed.root).map(|o| o.palette).ok();
            let b = reader().read(whole.get_ref()).map(|o| o.palette).ok();
            assert_eq!(a, b);
        }
        assert!(in_pieces > 0 && in_pieces < cases, "{in_pieces} of {cases} parsed in pieces");
    }
}
