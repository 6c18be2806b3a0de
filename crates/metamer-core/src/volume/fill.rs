//! The one way a reader fills a volume's voxels: [`Filler::new`] checks the machine's memory
//! ([`crate::memory`]) and allocates one buffer of exactly the size the header requires, in the type the
//! voxels are kept in; [`Filler::read_from`] reads a file's bytes (a raw file, a NRRD's data, an inflating
//! gzip or zlib stream, decoded base64) straight into it, never more than it holds. Nothing is read into a
//! second full-size copy; u32, i32 and f64 values are converted to f32 a chunk at a time.

use super::{Buf, Endian, ScalarType, VolumeError, Voxels, to_native};
use std::io::{ErrorKind, Read};
use std::path::Path;

/// A voxel buffer being filled from a stream of the file's bytes.
pub(crate) struct Filler {
    dest: Dest,
    ty: ScalarType,
    endian: Endian,
    /// Bytes of the file's data the volume takes (`count × ty.size()`).
    expected: usize,
    /// Bytes filled so far.
    filled: usize,
}

enum Dest {
    Kept(Voxels),
    /// u32, i32, f64 → f32: the values so far and the bytes of a value cut by a chunk's end.
    Converted {
        out: Vec<f32>,
        carry: Vec<u8>,
    },
}

/// Bytes read per call when converting (and the scratch buffer's size).
const CHUNK: usize = 1 << 16;

impl Filler {
    /// A buffer for `dims` voxels of the file type `ty`, refused with the volume's size and the memory its
    /// rendering needs when the machine has less ([`crate::memory::render_estimate`]). `origin` names the
    /// volume in the message.
    pub(crate) fn new(origin: &Path, dims: [usize; 3], ty: ScalarType, endian: Endian) -> Result<Filler, VolumeError> {
        let count = check_memory(origin, dims, ty)?;
        let dest = match ty {
            ScalarType::U8 => Dest::Kept(Voxels::U8(Buf::zeroed(count))),
            ScalarType::I8 => Dest::Kept(Voxels::I8(Buf::zeroed(count))),
            ScalarType::U16 => Dest::Kept(Voxels::U16(Buf::zeroed(count))),
            ScalarType::I16 => Dest::Kept(Voxels::I16(Buf::zeroed(count))),
            ScalarType::F32 => Dest::Kept(Voxels::F32(Buf::zeroed(count))),
            ScalarType::U32 | ScalarType::I32 | ScalarType::F64 => {
                Dest::Converted { out: Vec::with_capacity(count), carry: Vec::new() }
            }
        };
        Ok(Filler { dest, ty, endian, expected: count * ty.size(), filled: 0 })
    }

    /// Read from `r` until `n` more bytes are filled (at most what the buffer still lacks) or `r` ends;
    /// returns how many were read.
    pub(crate) fn read_from(&mut self, r: &mut impl Read, n: usize) -> std::io::Result<usize> {
        let n = n.min(self.expected - self.filled);
        let start = self.filled;
        match &mut self.dest {
            Dest::Kept(v) => {
                let bytes = kept_bytes(v);
                let got = read_full(r, &mut bytes[start..start + n])?;
                self.filled += got;
                Ok(got)
            }
            Dest::Converted { out, carry } => {
                let mut scratch = vec![0u8; CHUNK.min(n.max(1))];
                let mut done = 0;
                while done < n {
                    let want = (n - done).min(scratch.len());
                    let got = read_full(r, &mut scratch[..want])?;
                    carry.extend_from_slice(&scratch[..got]);
                    let size = self.ty.size();
                    let whole = carry.len() / size * size;
                    convert(&carry[..whole], self.ty, self.endian, out);
                    carry.drain(..whole);
                    done += got;
                    if got < want {
                        break;
                    }
                }
                self.filled += done;
                Ok(done)
            }
        }
    }

    /// The voxels, in the machine's byte order. Only when every byte was filled (callers check).
    pub(crate) fn finish(self) -> Voxels {
        debug_assert_eq!(self.filled, self.expected);
        match self.dest {
            Dest::Kept(mut v) => {
                match &mut v {
                    Voxels::U8(_) | Voxels::I8(_) => {}
                    Voxels::U16(b) => to_native(b, self.endian),
                    Voxels::I16(b) => to_native(b, self.endian),
                    Voxels::F32(b) => to_native(b, self.endian),
                }
                v
            }
            Dest::Converted { out, .. } => Voxels::F32(Buf::from(out)),
        }
    }
}

fn kept_bytes(v: &mut Voxels) -> &mut [u8] {
    match v {
        Voxels::U8(b) => b.bytes_mut(),
        Voxels::I8(b) => b.bytes_mut(),
        Voxels::U16(b) => b.bytes_mut(),
        Voxels::I16(b) => b.bytes_mut(),
        Voxels::F32(b) => b.bytes_mut(),
    }
}

/// Append the whole values of `ty` in `bytes` to `out` as f32.
fn convert(bytes: &[u8], ty: ScalarType, endian: Endian, out: &mut Vec<f32>) {
    macro_rules! conv {
        ($t:ty, $n:expr) => {
            out.extend(bytes.chunks_exact($n).map(|c| {
                let mut a = [0u8; $n];
                a.copy_from_slice(c);
                (match endian {
                    Endian::Little => <$t>::from_le_bytes(a),
                    Endian::Big => <$t>::from_be_bytes(a),
                }) as f32
            }))
        };
    }
    match ty {
        ScalarType::U32 => conv!(u32, 4),
        ScalarType::I32 => conv!(i32, 4),
        ScalarType::F64 => conv!(f64, 8),
        // The kept types never reach here (they are read in place).
        _ => {}
    }
}

/// Refuse a volume of `dims` voxels of the file type `ty` that the machine's memory cannot render, naming
/// its size and the memory rendering it needs ([`crate::memory::render_estimate`]); the voxel count when it
/// fits. [`Filler::new`] calls it; text readers call it before parsing (their values become f32).
pub(crate) fn check_memory(origin: &Path, dims: [usize; 3], ty: ScalarType) -> Result<usize, VolumeError> {
    let count = super::voxel_count(origin, dims)?;
    let kept_size = if ty.is_kept() { ty.size() } else { 4 };
    let bytes = (count as u64).saturating_mul(kept_size as u64);
    crate::memory::ensure(
        || {
            format!(
                "volume {} is {}×{}×{} {} = {} MiB; rendering it",
                crate::fsio::show(origin),
                dims[0],
                dims[1],
                dims[2],
                type_name(ty),
                crate::memory::show_mib(bytes)
            )
        },
        crate::memory::render_estimate(bytes),
    )
    .map_err(|e| VolumeError::Memory(Box::new(e)))?;
    Ok(count)
}

/// Read until `buf` is full or `r` ends; the number of bytes read.
pub(crate) fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut at = 0;
    while at < buf.len() {
        match r.read(&mut buf[at..]) {
            Ok(0) => break,
            Ok(k) => at += k,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(at)
}

/// Whether `r` holds at least one more byte (reading it).
pub(crate) fn has_more(r: &mut impl Read) -> std::io::Result<bool> {
    Ok(read_full(r, &mut [0u8; 1])? == 1)
}

/// Skip `n` bytes of `r`; the number skipped (fewer when it ends).
pub(crate) fn skip(r: &mut impl Read, n: u64) -> std::io::Result<u64> {
    std::io::copy(&mut r.take(n), &mut std::io::sink())
}

/// The type as the short names write it (`u16`, `f32`…).
pub(crate) fn type_name(ty: ScalarType) -> &'static str {
    match ty {
        ScalarType::U8 => "u8",
        ScalarType::I8 => "i8",
        ScalarType::U16 => "u16",
        ScalarType::I16 => "i16",
        ScalarType::U32 => "u32",
        ScalarType::I32 => "i32",
        ScalarType::F32 => "f32",
        ScalarType::F64 => "f64",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fills_in_place_and_converts_across_chunk_ends() {
        let p = Path::new("t");
        let mut f = Filler::new(p, [3, 1, 1], ScalarType::U16, Endian::Big).unwrap();
        assert_eq!(f.read_from(&mut &[0u8, 1, 0, 2][..], 10).unwrap(), 4);
        assert_eq!(f.read_from(&mut &[1u8, 0, 9, 9][..], 10).unwrap(), 2);
        assert_eq!(f.filled, f.expected);
        assert_eq!(f.finish(), Voxels::from(vec![1u16, 2, 256]));
        // f64 values arriving in pieces that cut values in two.
        let values = [1.5f64, -2.0, 1e3];
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let mut f = Filler::new(p, [3, 1, 1], ScalarType::F64, Endian::Little).unwrap();
        for piece in bytes.chunks(5) {
            assert_eq!(f.read_from(&mut &piece[..], 100).unwrap(), piece.len());
        }
        assert_eq!(f.finish(), Voxels::from(vec![1.5f32, -2.0, 1000.0]));
        // A short stream fills what it has.
        let mut f = Filler::new(p, [4, 1, 1], ScalarType::I8, Endian::Little).unwrap();
        assert_eq!(f.read_from(&mut &[1u8, 2][..], 4).unwrap(), 2);
        assert_eq!(f.filled, 2);
    }
}
