//! Scalar volumes for the renderer: NRRD (`.nhdr` detached, `.nrrd` attached; raw or gzip), VTK XML
//! image data (`.vti`, base64 inline or appended, zlib-compressed blocks) and raw files with given
//! dimensions, plus a deterministic generated engine-like volume that needs no data files.
//!
//! A [`Volume`] keeps the file's voxel values in the file's own type ([`Voxels`]: u8, i8, u16, i16, f32;
//! u32, i32 and f64 converted to f32 once, and said so), x fastest, and their value range, so a scene's
//! material ranges are written in the file's own units (e.g. `0..=255` for 8-bit CT).
//! Every reader returns a [`VolumeError`] naming the file and the reason; none panics on bad input.

pub(crate) mod data;
pub(crate) mod fill;
pub(crate) mod generate;
pub mod nrrd;
pub mod raw;
pub(crate) mod voxels;
pub mod vti;

pub use data::{find_in, find_in_data_dir};
pub use generate::{U16_SCALE, engine_like_u16};
pub use voxels::{Buf, Voxel, VoxelVisitor, Voxels};

use std::path::{Path, PathBuf};

/// Why a volume could not be read.
#[derive(Debug, thiserror::Error)]
pub enum VolumeError {
    /// A volume file (header or data) could not be opened or read: what the file system said.
    #[error("{0}")]
    File(crate::fsio::FsError),
    /// A volume's content is wrong or could not be read through: a bad header field, a type or size that
    /// does not match, data that ends early, a non-finite value, a read that failed midway, …
    #[error("{}: {reason}", crate::fsio::show(path))]
    Invalid {
        /// The file at fault (a detached data file when its data is), as named by the caller or the
        /// header; for a generated or in-memory volume, the name it goes by.
        path: PathBuf,
        /// Why, in words.
        reason: String,
    },
    /// The volume is too large for the machine's memory (refused before it is allocated).
    #[error("{0}")]
    Memory(Box<crate::memory::MemoryError>),
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
    /// Unsigned 8-bit integers.
    U8,
    /// Signed 8-bit integers.
    I8,
    /// Unsigned 16-bit integers.
    U16,
    /// Signed 16-bit integers.
    I16,
    /// Unsigned 32-bit integers (converted to `f32` on reading).
    U32,
    /// Signed 32-bit integers (converted to `f32` on reading).
    I32,
    /// 32-bit IEEE floats.
    F32,
    /// 64-bit IEEE floats (converted to `f32` on reading).
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

    /// True for the types voxels are kept in (u8, i8, u16, i16, f32); the others are converted to f32.
    pub fn is_kept(self) -> bool {
        !matches!(self, ScalarType::U32 | ScalarType::I32 | ScalarType::F64)
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
    /// Least significant byte first (the default, as on x86 and most ARM machines).
    #[default]
    Little,
    /// Most significant byte first.
    Big,
}

/// Turn values read in `endian` byte order into the machine's.
pub(crate) fn to_native<T: Voxel>(values: &mut [T], endian: Endian) {
    let native = if cfg!(target_endian = "little") { Endian::Little } else { Endian::Big };
    if std::mem::size_of::<T>() > 1 && endian != native {
        values.iter_mut().for_each(|v| *v = v.swap_bytes());
    }
}

/// A scalar volume on a regular grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    /// Number of voxels along x, y, z.
    pub dims: [usize; 3],
    /// Distance between voxel centres along x, y, z (world units, e.g. mm).
    pub spacing: [f64; 3],
    /// Voxel values in the file's units and (for u8, i8, u16, i16, f32) its type, x fastest, then y,
    /// then z.
    pub voxels: Voxels,
    /// Smallest and largest value in `voxels` (all finite).
    pub value_range: [f32; 2],
    /// The file's voxel type when it was converted to `f32` on reading (u32, i32, f64), else None.
    pub converted_from: Option<ScalarType>,
}

impl Volume {
    /// Build a volume, checking that `voxels` holds `dims[0]·dims[1]·dims[2]` finite values and the
    /// spacings are positive. `origin` names the source in errors.
    pub fn new(
        origin: &Path,
        dims: [usize; 3],
        spacing: [f64; 3],
        voxels: impl Into<Voxels>,
    ) -> Result<Volume, VolumeError> {
        let voxels = voxels.into();
        let count = voxel_count(origin, dims)?;
        if voxels.len() != count {
            return Err(VolumeError::invalid(
                origin,
                format!("holds {} values but its sizes {:?} need {}", voxels.len(), dims, count),
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
        let value_range = crate::with_voxels!(&voxels, d => range_of(d))
            .ok_or_else(|| VolumeError::invalid(origin, "holds a value that is not a finite number"))?;
        Ok(Volume { dims, spacing, voxels, value_range, converted_from: None })
    }

    /// The same volume, noting that its values were converted to `f32` from the file's type `ty` (when
    /// `ty` is one that is not kept: u32, i32, f64).
    pub(crate) fn converted(mut self, ty: ScalarType) -> Volume {
        self.converted_from = (!ty.is_kept()).then_some(ty);
        self
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
    pub fn len(&self) -> usize {
        self.voxels.len()
    }

    /// True when the volume has no voxels (never: [`Volume::new`] refuses that).
    pub fn is_empty(&self) -> bool {
        self.voxels.is_empty()
    }

    /// Value of voxel (x, y, z), in the file's units (one type dispatch per call: see [`Voxels::get`]).
    pub fn at(&self, x: usize, y: usize, z: usize) -> f32 {
        self.voxels.get(x + self.dims[0] * (y + self.dims[1] * z))
    }

    /// Physical extent (dims − 1) × spacing along each axis.
    pub fn extent(&self) -> [f64; 3] {
        [0, 1, 2].map(|a| (self.dims[a].max(1) - 1) as f64 * self.spacing[a])
    }
}

/// The smallest and largest value, or None when one is not finite (in parallel over large volumes).
fn range_of<T: Voxel>(data: &[T]) -> Option<[f32; 2]> {
    use rayon::prelude::*;
    let fold = |acc: Option<(T, T)>, v: &T| -> Option<(T, T)> {
        let (lo, hi) = acc?;
        v.is_finite().then(|| (if *v < lo { *v } else { lo }, if *v > hi { *v } else { hi }))
    };
    let first = *data.first()?;
    let (lo, hi) = data.par_chunks(1 << 16).map(|c| c.iter().fold(Some((first, first)), fold)).reduce(
        || Some((first, first)),
        |a, b| {
            let ((a0, a1), (b0, b1)) = (a?, b?);
            Some((if b0 < a0 { b0 } else { a0 }, if b1 > a1 { b1 } else { a1 }))
        },
    )?;
    (first.is_finite()).then_some([lo.to_f32(), hi.to_f32()])
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
        let decode = |bytes: &[u8], ty: ScalarType, endian: Endian| {
            let mut f = fill::Filler::new(Path::new("t"), [1, 1, 1], ty, endian).unwrap();
            assert_eq!(f.read_from(&mut &bytes[..], bytes.len()).unwrap(), bytes.len());
            f.finish()
        };
        let v = decode(&[0x01, 0x02], ScalarType::U16, Endian::Little);
        assert_eq!(v, Voxels::from(vec![513u16]));
        let v = decode(&[0x01, 0x02], ScalarType::U16, Endian::Big);
        assert_eq!(v, Voxels::from(vec![258u16]));
        let v = decode(&(-2.5f64).to_be_bytes(), ScalarType::F64, Endian::Big);
        assert_eq!(v, Voxels::from(vec![-2.5f32]));
        let v = decode(&[0xff], ScalarType::I8, Endian::Little);
        assert_eq!(v, Voxels::from(vec![-1i8]));
        let v = decode(&(-1.5f32).to_be_bytes(), ScalarType::F32, Endian::Big);
        assert_eq!(v, Voxels::from(vec![-1.5f32]));
    }

    #[test]
    fn new_rejects_mismatch_and_non_finite() {
        let p = Path::new("t");
        assert!(Volume::new(p, [2, 2, 2], [1.0; 3], vec![0.0; 7]).is_err());
        assert!(Volume::new(p, [1, 1, 1], [1.0; 3], vec![f32::NAN]).is_err());
        assert!(Volume::new(p, [1, 1, 1], [0.0, 1.0, 1.0], vec![1.0]).is_err());
        assert!(Volume::new(p, [0, 1, 1], [1.0; 3], Vec::<f32>::new()).is_err());
        let v = Volume::new(p, [2, 1, 1], [1.0; 3], vec![3.0, -1.0]).unwrap();
        assert_eq!(v.value_range, [-1.0, 3.0]);
        let v = Volume::new(p, [3, 1, 1], [1.0; 3], vec![7u16, 65535, 2]).unwrap();
        assert_eq!(v.value_range, [2.0, 65535.0]);
        assert!(Volume::new(p, [2, 1, 1], [1.0; 3], vec![1.0, f32::INFINITY]).is_err());
    }
}
