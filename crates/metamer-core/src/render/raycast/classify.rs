//! The transfer function as lookup tables, per-brick min/max of values, and the runs of voxels that
//! belong to a material (what the camera frames).

use super::MaterialClass;
use crate::volume::Volume;
use rayon::prelude::*;

pub(super) const LUT_BINS: usize = 4096;

/// The transfer function as lookup tables over the volume's value range, and per-brick emptiness.
pub(super) struct Classifier {
    pub(super) lo: f32,
    pub(super) inv_bin: f32,
    /// Material index + 1 per bin (0 = nothing).
    pub(super) material: Vec<u8>,
    /// Step-corrected opacity per bin.
    pub(super) alpha: Vec<f32>,
    /// The same for a substep (a step split in `substeps`; equal to `alpha` when not split).
    pub(super) alpha_sub: Vec<f32>,
    /// Prefix count of occupied bins.
    pub(super) occupied_prefix: Vec<u32>,
    /// Per bin: the first bin of the run of bins with its material (a value range whose bins all lie
    /// in one run maps to one material, whatever the interpolation).
    run_start: Vec<u16>,
    /// Per material: one of its bins (every bin of a material has the same opacities).
    pub(super) material_bin: Vec<u16>,
    /// Materials of the transfer function.
    pub(super) materials: usize,
    /// Per material code (index + 1, as [`Self::material`] holds it): what compositing reads of a
    /// material at every sample, in one table a `u8` indexes without a bounds check.
    pub(super) per_code: [PerMaterial; 256],
    /// Whether some material's opacity depends on the gradient ([`PerMaterial::gradient_dependent`]).
    pub(super) gradient_dependent: bool,
    /// Per material: its step-corrected opacity (0 when it never shows).
    pub(super) material_alpha: Vec<f32>,
    /// Per material: its opacity corrected for a substep.
    pub(super) material_alpha_sub: Vec<f32>,
}

/// What compositing reads of one material per sample.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PerMaterial {
    /// Whether it attenuates the ray.
    pub(super) absorbs: bool,
    /// 1 / its `max_gradient` (0: the opacity does not depend on the gradient).
    pub(super) inv_max_gradient: f32,
}

impl PerMaterial {
    /// The share of the material's step opacity kept at gradient `g` (value units per voxel index):
    /// `max(0, 1 − |g| / max_gradient)`, 1 for a material without `max_gradient`. Scaling the
    /// step-corrected opacity instead of the per-voxel one differs by under 1 % for opacities ≤ 0.1.
    #[inline(always)]
    pub(super) fn gradient_share(&self, g: [f32; 3]) -> f32 {
        let inv = self.inv_max_gradient;
        if inv == 0.0 {
            return 1.0;
        }
        (1.0 - (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt() * inv).max(0.0)
    }

    /// Whether the material's opacity depends on the gradient.
    #[inline(always)]
    pub(super) fn gradient_dependent(&self) -> bool {
        self.inv_max_gradient != 0.0
    }
}

/// Opacity `a` per voxel step corrected for a step of `step` voxels: `1 − (1 − a)^step`.
fn corrected(a: f32, step: f64) -> f32 {
    (1.0 - (1.0 - f64::from(a.clamp(0.0, 1.0))).powf(step)).max(0.0) as f32
}

impl Classifier {
    /// `substeps`: how many substeps a refined step is split into (1 = never split).
    pub(super) fn new(volume: &Volume, materials: &[MaterialClass], step: f64, substeps: usize) -> Classifier {
        let [lo, hi] = volume.value_range;
        let width = (hi - lo).max(f32::EPSILON);
        let bin_width = width / (LUT_BINS - 1) as f32;
        let mut material = vec![0u8; LUT_BINS];
        let mut alpha = vec![0f32; LUT_BINS];
        let mut alpha_sub = vec![0f32; LUT_BINS];
        let sub = step / substeps.max(1) as f64;
        for b in 0..LUT_BINS {
            let v = lo + b as f32 * bin_width;
            if let Some((i, m)) = materials
                .iter()
                .enumerate()
                .find(|(_, m)| v >= m.range[0] - 0.5 * bin_width && v <= m.range[1] + 0.5 * bin_width)
            {
                let a = corrected(m.opacity, step);
                if a > 0.0 {
                    material[b] = (i + 1) as u8;
                    alpha[b] = a;
                    alpha_sub[b] = corrected(m.opacity, sub);
                }
            }
        }
        let mut occupied_prefix = vec![0u32; LUT_BINS + 1];
        for b in 0..LUT_BINS {
            occupied_prefix[b + 1] = occupied_prefix[b] + u32::from(material[b] != 0);
        }
        let mut run_start = vec![0u16; LUT_BINS];
        for b in 1..LUT_BINS {
            run_start[b] = if material[b] == material[b - 1] { run_start[b - 1] } else { b as u16 };
        }
        let mut material_bin = vec![0u16; materials.len()];
        for b in (0..LUT_BINS).rev() {
            if material[b] != 0 {
                material_bin[usize::from(material[b]) - 1] = b as u16;
            }
        }
        let mut per_code = [PerMaterial::default(); 256];
        for (code, m) in per_code[1..].iter_mut().zip(materials) {
            *code = PerMaterial {
                absorbs: m.absorbs,
                inv_max_gradient: m.max_gradient.map_or(0.0, |g| 1.0 / g.max(f32::EPSILON)),
            };
        }
        let material_alpha = materials.iter().map(|m| corrected(m.opacity, step)).collect();
        let material_alpha_sub = materials.iter().map(|m| corrected(m.opacity, sub)).collect();
        Classifier {
            lo,
            inv_bin: 1.0 / bin_width,
            material,
            alpha,
            alpha_sub,
            occupied_prefix,
            run_start,
            material_bin,
            materials: materials.len(),
            gradient_dependent: per_code.iter().any(PerMaterial::gradient_dependent),
            per_code,
            material_alpha,
            material_alpha_sub,
        }
    }

    /// Step-corrected opacity of a value (0 outside every material).
    #[inline(always)]
    pub(super) fn alpha_of(&self, v: f32) -> f32 {
        self.alpha[self.bin(v)]
    }

    #[inline(always)]
    pub(super) fn bin(&self, v: f32) -> usize {
        // Clamped in float first (`max` maps NaN to 0), then truncated: the same bin as the saturating
        // `as usize` followed by `min`, without the dozen instructions the saturating cast costs at every
        // sample.
        let b = ((v - self.lo) * self.inv_bin + 0.5).max(0.0).min((LUT_BINS - 1) as f32);
        // SAFETY: b is finite and in [0, LUT_BINS − 1], so the truncation is in range for u32.
        (unsafe { b.to_int_unchecked::<u32>() }) as usize
    }

    /// What every value in `[a, b]` maps to: [`EMPTY`] (no material, or only zero opacity), one
    /// material (its index + 1) or [`MIXED`]. Bins are monotone in the value, so a value between `a`
    /// and `b` (a trilinear blend of voxels in that range) falls in a bin between theirs.
    pub(super) fn class_of(&self, a: f32, b: f32) -> u8 {
        let (ba, bb) = (self.bin(a), self.bin(b));
        if self.occupied_prefix[bb + 1] == self.occupied_prefix[ba] {
            EMPTY
        } else if usize::from(self.run_start[bb]) <= ba {
            self.material[ba]
        } else {
            MIXED
        }
    }
}

/// A brick no sample inside maps to a material: stepped over whole.
pub(super) const EMPTY: u8 = 0;
/// A brick whose values map to more than one material (or to a material and to nothing): sampled in
/// full, refined at boundaries.
pub(super) const MIXED: u8 = u8::MAX;

/// The per-brick table of one raycast: each brick of a [`BrickMap`] classified against this transfer
/// function as [`EMPTY`], one material (index + 1: no value reconstruction or lookup needed, no
/// boundary to refine inside it) or [`MIXED`].
pub(super) struct BrickTable {
    pub(super) class: Vec<u8>,
    pub(super) empty: usize,
    pub(super) uniform: usize,
    /// The bricks in groups ([`Spans`]): which groups hold no brick a ray must sample.
    pub(super) spans: Spans,
}

/// Bricks per side of the [`Spans`] groups, coarsest first, as powers of two: 8, 4 and 2.
pub(super) const SPAN_SHIFTS: [u32; 3] = [3, 2, 1];

/// The empty bricks of a [`BrickTable`] in groups of 8³, 4³ and 2³ bricks ([`SPAN_SHIFTS`]; 64³, 32³ and 16³ voxels with the
/// default 8-voxel bricks): a group all of whose bricks are empty is crossed by a ray in one jump, where
/// brick by brick it took one per brick (each a located landing sample and an exit computed), so runs of
/// empty space cost a few jumps (the marcher, [`super::march`]). Groups at the volume's far faces hold
/// fewer bricks.
pub(super) struct Spans {
    /// Per level of [`SPAN_SHIFTS`], per group (x fastest): every brick of it is empty.
    empty: [Vec<bool>; 3],
    counts: [[usize; 3]; 3],
}

impl Spans {
    /// The groups of a brick table's classes (`class`, x fastest, `counts` bricks a side).
    pub(super) fn new(class: &[u8], counts: [usize; 3]) -> Spans {
        let level = |shift: u32| {
            let groups = counts.map(|c| c.div_ceil(1 << shift));
            let mut empty = vec![true; groups.iter().product()];
            for z in 0..counts[2] {
                for y in 0..counts[1] {
                    for x in 0..counts[0] {
                        if class[x + counts[0] * (y + counts[1] * z)] != EMPTY {
                            empty[(x >> shift) + groups[0] * ((y >> shift) + groups[1] * (z >> shift))] = false;
                        }
                    }
                }
            }
            (empty, groups)
        };
        let [(e0, c0), (e1, c1), (e2, c2)] = SPAN_SHIFTS.map(level);
        Spans { empty: [e0, e1, e2], counts: [c0, c1, c2] }
    }

    /// The largest empty group holding brick `b` (brick coordinates): its coordinates and its edge in bricks.
    #[inline(always)]
    pub(super) fn empty_around(&self, b: [usize; 3]) -> Option<([usize; 3], usize)> {
        for (l, shift) in SPAN_SHIFTS.into_iter().enumerate() {
            let g = b.map(|c| c >> shift);
            let n = self.counts[l];
            if self.empty[l][g[0] + n[0] * (g[1] + n[1] * g[2])] {
                return Some((g, 1 << shift));
            }
        }
        None
    }
}

impl BrickTable {
    /// `uniform`: whether single-material bricks may be taken as such (false in label mode, whose
    /// occupancy field depends on the neighbours, so only empty and mixed are used); `dilate`: bricks
    /// within this many bricks of an occupied one count as mixed (a label field spreads a material).
    pub(super) fn new(bricks: &BrickMap, classifier: &Classifier, uniform: bool, dilate: usize) -> BrickTable {
        let mut class: Vec<u8> = bricks
            .min
            .iter()
            .zip(&bricks.max)
            .map(|(lo, hi)| match classifier.class_of(*lo, *hi) {
                EMPTY => EMPTY,
                m if uniform => m,
                _ => MIXED,
            })
            .collect();
        if dilate > 0 {
            let empty: Vec<bool> = class.iter().map(|c| *c == EMPTY).collect();
            let grown = super::dilate_occupied(&empty, bricks.counts, dilate);
            for (c, e) in class.iter_mut().zip(grown) {
                if !e && *c == EMPTY {
                    *c = MIXED;
                }
            }
        }
        let empty = class.iter().filter(|c| **c == EMPTY).count();
        let uniform = class.iter().filter(|c| **c != EMPTY && **c != MIXED).count();
        let spans = Spans::new(&class, bricks.counts);
        BrickTable { class, empty, uniform, spans }
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
    /// The min/max map of `volume` in bricks of `size` voxels a side (clamped to 1…4096, rounded up to a power of two).
    pub fn new(volume: &Volume, size: usize) -> BrickMap {
        let size = size.clamp(1, 1 << 12).next_power_of_two();
        let shift = size.trailing_zeros();
        let d = volume.dims;
        let counts = [0, 1, 2].map(|a| d[a].div_ceil(size));
        let r = |b: usize, a: usize| (b * size, ((b + 1) * size).min(d[a] - 1));
        // A slab of bricks (one brick along y and z, all along x) at a time: the element-wise extremes of its
        // rows of voxels, whole rows at once (a loop the compiler vectorises), then those over each
        // brick's stretch along x. Slabs are consecutive runs of the x-fastest brick index. (Brick by brick,
        // rows of nine voxels compared one at a time, it cost about 4 % of a raycast's instructions.)
        let slabs: Vec<(Vec<f32>, Vec<f32>)> = (0..counts[1] * counts[2])
            .into_par_iter()
            .map(|s| {
                let ((y0, y1), (z0, z1)) = (r(s % counts[1], 1), r(s / counts[1], 2));
                // Compared in the voxels' own type (a volume's values are finite and `to_f32` is monotone,
                // so the extremes are those of the converted values), converted once: no float
                // conversion and min/max latency chain per voxel.
                crate::with_voxels!(&volume.voxels, data => {
                    let first = d[0] * (y0 + d[1] * z0);
                    let mut lo = data[first..first + d[0]].to_vec();
                    let mut hi = lo.clone();
                    for z in z0..=z1 {
                        for y in y0..=y1 {
                            let row = d[0] * (y + d[1] * z);
                            for ((l, h), &v) in lo.iter_mut().zip(hi.iter_mut()).zip(&data[row..row + d[0]]) {
                                *l = if v < *l { v } else { *l };
                                *h = if v > *h { v } else { *h };
                            }
                        }
                    }
                    (0..counts[0])
                        .map(|bx| {
                            let (x0, x1) = r(bx, 0);
                            let (mut l, mut h) = (lo[x0], hi[x0]);
                            for x in x0..=x1 {
                                l = if lo[x] < l { lo[x] } else { l };
                                h = if hi[x] > h { hi[x] } else { h };
                            }
                            (l.to_f32(), h.to_f32())
                        })
                        .unzip::<f32, f32, Vec<f32>, Vec<f32>>()
                })
            })
            .collect();
        let min = slabs.iter().flat_map(|(l, _)| l.iter().copied()).collect();
        let max = slabs.iter().flat_map(|(_, h)| h.iter().copied()).collect();
        BrickMap { size, shift, counts, min, max }
    }
}

/// The voxels whose value belongs to a material, as runs along x: per row (y, z) that holds one, its
/// first and last such voxel. Enough to frame them exactly: a projection is linear along a row, so a
/// row's extremes on the image plane are at its ends.
pub(super) struct MaterialRows {
    /// (x0, x1, y, z), inclusive.
    pub(super) rows: Vec<[usize; 4]>,
}

impl MaterialRows {
    /// `bricks`: the min/max bricks and their table for this transfer function, when there are: a row's
    /// stretch inside an [`EMPTY`] brick holds no material voxel, so only the others are read.
    pub(super) fn new(volume: &Volume, classifier: &Classifier, bricks: Option<(&BrickMap, &[u8])>) -> MaterialRows {
        let d = volume.dims;
        let rows = (0..d[2])
            .into_par_iter()
            .flat_map_iter(|z| {
                (0..d[1]).filter_map(move |y| {
                    let start = d[0] * (y + d[1] * z);
                    // The stretches of the row to read, [a, b) in x and in order: those of its bricks that are
                    // not empty, else the whole row.
                    let (n, shift, base) = match bricks {
                        Some((bm, _)) => {
                            (bm.counts[0], bm.shift, bm.counts[0] * ((y >> bm.shift) + bm.counts[1] * (z >> bm.shift)))
                        }
                        None => (1, usize::BITS - 1, 0),
                    };
                    let span = |bx: usize| {
                        let read = bricks.is_none_or(|(_, table)| table[base + bx] != EMPTY);
                        read.then(|| ((bx << shift).min(d[0]), ((bx + 1) << shift).min(d[0])))
                    };
                    let (x0, x1) = crate::with_voxels!(&volume.voxels, data => {
                        let row = &data[start..start + d[0]];
                        let hit = |v: &_| classifier.alpha_of(crate::volume::Voxel::to_f32(*v)) > 0.0;
                        let x0 = (0..n).filter_map(span).find_map(|(a, b)| row[a..b].iter().position(hit).map(|i| a + i))?;
                        let x1 = (0..n)
                            .rev()
                            .filter_map(span)
                            .find_map(|(a, b)| row[a..b].iter().rposition(hit).map(|i| a + i))
                            .unwrap_or(x0);
                        (x0, x1)
                    });
                    Some([x0, x1, y, z])
                })
            })
            .collect();
        MaterialRows { rows }
    }

    /// Index-space bounding box (inclusive voxel indices), or None when no voxel belongs to a material.
    pub(super) fn bounds(&self) -> Option<([usize; 3], [usize; 3])> {
        self.rows.iter().fold(None, |acc, &[x0, x1, y, z]| {
            let (lo, hi) = acc.unwrap_or(([usize::MAX; 3], [0; 3]));
            Some(([lo[0].min(x0), lo[1].min(y), lo[2].min(z)], [hi[0].max(x1), hi[1].max(y), hi[2].max(z)]))
        })
    }
}
