//! NRRD reader (<https://teem.sourceforge.net/nrrd/format.html>): `.nhdr` with a detached `data file`
//! and `.nrrd` with the data attached after the blank line ending the header; `raw` and `gzip`
//! encodings (and `text`); any of u8/i8/u16/i16/u32/i32/f32/f64 in either byte order; `sizes`,
//! `spacings` (or `space directions`), `byte skip` (including −1 for raw data at the end of the file)
//! and `line skip`.

use super::{Endian, ScalarType, Volume, VolumeError, decode_values, voxel_count};
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

/// Read a `.nhdr` or `.nrrd` file.
pub fn read(path: &Path) -> Result<Volume, VolumeError> {
    let bytes = super::read_file(path)?;
    // The detached data file goes through the same bounded reader: only regular files (a header naming
    // `/dev/zero` or a FIFO is refused, never read), at most the volume cap.
    parse(path, &bytes, super::read_file)
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
            let p = path.parent().unwrap_or(Path::new(".")).join(f);
            let b = load(&p)?;
            (p, b)
        }
        None => (path.to_path_buf(), bytes[data_start.min(bytes.len())..].to_vec()),
    };
    let values = decode_payload(&data_path, &header, &file_bytes, count)?;
    Volume::new(path, header.dims, header.spacing, values)
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
                return Err(VolumeError::invalid(path, format!("unknown magic `{line}`")));
            }
            continue;
        }
        if line.starts_with('#') || line.trim().is_empty() || line.contains(":=") {
            continue;
        }
        let Some((key, value)) = line.split_once(": ") else {
            return Err(VolumeError::invalid(path, format!("header line {} is not `field: value`: `{line}`", i + 1)));
        };
        let key = key.trim().to_ascii_lowercase();
        let value = value.trim();
        match key.as_str() {
            "type" => {
                ty = Some(ScalarType::parse(value).ok_or_else(|| bad("type", format!("unsupported type `{value}`")))?)
            }
            "dimension" => {
                dimension =
                    Some(value.parse::<usize>().map_err(|_| bad("dimension", format!("`{value}` is no number")))?)
            }
            "sizes" => {
                let v: Result<Vec<usize>, _> = value.split_whitespace().map(str::parse).collect();
                sizes = Some(v.map_err(|_| bad("sizes", format!("`{value}` are not whole numbers")))?);
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
                    let comps = comps.map_err(|_| bad("space directions", format!("`{part}` is not a vector")))?;
                    norms.push(comps.iter().map(|c| c * c).sum::<f64>().sqrt());
                }
                directions = Some(norms);
            }
            "encoding" => {
                encoding = Some(match value.to_ascii_lowercase().as_str() {
                    "raw" => Encoding::Raw,
                    "gzip" | "gz" => Encoding::Gzip,
                    "text" | "txt" | "ascii" => Encoding::Text,
                    other => return Err(bad("encoding", format!("unsupported encoding `{other}` (raw, gzip, text)"))),
                })
            }
            "endian" => {
                endian = Some(match value.to_ascii_lowercase().as_str() {
                    "little" => Endian::Little,
                    "big" => Endian::Big,
                    other => return Err(bad("endian", format!("`{other}` is neither little nor big"))),
                })
            }
            "data file" | "datafile" => {
                if value.starts_with("LIST") || value.split_whitespace().count() > 1 {
                    return Err(bad("data file", "multiple data files are not supported".into()));
                }
                data_file = Some(PathBuf::from(value));
            }
            "byte skip" => {
                byte_skip = value.parse().map_err(|_| bad("byte skip", format!("`{value}` is no whole number")))?;
                if byte_skip < -1 {
                    return Err(bad("byte skip", format!("{byte_skip} is below -1")));
                }
            }
            "line skip" => {
                line_skip = value.parse().map_err(|_| bad("line skip", format!("`{value}` is no whole number")))?
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

fn decode_payload(data_path: &Path, h: &Header, bytes: &[u8], count: usize) -> Result<Vec<f32>, VolumeError> {
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
        Encoding::Text => return parse_text(data_path, stored, count, h.byte_skip),
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
    Ok(decode_values(&payload, h.ty, endian))
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
