//! VTK XML image data (`.vti`) reader: one piece, the point-data scalar array (the one named by
//! `Scalars`, else the first), `format="binary"` (base64 inline), `"appended"` (raw or base64
//! `AppendedData`) or `"ascii"`, optionally compressed by `vtkZLibDataCompressor` in blocks, with
//! `UInt32` or `UInt64` headers and either byte order. The XML is small and regular, so it is read by a
//! light hand parser (attributes of the few tags we need), not a general XML library.
//!
//! The file is never read whole: its first [`XML_CAP`] bytes hold the XML up to the array (and the
//! `<AppendedData>` tag), the file's size is checked against what its extent can take, and the array is
//! then streamed straight into the voxel buffer ([`super::fill`]): base64 decoded in chunks, each zlib
//! block inflated into its own place in the buffer, never more than the extent requires.

use super::fill::{Filler, has_more, read_full, skip as skip_bytes};
use super::raw::MAX_DEFLATE_RATIO;
use super::{Endian, ScalarType, Volume, VolumeError, Voxels, voxel_count};
use base64::Engine;
use base64::engine::general_purpose::STANDARD;
use flate2::read::ZlibDecoder;
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Cursor, Read, Seek, SeekFrom};
use std::path::Path;

/// The most bytes of XML read before the array's data (the tags it needs must end within them).
pub const XML_CAP: u64 = 1 << 20;

/// The most bytes a point (or cell) can take in one data array of any file: 9 components of 8 bytes as
/// ASCII text of up to 48 characters each, with room to spare. A file larger than its arrays can take at
/// this rate is refused from its size.
const BYTES_PER_POINT_PER_ARRAY: u64 = 512;

/// Read a `.vti` file.
pub fn read(path: &Path) -> Result<Volume, VolumeError> {
    let kind = crate::fsio::Kind::Volume;
    let (file, size) = crate::fsio::open_capped(path, kind, kind.cap()).map_err(VolumeError::File)?;
    parse(path, BufReader::with_capacity(1 << 16, file), size)
}

/// Read `.vti` content held in memory (`path` names it in errors).
pub fn from_bytes(path: &Path, bytes: &[u8]) -> Result<Volume, VolumeError> {
    parse(path, Cursor::new(bytes), bytes.len() as u64)
}

fn parse(path: &Path, mut r: impl BufRead + Seek, size: u64) -> Result<Volume, VolumeError> {
    let bad = |reason: String| VolumeError::invalid(path, reason);
    let io = |e: std::io::Error| VolumeError::invalid(path, format!("cannot be read: {e}"));
    let mut bytes = Vec::with_capacity(usize::try_from(size.min(XML_CAP)).unwrap_or(0));
    (&mut r).take(XML_CAP).read_to_end(&mut bytes).map_err(io)?;
    let complete = bytes.len() as u64 >= size;
    // The appended section may hold raw binary; the XML before it is text.
    let appended_at = find(&bytes, b"<AppendedData");
    let xml_end = appended_at.unwrap_or(bytes.len());
    let xml = match std::str::from_utf8(&bytes[..xml_end]) {
        Ok(x) => x,
        // The first XML_CAP bytes may end inside a character.
        Err(e) if !complete && appended_at.is_none() && e.error_len().is_none() => {
            std::str::from_utf8(&bytes[..e.valid_up_to()]).map_err(|_| bad("the XML is not UTF-8 text".into()))?
        }
        Err(_) => return Err(bad("the XML is not UTF-8 text".into())),
    };
    let within = if complete { String::new() } else { format!(" within the first {XML_CAP} bytes") };

    let (_, file_attrs) =
        tag(xml, "VTKFile", 0).ok_or_else(|| bad(format!("no <VTKFile> element{within}: not a VTK XML file")))?;
    if file_attrs.get("type").map(String::as_str) != Some("ImageData") {
        return Err(bad(format!("VTKFile type is {:?}, expected \"ImageData\"", file_attrs.get("type"))));
    }
    let endian = match file_attrs.get("byte_order").map(String::as_str) {
        None | Some("LittleEndian") => Endian::Little,
        Some("BigEndian") => Endian::Big,
        Some(o) => return Err(bad(format!("VTKFile byte_order `{o}` is unknown"))),
    };
    let header_size = match file_attrs.get("header_type").map(String::as_str) {
        None | Some("UInt32") => 4,
        Some("UInt64") => 8,
        Some(o) => return Err(bad(format!("VTKFile header_type `{o}` is unsupported (UInt32, UInt64)"))),
    };
    let compressed = match file_attrs.get("compressor").map(String::as_str) {
        None | Some("") => false,
        Some("vtkZLibDataCompressor") => true,
        Some(o) => return Err(bad(format!("VTKFile compressor `{o}` is unsupported (vtkZLibDataCompressor)"))),
    };

    let (_, image) = tag(xml, "ImageData", 0).ok_or_else(|| bad(format!("no <ImageData> element{within}")))?;
    let (piece_at, piece) = tag(xml, "Piece", 0).ok_or_else(|| bad(format!("no <Piece> element{within}")))?;
    if tag(xml, "Piece", piece_at + 1).is_some() {
        return Err(bad("the file holds several pieces; only single-piece image data is supported".into()));
    }
    let extent_text = piece
        .get("Extent")
        .or_else(|| image.get("WholeExtent"))
        .ok_or_else(|| bad("ImageData has no WholeExtent / Piece Extent".into()))?;
    let ext = numbers::<i64>(extent_text)
        .filter(|e| e.len() == 6)
        .ok_or_else(|| bad(format!("Extent `{extent_text}` is not six integers")))?;
    let mut dims = [0usize; 3];
    for a in 0..3 {
        let n = ext[2 * a + 1].checked_sub(ext[2 * a]).and_then(|d| d.checked_add(1)).unwrap_or(i64::MAX);
        if n <= 0 {
            return Err(bad(format!("Extent `{extent_text}` is empty along axis {a}")));
        }
        dims[a] = n as usize;
    }
    let spacing = match image.get("Spacing") {
        Some(s) => {
            let v = numbers::<f64>(s)
                .filter(|v| v.len() == 3)
                .ok_or_else(|| bad(format!("Spacing `{s}` is not three numbers")))?;
            [v[0], v[1], v[2]]
        }
        None => [1.0; 3],
    };
    let count = voxel_count(path, dims)?;

    // What the header implies against the file's size, before anything more is read: every array of the
    // file holds one value (of up to 9 components) per point or cell.
    let arrays = xml.matches("<DataArray").count().max(1) as u64;
    let allowed = XML_CAP.saturating_add(arrays.saturating_mul(count as u64).saturating_mul(BYTES_PER_POINT_PER_ARRAY));
    if size > allowed {
        return Err(bad(format!(
            "is {size} bytes, far more than its extent {}×{}×{} can take in {arrays} data array{} (at most {allowed} \
             bytes; not read)",
            dims[0],
            dims[1],
            dims[2],
            if arrays == 1 { "" } else { "s" }
        )));
    }

    let (pd_at, point_data) =
        tag(xml, "PointData", piece_at).ok_or_else(|| bad(format!("the piece has no <PointData>{within}")))?;
    let pd_end = xml[pd_at..].find("</PointData>").map(|i| pd_at + i).unwrap_or(xml.len());
    let wanted = point_data.get("Scalars");
    let mut chosen = None;
    let mut at = pd_at;
    while let Some((pos, attrs)) = tag(xml, "DataArray", at) {
        if pos >= pd_end {
            break;
        }
        let matches = wanted.is_none() || attrs.get("Name") == wanted;
        if matches {
            chosen = Some((pos, attrs));
            break;
        }
        at = pos + 1;
    }
    let (arr_at, arr) = chosen.ok_or_else(|| bad(format!("PointData holds no DataArray named {wanted:?}{within}")))?;
    let name = arr.get("Name").cloned().unwrap_or_default();
    let ty_name = arr.get("type").ok_or_else(|| bad(format!("DataArray `{name}` has no type")))?;
    let ty =
        ScalarType::parse(ty_name).ok_or_else(|| bad(format!("DataArray `{name}` type `{ty_name}` is unsupported")))?;
    let comps = arr.get("NumberOfComponents").map(|c| c.parse::<usize>()).transpose();
    if !matches!(comps, Ok(None) | Ok(Some(1))) {
        return Err(bad(format!("DataArray `{name}` has {comps:?} components; only scalar data is supported")));
    }
    let format = arr.get("format").map(String::as_str).unwrap_or("ascii");
    let ctx = Ctx { path, header_size, endian, compressed, array: &name, dims, ty };
    let voxels = match format {
        "ascii" | "binary" => {
            let open_end = xml[arr_at..]
                .find('>')
                .map(|i| arr_at + i + 1)
                .ok_or_else(|| bad("unterminated DataArray tag".into()))?;
            r.seek(SeekFrom::Start(open_end as u64)).map_err(io)?;
            let left = size.saturating_sub(open_end as u64);
            if format == "ascii" {
                // As for NRRD text: the memory is checked when the text can hold the volume.
                if left.saturating_add(1) / 2 >= count as u64 {
                    super::fill::check_memory(path, dims, ScalarType::F32)?;
                }
                // A value as text: a number of up to 40 characters and a separator.
                let cap = (count as u64).saturating_mul(48).saturating_add(XML_CAP);
                let mut body = Vec::with_capacity(usize::try_from(left.min(cap)).unwrap_or(0));
                (&mut r).take(cap).read_to_end(&mut body).map_err(io)?;
                let close = find(&body, b"</DataArray>")
                    .ok_or_else(|| bad(format!("DataArray `{name}` is not closed (file truncated?)")))?;
                let text = std::str::from_utf8(&body[..close]).map_err(|_| bad("the XML is not UTF-8 text".into()))?;
                return Volume::new(path, dims, spacing, Voxels::from(parse_ascii(&ctx, text, count)?));
            }
            ctx.decode_array(&mut Base64::new(r), left / 4 * 3)?
        }
        "appended" => {
            let offset: u64 = arr
                .get("offset")
                .and_then(|o| o.trim().parse().ok())
                .ok_or_else(|| bad(format!("appended DataArray `{name}` has no valid offset")))?;
            let at = appended_at
                .ok_or_else(|| bad(format!("DataArray is appended but there is no <AppendedData>{within}")))?;
            let head_end = bytes[at..]
                .iter()
                .position(|&b| b == b'>')
                .map(|i| at + i)
                .ok_or_else(|| bad("unterminated AppendedData tag".into()))?;
            let head = String::from_utf8_lossy(&bytes[at..=head_end]).into_owned();
            let enc = attributes(&head).get("encoding").cloned().unwrap_or_else(|| "raw".into());
            let underscore = bytes[head_end..]
                .iter()
                .position(|&b| b == b'_')
                .map(|i| head_end + i + 1)
                .ok_or_else(|| bad("AppendedData lacks its `_` marker".into()))?;
            let left = size.saturating_sub(underscore as u64);
            match enc.as_str() {
                "raw" => {
                    if offset > left {
                        return Err(ctx.truncated(ctx.expected() as u64, 0));
                    }
                    r.seek(SeekFrom::Start(underscore as u64 + offset)).map_err(io)?;
                    ctx.decode_array(&mut r, left - offset)?
                }
                "base64" => {
                    r.seek(SeekFrom::Start(underscore as u64)).map_err(io)?;
                    let mut b64 = Base64::new(r);
                    if b64.skip_chars(offset).map_err(|e| ctx.bad(format!("invalid base64: {e}")))? < offset {
                        return Err(ctx.truncated(ctx.expected() as u64, 0));
                    }
                    ctx.decode_array(&mut b64, left.saturating_sub(offset) / 4 * 3)?
                }
                o => return Err(bad(format!("AppendedData encoding `{o}` is unsupported (raw, base64)"))),
            }
        }
        o => return Err(bad(format!("DataArray `{name}` format `{o}` is unsupported (ascii, binary, appended)"))),
    };
    Ok(Volume::new(path, dims, spacing, voxels)?.converted(ty))
}

struct Ctx<'a> {
    path: &'a Path,
    header_size: usize,
    endian: Endian,
    compressed: bool,
    array: &'a str,
    dims: [usize; 3],
    ty: ScalarType,
}

impl Ctx<'_> {
    fn bad(&self, reason: String) -> VolumeError {
        VolumeError::invalid(self.path, format!("DataArray `{}`: {reason}", self.array))
    }

    fn truncated(&self, expected: u64, found: u64) -> VolumeError {
        self.bad(format!("data is truncated: the extent needs {expected} bytes, the file holds {found}"))
    }

    /// Bytes of data the extent needs.
    fn expected(&self) -> usize {
        self.dims.iter().product::<usize>() * self.ty.size()
    }

    fn word(&self, b: &[u8]) -> u64 {
        let mut a = [0u8; 8];
        match (self.header_size, self.endian) {
            (4, Endian::Little) => a[..4].copy_from_slice(&b[..4]),
            (4, Endian::Big) => {
                a[..4].copy_from_slice(&b[..4]);
                a[..4].reverse();
            }
            (_, Endian::Little) => a.copy_from_slice(&b[..8]),
            (_, Endian::Big) => {
                a.copy_from_slice(&b[..8]);
                a.reverse();
            }
        }
        u64::from_le_bytes(a)
    }

    /// The next header word of `src` (`what` names it when the data end first).
    fn read_word(&self, src: &mut impl Read, what: &str) -> Result<u64, VolumeError> {
        let mut b = [0u8; 8];
        let hs = self.header_size;
        let got = read_full(src, &mut b[..hs]).map_err(|e| self.stream_error(e))?;
        if got < hs {
            return Err(self.bad(format!("data is truncated: the file ends in the header's {what}")));
        }
        Ok(self.word(&b[..hs]))
    }

    fn stream_error(&self, e: std::io::Error) -> VolumeError {
        self.bad(format!("cannot be read: {e}"))
    }

    /// The array's header and data from `src` (at most `left` bytes remain in the file) into the voxels:
    /// uncompressed data read straight into the buffer, compressed blocks each inflated into its place.
    /// The header's sizes must add up to exactly what the extent needs before anything is allocated.
    fn decode_array(&self, src: &mut impl Read, left: u64) -> Result<Voxels, VolumeError> {
        let expected = self.expected();
        let first = self.read_word(src, "byte count")?;
        if !self.compressed {
            if first != expected as u64 {
                return Err(self.bad(format!("its header says {first} bytes, the extent needs {expected}")));
            }
            if left < expected as u64 {
                return Err(self.truncated(expected as u64, left));
            }
            let mut fill = Filler::new(self.path, self.dims, self.ty, self.endian)?;
            let got = fill.read_from(src, expected).map_err(|e| self.stream_error(e))?;
            if got < expected {
                return Err(self.truncated(expected as u64, got as u64));
            }
            return Ok(fill.finish());
        }
        let blocks = first;
        let block_size = self.read_word(src, "block size")?;
        let last_size = self.read_word(src, "last block size")?;
        let last = if last_size == 0 { block_size } else { last_size };
        // What the blocks hold must be what the extent needs: never the header's own claim.
        let total = blocks
            .checked_sub(1)
            .and_then(|b| b.checked_mul(block_size))
            .and_then(|t| t.checked_add(last))
            .filter(|_| last <= block_size);
        if total != Some(expected as u64) {
            return Err(self.bad(format!(
                "its compressed blocks hold {} ({blocks} blocks of {block_size} bytes, the last {last}), the extent \
                 needs {expected} bytes",
                total.map_or("an impossible size".into(), |t| format!("{t} bytes"))
            )));
        }
        // The block sizes are read before the data: at most one word per 256 bytes of voxels (VTK writes
        // blocks of 32 KiB), and they must fit in the file.
        let most = expected as u64 / 256 + 16;
        if blocks > most {
            return Err(
                self.bad(format!("{blocks} compressed blocks for {expected} bytes are too many (at most {most})"))
            );
        }
        let header_bytes = blocks.saturating_mul(self.header_size as u64);
        if header_bytes > left {
            return Err(self.truncated(header_bytes, left));
        }
        let sizes: Vec<u64> =
            (0..blocks).map(|_| self.read_word(src, "compressed block sizes")).collect::<Result<_, _>>()?;
        let packed = sizes.iter().fold(0u64, |a, s| a.saturating_add(*s));
        if packed > left - header_bytes {
            return Err(self.bad(format!(
                "data is truncated: its compressed blocks take {packed} bytes, the file holds {}",
                left - header_bytes
            )));
        }
        let mut fill = Filler::new(self.path, self.dims, self.ty, self.endian)?;
        for (i, cs) in sizes.iter().enumerate() {
            let want = if i as u64 + 1 == blocks { last } else { block_size } as usize;
            if cs.saturating_mul(MAX_DEFLATE_RATIO).saturating_add(1 << 10) < want as u64 {
                return Err(self.bad(format!(
                    "compressed block {} of {blocks} is {cs} bytes, too few to inflate to {want}",
                    i + 1
                )));
            }
            let inflate = |e: std::io::Error| self.bad(format!("compressed block {} cannot be inflated: {e}", i + 1));
            let mut block = (&mut *src).take(*cs);
            let mut z = ZlibDecoder::new(&mut block);
            let got = fill.read_from(&mut z, want).map_err(inflate)?;
            if got < want || has_more(&mut z).map_err(inflate)? {
                return Err(self.bad(format!(
                    "compressed block {} inflates to {} bytes, its header says {want}",
                    i + 1,
                    if got < want { got.to_string() } else { "more".into() }
                )));
            }
            drop(z);
            // Whatever of the block the zlib stream did not use.
            skip_bytes(&mut block, u64::MAX).map_err(|e| self.stream_error(e))?;
        }
        Ok(fill.finish())
    }
}

/// Base64 text (whitespace ignored) decoded a chunk at a time, up to the `<` that ends the element or the
/// end of the file. Padding may end a run inside the text: VTK writes an array's header and its data as two
/// runs, each padded.
struct Base64<R> {
    r: R,
    /// Characters gathered, not yet decoded.
    chars: Vec<u8>,
    /// Decoded bytes not yet read, from `at`.
    out: Vec<u8>,
    at: usize,
    ended: bool,
}

/// Characters decoded per chunk.
const BASE64_CHUNK: usize = 1 << 16;

impl<R: BufRead> Base64<R> {
    fn new(r: R) -> Base64<R> {
        Base64 { r, chars: Vec::with_capacity(BASE64_CHUNK), out: Vec::new(), at: 0, ended: false }
    }

    /// Gather up to `max` more characters into `chars` (fewer at the end of the text).
    fn gather(&mut self, max: usize) -> std::io::Result<()> {
        while !self.ended && self.chars.len() < max {
            let buf = self.r.fill_buf()?;
            if buf.is_empty() {
                self.ended = true;
                break;
            }
            let mut used = 0;
            for &b in buf {
                if self.chars.len() >= max {
                    break;
                }
                used += 1;
                if b == b'<' {
                    self.ended = true;
                    break;
                }
                if !b.is_ascii_whitespace() {
                    self.chars.push(b);
                }
            }
            self.r.consume(used);
        }
        Ok(())
    }

    /// Skip `n` characters (the offset of an array in appended base64 data); how many were skipped.
    fn skip_chars(&mut self, n: u64) -> std::io::Result<u64> {
        let mut done = 0u64;
        while done < n {
            let step = (n - done).min(BASE64_CHUNK as u64) as usize;
            self.gather(step)?;
            if self.chars.is_empty() {
                break;
            }
            done += self.chars.len() as u64;
            self.chars.clear();
        }
        Ok(done)
    }

    /// Decode the next chunk into `out`; false at the end of the text.
    fn refill(&mut self) -> std::io::Result<bool> {
        self.gather(BASE64_CHUNK)?;
        if self.chars.is_empty() {
            return Ok(false);
        }
        // Up to and including the first padded group (a run ends there), else whole groups.
        let cut = match self.chars.iter().position(|&c| c == b'=') {
            Some(p) => (p / 4 + 1) * 4,
            None => self.chars.len() / 4 * 4,
        };
        if cut == 0 || cut > self.chars.len() {
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidData, "base64 text ends inside a group"));
        }
        self.out.clear();
        self.out.resize(cut / 4 * 3, 0);
        let n = STANDARD
            .decode_slice(&self.chars[..cut], &mut self.out)
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, format!("invalid base64: {e}")))?;
        self.out.truncate(n);
        self.at = 0;
        self.chars.drain(..cut);
        Ok(true)
    }
}

impl<R: BufRead> Read for Base64<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while self.at == self.out.len() {
            if !self.refill()? {
                return Ok(0);
            }
        }
        let n = buf.len().min(self.out.len() - self.at);
        buf[..n].copy_from_slice(&self.out[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

fn parse_ascii(ctx: &Ctx, body: &str, count: usize) -> Result<Vec<f32>, VolumeError> {
    // Every value takes at least one byte: never reserve more than the text can hold.
    let mut out = Vec::with_capacity(count.min(body.len()));
    for tok in body.split_whitespace() {
        out.push(tok.parse::<f32>().map_err(|_| ctx.bad(format!("`{tok}` is no number")))?);
    }
    if out.len() != count {
        return Err(ctx.bad(format!("holds {} values, the extent needs {count}", out.len())));
    }
    Ok(out)
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

fn numbers<T: std::str::FromStr>(s: &str) -> Option<Vec<T>> {
    s.split_whitespace().map(|t| t.parse().ok()).collect()
}

/// The first `<name …>` start tag at or after byte `from`: its position and attributes.
fn tag(xml: &str, name: &str, from: usize) -> Option<(usize, HashMap<String, String>)> {
    let open = format!("<{name}");
    let mut at = from;
    loop {
        let pos = at + xml.get(at..)?.find(&open)?;
        let after = xml[pos + open.len()..].chars().next()?;
        if after.is_whitespace() || after == '>' || after == '/' {
            let end = pos + xml[pos..].find('>')?;
            return Some((pos, attributes(&xml[pos + open.len()..end])));
        }
        at = pos + 1;
    }
}

/// `key="value"` pairs (single or double quotes).
fn attributes(s: &str) -> HashMap<String, String> {
    let mut map = HashMap::new();
    let mut rest = s;
    while let Some(eq) = rest.find('=') {
        let key = rest[..eq].split_whitespace().last().unwrap_or("").trim_start_matches('<').to_string();
        let after = rest[eq + 1..].trim_start();
        let Some(q) = after.chars().next().filter(|c| *c == '"' || *c == '\'') else { break };
        let Some(close) = after[1..].find(q) else { break };
        map.insert(key, after[1..1 + close].to_string());
        rest = &after[close + 2..];
    }
    map
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attributes_parse() {
        let a = attributes(r#" type="UInt8" Name='Meta Image' format="binary" RangeMin="0""#);
        assert_eq!(a["type"], "UInt8");
        assert_eq!(a["Name"], "Meta Image");
        assert_eq!(a["RangeMin"], "0");
    }

    #[test]
    fn tag_requires_whole_name() {
        let xml = r#"<PointDataX a="1"><PointData Scalars="s">"#;
        let (pos, attrs) = tag(xml, "PointData", 0).unwrap();
        assert_eq!(pos, 18);
        assert_eq!(attrs["Scalars"], "s");
    }
}
