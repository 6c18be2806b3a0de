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

/// The one scan of a palette's text, skipping strings and comments ([`skip_literal`]) and tracking the
/// depth of arrays and inline tables, so that a line starting with `[` inside an array is no header.
pub(crate) fn scan(text: &str) -> Scan {
    let b = text.as_bytes();
    let mut c = Counts::default();
    let mut headers = Vec::new();
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
    Scan { counts: c, headers }
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

    #[test]
    fn counts_skip_strings_and_comments() {
        let c = count("# {[,=\n[[lights]]\nname = \"a{[,]\" # x, y\nsamples = [1, 2, 3]\nt = {a = 1}\n");
        assert_eq!(c, Counts { tables: 2, arrays: 1, values: 6 });
        let c = count("s = '''{\n[,'''\nu = \"\"\"a\\\"{b\"\"\"\n");
        assert_eq!(c, Counts { tables: 0, arrays: 0, values: 2 });
    }
}
