//! The orthographic camera's geometry in the volume's index space: framing, ray direction, clipping.

use super::classify::MaterialRows;
use super::{Camera, Shading};
use crate::volume::Volume;

/// Volume-space geometry of one view.
pub(super) struct View {
    /// Ray direction in index space, scaled to one step.
    pub(super) dir: [f64; 3],
    /// View direction in world space (unit), for shading.
    pub(super) view_world: [f64; 3],
    pub(super) right: [f64; 3],
    pub(super) up: [f64; 3],
    pub(super) half_extent: f64,
    /// The world point the image centre looks through.
    pub(super) centre_world: [f64; 3],
    /// Rays start this far before `centre_world` along the view direction.
    pub(super) radius: f64,
    /// The most steps one ray takes: enough to cross the box's index-space diagonal at `dir`'s length
    /// (so no ray inside the box is cut short), at most `MAX_ANISOTROPY × diagonal / step` and never more
    /// than [`MAX_RAY_STEPS`], whatever the spacings (a spacing of 1e-308 beside 1 cannot make a ray spin).
    pub(super) max_steps: f64,
    /// The view and light directions divided by the spacings, and the inverse squared spacings: a
    /// gradient per voxel index dotted with these gives its world-space dot products and length (f32,
    /// for the shading at every shaded sample).
    pub(super) view_index: [f32; 3],
    pub(super) light_index: [f32; 3],
    pub(super) inv_spacing2: [f32; 3],
    /// Index-space box the rays are clipped to.
    pub(super) clip_lo: [f64; 3],
    pub(super) clip_hi: [f64; 3],
}

/// The hard bound on the steps of one ray.
pub const MAX_RAY_STEPS: f64 = (1u64 << 22) as f64;

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if n > 0.0 { [v[0] / n, v[1] / n, v[2] / n] } else { v }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl View {
    /// `framed`: the voxels to fit, given when the camera fits the materials (None frames the whole
    /// grid). `reach`: how far (voxels) past the framed voxels a sample can still see them (1 for
    /// trilinear cells; more where a filtered field spreads them).
    pub(super) fn new(
        volume: &Volume,
        camera: &Camera,
        step: f64,
        shading: Shading,
        aspect: f64,
        framed: Option<&MaterialRows>,
        reach: f64,
    ) -> View {
        let (az, el) = (camera.azimuth_deg.to_radians(), camera.elevation_deg.to_radians());
        let eye = [az.sin() * el.cos(), -az.cos() * el.cos(), el.sin()];
        let view_world = [-eye[0], -eye[1], -eye[2]];
        let world_up = if el.cos().abs() < 1e-6 { [0.0, 1.0, 0.0] } else { [0.0, 0.0, 1.0] };
        let right = normalize(cross(view_world, world_up));
        let up = cross(right, view_world);
        let light_world = match shading {
            // Above left of the eye, towards the scene.
            Shading::Key => normalize([0, 1, 2].map(|a| eye[a] + 0.55 * up[a] - 0.45 * right[a])),
            Shading::Headlight | Shading::Unshaded => eye,
        };
        let min_spacing = volume.spacing.iter().copied().fold(f64::INFINITY, f64::min);
        let step_world = step * min_spacing;
        let dir = [0, 1, 2].map(|a| view_world[a] * step_world / volume.spacing[a]);
        let d = volume.dims;
        let whole = ([0usize; 3], [0, 1, 2].map(|a| d[a].saturating_sub(1)));
        let zoom = camera.zoom.max(1e-6);
        let (lo, hi) = framed.and_then(MaterialRows::bounds).unwrap_or(whole);
        // The box in world space (voxel centres at index × spacing, grown by the half voxel an
        // interpolated surface reaches past them), its centre and half diagonal.
        let lo_w = [0, 1, 2].map(|a| (lo[a] as f64 - 0.5).max(0.0) * volume.spacing[a]);
        let hi_w = [0, 1, 2].map(|a| (hi[a] as f64 + 0.5).min(d[a].saturating_sub(1) as f64) * volume.spacing[a]);
        let box_centre = [0, 1, 2].map(|a| 0.5 * (lo_w[a] + hi_w[a]));
        let half_diag = 0.5 * dot([0, 1, 2].map(|a| hi_w[a] - lo_w[a]), [0, 1, 2].map(|a| hi_w[a] - lo_w[a])).sqrt();
        let radius = half_diag.max(1e-9) + 2.0 * min_spacing;
        let (centre_world, half_extent) = match framed {
            Some(rows) if !rows.rows.is_empty() => {
                // The framed voxels' extent on the image plane: each row's two ends projected (a
                // projection is linear along a row), grown by a voxel's half width seen along `right`
                // and `up`. Centred on that extent, the larger side fitted.
                let sp = volume.spacing;
                let half_voxel = |v: [f64; 3]| 0.5 * (0..3).map(|a| (v[a] * sp[a]).abs()).sum::<f64>();
                let (hr, hu) = (half_voxel(right), half_voxel(up));
                let (mut r0, mut r1, mut u0, mut u1) =
                    (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
                for &[x0, x1, y, z] in &rows.rows {
                    for x in [x0, x1] {
                        let p = [x as f64 * sp[0], y as f64 * sp[1], z as f64 * sp[2]];
                        let p = [0, 1, 2].map(|a| p[a] - box_centre[a]);
                        let (r, u) = (dot(p, right), dot(p, up));
                        (r0, r1, u0, u1) = (r0.min(r - hr), r1.max(r + hr), u0.min(u - hu), u1.max(u + hu));
                    }
                }
                let (cr, cu) = (0.5 * (r0 + r1), 0.5 * (u0 + u1));
                let centre = [0, 1, 2].map(|a| box_centre[a] + cr * right[a] + cu * up[a]);
                // 4% margin; the vertical half extent of the image is `half_extent · aspect` (height/width).
                let half = (0.5 * (r1 - r0)).max(0.5 * (u1 - u0) / aspect.max(1e-6)).max(min_spacing) * 1.04;
                (centre, half / zoom)
            }
            _ => (box_centre, radius / zoom),
        };
        // Clip to the box grown by `reach` (interpolation reaches that far), within the grid.
        let clip_lo = [0, 1, 2].map(|a| (lo[a] as f64 - reach).max(0.0));
        let clip_hi = [0, 1, 2].map(|a| (hi[a] as f64 + reach).min(d[a].saturating_sub(1) as f64));
        let diagonal = volume.dims.iter().map(|&d| ((d.max(1) - 1) as f64).powi(2)).sum::<f64>().sqrt();
        let length = dir.iter().map(|v| v * v).sum::<f64>().sqrt();
        // With spacings at most MAX_ANISOTROPY apart (the readers' check) `length ≥ step / MAX_ANISOTROPY`,
        // so the second bound never cuts a ray of a valid volume; it stops one whose spacings are extreme.
        let max_steps = (diagonal / length).min(crate::volume::MAX_ANISOTROPY * diagonal / step).ceil() + 2.0;
        let max_steps = if max_steps.is_finite() { max_steps.min(MAX_RAY_STEPS) } else { MAX_RAY_STEPS };
        let sp = volume.spacing;
        let view_index = [0, 1, 2].map(|a| (view_world[a] / sp[a]) as f32);
        let light_index = [0, 1, 2].map(|a| (light_world[a] / sp[a]) as f32);
        let inv_spacing2 = [0, 1, 2].map(|a| (1.0 / (sp[a] * sp[a])) as f32);
        View {
            dir,
            view_world,
            right,
            up,
            half_extent,
            centre_world,
            radius,
            max_steps,
            view_index,
            light_index,
            inv_spacing2,
            clip_lo,
            clip_hi,
        }
    }
}
