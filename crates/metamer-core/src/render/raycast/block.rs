//! The geometry of a derived-field block, shared by the field store (`fields.rs`) and the label-contour
//! builder (`labels.rs`): a brick of 2^[`SHIFT`] voxels per edge and its upper seam.

/// log2 of the brick edge.
pub(super) const SHIFT: u32 = 3;
/// Brick edge in voxels.
pub(super) const FIELD_BRICK: usize = 1 << SHIFT;
/// Block entries per axis: the brick and its upper seam.
pub(super) const S: usize = FIELD_BRICK + 1;
/// Block entries.
pub(super) const S3: usize = S * S * S;
