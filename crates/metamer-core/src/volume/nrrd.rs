//! NRRD reader (<https://teem.sourceforge.net/nrrd/format.html>): `.nhdr` with a detached `data file`
//! and `.nrrd` with the data attached after the blank line ending the header; `raw` and `gzip`
//! encodings (and `text`); any of u8/i8/u16/i16/u32/i32/f32/f64 in either byte order; `sizes`,
//! `spacings` (or `space directions`), `byte skip` (including −1 for raw data at the end of the file)
//! and `line skip`.

use super::{Endian, ScalarType, Volume, VolumeError, Voxels, decode_voxels, voxel_count};
use flate2::read::MultiGzDecoder;
use std::io::Read;
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Raw,
    Gzip,
    Text,
}

/// The fields of a NRRD header that the reader uses.
#[derive(Debug)]
struct Header {
    ty: ScalarType,
    dims: [usize; 3],
    spacing: [f64; 3],
    encoding: Encoding,
    endian: Option<Endian>,
    data_file: Option<PathBuf>,
    byte_skip: i64,
    line_skip: usize,
}

/// The longest header read: real NRRD headers are a few hundred bytes. Only this much of a file is read
/// before its header says how many data bytes may follow.
pub(crate) const HEADER_CAP: u64 = 1 << 20;

/// Read a `.nhdr` or `.nrrd` file. Reads are bounded by what the header says: first at most
/// [`HEADER_CAP`] bytes (the header must end within them), then the data (attached, or the detached `data
/// file`) only when its size fits the header's sizes and type ([`data_cap`]), so a huge or sparse file is
/// refused from its size, never read whole.
pub fn read(path: &Path) -> Result<Volume, VolumeError> {
    let (head, size) =
        crate::fsio::read_head(path, crate::fsio::Kind::Volume, HEADER_CAP).map_err(VolumeError::File)?;
    let complete = head.len() as u64 >= size;
    if !complete && !head.windows(2).any(|w| w == b"\n\n") && !head.windows(3).any(|w| w == b"\n\r\n") {
        return Err(VolumeError::invalid(
            path,
            format!("the header does not end (with a blank line) within its first {HEADER_CAP} bytes"),
        ));
    }
    let (header_text, data_start) = split_header(path, &head)?;
    let header = parse_header(path, header_text)?;
    let count = voxel_count(path, header.dims)?;
    let cap = data_cap(&header, count);
    let (data_path, file_bytes) = match &header.data_file {
        Some(f) => {
            // The detached data file goes through the same bounded reader: only regular files (a header
            // naming `/dev/zero` or a FIFO is refused, never read), at most what the header allows.
            let p = data_file_path(path, f);
            let b = read_data(&p, cap)?;
            (p, b)
        }
        None => {
            let allowed = (data_start as u64).saturating_add(cap);
            if size > allowed {
                return Err(oversized(path, size, allowed));
            }
            let mut bytes = if complete { head } else { read_data(path, allowed)? };
            bytes.drain(..data_start.min(bytes.len()));
            (path.to_path_buf(), bytes)
        }
    };
    let values = decode_payload(&data_path, &header, &file_bytes, count)?;
    Ok(Volume::new(path, header.dims, header.spacing, values)?.converted(header.ty))
}

/// Where a header's `data file` is: relative to the header's folder.
fn data_file_path(header: &Path, file: &Path) -> PathBuf {
    header.parent().unwrap_or(Path::new(".")).join(file)
}

/// The most bytes the stored data of `h` (after the header, or in its data file) may take: the data
/// itself, the byte and line skips, and for gzip and text the most their encodings can need. A raw file
/// whose data sits at its end (`byte skip: -1`) may hold anything before it: the volume cap.
fn data_cap(h: &Header, count: usize) -> u64 {
    let cap = crate::fsio::Kind::Volume.cap();
    let expected = (count as u64).saturating_mul(h.ty.size() as u64);
    let skip = u64::try_from(h.byte_skip.max(0)).unwrap_or(0);
    // Skipped lines (a comment block before the data): up to 64 KiB each.
    let lines = (h.line_skip as u64).saturating_mul(64 << 10);
    let stored = match h.encoding {
        Encoding::Raw if h.byte_skip == -1 => return cap,
        Encoding::Raw => skip.saturating_add(expected),
        // Deflate grows incompressible data by well under 1/64; gzip's headers are a few bytes.
        Encoding::Gzip => {
            let inflated = skip.saturating_add(expected);
            inflated.saturating_add(inflated / 64).saturating_add(64 << 10)
        }
        // A value as text: a number of up to 40 characters and a separator.
        Encoding::Text => skip.saturating_add((count as u64).saturating_mul(48)).saturating_add(64 << 10),
    };
    // Plus 1 MiB: a file a little too long is read and told exactly how many bytes are too many.
    stored.saturating_add(lines).saturating_add(HEADER_CAP).min(cap)
}

fn read_data(path: &Path, cap: u64) -> Result<Vec<u8>, VolumeError> {
    match crate::fsio::read_capped(path, crate::fsio::Kind::Volume, cap) {
        Err(crate::fsio::FsError::TooLarge { size, cap, .. }) => Err(oversized(path, size, cap)),
        other => other.map_err(VolumeError::File),
    }
}

fn oversized(path: &Path, size: u64, allowed: u64) -> VolumeError {
    VolumeError::invalid(
        path,
        format!("is {size} bytes, more than the {allowed} the header's sizes, type and encoding allow (not read)"),
    )
}

/// At most 80 characters of `text`, control characters escaped: how header text is quoted in errors.
fn excerpt(text: &str) -> String {
    let short: String = text.chars().take(80).collect();
    let more = if short.len() < text.len() { "…" } else { "" };
    format!("{}{more}", crate::fsio::escape(&short))
}

/// Read an attached NRRD held in memory (`origin` names it in errors). A header that names a detached
/// `data file` is refused: there is no folder to find it in.
pub fn from_bytes(origin: &Path, bytes: &[u8]) -> Result<Volume, VolumeError> {
    parse(origin, bytes, |p| {
        Err(VolumeError::invalid(p, "names a detached data file, which cannot be read from memory"))
    })
}

/// Parse a NRRD file's bytes; `load` reads a detached data file (given its path beside `path`).
fn parse(
    path: &Path,
    bytes: &[u8],
    load: impl FnOnce(&Path) -> Result<Vec<u8>, VolumeError>,
) -> Result<Volume, VolumeError> {
    let (header_text, data_start) = split_header(path, bytes)?;
    let header = parse_header(path, header_text)?;
    let count = voxel_count(path, header.dims)?;
    let (data_path, file_bytes): (PathBuf, Vec<u8>) = match &header.data_file {
        Some(f) => {
            let p = data_file_path(path, f);
            let b = load(&p)?;
            (p, b)
        }
        None => (path.to_path_buf(), bytes[data_start.min(bytes.len())..].to_vec()),
    };
    let values = decode_payload(&data_path, &header, &file_bytes, count)?;
    Ok(Volume::new(path, header.dims, header.spacing, values)?.converted(header.ty))
}

/// Split the file into header text (lines up to the first empty line or EOF) and the offset of the
/// attached data.
fn split_header<'a>(path: &Path, bytes: &'a [u8]) -> Result<(&'a str, usize), VolumeError> {
    if !bytes.starts_with(b"NRRD") {
        return Err(VolumeError::invalid(path, "not a NRRD file (it does not start with the magic `NRRD000x`)"));
    }
    let mut pos = 0;
    let mut end = bytes.len();
    let mut data_start = bytes.len();
    while pos < bytes.len() {
        let nl = bytes[pos..].iter().position(|&b| b == b'\n').map(|i| pos + i);
        let line_end = nl.unwrap_or(bytes.len());
        let line = &bytes[pos..line_end];
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        if line.is_empty() {
            end = pos;
            data_start = line_end + 1;
            break;
        }
        pos = line_end + 1;
    }
    let text = std::str::from_utf8(&bytes[..end.min(bytes.len())])
        .map_err(|_| VolumeError::invalid(path, "the header is not text (is the blank line after it missing?)"))?;
    Ok((text, data_start))
}

fn parse_header(path: &Path, text: &str) -> Result<Header, VolumeError> {
    let bad = |key: &str, reason: String| VolumeError::invalid(path, format!("header field `{key}`: {reason}"));
    let mut ty = None;
    let mut dimension = None;
    let mut sizes: Option<Vec<usize>> = None;
    let mut spacings: Option<Vec<f64>> = None;
    let mut directions: Option<Vec<f64>> = None;
    let mut encoding = None;
    let mut endian = None;
    let mut data_file = None;
    let mut byte_skip = 0i64;
    let mut line_skip = 0usize;
    for (i, line) in text.lines().enumerate() {
        let line = line.trim_end_matches('\r');
        if i == 0 {
            if !line.starts_with("NRRD000") {
                return Err(VolumeError::invalid(path, format!("unknown magic `{}`", excerpt(line))));
            }
            continue;
        }
        if line.starts_with('#') || line.trim().is_empty() || line.contains(":=") {
            continue;
        }
        let Some((key, value)) = line.split_once(": ") else {
            return Err(VolumeError::invalid(
                path,
                format!("header line {} is not `field: value`: `{}`", i + 1, excerpt(line)),
            ));
        };
        let key = key.trim().to_ascii_lowercase();
        let value = value.trim();
        let shown = excerpt(value);
        match key.as_str() {
            "type" => {
                ty = Some(ScalarType::parse(value).ok_or_else(|| bad("type", format!("unsupported type `{shown}`")))?)
            }
            "dimension" => {
                dimension =
                    Some(value.parse::<usize>().map_err(|_| bad("dimension", format!("`{shown}` is no number")))?)
            }
            "sizes" => {
                let v: Result<Vec<usize>, _> = value.split_whitespace().map(str::parse).collect();
                sizes = Some(v.map_err(|_| bad("sizes", format!("`{shown}` are not whole numbers")))?);
            }
            "spacings" => {
                let v: Vec<f64> = value.split_whitespace().map(|s| s.parse::<f64>().unwrap_or(f64::NAN)).collect();
                spacings = Some(v);
            }
            "space directions" => {
                let mut norms = Vec::new();
                for part in value.split_whitespace() {
                    if part == "none" {
                        continue;
                    }
                    let inner = part.trim_start_matches('(').trim_end_matches(')');
                    let comps: Result<Vec<f64>, _> = inner.split(',').map(|c| c.trim().parse::<f64>()).collect();
                    let comps =
                        comps.map_err(|_| bad("space directions", format!("`{}` is not a vector", excerpt(part))))?;
                    norms.push(comps.iter().map(|c| c * c).sum::<f64>().sqrt());
                }
                directions = Some(norms);
            }
            "encoding" => {
                encoding = Some(match value.to_ascii_lowercase().as_str() {
                    "raw" => Encoding::Raw,
                    "gzip" | "gz" => Encoding::Gzip,
                    "text" | "txt" | "ascii" => Encoding::Text,
                    other => {
                        return Err(bad(
                            "encoding",
                            format!("unsupported encoding `{}` (raw, gzip, text)", excerpt(other)),
                        ));
                    }
                })
            }
            "endian" => {
                endian = Some(match value.to_ascii_lowercase().as_str() {
                    "little" => Endian::Little,
                    "big" => Endian::Big,
                    other => return Err(bad("endian", format!("`{}` is neither little nor big", excerpt(other)))),
                })
            }
            "data file" | "datafile" => {
                if value.starts_with("LIST") || value.split_whitespace().count() > 1 {
                    return Err(bad("data file", "multiple data files are not supported".into()));
                }
                data_file = Some(PathBuf::from(value));
            }
            "byte skip" => {
                byte_skip = value.parse().map_err(|_| bad("byte skip", format!("`{shown}` is no whole number")))?;
                if byte_skip < -1 {
                    return Err(bad("byte skip", format!("{byte_skip} is below -1")));
                }
            }
            "line skip" => {
                line_skip = value.parse().map_err(|_| bad("line skip", format!("`{shown}` is no whole number")))?
            }
            _ => {}
        }
    }
    let ty = ty.ok_or_else(|| VolumeError::invalid(path, "header field `type` is missing"))?;
    let sizes = sizes.ok_or_else(|| VolumeError::invalid(path, "header field `sizes` is missing"))?;
    let encoding = encoding.ok_or_else(|| VolumeError::invalid(path, "header field `encoding` is missing"))?;
    if let Some(d) = dimension
        && d != sizes.len()
    {
        return Err(bad("sizes", format!("{} sizes given but `dimension` is {d}", sizes.len())));
    }
    if sizes.is_empty() || sizes.len() > 3 {
        return Err(bad("sizes", format!("{} axes; only 1-, 2- and 3-D scalar volumes are supported", sizes.len())));
    }
    let mut dims = [1usize; 3];
    dims[..sizes.len()].copy_from_slice(&sizes);
    let mut spacing = [1.0f64; 3];
    if let Some(s) = spacings.or(directions) {
        if s.len() != sizes.len() {
            return Err(bad("spacings", format!("{} spacings for {} axes", s.len(), sizes.len())));
        }
        for (a, v) in s.iter().enumerate() {
            // Every spacing must be a usable number: `nan` and `inf` are refused (the renderer's step
            // count depends on them), and the range is checked by `Volume::new`.
            if !(v.is_finite() && *v > 0.0) {
                return Err(bad("spacings", format!("spacing {v} is not a positive finite number")));
            }
            spacing[a] = *v;
        }
    }
    if ty.size() > 1 && endian.is_none() && encoding != Encoding::Text {
        return Err(VolumeError::invalid(path, "header field `endian` is missing (needed for multi-byte types)"));
    }
    if byte_skip == -1 && encoding != Encoding::Raw {
        return Err(bad("byte skip", "-1 is only allowed with raw encoding".into()));
    }
    Ok(Header { ty, dims, spacing, encoding, endian, data_file, byte_skip, line_skip })
}

fn decode_payload(data_path: &Path, h: &Header, bytes: &[u8], count: usize) -> Result<Voxels, VolumeError> {
    // Line skip applies to the file as stored.
    let mut start = 0usize;
    for _ in 0..h.line_skip {
        match bytes[start..].iter().position(|&b| b == b'\n') {
            Some(i) => start += i + 1,
            None => {
                return Err(VolumeError::invalid(data_path, format!("has fewer than {} lines to skip", h.line_skip)));
            }
        }
    }
    let stored = &bytes[start..];
    let expected = count * h.ty.size();
    let endian = h.endian.unwrap_or_default();
    let payload: Vec<u8> = match h.encoding {
        Encoding::Text => return parse_text(data_path, stored, count, h.byte_skip).map(Voxels::from),
        Encoding::Raw => {
            let skip = if h.byte_skip == -1 {
                stored.len().checked_sub(expected).ok_or_else(|| truncated(data_path, expected, stored.len()))?
            } else {
                h.byte_skip as usize
            };
            stored.get(skip..).unwrap_or(&[]).to_vec()
        }
        Encoding::Gzip => {
            // Inflate no more than the header needs (plus one byte to notice excess): a small file must not
            // inflate without bound, and a huge `byte skip` must not overflow.
            let skip = usize::try_from(h.byte_skip.max(0)).unwrap_or(usize::MAX);
            let limit = expected.saturating_add(skip).saturating_add(1);
            let mut out = Vec::with_capacity(limit.min(1 << 24));
            MultiGzDecoder::new(stored)
                .take(u64::try_from(limit).unwrap_or(u64::MAX))
                .read_to_end(&mut out)
                .map_err(|e| VolumeError::invalid(data_path, format!("gzip data cannot be decompressed: {e}")))?;
            if out.len() == limit {
                return Err(VolumeError::invalid(
                    data_path,
                    format!("gzip data inflates to more than the {} bytes the header needs", limit - 1),
                ));
            }
            out.get(skip..).unwrap_or(&[]).to_vec()
        }
    };
    if payload.len() < expected {
        return Err(truncated(data_path, expected, payload.len()));
    }
    if payload.len() > expected {
        return Err(VolumeError::invalid(
            data_path,
            format!("holds {} data bytes but the header's sizes and type need {expected}", payload.len()),
        ));
    }
    Ok(decode_voxels(&payload, h.ty, endian))
}

fn truncated(path: &Path, expected: usize, found: usize) -> VolumeError {
    VolumeError::invalid(path, format!("data is truncated: the header needs {expected} bytes, the file holds {found}"))
}

fn parse_text(path: &Path, bytes: &[u8], count: usize, byte_skip: i64) -> Result<Vec<f32>, VolumeError> {
    let bytes = bytes.get(byte_skip.max(0) as usize..).unwrap_or(&[]);
    let text = std::str::from_utf8(bytes).map_err(|_| VolumeError::invalid(path, "text data is not UTF-8"))?;
    // Every value takes at least one byte: never reserve more than the text can hold.
    let mut out = Vec::with_capacity(count.min(bytes.len()));
    for tok in text.split(|c: char| c.is_whitespace() || c == ',').filter(|t| !t.is_empty()) {
        let v: f32 =
            tok.parse().map_err(|_| VolumeError::invalid(path, format!("`{tok}` in the text data is no number")))?;
        out.push(v);
    }
    if out.len() != count {
        return Err(VolumeError::invalid(
            path,
            format!("text data holds {} values, the header needs {count}", out.len()),
        ));
    }
    Ok(out)
}
