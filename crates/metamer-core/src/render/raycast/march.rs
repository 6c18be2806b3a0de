//! Marching one ray: sample reconstruction, classification, shading and front-to-back compositing.

use super::classify::{BrickMap, Classifier};
use super::fields::{CORNERS, FIELD_BRICK, Fields, S3, corner_weights};
use super::labels::{self, LABEL_REACH, SDF_UNIT};
use super::view::{View, dot};
use super::{
    Gradient, Interpolation, MAX_MATERIALS, RaycastOptions, RaycastStats, Shading, interleaved_gradient_noise,
};
use crate::volume::Volume;

/// The eight voxels around a sample and the sample's fractional position among them
/// (`v[x + 2y + 4z]`).
struct Cell {
    v: [f32; 8],
    f: [f32; 3],
}

impl Cell {
    /// Trilinear interpolation.
    #[inline(always)]
    fn value(&self) -> f32 {
        let [fx, fy, fz] = self.f;
        let v = &self.v;
        let c00 = v[0] + fx * (v[1] - v[0]);
        let c10 = v[2] + fx * (v[3] - v[2]);
        let c01 = v[4] + fx * (v[5] - v[4]);
        let c11 = v[6] + fx * (v[7] - v[6]);
        let c0 = c00 + fy * (c10 - c00);
        let c1 = c01 + fy * (c11 - c01);
        c0 + fz * (c1 - c0)
    }

    /// Gradient of the trilinear interpolant at the sample, per voxel index.
    #[inline(always)]
    fn gradient(&self) -> [f32; 3] {
        let [fx, fy, fz] = self.f;
        let v = &self.v;
        let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
        let dx = gy * gz * (v[1] - v[0]) + fy * gz * (v[3] - v[2]) + gy * fz * (v[5] - v[4]) + fy * fz * (v[7] - v[6]);
        let dy = gx * gz * (v[2] - v[0]) + fx * gz * (v[3] - v[1]) + gx * fz * (v[6] - v[4]) + fx * fz * (v[7] - v[5]);
        let dz = gx * gy * (v[4] - v[0]) + fx * gy * (v[5] - v[1]) + gx * fy * (v[6] - v[2]) + fx * fy * (v[7] - v[3]);
        [dx, dy, dz]
    }
}

pub(super) struct RayContext<'a> {
    pub(crate) volume: &'a Volume,
    pub(crate) classifier: &'a Classifier,
    /// The lazily built per-brick fields: smooth gradients and, in label mode, smoothed occupancy
    /// (None when neither is needed).
    pub(crate) fields: Option<&'a Fields<'a>>,
    pub(crate) bricks: Option<(&'a BrickMap, &'a [bool])>,
    pub(crate) view: &'a View,
    pub(crate) options: &'a RaycastOptions,
    pub(crate) n_mat: usize,
    pub(crate) width: usize,
    pub(crate) height: usize,
}

impl RayContext<'_> {
    #[inline(always)]
    fn voxel(&self, x: usize, y: usize, z: usize) -> f32 {
        let d = self.volume.dims;
        self.volume.data[x + d[0] * (y + d[1] * z)]
    }

    /// Where index-space point p (clamped into [0, dims−1]) falls: its trilinear cell's first voxel (as
    /// an index and as coordinates), the strides to the next voxel along x, y and z (0 along an axis of
    /// one voxel) and the fractions along each axis.
    #[inline(always)]
    fn locate(&self, p: [f64; 3]) -> (usize, [usize; 3], [usize; 3], [f32; 3]) {
        let d = self.volume.dims;
        let mut i = [0usize; 3];
        let mut f = [0f32; 3];
        for a in 0..3 {
            // p ≥ 0 after the clamp, so truncation is floor (and avoids a libm call).
            let q = p[a].clamp(0.0, (d[a] - 1) as f64);
            i[a] = (q as usize).min(d[a].saturating_sub(2));
            f[a] = (q - i[a] as f64) as f32;
        }
        let sx = usize::from(d[0] > 1);
        let sy = if d[1] > 1 { d[0] } else { 0 };
        let sz = if d[2] > 1 { d[0] * d[1] } else { 0 };
        let b = i[0] + d[0] * (i[1] + d[1] * i[2]);
        (b, i, [sx, sy, sz], f)
    }

    /// The trilinear cell of the volume's values at a located sample.
    #[inline(always)]
    fn cell_at(&self, b: usize, [sx, sy, sz]: [usize; 3], f: [f32; 3]) -> Cell {
        let v = &self.volume.data;
        Cell {
            v: [
                v[b],
                v[b + sx],
                v[b + sy],
                v[b + sy + sx],
                v[b + sz],
                v[b + sz + sx],
                v[b + sz + sy],
                v[b + sz + sy + sx],
            ],
            f,
        }
    }

    /// The nearest voxel's value.
    #[inline(always)]
    fn nearest(&self, p: [f64; 3]) -> f32 {
        let d = self.volume.dims;
        let c = [0, 1, 2].map(|a| ((p[a].max(0.0) + 0.5) as usize).min(d[a] - 1));
        self.voxel(c[0], c[1], c[2])
    }

    /// The smooth gradient at a located sample (cell start `i`, fractions `f`).
    #[inline(always)]
    fn smooth_gradient(&self, i: [usize; 3], f: [f32; 3]) -> [f32; 3] {
        let Some(fields) = self.fields else { return [0.0; 3] };
        let (block, base) = fields.block(i);
        fields.gradient(block, base, f)
    }

    /// Shading from a field gradient g (per voxel index): `ambient + (1 − ambient)·max(n·l, 0)` with the
    /// normal turned to face the eye; 1 where the gradient vanishes.
    #[inline(always)]
    fn shade(&self, g: [f32; 3]) -> f32 {
        let s = self.volume.spacing;
        let g = [f64::from(g[0]) / s[0], f64::from(g[1]) / s[1], f64::from(g[2]) / s[2]];
        let n2 = dot(g, g);
        if n2 < 1e-12 {
            return 1.0;
        }
        let facing = if dot(g, self.view.view_world) > 0.0 { -1.0 } else { 1.0 };
        let cos = facing * dot(g, self.view.light_world) / n2.sqrt();
        let a = self.options.ambient.clamp(0.0, 1.0);
        (a + (1.0 - a) * cos.max(0.0)) as f32
    }

    /// Value-classified sample (trilinear or nearest): adds its material's weight, returns the opacity
    /// it absorbs.
    #[inline(always)]
    fn sample_values(&self, p: [f64; 3], transmittance: f32, out: &mut [f32]) -> f32 {
        let (b, i, strides, f) = self.locate(p);
        let trilinear = self.options.interpolation == Interpolation::Trilinear;
        let cell = trilinear.then(|| self.cell_at(b, strides, f));
        let v = match &cell {
            Some(c) => c.value(),
            None => self.nearest(p),
        };
        let bin = self.classifier.bin(v);
        let m = usize::from(self.classifier.material[bin]);
        if m == 0 {
            return 0.0;
        }
        let alpha = self.classifier.alpha[bin];
        let shade = match (self.options.shading, self.options.gradient) {
            (Shading::Unshaded, _) => 1.0,
            (_, Gradient::Smooth) => self.shade(self.smooth_gradient(i, f)),
            (_, Gradient::Cell) => self.shade(cell.unwrap_or_else(|| self.cell_at(b, strides, f)).gradient()),
        };
        out[m - 1] += transmittance * alpha * shade;
        if self.classifier.absorbs[m - 1] { alpha } else { 0.0 }
    }

    /// Label sample: every nearby material's signed distance, interpolated trilinearly and turned into
    /// an occupancy ([`labels::ramp`]), times the material's opacity; each material shaded by its own
    /// distance gradient. Adds their weights, returns the opacity absorbed.
    #[inline(always)]
    fn sample_labels(&self, p: [f64; 3], transmittance: f32, out: &mut [f32]) -> Result<f32, [usize; 3]> {
        let Some(fields) = self.fields else { return Ok(0.0) };
        let (_, i, _, f) = self.locate(p);
        let (block, base) = fields.block(i);
        let n = block.mats.len();
        if n == 0 {
            return Err(fields.brick_of(i));
        }
        let w = corner_weights(f);
        let mut occ = [0f32; MAX_MATERIALS];
        let mut sum = 0.0;
        for (j, o) in occ[..n].iter_mut().enumerate() {
            let q = &block.sdf[j * S3 + base..];
            let mut v = 0.0;
            for (c, wc) in CORNERS.iter().zip(w) {
                v += wc * f32::from(q[*c]);
            }
            *o = labels::ramp(v * SDF_UNIT - LABEL_REACH);
            sum += *o;
        }
        if sum <= 0.0 {
            return Ok(0.0);
        }
        // Where three materials meet, the occupancies may sum a little above 1.
        let norm = if sum > 1.0 { 1.0 / sum } else { 1.0 };
        let mut absorbed = 0.0;
        for (j, (m, o)) in block.mats.iter().zip(&occ[..n]).enumerate() {
            let m = usize::from(*m);
            let wgt = o * norm * self.classifier.material_alpha[m];
            if wgt <= 0.0 {
                continue;
            }
            let at = j * S3 + base;
            let shade = match (self.options.shading, self.options.gradient) {
                (Shading::Unshaded, _) => 1.0,
                (_, Gradient::Smooth) => self.shade(fields.gradient(block, at, f)),
                (_, Gradient::Cell) => {
                    let q = &block.sdf[at..];
                    self.shade(Cell { v: CORNERS.map(|c| f32::from(q[c])), f }.gradient())
                }
            };
            out[m] += transmittance * wgt * shade;
            if self.classifier.absorbs[m] {
                absorbed += wgt;
            }
        }
        Ok(absorbed)
    }

    /// March the ray of pixel (px, py), accumulating material weights into `out`.
    pub(crate) fn trace(&self, px: usize, py: usize, out: &mut [f32], stats: &mut RaycastStats) {
        let view = self.view;
        let vol = self.volume;
        let sx = ((px as f64 + 0.5) / self.width as f64 * 2.0 - 1.0) * view.half_extent;
        let sy = (1.0 - (py as f64 + 0.5) / self.height as f64 * 2.0) * view.half_extent * self.height as f64
            / self.width as f64;
        // Start `radius` before the image plane through the framed box's centre, in index space.
        let start_world = [0, 1, 2]
            .map(|a| view.centre_world[a] + sx * view.right[a] + sy * view.up[a] - view.radius * view.view_world[a]);
        let origin = [0, 1, 2].map(|a| start_world[a] / vol.spacing[a]);
        let dir = view.dir;
        // Clip against the box (slab method), in units of steps.
        let mut t0 = 0.0f64;
        let mut t1 = f64::INFINITY;
        for a in 0..3 {
            let (lo, hi) = (view.clip_lo[a], view.clip_hi[a]);
            if dir[a].abs() < 1e-12 {
                if origin[a] < lo || origin[a] > hi {
                    return;
                }
            } else {
                let (mut ta, mut tb) = ((lo - origin[a]) / dir[a], (hi - origin[a]) / dir[a]);
                if ta > tb {
                    std::mem::swap(&mut ta, &mut tb);
                }
                t0 = t0.max(ta);
                t1 = t1.min(tb);
            }
        }
        let t1 = t1.min(t0 + view.max_steps);
        // Steps are whole numbers in f64: beyond 2^52 `k + 1 == k` and a ray would never advance.
        if t0.is_nan() || t1.is_nan() || t0 > t1 || t1 >= (1u64 << 52) as f64 {
            return;
        }
        // Samples sit at whole steps plus this pixel's jitter from the origin, so skipping never
        // shifts them.
        let jitter = if self.options.jitter { interleaved_gradient_noise(px, py) } else { 0.0 };
        let mut k = (t0 - jitter).ceil();
        let mut transmittance = 1.0f32;
        let threshold = self.options.termination_transmittance as f32;
        while k + jitter <= t1 {
            let t = k + jitter;
            let p = [origin[0] + t * dir[0], origin[1] + t * dir[1], origin[2] + t * dir[2]];
            if let Some((bm, empty)) = self.bricks {
                let b = [0, 1, 2].map(|a| ((p[a].max(0.0) as usize) >> bm.shift).min(bm.counts[a] - 1));
                let bi = b[0] + bm.counts[0] * (b[1] + bm.counts[1] * b[2]);
                if empty[bi] {
                    let next = brick_exit(origin, dir, b, bm.size, jitter, k);
                    stats.skipped += (next - k) as u64;
                    k = next;
                    continue;
                }
            }
            stats.samples += 1;
            let absorbed = match self.options.interpolation {
                Interpolation::Trilinear | Interpolation::Nearest => self.sample_values(p, transmittance, out),
                Interpolation::Labels => match self.sample_labels(p, transmittance, out) {
                    Ok(a) => a,
                    // No material reaches this field brick: with skipping on, jump over it.
                    Err(b) if self.bricks.is_some() => {
                        let next = brick_exit(origin, dir, b, FIELD_BRICK, jitter, k);
                        stats.skipped += (next - k - 1.0) as u64;
                        k = next;
                        continue;
                    }
                    Err(_) => 0.0,
                },
            };
            if absorbed > 0.0 {
                transmittance *= 1.0 - absorbed;
                if self.options.early_termination && transmittance < threshold {
                    stats.terminated += 1;
                    break;
                }
            }
            k += 1.0;
        }
        debug_assert!(out.len() == self.n_mat);
    }
}

/// The first whole step (plus jitter) past the far faces of brick `b` (edge `size` voxels) on the ray
/// `origin + t·dir`, and at least one step past `k`.
#[inline]
fn brick_exit(origin: [f64; 3], dir: [f64; 3], b: [usize; 3], size: usize, jitter: f64, k: f64) -> f64 {
    let mut exit = f64::INFINITY;
    for a in 0..3 {
        if dir[a] > 1e-12 {
            exit = exit.min((((b[a] + 1) * size) as f64 - origin[a]) / dir[a]);
        } else if dir[a] < -1e-12 {
            exit = exit.min(((b[a] * size) as f64 - origin[a]) / dir[a]);
        }
    }
    let next = (exit - jitter).floor() + 1.0;
    if next > k { next } else { k + 1.0 }
}
