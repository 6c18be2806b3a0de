//! The transfer function as lookup tables, per-brick min/max of values, and the bounding box of the
//! voxels that belong to a material.

use super::MaterialClass;
use crate::volume::Volume;
use rayon::prelude::*;

const LUT_BINS: usize = 4096;

/// The transfer function as lookup tables over the volume's value range, and per-brick emptiness.
pub(super) struct Classifier {
    pub(super) lo: f32,
    pub(super) inv_bin: f32,
    /// Material index + 1 per bin (0 = nothing).
    pub(super) material: Vec<u8>,
    /// Step-corrected opacity per bin.
    pub(super) alpha: Vec<f32>,
    /// Prefix count of occupied bins.
    pub(super) occupied_prefix: Vec<u32>,
    /// Per material: whether it attenuates the ray.
    pub(super) absorbs: Vec<bool>,
    /// Per material: its step-corrected opacity (0 when it never shows).
    pub(super) material_alpha: Vec<f32>,
}

impl Classifier {
    pub(super) fn new(volume: &Volume, materials: &[MaterialClass], step: f64) -> Classifier {
        let [lo, hi] = volume.value_range;
        let width = (hi - lo).max(f32::EPSILON);
        let bin_width = width / (LUT_BINS - 1) as f32;
        let mut material = vec![0u8; LUT_BINS];
        let mut alpha = vec![0f32; LUT_BINS];
        for b in 0..LUT_BINS {
            let v = lo + b as f32 * bin_width;
            if let Some((i, m)) = materials
                .iter()
                .enumerate()
                .find(|(_, m)| v >= m.range[0] - 0.5 * bin_width && v <= m.range[1] + 0.5 * bin_width)
            {
                let a = f64::from(m.opacity.clamp(0.0, 1.0));
                let corrected = 1.0 - (1.0 - a).powf(step);
                if corrected > 0.0 {
                    material[b] = (i + 1) as u8;
                    alpha[b] = corrected as f32;
                }
            }
        }
        let mut occupied_prefix = vec![0u32; LUT_BINS + 1];
        for b in 0..LUT_BINS {
            occupied_prefix[b + 1] = occupied_prefix[b] + u32::from(material[b] != 0);
        }
        let absorbs = materials.iter().map(|m| m.absorbs).collect();
        let material_alpha = materials
            .iter()
            .map(|m| (1.0 - (1.0 - f64::from(m.opacity.clamp(0.0, 1.0))).powf(step)).max(0.0) as f32)
            .collect();
        Classifier { lo, inv_bin: 1.0 / bin_width, material, alpha, occupied_prefix, absorbs, material_alpha }
    }

    /// Step-corrected opacity of a value (0 outside every material).
    #[inline(always)]
    pub(super) fn alpha_of(&self, v: f32) -> f32 {
        self.alpha[self.bin(v)]
    }

    #[inline(always)]
    pub(super) fn bin(&self, v: f32) -> usize {
        (((v - self.lo) * self.inv_bin + 0.5) as usize).min(LUT_BINS - 1)
    }

    /// True when some value in `[a, b]` belongs to a material.
    pub(super) fn any_in(&self, a: f32, b: f32) -> bool {
        let (ba, bb) = (self.bin(a), self.bin(b));
        self.occupied_prefix[bb + 1] > self.occupied_prefix[ba]
    }
}

/// Per-brick min/max of voxel values (each brick also covers the one-voxel seam to its neighbours, so
/// every trilinear cell starting inside a brick is bounded by it).
pub struct BrickMap {
    /// Edge in voxels, a power of two.
    pub(crate) size: usize,
    /// log2 of `size`.
    pub(crate) shift: u32,
    pub(crate) counts: [usize; 3],
    pub(crate) min: Vec<f32>,
    pub(crate) max: Vec<f32>,
}

impl BrickMap {
    pub fn new(volume: &Volume, size: usize) -> BrickMap {
        let size = size.clamp(1, 1 << 12).next_power_of_two();
        let shift = size.trailing_zeros();
        let d = volume.dims;
        let counts = [0, 1, 2].map(|a| d[a].div_ceil(size));
        let n = counts[0] * counts[1] * counts[2];
        let (min, max): (Vec<f32>, Vec<f32>) = (0..n)
            .into_par_iter()
            .map(|i| {
                let bx = i % counts[0];
                let by = (i / counts[0]) % counts[1];
                let bz = i / (counts[0] * counts[1]);
                let r = |b: usize, a: usize| (b * size, ((b + 1) * size).min(d[a] - 1));
                let ((x0, x1), (y0, y1), (z0, z1)) = (r(bx, 0), r(by, 1), r(bz, 2));
                let mut lo = f32::INFINITY;
                let mut hi = f32::NEG_INFINITY;
                for z in z0..=z1 {
                    for y in y0..=y1 {
                        let row = d[0] * (y + d[1] * z);
                        for v in &volume.data[row + x0..=row + x1] {
                            lo = lo.min(*v);
                            hi = hi.max(*v);
                        }
                    }
                }
                (lo, hi)
            })
            .unzip();
        BrickMap { size, shift, counts, min, max }
    }
}

/// Index-space bounding box (inclusive voxel indices) of the voxels whose value belongs to a material,
/// or None when no voxel does.
pub(super) fn material_bounds(volume: &Volume, classifier: &Classifier) -> Option<([usize; 3], [usize; 3])> {
    let d = volume.dims;
    let slices: Vec<Option<([usize; 3], [usize; 3])>> = (0..d[2])
        .into_par_iter()
        .map(|z| {
            let mut lo = [usize::MAX; 3];
            let mut hi = [0usize; 3];
            let mut any = false;
            for y in 0..d[1] {
                let row = &volume.data[d[0] * (y + d[1] * z)..d[0] * (y + 1 + d[1] * z)];
                let first = row.iter().position(|v| classifier.alpha_of(*v) > 0.0);
                if let Some(x0) = first {
                    let x1 = row.iter().rposition(|v| classifier.alpha_of(*v) > 0.0).unwrap_or(x0);
                    any = true;
                    lo = [lo[0].min(x0), lo[1].min(y), z];
                    hi = [hi[0].max(x1), hi[1].max(y), z];
                }
            }
            any.then_some((lo, hi))
        })
        .collect();
    slices.into_iter().flatten().reduce(|(a_lo, a_hi), (b_lo, b_hi)| {
        ([0, 1, 2].map(|i| a_lo[i].min(b_lo[i])), [0, 1, 2].map(|i| a_hi[i].max(b_hi[i])))
    })
}
