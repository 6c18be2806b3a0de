//! Per-brick fields the marcher samples besides the raw values, built lazily: a brick's block is
//! computed the first time a ray needs it (under a `OnceLock`, so each block is built once whichever
//! thread gets there first, and its contents depend only on the volume and the transfer function:
//! frames stay byte-identical run to run). Rays stop at the first opaque surface and skip empty
//! bricks, so only the bricks rays actually reach are ever built — a fraction of the volume — instead
//! of a whole-volume grid per raycast.
//!
//! A block covers the `BRICK + 1` voxels per axis of one 8³ brick plus the one-voxel seam to its
//! upper neighbours, so every trilinear cell that starts in the brick finds its eight corners in it.
//! It holds:
//! - **the smooth gradient** (`i16` triples, 6 bytes an entry): central differences of the field
//!   shading normals come from, `h` voxels either side. Shifting a trilinear interpolant by whole
//!   voxels keeps the sample's fractional position, so the trilinear interpolation of these is the
//!   central difference of the interpolated field (the same normal as six interpolated lookups, for one
//!   cell fetch). The field is the value (trilinear mode, `h` = 1), the step-corrected opacity
//!   (nearest mode, `h` = 2) or the smoothed total opacity filtered once more (label mode, `h` =
//!   [`NORMAL_H`]).
//! - **smoothed label occupancy** (label mode, `u8` per material present): each material's indicator
//!   (1 where a voxel's label belongs to it) filtered by a separable Gaussian of σ = [`LABEL_SIGMA`]
//!   voxels truncated at [`LABEL_RADIUS`], quantised to 1/255. Sampled trilinearly, the occupancies make
//!   label boundaries smooth surfaces (no voxel terraces), they still sum to at most 1 (the filter is a
//!   partition of unity), and the shading normals come from the same smoothed field.

use super::classify::Classifier;
use crate::volume::Volume;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

/// log2 of the brick edge.
const SHIFT: u32 = 3;
/// Brick edge in voxels.
pub(super) const FIELD_BRICK: usize = 1 << SHIFT;
const BRICK: usize = FIELD_BRICK;
/// Block entries per axis: the brick and its upper seam.
pub(super) const S: usize = BRICK + 1;
/// Block entries.
pub(super) const S3: usize = S * S * S;

/// Standard deviation (voxels, along each index axis) of the Gaussian that smooths label indicators.
pub const LABEL_SIGMA: f32 = 1.0;
/// Truncation radius of that Gaussian (voxels).
pub const LABEL_RADIUS: usize = 2;

/// What a [`Fields`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    /// Gradient of the values (trilinear sampling).
    Values,
    /// Gradient of the step-corrected opacity, two voxels either side (nearest sampling).
    Opacity,
    /// Smoothed label occupancy, and the gradient of the smoothed total opacity.
    Labels,
}

/// One brick's block.
pub(super) struct Block {
    /// `S3` gradient triples (empty when no gradients are needed).
    pub(crate) grad: Vec<[i16; 3]>,
    /// Materials (0-based) with some occupancy in the block (label mode).
    pub(crate) mats: Vec<u8>,
    /// `mats.len() × S3` occupancies in 1/255 (label mode).
    pub(crate) occ: Vec<u8>,
}

/// The lazily built per-brick blocks of one raycast.
pub(super) struct Fields<'a> {
    volume: &'a Volume,
    classifier: &'a Classifier,
    kind: Kind,
    gradients: bool,
    counts: [usize; 3],
    blocks: Vec<OnceLock<Block>>,
    /// Field units per stored gradient unit.
    pub(crate) scale: f32,
    kernel: [f32; 2 * LABEL_RADIUS + 1],
    bytes: AtomicU64,
    built: AtomicU64,
}

impl<'a> Fields<'a> {
    pub fn new(volume: &'a Volume, classifier: &'a Classifier, kind: Kind, gradients: bool) -> Fields<'a> {
        let d = volume.dims;
        let counts = [0, 1, 2].map(|a| d[a].div_ceil(BRICK).max(1));
        let n = counts[0] * counts[1] * counts[2];
        let (h, span) = match kind {
            Kind::Values => (1.0f32, (volume.value_range[1] - volume.value_range[0]).abs()),
            Kind::Opacity => (2.0, 1.0),
            Kind::Labels => (NORMAL_H as f32, 1.0),
        };
        // A central difference is at most the field's span over 2h.
        let bound = span / (2.0 * h);
        let scale = if bound > 0.0 && bound.is_finite() { bound / f32::from(i16::MAX) } else { 1.0 };
        let mut kernel = [0f32; 2 * LABEL_RADIUS + 1];
        for (k, w) in kernel.iter_mut().enumerate() {
            let x = k as f32 - LABEL_RADIUS as f32;
            *w = (-0.5 * x * x / (LABEL_SIGMA * LABEL_SIGMA)).exp();
        }
        let sum: f32 = kernel.iter().sum();
        kernel.iter_mut().for_each(|w| *w /= sum);
        Fields {
            volume,
            classifier,
            kind,
            gradients,
            counts,
            blocks: (0..n).map(|_| OnceLock::new()).collect(),
            scale,
            kernel,
            bytes: AtomicU64::new(0),
            built: AtomicU64::new(0),
        }
    }

    /// Blocks built so far and their bytes.
    pub(crate) fn usage(&self) -> (u64, u64) {
        (self.built.load(Ordering::Relaxed), self.bytes.load(Ordering::Relaxed))
    }

    /// The brick holding cell start `i`.
    #[inline(always)]
    pub(crate) fn brick_of(&self, i: [usize; 3]) -> [usize; 3] {
        [0, 1, 2].map(|a| (i[a] >> SHIFT).min(self.counts[a] - 1))
    }

    /// The block of the brick holding cell start `i`, and the local index of `i` in it.
    #[inline(always)]
    pub(crate) fn block(&self, i: [usize; 3]) -> (&Block, usize) {
        let b = self.brick_of(i);
        let l = [0, 1, 2].map(|a| i[a] - (b[a] << SHIFT));
        let bi = b[0] + self.counts[0] * (b[1] + self.counts[1] * b[2]);
        let block = self.blocks[bi].get_or_init(|| self.build(b));
        (block, l[0] + S * (l[1] + S * l[2]))
    }

    /// The trilinear interpolation of the block's gradients at local index `base` and fractions `f`
    /// (field units per voxel).
    #[inline(always)]
    pub(crate) fn gradient(&self, block: &Block, base: usize, f: [f32; 3]) -> [f32; 3] {
        if block.grad.is_empty() {
            return [0.0; 3];
        }
        let g = &block.grad;
        let corners = [
            base,
            base + 1,
            base + S,
            base + S + 1,
            base + S * S,
            base + S * S + 1,
            base + S * S + S,
            base + S * S + S + 1,
        ];
        let w = corner_weights(f);
        let mut out = [0f32; 3];
        for (c, wc) in corners.iter().zip(w) {
            let v = g[*c];
            out[0] += wc * f32::from(v[0]);
            out[1] += wc * f32::from(v[1]);
            out[2] += wc * f32::from(v[2]);
        }
        out.map(|c| c * self.scale)
    }

    fn build(&self, b: [usize; 3]) -> Block {
        let block = match self.kind {
            Kind::Values | Kind::Opacity => Block { grad: self.build_gradient(b), mats: vec![], occ: vec![] },
            Kind::Labels => self.build_labels(b),
        };
        let bytes = block.grad.len() * 6 + block.occ.len() + block.mats.len() + std::mem::size_of::<Block>();
        self.bytes.fetch_add(bytes as u64, Ordering::Relaxed);
        self.built.fetch_add(1, Ordering::Relaxed);
        block
    }

    /// Central differences of the value (or opacity) field, exactly as a whole-volume grid would hold
    /// them (neighbours clamped into the grid).
    fn build_gradient(&self, b: [usize; 3]) -> Vec<[i16; 3]> {
        let d = self.volume.dims;
        let data = &self.volume.data;
        let opacity = self.kind == Kind::Opacity;
        let h = if opacity { 2 } else { 1 };
        let den = 2.0 * h as f32;
        let inv = 1.0 / self.scale;
        let q = |c: f32| (c * inv).round().clamp(-f32::from(i16::MAX), f32::from(i16::MAX)) as i16;
        let at = |x: usize, y: usize, z: usize| {
            let v = data[x + d[0] * (y + d[1] * z)];
            if opacity { self.classifier.alpha_of(v) } else { v }
        };
        let o = b.map(|v| v << SHIFT);
        let mut grad = vec![[0i16; 3]; S3];
        for lz in 0..S {
            let z = (o[2] + lz).min(d[2] - 1);
            let (z0, z1) = (z.saturating_sub(h), (z + h).min(d[2] - 1));
            for ly in 0..S {
                let y = (o[1] + ly).min(d[1] - 1);
                let (y0, y1) = (y.saturating_sub(h), (y + h).min(d[1] - 1));
                for lx in 0..S {
                    let x = (o[0] + lx).min(d[0] - 1);
                    let (x0, x1) = (x.saturating_sub(h), (x + h).min(d[0] - 1));
                    grad[lx + S * (ly + S * lz)] = [
                        q((at(x1, y, z) - at(x0, y, z)) / den),
                        q((at(x, y1, z) - at(x, y0, z)) / den),
                        q((at(x, y, z1) - at(x, y, z0)) / den),
                    ];
                }
            }
        }
        grad
    }

    /// Smoothed occupancy of every material near the brick, and the gradient of the smoothed total
    /// opacity, smoothed once more for the normals ([`NORMAL_H`], one more pass of the same filter).
    fn build_labels(&self, b: [usize; 3]) -> Block {
        const R: usize = LABEL_RADIUS;
        // Regions, per axis: the block (S), the twice-smoothed total opacity its central differences
        // read (S + 2h), the smoothed total opacity that is filtered from (+ 2R), the labels (+ 2R).
        const G: usize = S + 2 * NORMAL_H;
        const M: usize = G + 2 * R;
        const N: usize = M + 2 * R;
        let d = self.volume.dims;
        let data = &self.volume.data;
        let o = b.map(|v| (v << SHIFT) as isize - (NORMAL_H + 2 * R) as isize);
        let coord = |a: usize, j: usize| (o[a] + j as isize).clamp(0, d[a] as isize - 1) as usize;
        let mut labels = vec![0u8; N * N * N];
        for z in 0..N {
            let vz = coord(2, z);
            for y in 0..N {
                let vy = coord(1, y);
                let row = d[0] * (vy + d[1] * vz);
                for x in 0..N {
                    let v = data[row + coord(0, x)];
                    labels[x + N * (y + N * z)] = self.classifier.material[self.classifier.bin(v)];
                }
            }
        }
        let mut present: Vec<u8> = Vec::new();
        for &m in &labels {
            if m != 0 && !present.contains(&m) {
                present.push(m);
            }
        }
        present.sort_unstable();
        let mut total = vec![0f32; M * M * M];
        let mut mats = Vec::new();
        let mut occ = Vec::new();
        let mut indicator = vec![0f32; N * N * N];
        // The block's entries sit at offset `NORMAL_H + R` inside the M region.
        let off = NORMAL_H + R;
        for &m in &present {
            for (i, l) in indicator.iter_mut().zip(&labels) {
                *i = if *l == m { 1.0 } else { 0.0 };
            }
            let field = blur3(&indicator, N, &self.kernel);
            let mut block = vec![0u8; S3];
            let mut any = false;
            for z in 0..S {
                for y in 0..S {
                    for x in 0..S {
                        let v = field[(x + off) + M * ((y + off) + M * (z + off))];
                        let q = (v * 255.0).round().clamp(0.0, 255.0) as u8;
                        any |= q != 0;
                        block[x + S * (y + S * z)] = q;
                    }
                }
            }
            // Every material near the block enters the normals' field, whether or not it reaches the
            // block itself, so neighbouring blocks agree on their shared seam.
            let alpha = self.classifier.material_alpha[usize::from(m) - 1];
            for (t, f) in total.iter_mut().zip(&field) {
                *t += alpha * f;
            }
            if any {
                mats.push(m - 1);
                occ.extend_from_slice(&block);
            }
        }
        let grad = if self.gradients && !mats.is_empty() {
            let smooth = blur3(&total, M, &self.kernel);
            let inv = 1.0 / self.scale;
            let q = |c: f32| (c * inv).round().clamp(-f32::from(i16::MAX), f32::from(i16::MAX)) as i16;
            let at = |x: usize, y: usize, z: usize| smooth[x + G * (y + G * z)];
            let (h, den) = (NORMAL_H, 1.0 / (2.0 * NORMAL_H as f32));
            let mut grad = vec![[0i16; 3]; S3];
            for z in 0..S {
                for y in 0..S {
                    for x in 0..S {
                        let (cx, cy, cz) = (x + h, y + h, z + h);
                        grad[x + S * (y + S * z)] = [
                            q(den * (at(cx + h, cy, cz) - at(cx - h, cy, cz))),
                            q(den * (at(cx, cy + h, cz) - at(cx, cy - h, cz))),
                            q(den * (at(cx, cy, cz + h) - at(cx, cy, cz - h))),
                        ];
                    }
                }
            }
            grad
        } else {
            vec![]
        };
        Block { grad, mats, occ }
    }
}

/// Half-width (voxels) of the central differences that give label normals: wider than the one voxel of
/// value fields, so the normals of a smoothed voxel staircase do not ripple with its treads.
pub const NORMAL_H: usize = 2;

/// Separable filter of an `n³` grid by `kernel` along x, y and z (valid part only: `(n − 2r)³`).
fn blur3(src: &[f32], n: usize, kernel: &[f32; 2 * LABEL_RADIUS + 1]) -> Vec<f32> {
    let r = LABEL_RADIUS;
    let m = n - 2 * r;
    let mut px = vec![0f32; m * n * n];
    for z in 0..n {
        for y in 0..n {
            let row = &src[n * (y + n * z)..][..n];
            for x in 0..m {
                px[x + m * (y + n * z)] = kernel.iter().zip(&row[x..x + 2 * r + 1]).map(|(w, v)| w * v).sum();
            }
        }
    }
    let mut py = vec![0f32; m * m * n];
    for z in 0..n {
        for y in 0..m {
            for x in 0..m {
                py[x + m * (y + m * z)] = kernel.iter().enumerate().map(|(t, w)| w * px[x + m * (y + t + n * z)]).sum();
            }
        }
    }
    let mut out = vec![0f32; m * m * m];
    for z in 0..m {
        for y in 0..m {
            for x in 0..m {
                out[x + m * (y + m * z)] =
                    kernel.iter().enumerate().map(|(t, w)| w * py[x + m * (y + m * (z + t))]).sum();
            }
        }
    }
    out
}

/// Trilinear weights of the eight corners (`x + 2y + 4z`) at fractions `f`.
#[inline(always)]
pub(super) fn corner_weights(f: [f32; 3]) -> [f32; 8] {
    let [fx, fy, fz] = f;
    [
        (1.0 - fx) * (1.0 - fy) * (1.0 - fz),
        fx * (1.0 - fy) * (1.0 - fz),
        (1.0 - fx) * fy * (1.0 - fz),
        fx * fy * (1.0 - fz),
        (1.0 - fx) * (1.0 - fy) * fz,
        fx * (1.0 - fy) * fz,
        (1.0 - fx) * fy * fz,
        fx * fy * fz,
    ]
}

/// Local offsets of the eight corners of a block cell (`x + 2y + 4z`).
pub(super) const CORNERS: [usize; 8] = [0, 1, S, S + 1, S * S, S * S + 1, S * S + S, S * S + S + 1];
