//! VTK XML image data (`.vti`) reader: one piece, the point-data scalar array (the one named by
//! `Scalars`, else the first), `format="binary"` (base64 inline), `"appended"` (raw or base64
//! `AppendedData`) or `"ascii"`, optionally compressed by `vtkZLibDataCompressor` in blocks, with
//! `UInt32` or `UInt64` headers and either byte order. The XML is small and regular, so it is read by a
//! light hand parser (attributes of the few tags we need), not a general XML library.

use super::{Endian, ScalarType, Volume, VolumeError, Voxels, decode_voxels, voxel_count};
use base64::Engine;
use base64::engine::general_purpose::STANDARD;
use flate2::read::ZlibDecoder;
use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

/// Read a `.vti` file.
pub fn read(path: &Path) -> Result<Volume, VolumeError> {
    let bytes = super::read_file(path)?;
    from_bytes(path, &bytes)
}

/// Read `.vti` content held in memory (`path` names it in errors).
pub fn from_bytes(path: &Path, bytes: &[u8]) -> Result<Volume, VolumeError> {
    let bad = |reason: String| VolumeError::invalid(path, reason);
    // The appended section may hold raw binary; the XML before it is text.
    let appended_at = find(bytes, b"<AppendedData");
    let xml_end = appended_at.unwrap_or(bytes.len());
    let xml = std::str::from_utf8(&bytes[..xml_end]).map_err(|_| bad("the XML is not UTF-8 text".into()))?;

    let (_, file_attrs) =
        tag(xml, "VTKFile", 0).ok_or_else(|| bad("no <VTKFile> element: not a VTK XML file".into()))?;
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

    let (_, image) = tag(xml, "ImageData", 0).ok_or_else(|| bad("no <ImageData> element".into()))?;
    let (piece_at, piece) = tag(xml, "Piece", 0).ok_or_else(|| bad("no <Piece> element".into()))?;
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

    let (pd_at, point_data) =
        tag(xml, "PointData", piece_at).ok_or_else(|| bad("the piece has no <PointData>".into()))?;
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
    let (arr_at, arr) = chosen.ok_or_else(|| bad(format!("PointData holds no DataArray named {wanted:?}")))?;
    let name = arr.get("Name").cloned().unwrap_or_default();
    let ty_name = arr.get("type").ok_or_else(|| bad(format!("DataArray `{name}` has no type")))?;
    let ty =
        ScalarType::parse(ty_name).ok_or_else(|| bad(format!("DataArray `{name}` type `{ty_name}` is unsupported")))?;
    let comps = arr.get("NumberOfComponents").map(|c| c.parse::<usize>()).transpose();
    if !matches!(comps, Ok(None) | Ok(Some(1))) {
        return Err(bad(format!("DataArray `{name}` has {comps:?} components; only scalar data is supported")));
    }
    let expected = count * ty.size();
    let format = arr.get("format").map(String::as_str).unwrap_or("ascii");
    let ctx = Ctx { path, header_size, endian, compressed, array: &name };
    let payload: Vec<u8> = match format {
        "ascii" | "binary" => {
            let open_end = xml[arr_at..]
                .find('>')
                .map(|i| arr_at + i + 1)
                .ok_or_else(|| bad("unterminated DataArray tag".into()))?;
            let close = xml[open_end..]
                .find("</DataArray>")
                .map(|i| open_end + i)
                .ok_or_else(|| bad(format!("DataArray `{name}` is not closed (file truncated?)")))?;
            let body = &xml[open_end..close];
            if format == "ascii" {
                return finish(path, dims, spacing, Voxels::from(parse_ascii(&ctx, body, count)?));
            }
            let chars: Vec<u8> = body.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
            ctx.decode_base64_array(&chars)?
        }
        "appended" => {
            let offset: usize = arr
                .get("offset")
                .and_then(|o| o.trim().parse().ok())
                .ok_or_else(|| bad(format!("appended DataArray `{name}` has no valid offset")))?;
            let at = appended_at.ok_or_else(|| bad("DataArray is appended but there is no <AppendedData>".into()))?;
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
            let data = &bytes[underscore..];
            match enc.as_str() {
                "raw" => ctx.decode_binary_array(data.get(offset..).ok_or_else(|| ctx.truncated(expected, 0))?)?,
                "base64" => {
                    let end = find(data, b"</AppendedData>").unwrap_or(data.len());
                    let chars: Vec<u8> = data[..end].iter().copied().filter(|b| !b.is_ascii_whitespace()).collect();
                    ctx.decode_base64_array(chars.get(offset..).ok_or_else(|| ctx.truncated(expected, 0))?)?
                }
                o => return Err(bad(format!("AppendedData encoding `{o}` is unsupported (raw, base64)"))),
            }
        }
        o => return Err(bad(format!("DataArray `{name}` format `{o}` is unsupported (ascii, binary, appended)"))),
    };
    if payload.len() < expected {
        return Err(ctx.truncated(expected, payload.len()));
    }
    // Appended raw data may be followed by other arrays: use exactly what the extent needs.
    Ok(finish(path, dims, spacing, decode_voxels(&payload[..expected], ty, endian))?.converted(ty))
}

fn finish(path: &Path, dims: [usize; 3], spacing: [f64; 3], values: Voxels) -> Result<Volume, VolumeError> {
    Volume::new(path, dims, spacing, values)
}

struct Ctx<'a> {
    path: &'a Path,
    header_size: usize,
    endian: Endian,
    compressed: bool,
    array: &'a str,
}

impl Ctx<'_> {
    fn bad(&self, reason: String) -> VolumeError {
        VolumeError::invalid(self.path, format!("DataArray `{}`: {reason}", self.array))
    }

    fn truncated(&self, expected: usize, found: usize) -> VolumeError {
        self.bad(format!("data is truncated: the extent needs {expected} bytes, the file holds {found}"))
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

    /// Number of header words: 1 (byte count) uncompressed, `3 + blocks` compressed.
    fn header_words(&self, first: u64) -> Result<usize, VolumeError> {
        if !self.compressed {
            return Ok(1);
        }
        usize::try_from(first)
            .ok()
            .filter(|n| *n < 1 << 32)
            .map(|n| n + 3)
            .ok_or_else(|| self.bad(format!("{first} blocks is absurd")))
    }

    /// Base64 data: VTK encodes the header and the data as two separate base64 runs; files written as one
    /// run are accepted too.
    fn decode_base64_array(&self, chars: &[u8]) -> Result<Vec<u8>, VolumeError> {
        let hs = self.header_size;
        let first_chars = hs.div_ceil(3) * 4;
        let first = STANDARD
            .decode(chars.get(..first_chars).ok_or_else(|| self.truncated(hs, chars.len() * 3 / 4))?)
            .map_err(|e| self.bad(format!("invalid base64: {e}")))?;
        if first.len() < hs {
            return Err(self.truncated(hs, first.len()));
        }
        let words = self.header_words(self.word(&first))?;
        let header_chars = (words * hs).div_ceil(3) * 4;
        let separate = || -> Result<Vec<u8>, VolumeError> {
            let head = STANDARD
                .decode(chars.get(..header_chars).ok_or_else(|| self.truncated(words * hs, chars.len() * 3 / 4))?)
                .map_err(|e| self.bad(format!("invalid base64 in the header: {e}")))?;
            let data = STANDARD.decode(&chars[header_chars..]).map_err(|e| self.bad(format!("invalid base64: {e}")))?;
            let head = head.get(..words * hs).ok_or_else(|| self.truncated(words * hs, head.len()))?;
            self.unpack(head, &data)
        };
        match separate() {
            Ok(v) => Ok(v),
            Err(first_err) => {
                let all = STANDARD.decode(chars).map_err(|_| first_err)?;
                self.decode_binary_array(&all)
            }
        }
    }

    /// Header followed directly by data, as in raw appended data.
    fn decode_binary_array(&self, bytes: &[u8]) -> Result<Vec<u8>, VolumeError> {
        let hs = self.header_size;
        if bytes.len() < hs {
            return Err(self.truncated(hs, bytes.len()));
        }
        let words = self.header_words(self.word(bytes))?;
        let head = bytes.get(..words * hs).ok_or_else(|| self.truncated(words * hs, bytes.len()))?;
        self.unpack(head, &bytes[words * hs..])
    }

    /// Given the header words and the bytes that follow, return the uncompressed data.
    fn unpack(&self, head: &[u8], data: &[u8]) -> Result<Vec<u8>, VolumeError> {
        let hs = self.header_size;
        let w: Vec<u64> = head.chunks_exact(hs).map(|c| self.word(c)).collect();
        if !self.compressed {
            let n = usize::try_from(w[0]).map_err(|_| self.bad("byte count overflows".into()))?;
            return data.get(..n).map(<[u8]>::to_vec).ok_or_else(|| self.truncated(n, data.len()));
        }
        let (blocks, block_size, last_size) = (w[0] as usize, w[1] as usize, w[2] as usize);
        let last_size = if last_size == 0 { block_size } else { last_size };
        // The header's sizes are not trusted for the reservation (the blocks' real sizes are checked below).
        let mut out = Vec::with_capacity(blocks.saturating_mul(block_size).min(data.len()).min(1 << 24));
        let mut at = 0usize;
        for (i, cs) in w[3..].iter().enumerate() {
            let cs = *cs as usize;
            let end = at.checked_add(cs).filter(|e| *e <= data.len()).ok_or_else(|| {
                self.bad(format!("data is truncated: compressed block {} of {blocks} runs past the end", i + 1))
            })?;
            let want = if i + 1 == blocks { last_size } else { block_size };
            let before = out.len();
            ZlibDecoder::new(&data[at..end])
                .take(want as u64 + 1)
                .read_to_end(&mut out)
                .map_err(|e| self.bad(format!("compressed block {} cannot be inflated: {e}", i + 1)))?;
            if out.len() - before != want {
                return Err(self.bad(format!(
                    "compressed block {} inflates to {} bytes, its header says {want}",
                    i + 1,
                    out.len() - before
                )));
            }
            at = end;
        }
        Ok(out)
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
