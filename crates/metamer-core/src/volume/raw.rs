//! Raw volumes: a headerless file of voxel values with dimensions, type and byte order given by the
//! caller (gzip-compressed files are recognised by their magic bytes).

use super::{Endian, ScalarType, Volume, VolumeError, decode_voxels, voxel_count};
use flate2::read::MultiGzDecoder;
use std::io::Read;
use std::path::Path;

/// Read a raw volume of `dims` values of type `ty` (x fastest) with the given byte order and spacing.
/// The file must hold exactly that many bytes (after gzip decompression when it is gzipped).
pub fn read(
    path: &Path,
    dims: [usize; 3],
    ty: ScalarType,
    endian: Endian,
    spacing: [f64; 3],
) -> Result<Volume, VolumeError> {
    let count = voxel_count(path, dims)?;
    let expected = count * ty.size();
    // Never more than the volume needs (plus what gzip may add): a huge or sparse file is refused from its
    // size, not read whole.
    let cap = (expected as u64).saturating_add(expected as u64 / 64).saturating_add(1 << 20);
    let stored = match crate::fsio::read_capped(path, crate::fsio::Kind::Volume, cap) {
        Err(crate::fsio::FsError::TooLarge { size, .. }) => {
            return Err(VolumeError::invalid(
                path,
                format!("is {size} bytes, more than {dims:?} values of {ty:?} can take ({expected} bytes; not read)"),
            ));
        }
        other => other.map_err(VolumeError::File)?,
    };
    let bytes = if stored.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        // Inflate at most one byte more than the volume needs: a small gzip bomb stays small.
        MultiGzDecoder::new(&stored[..])
            .take(u64::try_from(expected).unwrap_or(u64::MAX).saturating_add(1))
            .read_to_end(&mut out)
            .map_err(|e| VolumeError::invalid(path, format!("gzip data cannot be decompressed: {e}")))?;
        out
    } else {
        stored
    };
    if bytes.len() < expected {
        return Err(VolumeError::invalid(
            path,
            format!(
                "data is truncated: {dims:?} values of {ty:?} need {expected} bytes, the file holds {}",
                bytes.len()
            ),
        ));
    }
    if bytes.len() > expected {
        return Err(VolumeError::invalid(
            path,
            format!("holds {} bytes but {dims:?} values of {ty:?} need {expected}", bytes.len()),
        ));
    }
    Ok(Volume::new(path, dims, spacing, decode_voxels(&bytes, ty, endian))?.converted(ty))
}
