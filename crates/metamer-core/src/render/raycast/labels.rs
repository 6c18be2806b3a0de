//! Label fields by shape-based interpolation: for every material near a brick, the signed distance to
//! its boundary within each slice (a 2D Euclidean distance transform per z slice, in the slice's world
//! units), clamped to ±[`LABEL_REACH`], smoothed in-plane by a small Gaussian ([`LABEL_SIGMA`],
//! truncated at [`LABEL_RADIUS`]) and stored per voxel as `u16`.
//!
//! The marcher interpolates these distances trilinearly and only then turns them into an occupancy
//! (a smoothstep of width [`LABEL_RAMP`] across the zero level). Between two slices the boundary is
//! therefore the linear blend of the two slices' contours — the contour of slice k morphs into that
//! of slice k + 1 — so a surface that runs almost parallel to the slices is a smooth ramp, not a
//! staircase of one-slice terraces with treads many voxels wide (which no small 3D blur of the label
//! indicators can remove: a tread wider than the blur stays flat). A sloped plane is reproduced
//! exactly as long as its treads are narrower than twice the clamp. Label volumes are segmented slice
//! by slice along z, often with a wider z spacing (the frog: 1 × 1 × 1.5), which is why z is the
//! interpolated axis.
//!
//! Shading normals are each material's own distance gradient (central differences one voxel either
//! side, stored as `i16` triples and interpolated trilinearly): continuous across cells and slices.

use super::block::{S, S3, SHIFT};
use super::classify::Classifier;
use crate::volume::Volume;

/// Standard deviation (voxels, in-plane) of the Gaussian that smooths each slice's signed distance.
pub const LABEL_SIGMA: f32 = 1.0;
/// Truncation radius of that Gaussian (voxels).
pub const LABEL_RADIUS: usize = 2;
/// Clamp of the in-plane signed distance (in-plane voxels): a contour interpolates smoothly to the next
/// slice's when the two lie within this distance of each other.
pub const LABEL_REACH: f32 = 8.0;
/// Width (in-plane voxels) of the occupancy ramp across a boundary.
pub const LABEL_RAMP: f32 = 2.0;

/// Stored distance units per in-plane voxel: `u16` over [−REACH, REACH].
pub(super) const SDF_UNIT: f32 = 2.0 * LABEL_REACH / 65535.0;

/// Occupancy of a point at signed distance `s` (in-plane voxels, positive outside) from a boundary.
#[inline(always)]
pub(super) fn ramp(s: f32) -> f32 {
    let t = (0.5 - s * (1.0 / LABEL_RAMP)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// How far (index voxels, along any axis) past a labelled voxel a material's occupancy can reach: the
/// ramp's half width, the in-plane blur and one interpolation cell.
pub(super) fn label_reach(volume: &Volume) -> usize {
    let s = volume.spacing;
    let h = s[0].min(s[1]);
    let stretch = if h > 0.0 { (s[0].max(s[1]) / h).ceil() as usize } else { 1 };
    2 + LABEL_RADIUS * stretch.max(1)
}

/// One brick's label fields.
pub(super) struct LabelBlock {
    /// Materials (0-based) with some occupancy in the block.
    pub(super) mats: Vec<u8>,
    /// `mats.len() × S3` signed distances, `u16` in units of [`SDF_UNIT`] from −REACH.
    pub(super) sdf: Vec<u16>,
    /// `mats.len() × S3` distance gradients (per index step) in units of `scale` (empty without
    /// gradients).
    pub(super) grad: Vec<[i16; 3]>,
}

/// Field units per stored gradient unit: a central difference of distances clamped to ±REACH is at
/// most REACH.
pub(super) const GRAD_SCALE: f32 = LABEL_REACH / i16::MAX as f32;

/// Build the label fields of brick `b`, each voxel's material (index + 1, 0 for none) by `classifier`.
pub(super) fn build(volume: &Volume, classifier: &Classifier, b: [usize; 3], gradients: bool) -> LabelBlock {
    const R: usize = LABEL_RADIUS;
    let d = volume.dims;
    let sp = volume.spacing;
    let h = sp[0].min(sp[1]).max(f64::MIN_POSITIVE);
    // Squared in-plane voxel lengths in units of h.
    let wx = ((sp[0] / h) * (sp[0] / h)) as f32;
    let wy = ((sp[1] / h) * (sp[1] / h)) as f32;
    // In-plane margins: the distance clamp, the blur and the central differences.
    let mx = (f64::from(LABEL_REACH) * h / sp[0]).ceil() as usize + R + 1;
    let my = (f64::from(LABEL_REACH) * h / sp[1]).ceil() as usize + R + 1;
    // z: the blur and the central differences.
    let mz = R + 1;
    let (nx, ny, nz) = (S + 2 * mx, S + 2 * my, S + 2 * mz);
    let o = [
        (b[0] << SHIFT) as isize - mx as isize,
        (b[1] << SHIFT) as isize - my as isize,
        (b[2] << SHIFT) as isize - mz as isize,
    ];
    let coord = |a: usize, j: usize| (o[a] + j as isize).clamp(0, d[a] as isize - 1) as usize;
    let mut labels = vec![0u8; nx * ny * nz];
    crate::with_voxels!(&volume.voxels, data => {
        for z in 0..nz {
            let vz = coord(2, z);
            for y in 0..ny {
                let row = d[0] * (coord(1, y) + d[1] * vz);
                let src = &data[row..row + d[0]];
                let dst = &mut labels[nx * (y + ny * z)..][..nx];
                for (x, l) in dst.iter_mut().enumerate() {
                    *l = classifier.material[classifier.bin(src[coord(0, x)].to_f32())];
                }
            }
        }
    });
    // The blurred distance is read over the block and its one-voxel rim (G³); the unblurred one over
    // that grown by the blur (W per axis), whose window starts at (x0, y0) in the region.
    const G: usize = S + 2;
    const W: usize = G + 2 * LABEL_RADIUS;
    let (x0, y0) = (mx - 1 - R, my - 1 - R);
    // Only materials within reach of the block's occupancy matter: a labelled voxel in the window
    // grown by the ramp's half width and a cell.
    let mut present: Vec<u8> = Vec::new();
    for z in 0..nz {
        for y in y0.saturating_sub(2)..(y0 + W + 2).min(ny) {
            let row = &labels[nx * (y + ny * z)..][..nx];
            for &m in &row[x0.saturating_sub(2)..(x0 + W + 2).min(nx)] {
                if m != 0 && !present.contains(&m) {
                    present.push(m);
                }
            }
        }
    }
    present.sort_unstable();

    let kernel = gaussian_kernel();
    let mut edt = Edt::new();
    let mut out = LabelBlock { mats: Vec::new(), sdf: Vec::new(), grad: Vec::new() };
    let mut unblurred = vec![0f32; W * W * nz];
    let mut bxy = vec![0f32; G * G * nz];
    let mut field = vec![0f32; G * G * G];
    let mut inside = vec![false; nx * ny];
    let window = Window { x0, y0, n: W };
    for &m in &present {
        for z in 0..nz {
            let lab = &labels[nx * ny * z..nx * ny * (z + 1)];
            for (i, l) in inside.iter_mut().zip(lab) {
                *i = *l == m;
            }
            let slice = &mut unblurred[W * W * z..W * W * (z + 1)];
            if let Some(c) = edt.signed(&inside, nx, ny, wx, wy, window, slice) {
                // All on one side: the blur keeps the constant.
                bxy[G * G * z..G * G * (z + 1)].iter_mut().for_each(|v| *v = c);
                continue;
            }
            // Blur in-plane.
            let mut bx = [[0f32; G]; W];
            for (yy, row) in bx.iter_mut().enumerate() {
                let src = &slice[W * yy..W * (yy + 1)];
                for (xx, v) in row.iter_mut().enumerate() {
                    *v = kernel.iter().zip(&src[xx..]).map(|(k, s)| k * s).sum();
                }
            }
            for yy in 0..G {
                for xx in 0..G {
                    bxy[xx + G * (yy + G * z)] = kernel.iter().enumerate().map(|(t, k)| k * bx[yy + t][xx]).sum();
                }
            }
        }
        // And across the slices.
        for z in 0..G {
            for i in 0..G * G {
                field[i + G * G * z] = kernel.iter().enumerate().map(|(t, k)| k * bxy[i + G * G * (z + t)]).sum();
            }
        }
        // Occupied somewhere in the block: a corner below the ramp's outer edge.
        let at = |x: usize, y: usize, z: usize| field[x + G * (y + G * z)];
        let mut any = false;
        for z in 1..=S {
            for y in 1..=S {
                for x in 1..=S {
                    any |= at(x, y, z) < 0.5 * LABEL_RAMP;
                }
            }
        }
        if !any {
            continue;
        }
        out.mats.push(m - 1);
        let q = |s: f32| ((s.clamp(-LABEL_REACH, LABEL_REACH) + LABEL_REACH) / SDF_UNIT).round() as u16;
        let g = |c: f32| (c / GRAD_SCALE).round().clamp(-f32::from(i16::MAX), f32::from(i16::MAX)) as i16;
        for z in 1..=S {
            for y in 1..=S {
                for x in 1..=S {
                    out.sdf.push(q(at(x, y, z)));
                    if gradients {
                        out.grad.push([
                            g(0.5 * (at(x + 1, y, z) - at(x - 1, y, z))),
                            g(0.5 * (at(x, y + 1, z) - at(x, y - 1, z))),
                            g(0.5 * (at(x, y, z + 1) - at(x, y, z - 1))),
                        ]);
                    }
                }
            }
        }
    }
    debug_assert_eq!(out.sdf.len(), out.mats.len() * S3);
    out
}

fn gaussian_kernel() -> [f32; 2 * LABEL_RADIUS + 1] {
    let mut kernel = [0f32; 2 * LABEL_RADIUS + 1];
    for (k, w) in kernel.iter_mut().enumerate() {
        let x = k as f32 - LABEL_RADIUS as f32;
        *w = (-0.5 * x * x / (LABEL_SIGMA * LABEL_SIGMA)).exp();
    }
    let sum: f32 = kernel.iter().sum();
    kernel.iter_mut().for_each(|w| *w /= sum);
    kernel
}

/// A square window of a slice region: its first column and row, and its edge.
#[derive(Clone, Copy)]
struct Window {
    x0: usize,
    y0: usize,
    n: usize,
}

/// Far: larger than any squared distance within the clamp.
const FAR: f32 = 1e20;

/// Scratch space of the bounded squared Euclidean distance transform: exact distances along each row
/// (two scans), then along the columns a minimum over the rows within the clamp. Exact up to
/// [`LABEL_REACH`], which is all the clamped distance needs.
struct Edt {
    /// Squared distance along x to the nearest feature of the row, per row and window column.
    rows: Vec<f32>,
    edge: Vec<bool>,
    hor_or: Vec<bool>,
    hor_and: Vec<bool>,
}

impl Edt {
    fn new() -> Edt {
        Edt { rows: Vec::new(), edge: Vec::new(), hor_or: Vec::new(), hor_and: Vec::new() }
    }

    /// Signed distance (in-plane voxels of length 1 for weight 1; positive outside), over `window`,
    /// of the pixels of an `nx × ny` slice to the boundary of `inside`, half a voxel past the
    /// boundary pixels' centres, clamped to ±REACH.
    ///
    /// One transform serves both signs: its features are the boundary pixels (those with a neighbour,
    /// diagonals included, on the other side). The pixel on the other side nearest to any pixel is such a boundary pixel
    /// (a step from it towards the pixel would otherwise stay on its side and come closer), so a
    /// pixel `k` voxels deep along an axis is `k − 1` from the nearest boundary pixel of its own side
    /// and `k` from the other's, and `±(distance + ½)` is its distance to the boundary between pixel
    /// centres (exact along the axes, within a fraction of a voxel elsewhere, before the blur).
    /// Returns the value when the whole slice lies on one side (every pixel ±REACH).
    #[allow(clippy::too_many_arguments)]
    fn signed(
        &mut self,
        inside: &[bool],
        nx: usize,
        ny: usize,
        wx: f32,
        wy: f32,
        window: Window,
        out: &mut [f32],
    ) -> Option<f32> {
        let n_in = inside.iter().filter(|i| **i).count();
        if n_in == 0 || n_in == inside.len() {
            let s = if n_in == 0 { LABEL_REACH } else { -LABEL_REACH };
            out.iter_mut().for_each(|o| *o = s);
            return Some(s);
        }
        let Window { x0, y0, n } = window;
        // A pixel is on the boundary when its 3×3 neighbourhood (clamped at the region's edge) is not all
        // on its side: separably, the neighbourhood's OR (dilation) and AND (erosion), row then column.
        let (hor_or, hor_and) = (&mut self.hor_or, &mut self.hor_and);
        hor_or.clear();
        hor_and.clear();
        for y in 0..ny {
            let r = &inside[nx * y..nx * (y + 1)];
            for x in 0..nx {
                let (a, b, c) = (r[x.saturating_sub(1)], r[x], r[(x + 1).min(nx - 1)]);
                hor_or.push(a | b | c);
                hor_and.push(a & b & c);
            }
        }
        let edge = &mut self.edge;
        edge.clear();
        for y in 0..ny {
            let (ya, yb) = (nx * y.saturating_sub(1), nx * (y + 1).min(ny - 1));
            let yc = nx * y;
            for x in 0..nx {
                let or = hor_or[ya + x] | hor_or[yc + x] | hor_or[yb + x];
                let and = hor_and[ya + x] & hor_and[yc + x] & hor_and[yb + x];
                edge.push(if inside[yc + x] { !and } else { or });
            }
        }
        // Along x: the nearest feature left and right of each window column.
        let rows = &mut self.rows;
        rows.clear();
        rows.resize(ny * n, FAR);
        for y in 0..ny {
            let e = &edge[nx * y..nx * (y + 1)];
            let r = &mut rows[n * y..n * (y + 1)];
            let mut last: Option<usize> = None;
            for (x, f) in e.iter().enumerate().take(x0 + n) {
                if *f {
                    last = Some(x);
                }
                if let (true, Some(l)) = (x >= x0, last) {
                    let dx = (x - l) as f32;
                    r[x - x0] = wx * dx * dx;
                }
            }
            let mut next: Option<usize> = None;
            for x in (x0..nx).rev() {
                if e[x] {
                    next = Some(x);
                }
                if let (true, Some(nn)) = (x < x0 + n, next) {
                    let dx = (nn - x) as f32;
                    r[x - x0] = r[x - x0].min(wx * dx * dx);
                }
            }
        }
        // Along y: the nearest row within the clamp.
        let reach = (LABEL_REACH / wy.sqrt()).ceil() as usize + 1;
        let half = 0.5 * wx.min(wy).sqrt();
        let mut best = vec![FAR; n];
        for yw in 0..n {
            let y = y0 + yw;
            best.iter_mut().for_each(|b| *b = FAR);
            for yy in y.saturating_sub(reach)..(y + reach + 1).min(ny) {
                let dy = yy as f32 - y as f32;
                let c = wy * dy * dy;
                for (b, r) in best.iter_mut().zip(&rows[n * yy..n * (yy + 1)]) {
                    *b = b.min(r + c);
                }
            }
            for (xw, b) in best.iter().enumerate() {
                let d = b.sqrt() + half;
                let i = (x0 + xw) + nx * y;
                out[xw + n * yw] = if inside[i] { -d } else { d }.clamp(-LABEL_REACH, LABEL_REACH);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_distance_matches_brute_force_on_a_small_grid() {
        let (nx, ny) = (7usize, 5usize);
        let mut inside = vec![false; nx * ny];
        inside[3 + nx * 2] = true;
        inside[4 + nx * 2] = true;
        let mut e = Edt::new();
        let n = ny;
        let mut out = vec![0f32; n * n];
        e.signed(&inside, nx, ny, 1.0, 1.0, Window { x0: 1, y0: 0, n }, &mut out);
        for y in 0..n {
            for x in 1..1 + n {
                let brute = (0..nx * ny)
                    .filter(|i| inside[*i])
                    .map(|i| {
                        let (px, py) = ((i % nx) as f32, (i / nx) as f32);
                        ((x as f32 - px).powi(2) + (y as f32 - py).powi(2)).sqrt()
                    })
                    .fold(f32::INFINITY, f32::min);
                let got = out[(x - 1) + n * y];
                let want = if inside[x + nx * y] { -0.5 } else { brute - 0.5 };
                // Exact along the axis through the pixels, within half a voxel off it.
                let tol = if y == 2 { 1e-5 } else { 0.5 };
                assert!((got - want).abs() <= tol, "({x}, {y}): {got} vs {want}");
            }
        }
    }

    #[test]
    fn ramp_is_monotone_and_half_at_the_boundary() {
        assert_eq!(ramp(-LABEL_RAMP), 1.0);
        assert_eq!(ramp(LABEL_RAMP), 0.0);
        assert!((ramp(0.0) - 0.5).abs() < 1e-6);
        assert!((ramp(0.2) + ramp(-0.2) - 1.0).abs() < 1e-6);
        assert!(ramp(0.1) < ramp(-0.1));
    }
}
