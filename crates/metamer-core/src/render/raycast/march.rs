//! Marching one ray: sample reconstruction, classification, shading and front-to-back compositing.

use super::block::{FIELD_BRICK, S3};
use super::classify::{BrickMap, Classifier, EMPTY, LUT_BINS, MIXED, Spans};
use super::fields::{CELL, CORNERS, Cursor, Fields, corner_weights};
use super::labels::{self, LABEL_REACH, SDF_UNIT};
#[cfg(target_arch = "x86_64")]
use super::lanes;
use super::view::View;
use super::{
    Gradient, Interpolation, MAX_MATERIALS, RaycastOptions, RaycastStats, Shading, interleaved_gradient_noise,
};
use crate::volume::{Volume, Voxel};

/// The trilinear cell of a sample: its eight voxels (`v[x + 2y + 4z]`) and the sample's fractional
/// position among them.
struct Cell;

impl Cell {
    /// Trilinear interpolation.
    #[inline(always)]
    fn value(v: &[f32; 8], [fx, fy, fz]: [f32; 3]) -> f32 {
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
    fn gradient(v: &[f32; 8], [fx, fy, fz]: [f32; 3]) -> [f32; 3] {
        let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
        let dx = gy * gz * (v[1] - v[0]) + fy * gz * (v[3] - v[2]) + gy * fz * (v[5] - v[4]) + fy * fz * (v[7] - v[6]);
        let dy = gx * gz * (v[2] - v[0]) + fx * gz * (v[3] - v[1]) + gx * fz * (v[6] - v[4]) + fx * fz * (v[7] - v[5]);
        let dz = gx * gy * (v[4] - v[0]) + fx * gy * (v[5] - v[1]) + gx * fy * (v[6] - v[2]) + fx * fy * (v[7] - v[3]);
        [dx, dy, dz]
    }
}

/// Length (voxels of the smallest in-plane spacing) a refined step's substeps aim at.
///
/// Refinement: a step whose two ends differ — value classes: another material, unless both are
/// thinner than [`Edge::MIN_ALPHA`] per step (smoke), and for a dense material ([`Edge::DENSE`]) the
/// step after its entry too; labels: either end's cell within [`near_band`] of some material's
/// boundary, or a jump in total occupancy — is composited as [`substeps`] substeps (opacity corrected
/// for their length), so that a surface or a thin plate inside one step is integrated finely and no
/// longer depends on where the jittered samples happen to fall (which shows as a fine dither on thin
/// plates and dense rims seen at an angle). Steps inside one material or in empty space keep one
/// sample.
pub const REFINED_STEP: f64 = 0.25;

/// Substeps per refined step of `step` voxels (of the smallest spacing): about [`REFINED_STEP`]
/// in-plane voxels each, 1 when the step is already that short, at most 32.
pub(super) fn substeps(volume: &Volume, step: f64) -> usize {
    ((in_plane_step(volume, step) / REFINED_STEP).ceil() as usize).clamp(1, 32)
}

/// The step in in-plane voxels (the unit of the label distances).
fn in_plane_step(volume: &Volume, step: f64) -> f64 {
    let s = volume.spacing;
    let min = s[0].min(s[1]).min(s[2]);
    let h = s[0].min(s[1]);
    if h > 0.0 { step * min / h } else { step }
}

/// How close (in-plane voxels) to a label boundary a sample must be for the step that ends there to
/// be refined: half the occupancy ramp plus one step. The in-plane distance changes by at most one
/// per voxel, so a step that meets the ramp anywhere ends within this band (a jump across slices is
/// caught by the occupancy test instead).
pub(super) fn near_band(volume: &Volume, step: f64) -> f32 {
    (0.5 * f64::from(labels::LABEL_RAMP) + in_plane_step(volume, step)) as f32
}

/// Where a sample falls: its trilinear cell's first voxel (as an index and as coordinates) and the
/// fractions along each axis.
#[derive(Clone, Copy)]
struct Located {
    b: usize,
    i: [usize; 3],
    f: [f32; 3],
}

/// A label sample before compositing. Its block is the one the cursor it was taken with holds: nothing
/// moves that cursor before the sample is composited ([`RayContext::march`] takes the substeps before it
/// with a cursor of their own), so the sample holds no block of its own (a counted block's reference count
/// was touched twice a sample).
struct LabelSample {
    /// The field brick of the sample's block (`usize::MAX`: no fields).
    brick: usize,
    base: usize,
    f: [f32; 3],
    /// Occupancy per material of the block (normalised to sum at most 1).
    occ: [f32; MAX_MATERIALS],
    total: f32,
    /// Within [`near_band`] of some material's boundary.
    near: bool,
}

impl Default for LabelSample {
    fn default() -> LabelSample {
        LabelSample { brick: usize::MAX, base: 0, f: [0.0; 3], occ: [0.0; MAX_MATERIALS], total: 0.0, near: false }
    }
}

/// What the refinement test compares at the two ends of a step.
#[derive(Clone, Copy)]
struct Edge {
    /// Labels: within [`near_band`] of some material's boundary.
    near: bool,
    /// Values: the material (index + 1, 0 = none).
    material: u8,
    /// Values: the step opacity; labels: the total occupancy.
    level: f32,
}

impl Edge {
    /// Past an empty brick (or before the first sample).
    const EMPTY: Edge = Edge { near: false, material: 0, level: 0.0 };

    /// Labels: an occupancy change that marks a crossing whose ends both lie outside the near band.
    const JUMP: f32 = 0.02;

    /// Values: a boundary between materials whose step opacities are all below this is not refined
    /// (thin smoke): the dither it could show is at most that share of a pixel's weight.
    const MIN_ALPHA: f32 = 0.05;

    /// Values: a material this dense (step opacity) absorbs most of a ray within two steps of its surface, so
    /// the step after a refined entry is refined too: the weight is spread over substeps instead of
    /// sitting in the one or two whole-step samples whose place the jitter decides.
    const DENSE: f32 = 0.3;
}

/// One way of reconstructing samples: what a sample holds before compositing, how it is taken and
/// composited, and what the refinement test compares. The marcher [`RayContext::march`] is generic over
/// it (label mode; value classes have their own loop, [`RayContext::march_values`], generic over the
/// voxel type instead).
trait Sampler<'a> {
    /// Held by the marcher and filled in place for each sample (a label sample's occupancies are an array
    /// of [`MAX_MATERIALS`]: returned by value, it was copied several times a sample).
    type Sample: Default;
    /// The sample at index-space point `p` into `into`, or the field brick no material reaches (label
    /// mode; `into` then unchanged). `uniform`: the material (index + 1) every value of the sample's brick
    /// maps to, or [`MIXED`] (value classes only; label mode always passes `MIXED`).
    fn sample(
        ctx: &RayContext<'a>,
        p: [f64; 3],
        at: Located,
        uniform: u8,
        cursor: &mut Cursor<'a>,
        into: &mut Self::Sample,
    ) -> Result<(), [usize; 3]>;
    fn edge(s: &Self::Sample) -> Edge;
    /// Whether the step between samples with these edges is refined.
    fn refine(a: &Edge, b: &Edge) -> bool;
    /// Whether the step after a refined one ending at this edge is refined too ([`Edge::DENSE`]).
    fn dense(e: &Edge) -> bool;
    /// Composite a sample standing for a whole step (`sub` false) or a substep: adds its weights,
    /// returns the opacity absorbed.
    fn composite(
        ctx: &RayContext<'a>,
        s: &Self::Sample,
        sub: bool,
        transmittance: f32,
        out: &mut [f32],
        cursor: &mut Cursor<'a>,
    ) -> f32;
}

/// Shape-based labels.
struct Labels;

impl<'a> Sampler<'a> for Labels {
    type Sample = LabelSample;
    #[inline(always)]
    fn sample(
        ctx: &RayContext<'a>,
        _: [f64; 3],
        at: Located,
        _: u8,
        cursor: &mut Cursor<'a>,
        into: &mut LabelSample,
    ) -> Result<(), [usize; 3]> {
        ctx.label_sample(at, cursor, into)
    }
    #[inline(always)]
    fn edge(s: &LabelSample) -> Edge {
        Edge { near: s.near, material: 0, level: s.total }
    }
    #[inline(always)]
    fn refine(a: &Edge, b: &Edge) -> bool {
        a.near || b.near || (a.level - b.level).abs() > Edge::JUMP
    }
    /// The near band already spans the steps around a boundary.
    #[inline(always)]
    fn dense(_: &Edge) -> bool {
        false
    }
    #[inline(always)]
    fn composite(
        ctx: &RayContext<'a>,
        s: &LabelSample,
        sub: bool,
        transmittance: f32,
        out: &mut [f32],
        cursor: &mut Cursor<'a>,
    ) -> f32 {
        let c = ctx.classifier;
        let alpha = if sub { &c.material_alpha_sub } else { &c.material_alpha };
        ctx.composite_labels(s, alpha, transmittance, out, cursor)
    }
}

/// A ray clipped to the framed box: samples at `origin + (k + jitter)·dir` for whole k with
/// `t0 ≤ k + jitter ≤ t1` (index space, steps).
#[derive(Clone, Copy)]
struct Ray {
    origin: [f64; 3],
    dir: [f64; 3],
    t0: f64,
    t1: f64,
    jitter: f64,
}

/// The volume's grid as the inner loop needs it, computed once per raycast.
pub(super) struct Grid {
    /// The largest index-space coordinate along each axis (dims − 1).
    pub(super) hi: [f64; 3],
    /// The largest first voxel of a cell (dims − 2, 0 along an axis of one voxel).
    pub(super) imax: [f64; 3],
    /// The strides to the next voxel along x, y and z (0 along an axis of one voxel).
    pub(super) strides: [usize; 3],
}

impl Grid {
    pub(super) fn new(volume: &Volume) -> Grid {
        let d = volume.dims;
        Grid {
            hi: d.map(|n| (n.max(1) - 1) as f64),
            imax: d.map(|n| n.saturating_sub(2) as f64),
            strides: [usize::from(d[0] > 1), if d[1] > 1 { d[0] } else { 0 }, if d[2] > 1 { d[0] * d[1] } else { 0 }],
        }
    }
}

pub(super) struct RayContext<'a> {
    pub(crate) volume: &'a Volume,
    pub(crate) classifier: &'a Classifier,
    /// The lazily built per-brick fields: smooth gradients and, in label mode, smoothed occupancy
    /// (None when neither is needed).
    pub(crate) fields: Option<&'a Fields<'a>>,
    /// The min/max bricks and their table for this transfer function ([`EMPTY`], a material, [`MIXED`]).
    pub(crate) bricks: Option<(&'a BrickMap, &'a [u8])>,
    /// The bricks' empty groups ([`Spans`]), with `bricks`.
    pub(crate) spans: Option<&'a Spans>,
    pub(crate) view: &'a View,
    pub(crate) grid: Grid,
    pub(crate) options: &'a RaycastOptions,
    /// Substeps a step that crosses a boundary is split into (1: refinement off, see [`substeps`]).
    pub(crate) substeps: usize,
    /// Label mode: a sample whose signed distance to some boundary is below this (in-plane voxels) is
    /// near it ([`near_band`]).
    pub(crate) near_band: f32,
    /// The shading's ambient share, in [0, 1].
    pub(crate) ambient: f32,
    /// A ray stops once its transmittance falls below this (the termination threshold, or 0 when early
    /// termination is off: a transmittance is never below 0).
    pub(crate) stop_below: f32,
    pub(crate) n_mat: usize,
    /// Value classes take their samples several at a time (AVX2 detected, the volume fits the lanes:
    /// [`super::lanes`]); false: the portable loop. The frames are the same.
    pub(crate) lanes: bool,
    pub(crate) width: usize,
    pub(crate) height: usize,
}

impl<'a> RayContext<'a> {
    /// Where index-space point p (clamped into [0, dims−1]) falls.
    #[inline(always)]
    fn locate(&self, p: [f64; 3]) -> Located {
        let mut i = [0usize; 3];
        let mut f = [0f32; 3];
        for a in 0..3 {
            // Clamped into [0, dims − 1], NaN to 0 (as `max(0.0)` then `min` would, without their NaN
            // handling: a comparison each).
            let q = if p[a] > 0.0 { p[a] } else { 0.0 };
            let q = if q < self.grid.hi[a] { q } else { self.grid.hi[a] };
            // The cell start min(⌊q⌋, imax) is ⌊min(q, imax)⌋ (imax is a whole number), clamped in f64.
            // SAFETY: the clamped q is finite and in [0, dims − 2] ⊂ [0, 2³²) (a volume has at most 2³²
            // voxels), so the truncation is in range for i64 (and is floor, as q ≥ 0); the saturating
            // `as` would cost a dozen instructions per axis in the inner loop. Converted back through
            // i64, not usize: the same number without the unsigned conversion's extra instructions.
            let t = unsafe { (if q < self.grid.imax[a] { q } else { self.grid.imax[a] }).to_int_unchecked::<i64>() };
            i[a] = t as usize;
            f[a] = (q - t as f64) as f32;
        }
        let d = self.volume.dims;
        Located { b: i[0] + d[0] * (i[1] + d[1] * i[2]), i, f }
    }

    /// The nearest voxel's value.
    #[inline(always)]
    fn nearest<T: Voxel>(&self, data: &[T], p: [f64; 3]) -> f32 {
        let d = self.volume.dims;
        let c = [0, 1, 2].map(|a| ((p[a].max(0.0) + 0.5) as usize).min(d[a] - 1));
        data[c[0] + d[0] * (c[1] + d[1] * c[2])].to_f32()
    }

    /// Shading from a field gradient g (per voxel index): `ambient + (1 − ambient)·max(n·l, 0)` with the
    /// normal turned to face the eye; 1 where the gradient vanishes.
    #[inline(always)]
    fn shade(&self, g: [f32; 3]) -> f32 {
        let v = self.view;
        let d = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let n2 = d([g[0] * g[0], g[1] * g[1], g[2] * g[2]], v.inv_spacing2);
        if n2 < 1e-12 {
            return 1.0;
        }
        let cos = d(g, v.light_index) / n2.sqrt();
        let cos = if d(g, v.view_index) > 0.0 { -cos } else { cos };
        let a = self.ambient;
        a + (1.0 - a) * cos.max(0.0)
    }

    /// The eight voxels of the trilinear cell whose first voxel is `b` (a [`Located::b`]).
    #[inline(always)]
    fn cell<T: Voxel>(&self, data: &[T], b: usize) -> [f32; 8] {
        let [sx, sy, sz] = self.grid.strides;
        let last = b + sz + sy + sx;
        assert!(last < data.len(), "cell {b} past the voxels");
        // SAFETY: the cell's voxels lie between its first voxel and its last, checked above (the strides
        // are non-negative). One check instead of eight: this runs at nearly every sample, and at a step
        // of half a voxel a ray enters a new cell at most samples, so the voxels are read afresh.
        let v = |o: usize| unsafe { data.get_unchecked(b + o) }.to_f32();
        [v(0), v(sx), v(sy), v(sy + sx), v(sz), v(sz + sx), v(sz + sy), v(sz + sy + sx)]
    }

    /// The material (index + 1, 0 = none) and bin of a value sample at `p` (located at `at`): the
    /// trilinear interpolation of its cell's voxels or the nearest voxel.
    #[inline(always)]
    fn classify<T: Voxel>(&self, data: &[T], p: [f64; 3], at: Located) -> (u8, usize) {
        let v = if self.options.interpolation == Interpolation::Nearest {
            self.nearest(data, p)
        } else {
            Cell::value(&self.cell(data, at.b), at.f)
        };
        let bin = self.classifier.bin(v);
        (self.classifier.material[bin], bin)
    }

    /// The smooth gradient at a located sample.
    #[inline(always)]
    fn smooth_gradient(&self, at: Located, cursor: &mut Cursor<'a>) -> [f32; 3] {
        let Some(fields) = self.fields else { return [0.0; 3] };
        let (block, base) = fields.block(at.i, cursor);
        fields.gradient(block, base, at.f)
    }

    /// Composite a value sample of material `material` (index + 1, 0 = none) in bin `bin` at `at` with
    /// opacities `alpha` (per bin, for the step it stands for): adds its material's weight, returns the
    /// opacity it absorbs.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn composite_value<T: Voxel>(
        &self,
        data: &[T],
        (material, bin): (u8, usize),
        at: Located,
        alpha: &[f32],
        transmittance: f32,
        out: &mut [f32],
        cursor: &mut Cursor<'a>,
    ) -> f32 {
        self.composite_value_by(data, (material, bin), at, alpha, transmittance, out, || {
            self.shade(self.smooth_gradient(at, cursor))
        })
    }

    /// [`Self::composite_value`] with the shading of the smooth gradient given by `smooth` (called only
    /// when the sample is shaded by it).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn composite_value_by<T: Voxel>(
        &self,
        data: &[T],
        (material, bin): (u8, usize),
        at: Located,
        alpha: &[f32],
        transmittance: f32,
        out: &mut [f32],
        smooth: impl FnOnce() -> f32,
    ) -> f32 {
        if material == 0 {
            return 0.0;
        }
        let mat = self.classifier.per_code[usize::from(material)];
        let mut alpha = alpha[bin];
        // The trilinear gradient, taken once per sample for the opacity and the shading alike.
        let mut cell_g = None;
        if mat.gradient_dependent() {
            // A transfer function over value and gradient (`max_gradient`).
            let g = Cell::gradient(&self.cell(data, at.b), at.f);
            cell_g = Some(g);
            alpha *= mat.gradient_share(g);
            if alpha <= 0.0 {
                return 0.0;
            }
        }
        let shade = match (self.options.shading, self.options.gradient) {
            (Shading::Unshaded, _) => 1.0,
            (_, Gradient::Smooth) => smooth(),
            (_, Gradient::Cell) => self.shade(cell_g.unwrap_or_else(|| Cell::gradient(&self.cell(data, at.b), at.f))),
        };
        out[usize::from(material) - 1] += transmittance * alpha * shade;
        if mat.absorbs { alpha } else { 0.0 }
    }

    /// Label sample: every nearby material's signed distance, interpolated trilinearly and turned into
    /// an occupancy ([`labels::ramp`]). `Err` names the field brick when no material reaches it.
    #[inline(always)]
    fn label_sample(&self, at: Located, cursor: &mut Cursor<'a>, into: &mut LabelSample) -> Result<(), [usize; 3]> {
        let Some(fields) = self.fields else {
            *into = LabelSample::default();
            return Ok(());
        };
        let Located { i, f, .. } = at;
        let (block, base) = fields.block(i, cursor);
        let n = block.mats.len();
        if n == 0 {
            return Err(fields.brick_of(i));
        }
        let w = corner_weights(f);
        // Only the block's materials' entries are written and read.
        let occ = &mut into.occ[..n];
        let mut sum = 0.0;
        let mut near = false;
        for (j, o) in occ.iter_mut().enumerate() {
            let q = &block.sdf[j * S3 + base..][..CELL];
            let mut v = 0.0;
            let (mut lo, mut hi) = (u16::MAX, 0u16);
            for (c, wc) in CORNERS.iter().zip(w) {
                let qc = q[*c];
                v += wc * f32::from(qc);
                lo = lo.min(qc);
                hi = hi.max(qc);
            }
            // Near when the distances at the cell's corners reach into the band: the cell may hold a
            // boundary even where the interpolated distance at the sample is far from it (a plate
            // thinner than a slice, crossed within one step).
            let to_d = |u: u16| f32::from(u) * SDF_UNIT - LABEL_REACH;
            near |= to_d(lo) < self.near_band && to_d(hi) > -self.near_band;
            *o = labels::ramp(v * SDF_UNIT - LABEL_REACH);
            sum += *o;
        }
        // Where three materials meet, the occupancies may sum a little above 1.
        if sum > 1.0 {
            occ.iter_mut().for_each(|o| *o /= sum);
            sum = 1.0;
        }
        into.brick = cursor.held().map_or(usize::MAX, |(_, brick)| brick);
        (into.base, into.f, into.total, into.near) = (base, f, sum, near);
        Ok(())
    }

    /// Composite a label sample with per-material opacities `alpha` (for the step it stands for): each
    /// material's occupancy times its opacity, shaded by its own distance gradient. Adds their weights,
    /// returns the opacity absorbed.
    #[inline(always)]
    fn composite_labels(
        &self,
        s: &LabelSample,
        alpha: &[f32],
        transmittance: f32,
        out: &mut [f32],
        cursor: &Cursor<'a>,
    ) -> f32 {
        let (Some((block, brick)), Some(fields)) = (cursor.held(), self.fields) else { return 0.0 };
        debug_assert_eq!(brick, s.brick, "the cursor moved between the sample and its composite");
        if s.total <= 0.0 {
            return 0.0;
        }
        let mut absorbed = 0.0;
        for (j, (m, o)) in block.mats.iter().zip(&s.occ).enumerate() {
            let m = usize::from(*m);
            let wgt = o * alpha[m];
            if wgt <= 0.0 {
                continue;
            }
            let at = j * S3 + s.base;
            let shade = match (self.options.shading, self.options.gradient) {
                (Shading::Unshaded, _) => 1.0,
                (_, Gradient::Smooth) => self.shade(fields.gradient(block, at, s.f)),
                (_, Gradient::Cell) => {
                    let q = &block.sdf[at..];
                    self.shade(Cell::gradient(&CORNERS.map(|c| f32::from(q[c])), s.f))
                }
            };
            out[m] += transmittance * wgt * shade;
            if self.classifier.per_code[m + 1].absorbs {
                absorbed += wgt;
            }
        }
        absorbed
    }

    /// Attenuate `transmittance` by the opacity a sample absorbed; true when early termination stops the
    /// ray there.
    #[inline(always)]
    fn attenuate(&self, absorbed: f32, transmittance: &mut f32, stats: &mut RaycastStats) -> bool {
        if absorbed > 0.0 {
            *transmittance *= 1.0 - absorbed;
            if *transmittance < self.stop_below {
                stats.terminated += 1;
                return true;
            }
        }
        false
    }

    /// March the ray of pixel (px, py), accumulating material weights into `out`.
    pub(crate) fn trace(&self, px: usize, py: usize, out: &mut [f32], stats: &mut RaycastStats) {
        let Some(ray) = self.ray(px, py) else { return };
        match self.options.interpolation {
            Interpolation::Trilinear | Interpolation::Nearest => crate::with_voxels!(&self.volume.voxels, data => {
                #[cfg(target_arch = "x86_64")]
                if self.lanes {
                    // SAFETY: `lanes` is set only where AVX2 was detected (`super::lanes::detected`).
                    return unsafe { self.march_values_avx2(data, &ray, out, stats) };
                }
                self.march_values(data, &ray, out, stats)
            }),
            Interpolation::Labels => self.march::<Labels>(&ray, out, stats),
        }
    }

    /// The ray of pixel (px, py) clipped to the framed box, or None when it misses it.
    #[inline(always)]
    fn ray(&self, px: usize, py: usize) -> Option<Ray> {
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
                    return None;
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
            return None;
        }
        // Samples sit at whole steps plus this pixel's jitter from the origin, so skipping never
        // shifts them.
        let jitter = if self.options.jitter { interleaved_gradient_noise(px, py) } else { 0.0 };
        Some(Ray { origin, dir, t0, t1, jitter })
    }

    /// March a ray through value classes (trilinear or nearest) of voxels `data`: the loop of
    /// [`Self::march`] for values, on the volume's own voxel type (no dispatch on it per sample), the
    /// counters kept per ray.
    #[inline(never)]
    fn march_values<T: Voxel>(&self, data: &[T], ray: &Ray, out: &mut [f32], stats: &mut RaycastStats) {
        self.march_values_in::<T, false>(data, ray, out, stats)
    }

    /// [`Self::march_values`] taking its samples [`lanes::LANES`] at a time ([`lanes::fill`]): the same
    /// frame, bit for bit.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    fn march_values_avx2<T: Voxel>(&self, data: &[T], ray: &Ray, out: &mut [f32], stats: &mut RaycastStats) {
        self.march_values_in::<T, true>(data, ray, out, stats)
    }

    /// The value loop; `LANES`: samples located and classified in batches (AVX2 only, and only inlined
    /// into [`Self::march_values_avx2`]).
    #[inline(always)]
    fn march_values_in<T: Voxel, const LANES: bool>(
        &self,
        data: &[T],
        ray: &Ray,
        out: &mut [f32],
        stats: &mut RaycastStats,
    ) {
        let Ray { origin, dir, t0, t1, jitter } = *ray;
        #[cfg(target_arch = "x86_64")]
        let mut batch = lanes::Batch::default();
        #[cfg(target_arch = "x86_64")]
        let ray_lanes = lanes::RayLanes { origin, dir, jitter };
        // Value reconstruction in the lanes: trilinear only (the nearest voxel is read by the scalar path).
        let values = self.options.interpolation == Interpolation::Trilinear;
        let brick_lanes = self.bricks.map(|(bm, _)| (bm.shift, bm.counts));
        // The smooth gradient's shading in the lanes too: trilinear values, shaded by the smooth gradient.
        let shade_lanes = self
            .fields
            .filter(|_| LANES && values && self.options.shading != Shading::Unshaded)
            .filter(|_| self.options.gradient == Gradient::Smooth);
        let classifier = self.classifier;
        // The tables every sample reads, as arrays of the bins' count (a bin is below it: indexed without a
        // bounds check) and held in locals rather than read through the classifier at every sample.
        let tables = |t: &'a [f32]| -> &'a [f32; LUT_BINS] { t.try_into().expect("a table per bin") };
        let (alpha_of, alpha_sub_of) = (tables(&classifier.alpha), tables(&classifier.alpha_sub));
        let material_of: &[u8; LUT_BINS] = classifier.material.as_slice().try_into().expect("a material per bin");
        let per_code = &classifier.per_code;
        let refining = self.substeps > 1;
        // The lanes' shaded composite (below): shaded in the lanes, no gradient-dependent material.
        let shade_fast = shade_lanes.filter(|_| !classifier.gradient_dependent);
        let mut k = (t0 - jitter).ceil();
        let mut transmittance = 1.0f32;
        let mut prev = Edge::EMPTY;
        // The step after a refined entry into a dense material is refined as well.
        let mut carry = false;
        let mut cursor = Cursor::default();
        let (mut samples, mut uniform_samples, mut skipped, mut skipped_bricks) = (0u64, 0u64, 0u64, 0u64);
        while k + jitter <= t1 {
            let t = k + jitter;
            // The sample's point and where it falls, taken where they are used: the lanes hold them already
            // (their common path reads neither).
            macro_rules! p {
                ($t:expr) => {{
                    let t = $t;
                    [origin[0] + t * dir[0], origin[1] + t * dir[1], origin[2] + t * dir[2]]
                }};
                () => {
                    p!(t)
                };
            }
            #[cfg(target_arch = "x86_64")]
            let lane = if LANES {
                let j = match batch.lane(k) {
                    Some(j) => j,
                    None => {
                        // SAFETY: LANES is true only inside `march_values_avx2`, which runs only where AVX2
                        // was detected; `lanes` was set only for a volume the lanes fit (`lanes::fits`).
                        unsafe { lanes::fill(&mut batch, &self.grid, self.volume.dims, brick_lanes, &ray_lanes, k) };
                        0
                    }
                };
                Some(j)
            } else {
                None
            };
            #[cfg(not(target_arch = "x86_64"))]
            let lane: Option<usize> = None;
            macro_rules! at {
                () => {
                    match lane {
                        #[cfg(target_arch = "x86_64")]
                        Some(j) => Located {
                            b: batch.b[j] as usize,
                            i: [batch.i[0][j] as usize, batch.i[1][j] as usize, batch.i[2][j] as usize],
                            f: [batch.f[0][j], batch.f[1][j], batch.f[2][j]],
                        },
                        _ => self.locate(p!()),
                    }
                };
            }
            // The portable loop locates every sample here (its brick needs the cell); the lanes' fast path
            // never builds it.
            let at_portable = if lane.is_none() { Some(self.locate(p!())) } else { None };
            macro_rules! at_ {
                () => {
                    match at_portable {
                        Some(at) => at,
                        None => at!(),
                    }
                };
            }
            let mut uniform = MIXED;
            if let Some((bm, table)) = self.bricks {
                // The brick of the sample's cell (it bounds the cell's eight voxels). A cell starts at most
                // at dims − 2 (0 along an axis of one voxel), so its brick is below the counts.
                // Written out: `[0, 1, 2].map` is not always inlined, and this runs at every sample.
                let sh = bm.shift;
                let brick = |at: Located| [at.i[0] >> sh, at.i[1] >> sh, at.i[2] >> sh];
                let index = |b: [usize; 3]| b[0] + bm.counts[0] * (b[1] + bm.counts[1] * b[2]);
                let bi = match (lane, at_portable) {
                    #[cfg(target_arch = "x86_64")]
                    (Some(j), _) => batch.brick[j] as usize,
                    (_, at) => {
                        let b = brick(at.unwrap_or_else(|| self.locate(p!())));
                        debug_assert!((0..3).all(|a| b[a] < bm.counts[a]), "{b:?} {:?}", bm.counts);
                        index(b)
                    }
                };
                uniform = table[bi];
                if uniform == EMPTY {
                    prev = Edge::EMPTY;
                    carry = false;
                    // Each landing sample is located in the crossing, as the portable loop locates it, so the
                    // batch of eight lanes is filled only where the ray lands in a brick that is not empty
                    // (one lane of a fresh batch per empty brick crossed cost more than the crossing itself).
                    let jumped = self.cross_empty(ray, brick(at_!()), k, (bm, table), brick, &mut skipped);
                    skipped_bricks += jumped.1;
                    k = jumped.0;
                    continue;
                }
            }
            samples += 1;
            // A brick whose values all map to one material: located, not reconstructed (the bin is one of
            // the material's, whose opacities are all alike).
            let sample = if uniform == MIXED {
                match lane {
                    #[cfg(target_arch = "x86_64")]
                    Some(j) if values => {
                        if !batch.classified {
                            // SAFETY: as for `lanes::fill` above.
                            unsafe { lanes::classify(&mut batch, &self.grid, classifier, data) };
                        }
                        let bin = batch.bin[j] as usize;
                        debug_assert!(bin < LUT_BINS);
                        (material_of[bin % LUT_BINS], bin)
                    }
                    _ => self.classify(data, p!(), at_!()),
                }
            } else {
                uniform_samples += 1;
                (uniform, usize::from(classifier.material_bin[usize::from(uniform) - 1]))
            };
            debug_assert!(sample.1 < LUT_BINS);
            let edge = Edge { near: false, material: sample.0, level: alpha_of[sample.1 % LUT_BINS] };
            // Refined: the two ends' materials differ and not both are thinner than smoke.
            let crossing = refining && prev.material != edge.material && prev.level.max(edge.level) >= Edge::MIN_ALPHA;
            let refine = crossing || carry;
            carry = crossing && edge.level >= Edge::DENSE;
            prev = edge;
            if refine {
                // The step from the previous sample to this one crosses a boundary: composite it as
                // `substeps` substeps ending at this sample (which is the last of them).
                let (n, stop) = self.value_substeps(data, ray, t, &mut transmittance, out, &mut cursor, stats);
                samples += n;
                if stop {
                    break;
                }
            }
            let alpha = if refine { alpha_sub_of } else { alpha_of };
            let absorbed = match (lane, shade_fast) {
                // Shaded in the lanes, no gradient-dependent material: `composite_value_by`'s operations
                // for that case, without building the sample's place unless its block is fetched.
                #[cfg(target_arch = "x86_64")]
                (Some(j), Some(fields)) => {
                    let (material, bin) = sample;
                    if material == 0 {
                        0.0
                    } else {
                        let mat = per_code[usize::from(material)];
                        let alpha = alpha[bin % LUT_BINS];
                        if batch.shaded & (1 << j) == 0 {
                            let i = [batch.i[0][j] as usize, batch.i[1][j] as usize, batch.i[2][j] as usize];
                            let (block, base) = fields.block(i, &mut cursor);
                            // SAFETY: as for `lanes::fill` above (AVX2 detected).
                            unsafe {
                                lanes::shade(&mut batch, j, &block.grad, base, fields.scale, self.view, self.ambient)
                            };
                        }
                        out[usize::from(material) - 1] += transmittance * alpha * batch.shade[j];
                        if mat.absorbs { alpha } else { 0.0 }
                    }
                }
                _ => {
                    let at = at_!();
                    let smooth = || match (lane, shade_lanes) {
                        #[cfg(target_arch = "x86_64")]
                        (Some(j), Some(fields)) => {
                            if batch.shaded & (1 << j) == 0 {
                                let (block, base) = fields.block(at.i, &mut cursor);
                                // SAFETY: as for `lanes::fill` above (AVX2 detected).
                                unsafe {
                                    lanes::shade(
                                        &mut batch,
                                        j,
                                        &block.grad,
                                        base,
                                        fields.scale,
                                        self.view,
                                        self.ambient,
                                    )
                                };
                            }
                            batch.shade[j]
                        }
                        _ => self.shade(self.smooth_gradient(at, &mut cursor)),
                    };
                    self.composite_value_by(data, sample, at, alpha, transmittance, out, smooth)
                }
            };
            if self.attenuate(absorbed, &mut transmittance, stats) {
                break;
            }
            k += 1.0;
        }
        stats.samples += samples;
        stats.uniform += uniform_samples;
        stats.skipped += skipped;
        stats.skipped_bricks += skipped_bricks;
        debug_assert!(out.len() == self.n_mat);
    }

    /// The refinement substeps of the value loop before the sample at `t` (all but that sample, the
    /// last of them): taken out of the loop (on the engine CT one step in 15 to 30 is refined), so that
    /// the loop keeps its state in registers. Scalar even where the loop's samples are taken in lanes:
    /// refined steps mostly come alone, so a batch of eight consecutive substeps would serve about one
    /// refined step and cost about what these do (tried on the engine CT: 488 k batches for 556 k
    /// refined steps at step 1). Returns the substeps taken and whether early termination stopped the ray.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn value_substeps<T: Voxel>(
        &self,
        data: &[T],
        ray: &Ray,
        t: f64,
        transmittance: &mut f32,
        out: &mut [f32],
        cursor: &mut Cursor<'a>,
        stats: &mut RaycastStats,
    ) -> (u64, bool) {
        let Ray { origin, dir, t0, .. } = *ray;
        let n = self.substeps as f64;
        let mut samples = 0;
        for j in 1..self.substeps {
            let tj = t - 1.0 + j as f64 / n;
            if tj < t0 {
                continue;
            }
            let pj = [origin[0] + tj * dir[0], origin[1] + tj * dir[1], origin[2] + tj * dir[2]];
            samples += 1;
            // A substep may lie in the brick before this sample's: reconstruct it in full.
            let at = self.locate(pj);
            let s = self.classify(data, pj, at);
            let absorbed = self.composite_value(data, s, at, &self.classifier.alpha_sub, *transmittance, out, cursor);
            if self.attenuate(absorbed, transmittance, stats) {
                return (samples, true);
            }
        }
        (samples, false)
    }

    /// Cross the empty brick `b` (of `bricks`, the map and its table) that the sample at step `k` falls in,
    /// and every empty brick the ray lands in after it; `brick`: the brick of a located sample, as the
    /// calling loop finds it. A group of empty bricks ([`classify::Spans`]) is left in one jump: every whole
    /// step before its far faces lies in it, so in one of its empty bricks, which the jumps brick by brick
    /// would each have stepped over (the same next sample either way). Each landing sample is located here
    /// and its brick looked up, without a pass through the loop. Adds the steps jumped over, up to the ray's
    /// last (a jump may end past it), to `skipped`; returns the step to sample next (past the ray's end when
    /// it ends in empty space) and the jumps taken.
    #[inline(always)]
    fn cross_empty(
        &self,
        ray: &Ray,
        mut b: [usize; 3],
        mut k: f64,
        (bm, table): (&BrickMap, &[u8]),
        brick: impl Fn(Located) -> [usize; 3],
        skipped: &mut u64,
    ) -> (f64, u64) {
        let Ray { origin, dir, t1, jitter, .. } = *ray;
        let last = (t1 - jitter).floor();
        let index = |b: [usize; 3]| b[0] + bm.counts[0] * (b[1] + bm.counts[1] * b[2]);
        let mut jumps = 0;
        loop {
            let next = match self.spans.and_then(|spans| spans.empty_around(b)) {
                Some((group, span)) => brick_exit(origin, dir, group, bm.size * span, jitter, k),
                None => brick_exit(origin, dir, b, bm.size, jitter, k),
            };
            *skipped += (next.min(last + 1.0) - k) as u64;
            jumps += 1;
            k = next;
            if k + jitter > t1 {
                return (k, jumps);
            }
            let t = k + jitter;
            let landed = brick(self.locate([origin[0] + t * dir[0], origin[1] + t * dir[1], origin[2] + t * dir[2]]));
            if table[index(landed)] != EMPTY {
                return (k, jumps);
            }
            b = landed;
        }
    }

    #[inline(always)]
    fn march<K: Sampler<'a>>(&self, ray: &Ray, out: &mut [f32], stats: &mut RaycastStats) {
        let Ray { origin, dir, t0, t1, jitter } = *ray;
        let mut k = (t0 - jitter).ceil();
        let mut transmittance = 1.0f32;
        let mut prev = Edge::EMPTY;
        // The step after a refined entry into a dense material is refined as well.
        let mut carry = false;
        let mut cursor = Cursor::default();
        // The substeps' own: a sample is composited with the block its cursor holds, after the substeps.
        let mut sub_cursor = Cursor::default();
        // The samples, filled in place: the step's and a substep's.
        let (mut sample, mut sub) = (K::Sample::default(), K::Sample::default());
        while k + jitter <= t1 {
            let t = k + jitter;
            let p = [origin[0] + t * dir[0], origin[1] + t * dir[1], origin[2] + t * dir[2]];
            let at = self.locate(p);
            let mut uniform = MIXED;
            if let Some((bm, table)) = self.bricks {
                // The brick of the sample's cell (it bounds the cell's eight voxels).
                // Written out: `[0, 1, 2].map` is not always inlined, and this runs at every sample.
                let (c, sh) = (&bm.counts, bm.shift);
                let brick = |at: Located| {
                    [(at.i[0] >> sh).min(c[0] - 1), (at.i[1] >> sh).min(c[1] - 1), (at.i[2] >> sh).min(c[2] - 1)]
                };
                let b = brick(at);
                uniform = table[b[0] + c[0] * (b[1] + c[1] * b[2])];
                if uniform == EMPTY {
                    prev = Edge::EMPTY;
                    carry = false;
                    let jumped = self.cross_empty(ray, b, k, (bm, table), brick, &mut stats.skipped);
                    stats.skipped_bricks += jumped.1;
                    k = jumped.0;
                    continue;
                }
            }
            stats.samples += 1;
            stats.uniform += u64::from(uniform != MIXED);
            match K::sample(self, p, at, uniform, &mut cursor, &mut sample) {
                Ok(()) => {}
                // No material reaches this field brick: with skipping on, jump over it.
                Err(b) => {
                    prev = Edge::EMPTY;
                    carry = false;
                    if self.bricks.is_some() {
                        let next = brick_exit(origin, dir, b, FIELD_BRICK, jitter, k);
                        stats.skipped += (next - k - 1.0) as u64;
                        stats.skipped_bricks += 1;
                        k = next;
                    } else {
                        k += 1.0;
                    }
                    continue;
                }
            }
            let edge = K::edge(&sample);
            let crossing = self.substeps > 1 && K::refine(&prev, &edge);
            let refine = crossing || carry;
            carry = crossing && K::dense(&edge);
            prev = edge;
            if refine {
                // The step from the previous sample to this one crosses a boundary: composite it as
                // `substeps` substeps ending at this sample (which is the last of them).
                let n = self.substeps as f64;
                for j in 1..self.substeps {
                    let tj = t - 1.0 + j as f64 / n;
                    if tj < t0 {
                        continue;
                    }
                    let pj = [origin[0] + tj * dir[0], origin[1] + tj * dir[1], origin[2] + tj * dir[2]];
                    stats.samples += 1;
                    // A substep may lie in the brick before this sample's: reconstruct it in full.
                    let Ok(()) = K::sample(self, pj, self.locate(pj), MIXED, &mut sub_cursor, &mut sub) else {
                        continue;
                    };
                    let absorbed = K::composite(self, &sub, true, transmittance, out, &mut sub_cursor);
                    if self.attenuate(absorbed, &mut transmittance, stats) {
                        return;
                    }
                }
            }
            let absorbed = K::composite(self, &sample, refine, transmittance, out, &mut cursor);
            if self.attenuate(absorbed, &mut transmittance, stats) {
                break;
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
