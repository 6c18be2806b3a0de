//! Raw volumes: a headerless file of voxel values with dimensions, type and byte order given by the
//! caller (gzip-compressed files are recognised by their magic bytes). The file is streamed straight into
//! the voxel buffer ([`super::fill`]); its size is checked against the dimensions before anything is
//! allocated.

use super::fill::{Filler, has_more};
use super::{Endian, ScalarType, Volume, VolumeError, voxel_count};
use flate2::bufread::MultiGzDecoder;
use std::io::{BufRead, BufReader};
use std::path::Path;

/// Deflate's largest ratio of inflated to compressed bytes (a stream of one repeated byte): a gzip
/// payload of `n` bytes cannot inflate to more than `n × MAX_DEFLATE_RATIO` (plus a block's worth).
pub(crate) const MAX_DEFLATE_RATIO: u64 = 1032;

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
    // size, not read.
    let cap = (expected as u64).saturating_add(expected as u64 / 64).saturating_add(1 << 20);
    let (file, size) = match crate::fsio::open_capped(path, crate::fsio::Kind::Volume, cap) {
        Err(crate::fsio::FsError::TooLarge { size, .. }) => {
            return Err(VolumeError::invalid(
                path,
                format!("is {size} bytes, more than {dims:?} values of {ty:?} can take ({expected} bytes; not read)"),
            ));
        }
        other => other.map_err(VolumeError::File)?,
    };
    let io = |e: std::io::Error| VolumeError::invalid(path, format!("cannot be read: {e}"));
    let mut r = BufReader::with_capacity(1 << 16, file);
    let gzipped = r.fill_buf().map_err(io)?.starts_with(&[0x1f, 0x8b]);
    let truncated = |got: usize| {
        VolumeError::invalid(
            path,
            format!("data is truncated: {dims:?} values of {ty:?} need {expected} bytes, the file holds {got}"),
        )
    };
    let voxels = if gzipped {
        if size.saturating_mul(MAX_DEFLATE_RATIO).saturating_add(1 << 16) < expected as u64 {
            return Err(VolumeError::invalid(
                path,
                format!(
                    "data is truncated: {dims:?} values of {ty:?} need {expected} bytes, more than {size} bytes of \
                     gzip can inflate to"
                ),
            ));
        }
        let gz_err = |e: std::io::Error| VolumeError::invalid(path, format!("gzip data cannot be decompressed: {e}"));
        let mut fill = Filler::new(path, dims, ty, endian)?;
        // Inflated straight into the voxels, and one byte more to notice excess: a gzip bomb stays small.
        let mut z = MultiGzDecoder::new(r);
        let got = fill.read_from(&mut z, expected).map_err(gz_err)?;
        if got < expected {
            return Err(truncated(got));
        }
        if has_more(&mut z).map_err(gz_err)? {
            return Err(VolumeError::invalid(
                path,
                format!("gzip data inflates to more than the {expected} bytes {dims:?} values of {ty:?} need"),
            ));
        }
        fill.finish()
    } else {
        if size < expected as u64 {
            return Err(truncated(size as usize));
        }
        if size > expected as u64 {
            return Err(VolumeError::invalid(
                path,
                format!("holds {size} bytes but {dims:?} values of {ty:?} need {expected}"),
            ));
        }
        let mut fill = Filler::new(path, dims, ty, endian)?;
        let got = fill.read_from(&mut r, expected).map_err(io)?;
        if got < expected {
            return Err(truncated(got));
        }
        fill.finish()
    };
    Ok(Volume::new(path, dims, spacing, voxels)?.converted(ty))
}
