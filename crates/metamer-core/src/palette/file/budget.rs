//! A bound on the memory a palette's parse takes, checked before parsing.
//!
//! The TOML parsers keep every value with its span: measured on this crate's parse path, a scalar costs about
//! 140 bytes, an array about 470 and a table about 1.4 KB, whatever the text spells it with. A value can be
//! written in two bytes (`1,`) and an inline table in five (`{a=1}`), so a 12 MB file of inline tables took
//! 2.8 GB. A single pass over the text counts tables, arrays and values (outside strings and comments) and
//! refuses a file whose estimated parse exceeds [`budget`] bytes: a fixed allowance plus a small multiple of
//! the input, far above what real palettes need (spectra written as `samples = [...]` cost about 19 times
//! their text, colour cells about 40 times).

/// Estimated parse cost per element, bytes (measured, rounded up).
const TABLE: u64 = 1536;
const ARRAY: u64 = 512;
const VALUE: u64 = 160;

/// The largest estimated parse of a text of `len` bytes: 64 MiB plus 48 bytes per byte of input.
pub(crate) fn budget(len: usize) -> u64 {
    (64u64 << 20) + 48 * len as u64
}

/// What the text holds, counted outside strings and comments.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Counts {
    pub(crate) tables: u64,
    pub(crate) arrays: u64,
    pub(crate) values: u64,
}

impl Counts {
    /// The estimated parse memory, bytes.
    pub(crate) fn cost(&self) -> u64 {
        self.tables * TABLE + self.arrays * ARRAY + self.values * VALUE
    }
}

/// What one pass over a palette's text finds: the [`Counts`] of the parse budget, and where the lines opening
/// a `[[name]]` header (bare key, at the top level) start, after the last header of another shape (where the
/// parse may cut the text into pieces, see [`super::pieces`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Scan {
    pub(crate) counts: Counts,
    pub(crate) headers: Vec<usize>,
}

/// Count tables (`{`, and `[` at the start of a line), arrays (other `[`) and values (`=` and `,`), outside
/// strings and comments ([`count`]).
pub(crate) fn count(text: &str) -> Counts {
    scan(text).counts
}

/// Texts shorter than this are scanned in one piece (a thread's start costs more than scanning them).
const MIN_PIECE: usize = 64 * 1024;

/// The one scan of a palette's text ([`scan_piece`]). A long text is scanned in pieces on several threads,
/// cut at lines opening with `[[`: the scan is a machine whose state between bytes is the depth of arrays
/// and inline tables, whether a line has started, and whether a string or comment is open; a piece
/// scanned from the first state (depth 0, at a line's start, outside strings) that ends in that same state
/// (depth 0, after its last line feed, no string or comment left open) leaves the next piece where the
/// scan of the whole text would. The pieces' counts add up and their headers join (a non-simple header
/// clears those before it); when any piece but the last ends in another state, the text is scanned whole.
pub(crate) fn scan(text: &str) -> Scan {
    scan_in_pieces(text).unwrap_or_else(|| scan_piece(text.as_bytes()).scan)
}

/// [`scan`] in pieces on several threads; `None` for a short text or when a piece but the last does not end
/// in the first state.
fn scan_in_pieces(text: &str) -> Option<Scan> {
    let b = text.as_bytes();
    let pieces = (b.len() / MIN_PIECE).min(4 * rayon::current_num_threads());
    if pieces >= 2 {
        let mut starts = vec![0];
        for k in 1..pieces {
            let from = (k * b.len() / pieces).max(starts[starts.len() - 1]);
            match b[from..].windows(3).position(|w| w == b"\n[[") {
                Some(p) if from + p + 1 > starts[starts.len() - 1] => starts.push(from + p + 1),
                _ => {}
            }
        }
        if starts.len() >= 2 {
            return scan_at(b, &starts);
        }
    }
    None
}

/// The scan of `b` in pieces starting at `starts` (the first at 0, each at a line's start), joined; `None`
/// when a piece but the last does not end in the first state.
fn scan_at(b: &[u8], starts: &[usize]) -> Option<Scan> {
    use rayon::prelude::*;
    let bounds: Vec<std::ops::Range<usize>> =
        starts.iter().enumerate().map(|(i, &a)| a..starts.get(i + 1).copied().unwrap_or(b.len())).collect();
    let parts: Vec<Piece> = bounds.par_iter().map(|r| scan_piece(&b[r.clone()])).collect();
    if !parts[..parts.len() - 1].iter().all(|p| p.clean) {
        return None;
    }
    let mut whole = Scan::default();
    for (part, range) in parts.into_iter().zip(&bounds) {
        whole.counts.tables += part.scan.counts.tables;
        whole.counts.arrays += part.scan.counts.arrays;
        whole.counts.values += part.scan.counts.values;
        if part.cleared {
            whole.headers.clear();
        }
        whole.headers.extend(part.scan.headers.iter().map(|h| h + range.start));
    }
    Some(whole)
}

/// The scan of a piece of text: its counts and headers (from the piece's start), whether a non-simple
/// header cleared the headers before it, and whether it ends in the state it started in.
struct Piece {
    scan: Scan,
    cleared: bool,
    clean: bool,
}

/// The scan of `b` from the start of a line outside strings and comments, skipping strings and comments
/// ([`skip_literal`]) and tracking the depth of arrays and inline tables, so that a line starting with `[`
/// inside an array is no header.
fn scan_piece(b: &[u8]) -> Piece {
    let mut c = Counts::default();
    let mut headers = Vec::new();
    let mut cleared = false;
    let mut depth = 0usize;
    let mut i = 0;
    let mut line_start = true;
    while i < b.len() {
        if PLAIN[usize::from(b[i])] {
            // A run of bytes whose only role is to end the line's start (numbers, bare keys, UTF-8).
            line_start = false;
            i += 1;
            while i < b.len() && PLAIN[usize::from(b[i])] {
                i += 1;
            }
            continue;
        }
        match b[i] {
            b'#' | b'"' | b'\'' => {
                // Comments keep the line's start; a string ends it.
                line_start &= b[i] == b'#';
                i = skip_literal(b, i);
                continue;
            }
            b'\n' => line_start = true,
            b' ' | b'\t' | b'\r' => {}
            ch => {
                match ch {
                    b'{' => {
                        c.tables += 1;
                        depth += 1;
                    }
                    b'[' if line_start => {
                        if depth == 0 {
                            let line_end = b[i..].iter().position(|&c| c == b'\n').map_or(b.len(), |p| i + p);
                            if is_simple_header(&b[i..line_end]) {
                                // The cut is at the start of the line (its indentation goes with the header).
                                headers.push(b[..i].iter().rposition(|&c| c == b'\n').map_or(0, |p| p + 1));
                            } else {
                                headers.clear();
                                cleared = true;
                            }
                        }
                        // `[[x]]` is one table (its brackets still count for the depth).
                        c.tables += 1;
                        depth += 1;
                        if b.get(i + 1) == Some(&b'[') {
                            depth += 1;
                            i += 1;
                        }
                    }
                    b'[' => {
                        c.arrays += 1;
                        depth += 1;
                    }
                    b']' | b'}' => depth = depth.saturating_sub(1),
                    b'=' | b',' => c.values += 1,
                    _ => {}
                }
                line_start = false;
            }
        }
        i += 1;
    }
    // A string or escape run past the end leaves `i` beyond it, or the line not started.
    let clean = i == b.len() && line_start && depth == 0 && b.last() == Some(&b'\n');
    Piece { scan: Scan { counts: c, headers }, cleared, clean }
}

/// Bytes the scan gives no role but ending a line's start: all but comment and string openers, blanks, line
/// feeds, brackets, braces, `=` and `,`.
const PLAIN: [bool; 256] = {
    let mut t = [true; 256];
    let special = b"#\"' \t\r\n[]{}=,";
    let mut k = 0;
    while k < special.len() {
        t[special[k] as usize] = false;
        k += 1;
    }
    t
};

/// `[[name]]` with a bare key, then only blanks or a comment.
fn is_simple_header(line: &[u8]) -> bool {
    let Some(rest) = line.strip_prefix(b"[[") else { return false };
    let key_len = rest.iter().take_while(|c| c.is_ascii_alphanumeric() || **c == b'_' || **c == b'-').count();
    let Some(after) = rest.get(key_len..).and_then(|r| r.strip_prefix(b"]]")) else { return false };
    let after = after.trim_ascii_start();
    key_len > 0 && (after.is_empty() || after.starts_with(b"#"))
}

/// The index just past the comment or string that starts at `b[i]` (`#`, `"`, `'`, or their triple
/// forms), for the byte scan over palette text ([`scan`]):
/// a comment ends before its line feed; an unterminated string at its line's end (single-line forms) or
/// the text's end. `b[i]` that starts neither is returned as `i + 1`.
fn skip_literal(b: &[u8], mut i: usize) -> usize {
    match b.get(i) {
        Some(b'#') => {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
            i
        }
        Some(&q @ (b'"' | b'\'')) => {
            let triple = b.get(i..i + 3).is_some_and(|s| s == [q, q, q]);
            i += if triple { 3 } else { 1 };
            while i < b.len() {
                if q == b'"' && b[i] == b'\\' {
                    i += 2;
                    continue;
                }
                if !triple && b[i] == b'\n' {
                    break;
                }
                if b[i] == q && (!triple || b.get(i..i + 3).is_some_and(|s| s == [q, q, q])) {
                    i += if triple { 3 } else { 1 };
                    // A triple-quoted string may end in up to two more quotes.
                    while triple && b.get(i) == Some(&q) {
                        i += 1;
                    }
                    break;
                }
                i += 1;
            }
            i
        }
        _ => i + 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Long texts scanned in pieces give the scan of the whole text, whatever the pieces' cuts fall in:
    /// multi-line strings and arrays holding lines that open with `[[`, comments, a header of another shape
    /// late in the text, CRLF; and a batch of designs is scanned in pieces.
    #[test]
    fn the_scan_in_pieces_is_the_scan_of_the_whole_text() {
        let col = crate::colorimetry::Colorimetry::default();
        let p = crate::palette::random::reachable_batch_palette(600, 3, &col);
        let batch = super::super::PaletteFile::from_palette(&p).text();
        assert!(scan_in_pieces(&batch).is_some(), "a batch is scanned in pieces");
        let mut traps = String::new();
        for i in 0..6000 {
            traps += &format!("[[reflectances]]\nname = \"r{i}\" # [[x]] {{\nsamples = [1, 2,\n  3]\n");
            match i % 1000 {
                100 => traps += "note = \"\"\"\n[[reflectances]]\n\"\"\"\n",
                300 => traps += "list = [\n[[1]], [[2]],\n]\n",
                500 => traps += "lit = '''\n[[colours]]\n'''\n",
                700 => traps += "esc = \"a\\\"\n",
                900 => traps += "[settings]\nx = {a = [1, {b = 2}]}\n",
                _ => {}
            }
        }
        let open = format!("{traps}x = \"\"\"\n[[a]]\n");
        let mut in_pieces = 0;
        for text in [batch, traps.clone(), traps.replace('\n', "\r\n"), open] {
            let whole = scan_piece(text.as_bytes()).scan;
            assert_eq!(scan(&text), whole);
            if let Some(pieces) = scan_in_pieces(&text) {
                assert_eq!(pieces, whole);
                in_pieces += 1;
            }
        }
        assert!(in_pieces >= 2, "{in_pieces}");
        // Cut at every line opening with `[[` around the traps, inside strings and arrays too: a piece that
        // ends inside one is refused, any other gives the whole text's scan.
        let short: String = traps.lines().take(4400).map(|l| format!("{l}\n")).collect();
        let whole = scan_piece(short.as_bytes()).scan;
        let (mut refused, mut joined) = (0, 0);
        for (p, _) in short.match_indices("\n[[") {
            match scan_at(short.as_bytes(), &[0, p + 1]) {
                Some(s) => {
                    assert_eq!(s, whole, "cut at {p}");
                    joined += 1;
                }
                None => refused += 1,
            }
        }
        assert!(refused >= 3 && joined > 100, "{refused} refused, {joined} joined");
    }

    #[test]
    fn counts_skip_strings_and_comments() {
        let c = count("# {[,=\n[[lights]]\nname = \"a{[,]\" # x, y\nsamples = [1, 2, 3]\nt = {a = 1}\n");
        assert_eq!(c, Counts { tables: 2, arrays: 1, values: 6 });
        let c = count("s = '''{\n[,'''\nu = \"\"\"a\\\"{b\"\"\"\n");
        assert_eq!(c, Counts { tables: 0, arrays: 0, values: 2 });
    }
}
