//! Scalar volumes for the renderer: NRRD (`.nhdr` detached, `.nrrd` attached; raw or gzip), VTK XML
//! image data (`.vti`, base64 inline or appended, zlib-compressed blocks) and raw files with given
//! dimensions, plus a deterministic generated engine-like volume that needs no data files.
//!
//! A [`Volume`] keeps the file's voxel values (converted to `f32`, x fastest) and their value range, so
//! a scene's material ranges are written in the file's own units (e.g. `0..=255` for 8-bit CT).
//! Every reader returns a [`VolumeError`] naming the file and the reason; none panics on bad input.

pub mod data;
pub mod generate;
pub mod nrrd;
pub mod raw;
pub mod vti;

use std::path::{Path, PathBuf};

/// Why a volume could not be read.
#[derive(Debug, thiserror::Error)]
pub enum VolumeError {
    #[error("{0}")]
    File(crate::fsio::FsError),
    #[error("{}: {reason}", crate::fsio::show(path))]
    Invalid { path: PathBuf, reason: String },
}

/// Read a volume file (header, attached or detached data) through the one bounded reader
/// ([`crate::fsio::read`]): regular files only, at most [`crate::fsio::Kind::Volume`]'s cap.
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>, VolumeError> {
    crate::fsio::read(path, crate::fsio::Kind::Volume).map_err(VolumeError::File)
}

impl VolumeError {
    pub(crate) fn invalid(path: &Path, reason: impl Into<String>) -> VolumeError {
        VolumeError::Invalid { path: path.to_path_buf(), reason: reason.into() }
    }
}

/// The smallest and largest voxel spacing accepted (any unit: only ratios matter to the renderer).
pub(crate) const MIN_SPACING: f64 = 1e-9;
pub(crate) const MAX_SPACING: f64 = 1e9;
/// The largest ratio of the largest to the smallest spacing: the renderer steps by the smallest spacing,
/// so this ratio bounds how many steps a ray takes per voxel of the coarsest axis.
pub const MAX_ANISOTROPY: f64 = 100.0;

/// The storage type of voxel values in a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScalarType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
    F64,
}

impl ScalarType {
    /// Bytes per value.
    pub(crate) fn size(self) -> usize {
        match self {
            ScalarType::U8 | ScalarType::I8 => 1,
            ScalarType::U16 | ScalarType::I16 => 2,
            ScalarType::U32 | ScalarType::I32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }

    /// Parse a type name as NRRD (`unsigned char`, `uint16`, `float`…), VTK (`UInt8`, `Float32`…) or the
    /// short names `u8 i8 u16 i16 u32 i32 f32 f64` write it.
    pub fn parse(name: &str) -> Option<ScalarType> {
        let n = name.trim().to_ascii_lowercase();
        let n = n.split_whitespace().collect::<Vec<_>>().join(" ");
        Some(match n.as_str() {
            "u8" | "uchar" | "unsigned char" | "uint8" | "uint8_t" => ScalarType::U8,
            "i8" | "signed char" | "int8" | "int8_t" => ScalarType::I8,
            "u16" | "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => ScalarType::U16,
            "i16" | "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
                ScalarType::I16
            }
            "u32" | "uint" | "unsigned int" | "uint32" | "uint32_t" => ScalarType::U32,
            "i32" | "int" | "signed int" | "int32" | "int32_t" => ScalarType::I32,
            "f32" | "float" | "float32" => ScalarType::F32,
            "f64" | "double" | "float64" => ScalarType::F64,
            _ => return None,
        })
    }
}

/// Byte order of multi-byte values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Endian {
    #[default]
    Little,
    Big,
}

/// Decode `count` values of `ty` from `bytes` (exactly `count × size` bytes are used).
pub(crate) fn decode_values(bytes: &[u8], ty: ScalarType, endian: Endian) -> Vec<f32> {
    macro_rules! conv {
        ($t:ty, $n:expr) => {
            bytes
                .chunks_exact($n)
                .map(|c| {
                    let mut a = [0u8; $n];
                    a.copy_from_slice(c);
                    (match endian {
                        Endian::Little => <$t>::from_le_bytes(a),
                        Endian::Big => <$t>::from_be_bytes(a),
                    }) as f32
                })
                .collect()
        };
    }
    match ty {
        ScalarType::U8 => bytes.iter().map(|&b| f32::from(b)).collect(),
        ScalarType::I8 => bytes.iter().map(|&b| f32::from(b as i8)).collect(),
        ScalarType::U16 => conv!(u16, 2),
        ScalarType::I16 => conv!(i16, 2),
        ScalarType::U32 => conv!(u32, 4),
        ScalarType::I32 => conv!(i32, 4),
        ScalarType::F32 => conv!(f32, 4),
        ScalarType::F64 => conv!(f64, 8),
    }
}

/// A scalar volume on a regular grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    /// Number of voxels along x, y, z.
    pub dims: [usize; 3],
    /// Distance between voxel centres along x, y, z (world units, e.g. mm).
    pub spacing: [f64; 3],
    /// Voxel values in the file's units, x fastest, then y, then z.
    pub data: Vec<f32>,
    /// Smallest and largest finite value in `data`.
    pub value_range: [f32; 2],
}

impl Volume {
    /// Build a volume, checking that `data` holds `dims[0]·dims[1]·dims[2]` finite values and the
    /// spacings are positive. `origin` names the source in errors.
    pub fn new(origin: &Path, dims: [usize; 3], spacing: [f64; 3], data: Vec<f32>) -> Result<Volume, VolumeError> {
        let count = voxel_count(origin, dims)?;
        if data.len() != count {
            return Err(VolumeError::invalid(
                origin,
                format!("holds {} values but its sizes {:?} need {}", data.len(), dims, count),
            ));
        }
        if let Some(s) = spacing.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
            return Err(VolumeError::invalid(origin, format!("spacing {s} is not a positive number")));
        }
        if let Some(s) = spacing.iter().find(|s| !(MIN_SPACING..=MAX_SPACING).contains(*s)) {
            return Err(VolumeError::invalid(
                origin,
                format!("spacing {s} is outside the sane range {MIN_SPACING:e} … {MAX_SPACING:e}"),
            ));
        }
        let (lo_s, hi_s) = spacing.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), s| (lo.min(*s), hi.max(*s)));
        if hi_s / lo_s > MAX_ANISOTROPY {
            return Err(VolumeError::invalid(
                origin,
                format!(
                    "spacings {spacing:?} differ by a factor {:.3e}, more than {MAX_ANISOTROPY} \
                     (the renderer steps by the smallest spacing)",
                    hi_s / lo_s
                ),
            ));
        }
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for v in &data {
            if !v.is_finite() {
                return Err(VolumeError::invalid(origin, "holds a value that is not a finite number"));
            }
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
        Ok(Volume { dims, spacing, data, value_range: [lo, hi] })
    }

    /// Read a volume, choosing the reader by the file name: `.nhdr`/`.nrrd` → NRRD, `.vti` → VTK image data.
    /// Raw files need their dimensions and type: use [`raw::read`].
    pub fn open(path: &Path) -> Result<Volume, VolumeError> {
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("").to_ascii_lowercase();
        if name.ends_with(".nhdr") || name.ends_with(".nrrd") {
            nrrd::read(path)
        } else if name.ends_with(".vti") {
            vti::read(path)
        } else {
            Err(VolumeError::invalid(
                path,
                "unknown volume format (expected .nhdr, .nrrd or .vti; raw files need dims and type)",
            ))
        }
    }

    /// Number of voxels.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.data.len()
    }

    /// Value of voxel (x, y, z).
    pub fn at(&self, x: usize, y: usize, z: usize) -> f32 {
        self.data[x + self.dims[0] * (y + self.dims[1] * z)]
    }

    /// Physical extent (dims − 1) × spacing along each axis.
    pub fn extent(&self) -> [f64; 3] {
        [0, 1, 2].map(|a| (self.dims[a].max(1) - 1) as f64 * self.spacing[a])
    }
}

/// `dims[0]·dims[1]·dims[2]`, refusing zero sizes and overflow (and absurd sizes above 2³² voxels).
pub(crate) fn voxel_count(origin: &Path, dims: [usize; 3]) -> Result<usize, VolumeError> {
    if dims.contains(&0) {
        return Err(VolumeError::invalid(origin, format!("sizes {dims:?} contain a zero")));
    }
    dims.iter()
        .try_fold(1usize, |acc, d| acc.checked_mul(*d))
        .filter(|n| *n <= 1 << 32)
        .ok_or_else(|| VolumeError::invalid(origin, format!("sizes {dims:?} are too large")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_names_parse() {
        assert_eq!(ScalarType::parse("unsigned char"), Some(ScalarType::U8));
        assert_eq!(ScalarType::parse("UInt16"), Some(ScalarType::U16));
        assert_eq!(ScalarType::parse("signed  short int"), Some(ScalarType::I16));
        assert_eq!(ScalarType::parse("Float64"), Some(ScalarType::F64));
        assert_eq!(ScalarType::parse("complex"), None);
    }

    #[test]
    fn decode_respects_endianness() {
        let v = decode_values(&[0x01, 0x02], ScalarType::U16, Endian::Little);
        assert_eq!(v, vec![513.0]);
        let v = decode_values(&[0x01, 0x02], ScalarType::U16, Endian::Big);
        assert_eq!(v, vec![258.0]);
        let v = decode_values(&(-2.5f64).to_be_bytes(), ScalarType::F64, Endian::Big);
        assert_eq!(v, vec![-2.5]);
        let v = decode_values(&[0xff], ScalarType::I8, Endian::Little);
        assert_eq!(v, vec![-1.0]);
    }

    #[test]
    fn new_rejects_mismatch_and_non_finite() {
        let p = Path::new("t");
        assert!(Volume::new(p, [2, 2, 2], [1.0; 3], vec![0.0; 7]).is_err());
        assert!(Volume::new(p, [1, 1, 1], [1.0; 3], vec![f32::NAN]).is_err());
        assert!(Volume::new(p, [1, 1, 1], [0.0, 1.0, 1.0], vec![1.0]).is_err());
        assert!(Volume::new(p, [0, 1, 1], [1.0; 3], vec![]).is_err());
        let v = Volume::new(p, [2, 1, 1], [1.0; 3], vec![3.0, -1.0]).unwrap();
        assert_eq!(v.value_range, [-1.0, 3.0]);
    }
}
