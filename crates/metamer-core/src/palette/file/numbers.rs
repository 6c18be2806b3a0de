//! The numeric `samples = [ ... ]` arrays of a palette (and the cells' `target = [r, g, b]`, [`KEYS`]),
//! read by hand before the TOML parse.
//!
//! Why this exists: measured on a palette of 1200 designed reflectances (`metamer solve`, whole process),
//! `toml`'s generic parse of the spectra's sample arrays was the largest single cost: every sample becomes a
//! spanned value holding its text, is moved when the parse runs in pieces, checked and parsed again by the
//! reader. A sample array is a run of numbers; this reads it directly into `f64`s.
//!
//! How it stays exact: only an array this module fully understands is read (a line `samples = [`, then
//! decimal integers and floats as TOML spells them, with no underscores, no `inf`/`nan`, separated by commas
//! and blanks or line feeds, an optional trailing comma, no comment); anything else is left in the text for
//! the parser. A read array's text is replaced by spaces of the same length in a copy of the piece of text
//! the events' parse reads ([`super::events`]), so the parser sees an empty array at the same span and every
//! other span is unchanged. The reader takes
//! the numbers of an empty `samples` array at exactly a read array's span ([`Read::take`]); the palette is
//! accepted from this path only when the parse and the read succeed and every read array was taken (so none
//! was, say, inside a multi-line string). Otherwise the original text is parsed as before, so errors and
//! results are those of the parser alone. Tests compare both paths (a property test and every shipped
//! palette).

use std::borrow::Cow;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};

/// The keys whose arrays are read: a spectrum's `samples` and a colour cell's `target` (`[r, g, b]`; a
/// batch of designs has three cells per spectrum, and their targets were half of the numbers the parser
/// read and checked).
pub(super) const KEYS: [&str; 2] = ["samples", "target"];

/// The arrays read from a text, by span (in text order), and which of them the reader took. The numbers of
/// the arrays of each piece of the text read sit in one vector (a batch of designs has thousands of arrays:
/// one allocation a piece, not one an array, kept as the piece's pass filled it; the reader borrows them).
pub(super) struct Read {
    /// The pieces that hold arrays, in text order.
    pieces: Vec<ReadPiece>,
    taken: Vec<AtomicBool>,
}

/// The arrays read from a piece of a text: each array's span and where its numbers sit in the piece's
/// values, and the values.
pub(super) type PieceArrays = (Vec<(Range<usize>, Range<usize>)>, Vec<f64>);

/// The arrays read from one piece of a text.
struct ReadPiece {
    /// Each array's span in the text and where its numbers sit in `values`, in text order.
    arrays: Vec<(Range<usize>, Range<usize>)>,
    values: Vec<f64>,
    /// The index of its first array among all the pieces' (in [`Read::taken`]).
    first: usize,
}

impl Read {
    /// The numbers of the array read at exactly `span`, marked as taken (`None` when none was read there).
    pub(super) fn take(&self, span: &Range<usize>) -> Option<&[f64]> {
        // The last piece whose first array starts at or before the span.
        let p = self.pieces.partition_point(|p| p.arrays[0].0.start <= span.start);
        let piece = &self.pieces[p.checked_sub(1)?];
        let i = piece.arrays.binary_search_by_key(&span.start, |(r, _)| r.start).ok()?;
        let (range, values) = &piece.arrays[i];
        if range != span {
            return None;
        }
        self.taken[piece.first + i].store(true, Ordering::Relaxed);
        piece.values.get(values.clone())
    }

    /// Every read array was taken by the reader.
    pub(super) fn all_taken(&self) -> bool {
        self.taken.iter().all(|t| t.load(Ordering::Relaxed))
    }
}

impl Read {
    /// The arrays read (in any order; kept in text order).
    pub(super) fn new(arrays: Vec<(Range<usize>, Vec<f64>)>) -> Read {
        let mut values = Vec::with_capacity(arrays.iter().map(|(_, v)| v.len()).sum());
        let mut spans = Vec::with_capacity(arrays.len());
        for (span, v) in arrays {
            spans.push((span, values.len()..values.len() + v.len()));
            values.extend_from_slice(&v);
        }
        Read::pieces(vec![(spans, values)])
    }

    /// The arrays read from each piece of a text, pieces in text order (within a piece in any order; kept in
    /// text order), each with where its numbers sit in its piece's values.
    pub(super) fn pieces(pieces: Vec<PieceArrays>) -> Read {
        let mut first = 0;
        let pieces: Vec<ReadPiece> = pieces
            .into_iter()
            .filter(|(arrays, _)| !arrays.is_empty())
            .map(|(mut arrays, values)| {
                // In text order ([`Read::take`] searches by start); arrays of different keys never overlap (an
                // array read holds only numbers, commas and blanks).
                if !arrays.is_sorted_by_key(|(range, _)| range.start) {
                    arrays.sort_unstable_by_key(|(range, _)| range.start);
                }
                first += arrays.len();
                ReadPiece { first: first - arrays.len(), arrays, values }
            })
            .collect();
        let taken = (0..first).map(|_| AtomicBool::new(false)).collect();
        Read { pieces, taken }
    }

    /// How many arrays were read.
    pub(super) fn len(&self) -> usize {
        self.taken.len()
    }

    /// Every array read: its span and its numbers, in text order.
    #[cfg(test)]
    pub(super) fn arrays(&self) -> Vec<(Range<usize>, &[f64])> {
        self.pieces
            .iter()
            .flat_map(|p| p.arrays.iter().map(|(span, at)| (span.clone(), &p.values[at.clone()])))
            .collect()
    }
}

/// `piece` (which starts at byte `offset` of the text) with the insides of the `arrays` read from it (spans
/// in the whole text) replaced by spaces, line feeds too: the parser sees an empty array at the same span
/// (one blank run, not a token per line), and every other span is unchanged. Line numbers inside the arrays
/// change, which no one reads: the events' path reports no error (any error is the whole parse's). Borrowed
/// as it is when no array was read.
pub(super) fn blank<'t>(piece: &'t str, offset: usize, arrays: &[(Range<usize>, Vec<f64>)]) -> Option<Cow<'t, str>> {
    if arrays.is_empty() {
        return Some(Cow::Borrowed(piece));
    }
    let mut blanked = piece.as_bytes().to_vec();
    for (range, _) in arrays {
        blanked.get_mut(range.start + 1 - offset..range.end - 1 - offset)?.fill(b' ');
    }
    // Only ASCII bytes of the arrays were replaced by spaces: the text is still UTF-8.
    String::from_utf8(blanked).ok().map(Cow::Owned)
}

/// The arrays of [`KEYS`] whose key starts in `text[piece]`, in text order: a line at a time (a key is read
/// only after nothing but blanks on its line), the next line found by the standard library's byte search.
pub(super) fn arrays_in(text: &str, piece: Range<usize>) -> Vec<(Range<usize>, Vec<f64>)> {
    let b = text.as_bytes();
    let end = piece.end.min(b.len());
    let mut arrays = Vec::new();
    let mut line = piece.start;
    while line < end {
        let mut next = line;
        let i = skip_blanks(b, line);
        if let Some(name) = KEYS.iter().find(|k| b.get(i..).is_some_and(|r| r.starts_with(k.as_bytes()))) {
            let j = skip_blanks(b, i + name.len());
            if b.get(j) == Some(&b'=') {
                let j = skip_blanks(b, j + 1);
                if let Some((after, values)) = array(text, j) {
                    arrays.push((j..after, values));
                    next = after;
                }
            }
        }
        match text.get(next..end).and_then(|rest| rest.find('\n')) {
            Some(p) => line = next + p + 1,
            None => break,
        }
    }
    arrays
}

fn skip_blanks(b: &[u8], mut i: usize) -> usize {
    while matches!(b.get(i), Some(b' ' | b'\t')) {
        i += 1;
    }
    i
}

/// Blanks, line feeds and CRLFs inside an array.
fn skip_array_space(b: &[u8], mut i: usize) -> usize {
    loop {
        match b.get(i) {
            Some(b' ' | b'\t' | b'\n') => i += 1,
            Some(b'\r') if b.get(i + 1) == Some(&b'\n') => i += 2,
            _ => return i,
        }
    }
}

/// A non-empty array of numbers starting at `b[i] == '['`: the index past its `]` and its values.
pub(super) fn array(t: &str, i: usize) -> Option<(usize, Vec<f64>)> {
    let mut values = Vec::with_capacity(crate::spectrum::SAMPLES);
    array_into(t, i, &mut values).map(|end| (end, values))
}

/// [`array`] with its values pushed onto `values` (left as it was when `None`).
pub(super) fn array_into(t: &str, i: usize, values: &mut Vec<f64>) -> Option<usize> {
    let from = values.len();
    let end = numbers_into(t, i, values);
    if end.is_none() {
        values.truncate(from);
    }
    end
}

fn numbers_into(t: &str, i: usize, values: &mut Vec<f64>) -> Option<usize> {
    let b = t.as_bytes();
    if b.get(i) != Some(&b'[') {
        return None;
    }
    let from = values.len();
    let mut i = skip_array_space(b, i + 1);
    loop {
        if b.get(i) == Some(&b']') && values.len() > from {
            return Some(i + 1);
        }
        let (end, x) = number(t, i)?;
        values.push(x);
        i = skip_array_space(b, end);
        match b.get(i)? {
            b',' => i = skip_array_space(b, i + 1),
            b']' => return Some(i + 1),
            _ => return None,
        }
    }
}

/// A finite decimal number as TOML writes it, without underscores: `[+-]` then `0` or a digit run not
/// starting with 0, then an optional `.digits` and an optional exponent `[eE][+-]digits`. An integer is
/// read as the parser's reader reads it (as `i64`, then converted); `None` for anything else. A float whose
/// digits and exponent are small enough is computed from them as it is scanned ([`exact`]), any other parsed
/// by the standard library: the same bits either way.
pub(super) fn number(t: &str, start: usize) -> Option<(usize, f64)> {
    let b = t.as_bytes();
    // A run of digits from `i`, at least one: where it ends, with its digits added to `digits` (`m` is their
    // integer while they are at most 19, and wraps around beyond: [`exact`] then does not read it).
    let run = |mut i: usize, digits: &mut Digits| {
        let from = i;
        while let Some(&c) = b.get(i) {
            let d = c.wrapping_sub(b'0');
            if d >= 10 {
                break;
            }
            digits.m = digits.m.wrapping_mul(10).wrapping_add(u64::from(d));
            i += 1;
        }
        digits.count += i - from;
        (i > from).then_some(i)
    };
    let mut digits = Digits { m: 0, count: 0 };
    let mut i = start;
    let negative = b.get(i) == Some(&b'-');
    if matches!(b.get(i), Some(b'+' | b'-')) {
        i += 1;
    }
    let int_start = i;
    i = run(i, &mut digits)?;
    if b[int_start] == b'0' && i - int_start > 1 {
        return None;
    }
    let mut float = false;
    let mut scale = 0i64;
    if b.get(i) == Some(&b'.') {
        let from = i + 1;
        i = run(from, &mut digits)?;
        scale = -((i - from) as i64);
        float = true;
    }
    if matches!(b.get(i), Some(b'e' | b'E')) {
        i += 1;
        let below = b.get(i) == Some(&b'-');
        if matches!(b.get(i), Some(b'+' | b'-')) {
            i += 1;
        }
        let mut exponent = Digits { m: 0, count: 0 };
        i = run(i, &mut exponent)?;
        // An exponent of more than four digits is left to the standard library's parse.
        let e = if exponent.count > 4 { i64::MAX / 2 } else { exponent.m as i64 };
        scale += if below { -e } else { e };
        float = true;
    }
    // The number must end here (`1.5x`, `1_0` and `0x1` are the parser's).
    if b.get(i).is_some_and(|c| !matches!(c, b' ' | b'\t' | b'\n' | b'\r' | b',' | b']')) {
        return None;
    }
    let x = if !float {
        t.get(start..i)?.parse::<i64>().ok()? as f64
    } else if let Some(x) = exact(&digits, scale) {
        if negative { -x } else { x }
    } else {
        t.get(start..i)?.parse::<f64>().ok()?
    };
    x.is_finite().then_some((i, x))
}

/// A number's digits (integer part and fraction): how many, and as an integer when they are at most 19.
struct Digits {
    m: u64,
    count: usize,
}

/// 10^k for k from 0 to 22: the powers of ten an `f64` holds exactly.
const POWERS_OF_TEN: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20,
    1e21, 1e22,
];

/// The magnitude of the decimal number `digits` × 10^`scale` when it needs no more than one rounding: all its
/// digits make an integer m of at most 2^53 and |scale| is at most 22, so m and 10^|scale| are exact `f64`s
/// and m × 10^scale (or m / 10^-scale) is one correctly rounded operation, which is what the standard
/// library's correctly rounded parse gives (Clinger's fast path, which that parse tries first after reading
/// the digits again). `None` otherwise: the caller parses the text. Why it exists: a batch of designs' samples
/// are short numbers (`0.5`), and the standard library's parse of each took about 290 instructions of the 330
/// a number cost.
fn exact(digits: &Digits, scale: i64) -> Option<f64> {
    if digits.count > 19 || digits.m > 1 << 53 {
        return None;
    }
    let m = digits.m as f64;
    match scale {
        0 => Some(m),
        1..=22 => Some(m * POWERS_OF_TEN[scale as usize]),
        -22..=-1 => Some(m / POWERS_OF_TEN[(-scale) as usize]),
        _ => None,
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    fn one(s: &str) -> Option<Vec<f64>> {
        array(s, 0).filter(|(end, _)| *end == s.len()).map(|(_, v)| v)
    }

    #[test]
    fn arrays_it_reads_and_arrays_it_leaves_to_the_parser() {
        assert_eq!(
            one("[1, 2.5, -3e2, +0.25E-1, 0, -0.0, 1e05,]"),
            Some(vec![1.0, 2.5, -300.0, 0.025, 0.0, -0.0, 1e5])
        );
        assert_eq!(one("[\r\n  0.5,\r\n\t0.75\r\n]"), Some(vec![0.5, 0.75]));
        for left in [
            "[]",
            "[ ]",
            "[1 2]",
            "[1,,2]",
            "[01]",
            "[00.5]",
            "[1.]",
            "[.5]",
            "[1e]",
            "[1_0]",
            "[0x10]",
            "[inf]",
            "[nan]",
            "[1e999]",
            "[9223372036854775808]",
            "[1, # c\n 2]",
            "[\"a\"]",
            "[1\r2]",
            "[1.5x]",
            "[[1]]",
            "[1, 2",
        ] {
            assert_eq!(one(left), None, "{left}");
        }
    }

    #[test]
    fn blanked_text_keeps_every_span_and_line() {
        let arr = "[\n  0.1, 0.2,\n  0.3,\n]";
        let mut text = String::from("name = \"x\"\nnote = \"samples = [1, 2]\"\n");
        for i in 0..8 {
            text += &format!("[[reflectances]]\nname = \"r{i}\"\n  samples = {arr}\n# samples = [5, 6]\n");
        }
        let arrays = arrays_in(&text, 0..text.len());
        let blanked = blank(&text, 0, &arrays).unwrap();
        assert_eq!(blanked.len(), text.len());
        assert_eq!(
            blanked.matches('\n').count(),
            text.matches('\n').count() - 3 * 8,
            "the line feeds inside the arrays are blanks too"
        );
        let read = Read::new(arrays);
        assert_eq!(read.len(), 8, "only the keys at a line's start");
        for (range, values) in read.arrays() {
            assert_eq!(&text[range.clone()], arr);
            assert_eq!(blanked[range.clone()].replace(' ', ""), "[]");
            assert_eq!(values, &[0.1, 0.2, 0.3]);
        }
        assert!(!read.all_taken());
        let first = read.arrays()[0].0.clone();
        assert!(read.take(&(first.start..first.end - 1)).is_none(), "only the exact span");
        // A piece later in the text: its arrays' spans count from the text's start.
        let at = text.find("[[reflectances]]").unwrap();
        let piece_arrays = arrays_in(&text, at..text.len());
        assert_eq!(blank(&text[at..], at, &piece_arrays).unwrap(), blanked[at..]);
    }

    /// What a parse gives, comparably: the file's model, warnings and table layout, or the error message;
    /// and how many arrays were read by hand when the events' path ([`super::super::events`]) gave it.
    fn outcome(
        r: Result<(super::super::PaletteFile, Option<usize>), super::super::PaletteError>,
    ) -> (String, Option<usize>) {
        match r {
            Ok((f, fast)) => {
                (format!("{:?}\n{:?}\n{:?}\n{:?}", f.palette, f.warnings, f.tables, f.csv_raw.len()), fast)
            }
            Err(e) => (format!("error: {e}"), None),
        }
    }

    /// Both paths on `text`: the same outcome; how many arrays the hand-read path read when it gave it.
    pub(in crate::palette::file) fn both(text: &str, path: &std::path::Path) -> (String, Option<usize>) {
        let (slow, _) = outcome(super::super::PaletteFile::parse_with(text, path, false));
        let (fast, used) = outcome(super::super::PaletteFile::parse_with(text, path, true));
        assert_eq!(fast, slow, "the hand-read sample arrays change what {} reads as", path.display());
        (slow, used)
    }

    #[test]
    fn every_shipped_palette_reads_the_same_both_ways() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut files: Vec<std::path::PathBuf> = ["palettes", "volumes"]
            .iter()
            .flat_map(|d| std::fs::read_dir(root.join(d)).unwrap().map(|e| e.unwrap().path()))
            // The palettes' TOML files only: the designer leaves ignored `.basis.json` stores beside them.
            .filter(|p| {
                p.extension().is_some_and(|e| e == "toml")
                    && (p.to_string_lossy().contains("palette") || p.parent().is_some_and(|d| d.ends_with("palettes")))
            })
            .collect();
        files.sort();
        assert!(files.len() >= 5, "{files:?}");
        for path in files {
            let text = std::fs::read_to_string(&path).unwrap();
            let (read, used) = both(&text, &path);
            assert!(!read.starts_with("error"), "{}: {read}", path.display());
            assert!(used.is_some(), "{}: read from the parser's events", path.display());
            // The same palette with every spectrum given as samples, as a solve writes them.
            let mut p = super::super::PaletteFile::parse(&text, &path).unwrap().palette;
            for e in p.lights.iter_mut().chain(p.reflectances.iter_mut()) {
                e.source = crate::palette::Source::Samples(e.spectrum.as_slice().to_vec());
            }
            let sampled = super::super::PaletteFile::from_palette(&p).text();
            let (read, used) = both(&sampled, &path);
            assert!(!read.starts_with("error"), "{}: {read}", path.display());
            assert!(used.is_some_and(|n| n > 0), "{}: the sample arrays as written are read by hand", path.display());
        }
    }

    /// A colour cell's `target = [r, g, b]` is read by hand too, and reads (or is refused) as the parser
    /// reads it: the same palette or the same error, whatever its spelling.
    #[test]
    fn cell_targets_read_the_same_both_ways() {
        let cases = [
            ("[0.1, 0.2, 0.3]", true),
            ("[\n  1e-3 ,\n  2,\t3 ,\n]", true),
            ("[-0.0, 0, 1]", true),
            ("[1, 2]", true),
            ("[0.1, 0.2, 0.3, 0.4]", true),
            ("[inf, 0, 0]", false),
            ("[0.1, 0.2, nan]", false),
            ("[1_0, 2, 3]", false),
            ("[0.1, \"a\", 0.3]", false),
            ("[]", false),
            ("\"#808080\"", false),
        ];
        for (target, by_hand) in cases {
            let mut text = String::from("name = \"p\"\n[[lights]]\nname = \"L\"\nilluminant = \"D65\"\n");
            let samples = vec!["0.5"; crate::spectrum::SAMPLES].join(", ");
            text += &format!("[[reflectances]]\nname = \"r0\"\nsamples = [{samples}]\ndesign = true\n");
            for light in 0..2 {
                text += &format!(
                    "[[colours]]\nlight = \"L\"\nreflectance = \"r0\"\n  target = {target}\nweight = {}\n",
                    light + 1
                );
            }
            let (read, used) = both(&text, std::path::Path::new("p.toml"));
            let valid = !read.starts_with("error");
            assert_eq!(used == Some(3), by_hand && valid, "{target}: {read}");
            assert_eq!(used.is_some(), valid, "{target}: {read}");
            if target.contains("1, 2]") || target.contains("0.4]") {
                assert!(read.contains("expected 3 numbers"), "{target}: {read}");
            }
        }
    }

    /// A batch long enough to be read in pieces on several threads reads as the parser reads it, by hand.
    #[test]
    fn a_long_batch_is_read_by_hand_in_pieces_as_the_parser_reads_it() {
        use crate::palette::Source;
        let col = crate::colorimetry::Colorimetry::default();
        let p = crate::palette::random::reachable_batch_palette(600, 3, &col);
        let text = super::super::PaletteFile::from_palette(&p).text();
        let scan = super::super::budget::scan(&text);
        assert!(super::super::pieces::starts(&text, &scan.headers).len() > 1, "{} bytes", text.len());
        let (_, read) = super::super::events::parse(&text, &scan.headers).unwrap();
        let sampled = p.lights.iter().chain(&p.reflectances).filter(|e| matches!(e.source, Source::Samples(_))).count();
        assert_eq!(read.len(), sampled + p.colours.len(), "every spectrum's samples and every cell's target");
        assert_eq!(p.colours.len(), 1800);
        assert!(read.arrays().windows(2).all(|w| w[0].0.end <= w[1].0.start), "in text order");
        let (outcome, used) = both(&text, std::path::Path::new("batch.toml"));
        assert!(used == Some(read.len()) && !outcome.starts_with("error"), "{outcome}");
    }

    /// The number at the start of `s` (which must be all of it) and its bits.
    fn bits(s: &str) -> Option<u64> {
        number(s, 0).filter(|(end, _)| *end == s.len()).map(|(_, x)| x.to_bits())
    }

    #[test]
    fn numbers_computed_from_their_digits_are_the_standard_parse() {
        // Inside the fast path, at its edges (2^53 and 2^53 + 1 as digits, 19 and 20 digits, 10^±22 and
        // 10^±23), signed zeros, and numbers that need the full parse.
        for s in [
            "0.5",
            "-0.5",
            "+0.5",
            "0.0",
            "-0.0",
            "0e0",
            "-0e-30",
            "1.0",
            "0.1",
            "0.3",
            "123.456",
            "1e22",
            "1e23",
            "1e-22",
            "1e-23",
            "9007199254740992.0",
            "9007199254740993.0",
            "0.9007199254740993",
            "900719925474099.2e-3",
            "1234567890123456789.0",
            "12345678901234567890.0",
            "0.0000000000000000001",
            "0.00000000000000000001",
            "4.35e-5",
            "1.5E+3",
            "2.5e0010",
            "2.5e00010",
            "0.16181228447280316",
            "-0.0108820558012247",
            "1.7976931348623157e308",
            "2.2250738585072014e-308",
            "4.9e-324",
            "123456789e-30",
            "9.999999999999999e22",
        ] {
            assert_eq!(bits(s), Some(s.parse::<f64>().unwrap().to_bits()), "{s}");
        }
    }

    mod prop {
        use super::*;
        use proptest::prelude::*;

        /// A number as a solve writes it, or as a person might: always read by hand.
        fn plain_token() -> impl Strategy<Value = String> {
            let x = prop_oneof![0.0..1.0f64, -2.0..2.0f64, Just(0.0), Just(-0.0)];
            prop_oneof![
                4 => x.clone().prop_map(|x| format!("{x}")),
                2 => x.prop_map(|x| format!("{x:e}")),
                1 => (-3i64..3).prop_map(|i| i.to_string()),
            ]
        }

        /// A number as the file might spell it: the common forms, and forms only the parser takes (or
        /// refuses).
        fn token() -> impl Strategy<Value = String> {
            let x = prop_oneof![-2.0..2.0f64, proptest::num::f64::NORMAL, Just(0.0), Just(-0.0)];
            prop_oneof![
                4 => x.clone().prop_map(|x| format!("{x}")),
                2 => x.clone().prop_map(|x| format!("{x:e}")),
                1 => x.prop_map(|x| format!("+{x:E}")),
                1 => any::<i64>().prop_map(|i| i.to_string()),
                1 => proptest::sample::select(vec![
                    "01.5", "1_000.5", "1_0", "inf", "-inf", "nan", "1e999", "0x1F", ".5", "1.", "\"a\"", "true",
                    "1e05", "0e0", "-0", "9223372036854775808", "1.5 # c\n", "[1]",
                ])
                .prop_map(str::to_string),
            ]
        }

        /// An array of `SAMPLES` numbers (or a few more or fewer); only plain numbers when `plain`.
        fn array(plain: bool) -> impl Strategy<Value = String> {
            let sep = proptest::sample::select(vec![", ", ",", ",\n    ", " ,\t", ",\r\n  ", ",\n\n"]);
            let len = prop_oneof![3 => Just(crate::spectrum::SAMPLES), 1 => 29..=32usize];
            let tok = if plain { plain_token().boxed() } else { token().boxed() };
            let items = len.prop_flat_map(move |n| proptest::collection::vec((tok.clone(), sep.clone()), n));
            (items, any::<bool>(), any::<bool>()).prop_map(|(items, trailing, newline)| {
                let mut t = String::from(if newline { "[\n    " } else { "[" });
                for (i, (tok, sep)) in items.iter().enumerate() {
                    t += tok;
                    if i + 1 < items.len() || trailing {
                        t += sep;
                    }
                }
                t += if newline { "\n]" } else { "]" };
                t
            })
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(4000))]
            #[test]
            fn every_decimal_spelling_reads_as_the_standard_parse(
                sign in proptest::sample::select(vec!["", "-", "+"]),
                int in "0|[1-9][0-9]{0,19}",
                fraction in "[0-9]{1,22}",
                exponent in proptest::option::of((proptest::sample::select(vec!["e", "E"]),
                    proptest::sample::select(vec!["", "-", "+"]), "[0-9]{1,3}")),
            ) {
                let mut s = format!("{sign}{int}.{fraction}");
                if let Some((e, es, digits)) = exponent {
                    s += &format!("{e}{es}{digits}");
                }
                let expected = s.parse::<f64>().unwrap();
                let got = number(&s, 0);
                if expected.is_finite() {
                    prop_assert_eq!(got.map(|(end, x)| (end, x.to_bits())), Some((s.len(), expected.to_bits())), "{}", s);
                } else {
                    prop_assert_eq!(got, None, "{}", s);
                }
            }
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(200))]
            #[test]
            fn hand_read_sample_arrays_read_as_the_parser_reads_them(
                arrays in proptest::collection::vec(
                    any::<bool>().prop_flat_map(|plain| (array(plain), Just(plain), any::<bool>())),
                    1..4,
                ),
                note in any::<bool>(),
            ) {
                let mut text = String::from("name = \"p\"\n");
                if note {
                    text += "note = \"\"\"\nsamples = [1, 2, 3]\n\"\"\"\n";
                }
                text += "[[lights]]\nname = \"L\"\nilluminant = \"D65\"\n";
                for (i, (a, _, design)) in arrays.iter().enumerate() {
                    text += &format!("[[reflectances]]\nname = \"r{i}\"\n  samples = {a}\ndesign = {design}\n");
                }
                text += "[[colours]]\nlight = \"L\"\nreflectance = \"r0\"\ntarget = \"#808080\"\n";
                let (read, used) = both(&text, std::path::Path::new("p.toml"));
                if note {
                    // The array inside the string is read, blanked and never taken: the text as it is.
                    prop_assert!(used.is_none(), "{read}");
                } else if arrays.iter().all(|(_, plain, _)| *plain) && !read.starts_with("error") {
                    prop_assert!(used.is_some(), "{read}");
                }
            }
        }
    }
}
