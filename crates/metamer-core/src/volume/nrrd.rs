//! NRRD reader (<https://teem.sourceforge.net/nrrd/format.html>): `.nhdr` with a detached `data file`
//! and `.nrrd` with the data attached after the blank line ending the header; `raw` and `gzip`
//! encodings (and `text`); any of u8/i8/u16/i16/u32/i32/f32/f64 in either byte order; `sizes`,
//! `spacings` (or `space directions`), `byte skip` (including −1 for raw data at the end of the file)
//! and `line skip`.

use super::fill::{Filler, check_memory, has_more, skip as skip_bytes};
use super::raw::MAX_DEFLATE_RATIO;
use super::{Endian, ScalarType, Volume, VolumeError, Voxels, voxel_count};
use flate2::bufread::MultiGzDecoder;
use std::io::{BufRead, BufReader, Cursor, Read, Seek, SeekFrom};
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
/// refused from its size, never read whole. The data are streamed (raw) or inflated (gzip) straight into
/// the voxel buffer, which is allocated once the file's size is known to fit ([`super::fill`]).
pub fn read(path: &Path) -> Result<Volume, VolumeError> {
    let kind = crate::fsio::Kind::Volume;
    let (file, size) = crate::fsio::open_capped(path, kind, kind.cap()).map_err(VolumeError::File)?;
    let io = |e: std::io::Error| VolumeError::invalid(path, format!("cannot be read: {e}"));
    let mut r = BufReader::with_capacity(1 << 16, file);
    let mut head = Vec::with_capacity(usize::try_from(size.min(HEADER_CAP)).unwrap_or(0));
    (&mut r).take(HEADER_CAP).read_to_end(&mut head).map_err(io)?;
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
    let values = match &header.data_file {
        Some(f) => {
            // The detached data file goes through the same bounded opener: only regular files (a header
            // naming `/dev/zero` or a FIFO is refused, never read), at most what the header allows.
            let p = data_file_path(path, f);
            let (data, data_size) = match crate::fsio::open_capped(&p, kind, cap) {
                Err(crate::fsio::FsError::TooLarge { size, cap, .. }) => return Err(oversized(&p, size, cap)),
                other => other.map_err(VolumeError::File)?,
            };
            decode_payload(path, &p, &header, BufReader::with_capacity(1 << 16, data), data_size, count)?
        }
        None => {
            let allowed = (data_start as u64).saturating_add(cap);
            if size > allowed {
                return Err(oversized(path, size, allowed));
            }
            let start = (data_start as u64).min(size);
            r.seek(SeekFrom::Start(start)).map_err(io)?;
            decode_payload(path, path, &header, r, size - start, count)?
        }
    };
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
    let (header_text, data_start) = split_header(origin, bytes)?;
    let header = parse_header(origin, header_text)?;
    let count = voxel_count(origin, header.dims)?;
    if header.data_file.is_some() {
        return Err(VolumeError::invalid(origin, "names a detached data file, which cannot be read from memory"));
    }
    let data = &bytes[data_start.min(bytes.len())..];
    let values = decode_payload(origin, origin, &header, Cursor::new(data), data.len() as u64, count)?;
    Ok(Volume::new(origin, header.dims, header.spacing, values)?.converted(header.ty))
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

/// Decode the stored data of `h` from `r` (`stored` bytes long: what follows the header, or the data
/// file) into the voxels of `origin` (the volume, named when memory is short); `data_path` names the data
/// in errors. Sizes are checked against the header before the voxel buffer is allocated: raw data exactly,
/// gzip data by what deflate can inflate at most.
fn decode_payload(
    origin: &Path,
    data_path: &Path,
    h: &Header,
    mut r: impl BufRead + Seek,
    stored: u64,
    count: usize,
) -> Result<Voxels, VolumeError> {
    let io = |e: std::io::Error| VolumeError::invalid(data_path, format!("cannot be read: {e}"));
    // Line skip applies to the file as stored.
    let mut used = 0u64;
    for _ in 0..h.line_skip {
        match skip_line(&mut r).map_err(io)? {
            Some(n) => used += n,
            None => {
                return Err(VolumeError::invalid(data_path, format!("has fewer than {} lines to skip", h.line_skip)));
            }
        }
    }
    let left = stored.saturating_sub(used);
    let expected = count * h.ty.size();
    let endian = h.endian.unwrap_or_default();
    match h.encoding {
        Encoding::Text => {
            // Text of `left` bytes holds at most (left + 1) / 2 values (a digit and a separator each): when
            // it can hold the volume, the memory is checked before it is read (values become f32).
            if left.saturating_add(1) / 2 >= count as u64 {
                check_memory(origin, h.dims, ScalarType::F32)?;
            }
            // Bounded by the data cap the file's size was checked against.
            let mut text = Vec::with_capacity(usize::try_from(left).unwrap_or(0));
            r.read_to_end(&mut text).map_err(io)?;
            parse_text(data_path, &text, count, h.byte_skip).map(Voxels::from)
        }
        Encoding::Raw => {
            let skip = if h.byte_skip == -1 {
                left.checked_sub(expected as u64).ok_or_else(|| truncated(data_path, expected, left))?
            } else {
                h.byte_skip as u64
            };
            let data = left.saturating_sub(skip);
            if data < expected as u64 {
                return Err(truncated(data_path, expected, data));
            }
            if data > expected as u64 {
                return Err(VolumeError::invalid(
                    data_path,
                    format!("holds {data} data bytes but the header's sizes and type need {expected}"),
                ));
            }
            r.seek(SeekFrom::Current(skip as i64)).map_err(io)?;
            let mut fill = Filler::new(origin, h.dims, h.ty, endian)?;
            let got = fill.read_from(&mut r, expected).map_err(io)?;
            if got < expected {
                return Err(truncated(data_path, expected, got as u64));
            }
            Ok(fill.finish())
        }
        Encoding::Gzip => {
            // Inflated straight into the voxel buffer, no more than the header needs (plus one byte to notice
            // excess): a small file must not inflate without bound, and a huge `byte skip` must not overflow.
            let skip = u64::try_from(h.byte_skip.max(0)).unwrap_or(0);
            let needed = skip.saturating_add(expected as u64);
            if left.saturating_mul(MAX_DEFLATE_RATIO).saturating_add(1 << 16) < needed {
                return Err(VolumeError::invalid(
                    data_path,
                    format!(
                        "data is truncated: the header needs {needed} bytes, more than {left} bytes of gzip data can \
                         inflate to"
                    ),
                ));
            }
            let gz =
                |e: std::io::Error| VolumeError::invalid(data_path, format!("gzip data cannot be decompressed: {e}"));
            let short = |got: u64| {
                VolumeError::invalid(
                    data_path,
                    format!("data is truncated: the header needs {needed} bytes, the gzip data inflates to {got}"),
                )
            };
            let mut z = MultiGzDecoder::new(r);
            let skipped = skip_bytes(&mut z, skip).map_err(gz)?;
            if skipped < skip {
                return Err(short(skipped));
            }
            let mut fill = Filler::new(origin, h.dims, h.ty, endian)?;
            let got = fill.read_from(&mut z, expected).map_err(gz)?;
            if got < expected {
                return Err(short(skip + got as u64));
            }
            if has_more(&mut z).map_err(gz)? {
                return Err(VolumeError::invalid(
                    data_path,
                    format!("gzip data inflates to more than the {needed} bytes the header needs"),
                ));
            }
            Ok(fill.finish())
        }
    }
}

/// Skip one line of `r` (through its `\n`): the bytes skipped, or None when `r` ends first.
fn skip_line(r: &mut impl BufRead) -> std::io::Result<Option<u64>> {
    let mut n = 0u64;
    loop {
        let buf = r.fill_buf()?;
        if buf.is_empty() {
            return Ok(None);
        }
        match buf.iter().position(|&b| b == b'\n') {
            Some(i) => {
                r.consume(i + 1);
                return Ok(Some(n + i as u64 + 1));
            }
            None => {
                let k = buf.len();
                r.consume(k);
                n += k as u64;
            }
        }
    }
}

fn truncated(path: &Path, expected: usize, found: u64) -> VolumeError {
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
