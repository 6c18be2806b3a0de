//! The raycaster: orthographic rays through the volume, trilinear, nearest or pre-classified (label)
//! sampling, a spectral transfer function of materials (value range → opacity), front-to-back
//! emission–absorption compositing under a flat white light with a scalar diffuse shading term, early
//! ray termination and empty-space skipping from min/max bricks (both switchable for benchmarking),
//! rayon over tiles.
//!
//! Sampling quality (each switchable in [`RaycastOptions`], costs in `metamer bench render`):
//! - **jitter**: every ray starts a fraction of a step further in, given by interleaved gradient noise
//!   of the pixel (deterministic, so frames are reproducible). It turns the wood-grain banding of
//!   fixed-phase sampling into fine, unstructured noise that supersampling (`--ss 2`) averages away.
//! - **opacity correction**: a material's opacity is given per voxel step; a step of `s` voxels uses
//!   `1 − (1 − α)^s`, so changing the step does not change how dense a material looks.
//! - **smooth gradients**: shading normals are central differences of the interpolated field (value
//!   for CT, total opacity for label volumes) one voxel either side, which is the gradient of a
//!   smoothed field: continuous across voxel cells, so no faceted terraces.
//!   They come from a per-voxel gradient grid built once per raycast (`GradientGrid`, `i16`, 6 bytes a
//!   voxel), interpolated trilinearly at shaded samples only.
//! - **pre-classified interpolation** ([`Interpolation::Labels`]): for label volumes each of the eight
//!   voxels around a sample is classified first and the materials' opacities are interpolated
//!   trilinearly, so label boundaries are smooth surfaces instead of voxel staircases.
//!
//! Shading is a scalar per sample (`ambient + (1 − ambient)·max(n·l, 0)`, headlight or a fixed key
//! light above left of the eye, or 1 for the seed's unshaded look, [`Shading`]). It multiplies the
//! material's weight, never its spectrum, so the image stays linear in the materials' colours and
//! post-illumination stays exact.
//!
//! A material with `absorbs = false` ([`MaterialClass::absorbs`]) is emissive only: it adds its colour
//! but does not attenuate what lies behind it. By default every material absorbs, as emission–absorption
//! compositing does: a material whose colour is black under the current light (a metameric black) still
//! darkens what is behind it. Emissive-only materials keep the one raycast per view (weights stay
//! linear); an opacity that followed the material's luminance under the dial light would instead need
//! one raycast per frame, which is why it is not offered.
//!
//! Compositing is linear in colour, so the raycaster accumulates, per pixel, each material's
//! composited weight `Σ T·α·shade` (a one-hot "colour" per material). [`MaterialWeights::project`]
//! then turns these into any colour representation — m factor-model coefficients `B⁺S`, the 31 samples
//! of S, or reflectance RGB — exactly as if those colours had been composited along the ray, so the
//! three render modes share one raycast.

use crate::volume::Volume;
use rayon::prelude::*;

/// How samples between voxel centres are reconstructed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Interpolation {
    /// Trilinear interpolation of values (continuous data such as CT).
    #[default]
    Trilinear,
    /// The nearest voxel's value (label volumes such as the frog tissues, where blending labels is
    /// meaningless).
    Nearest,
    /// Pre-classified trilinear: the eight voxels around a sample are classified into materials first
    /// and the materials' opacities are interpolated (label volumes without voxel staircases).
    Labels,
}

/// How the scalar shading term of a sample is formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Shading {
    /// Diffuse light from a fixed key light above left of the eye, plus ambient.
    #[default]
    Key,
    /// Diffuse light from the eye (`|n·v|`), plus ambient.
    Headlight,
    /// No shading (shade = 1): the seed's unshaded emission–absorption look.
    Unshaded,
}

/// Where shading normals come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Gradient {
    /// Central differences of the interpolated field one voxel either side (a smoothed field).
    #[default]
    Smooth,
    /// The gradient of the trilinear cell the sample lies in (piecewise, faceted).
    Cell,
}

/// One material of the transfer function: the voxel values it covers and its opacity per voxel step.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialClass {
    /// Inclusive value range in the volume's units.
    pub range: [f32; 2],
    /// Opacity per step of one voxel, in [0, 1].
    pub opacity: f32,
    /// False for an emissive-only material: it adds its colour without attenuating the ray.
    pub absorbs: bool,
}

impl MaterialClass {
    /// An absorbing material (the emission–absorption default).
    pub fn new(range: [f32; 2], opacity: f32) -> MaterialClass {
        MaterialClass { range, opacity, absorbs: true }
    }
}

/// Most materials a transfer function may hold.
pub const MAX_MATERIALS: usize = 64;

/// View direction and framing of the orthographic camera. Azimuth turns about the volume's z axis
/// (0° looks along +y), elevation lifts the camera towards +z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    /// 1 frames the view's target (see `fit`) with a small margin; larger values magnify.
    pub zoom: f64,
    /// Frame the bounding box of the voxels that belong to a material (centred on its projection),
    /// instead of the bounding sphere of the whole grid.
    pub fit_materials: bool,
}

impl Default for Camera {
    fn default() -> Self {
        Camera { azimuth_deg: 30.0, elevation_deg: 20.0, zoom: 1.0, fit_materials: true }
    }
}

/// Raycasting settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RaycastOptions {
    pub width: usize,
    pub height: usize,
    /// Distance between samples in voxels (of the smallest spacing).
    pub step: f64,
    /// Weight of the shading-independent part: `shade = ambient + (1 − ambient)·max(n·l, 0)`.
    pub ambient: f64,
    pub shading: Shading,
    pub gradient: Gradient,
    /// Start every ray a pixel-dependent fraction of a step in (interleaved gradient noise).
    pub jitter: bool,
    pub interpolation: Interpolation,
    /// Stop a ray once its transmittance falls below `termination_transmittance`.
    pub early_termination: bool,
    /// Transmittance below which a ray stops (the remaining contribution is at most this share).
    pub termination_transmittance: f64,
    /// Skip bricks whose value range holds no material.
    pub empty_space_skipping: bool,
    /// Edge of a skipping brick in voxels (rounded up to a power of two).
    pub brick_size: usize,
}

impl Default for RaycastOptions {
    fn default() -> Self {
        RaycastOptions {
            width: 256,
            height: 256,
            step: 1.0,
            ambient: 0.3,
            shading: Shading::Key,
            gradient: Gradient::Smooth,
            jitter: true,
            interpolation: Interpolation::Trilinear,
            early_termination: true,
            termination_transmittance: 0.01,
            empty_space_skipping: true,
            brick_size: 8,
        }
    }
}

/// Per pixel, the composited weight of every material (row-major pixels, materials innermost).
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialWeights {
    pub width: usize,
    pub height: usize,
    pub materials: usize,
    pub data: Vec<f32>,
}

/// A multi-channel image: per pixel `channels` values (row-major pixels, channels innermost).
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelImage {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub data: Vec<f32>,
}

impl MaterialWeights {
    /// Composite colour per pixel given each material's colour vector (all of the same length K):
    /// `c = Σ_materials w · colour`.
    pub fn project(&self, colours: &[Vec<f32>]) -> ChannelImage {
        let k = colours.first().map_or(0, Vec::len);
        debug_assert_eq!(colours.len(), self.materials);
        let mut data = vec![0f32; self.width * self.height * k];
        if k > 0 && self.materials > 0 {
            data.par_chunks_mut(k * 1024).zip(self.data.par_chunks(self.materials * 1024)).for_each(|(out, w)| {
                for (px, wpx) in out.chunks_exact_mut(k).zip(w.chunks_exact(self.materials)) {
                    for (wm, col) in wpx.iter().zip(colours) {
                        if *wm != 0.0 {
                            for (o, c) in px.iter_mut().zip(col) {
                                *o += wm * c;
                            }
                        }
                    }
                }
            });
        }
        ChannelImage { width: self.width, height: self.height, channels: k, data }
    }
}

/// Counters of one raycast.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RaycastStats {
    /// Samples reconstructed (value looked up).
    pub samples: u64,
    /// Steps jumped over inside empty bricks.
    pub skipped: u64,
    /// Rays stopped early by low transmittance.
    pub terminated: u64,
}

const LUT_BINS: usize = 4096;

/// The transfer function as lookup tables over the volume's value range, and per-brick emptiness.
struct Classifier {
    lo: f32,
    inv_bin: f32,
    /// Material index + 1 per bin (0 = nothing).
    material: Vec<u8>,
    /// Step-corrected opacity per bin.
    alpha: Vec<f32>,
    /// Prefix count of occupied bins.
    occupied_prefix: Vec<u32>,
    /// Per material: whether it attenuates the ray.
    absorbs: Vec<bool>,
}

impl Classifier {
    fn new(volume: &Volume, materials: &[MaterialClass], step: f64) -> Classifier {
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
        Classifier { lo, inv_bin: 1.0 / bin_width, material, alpha, occupied_prefix, absorbs }
    }

    /// Step-corrected opacity of a value (0 outside every material).
    #[inline(always)]
    fn alpha_of(&self, v: f32) -> f32 {
        self.alpha[self.bin(v)]
    }

    #[inline(always)]
    fn bin(&self, v: f32) -> usize {
        (((v - self.lo) * self.inv_bin + 0.5) as usize).min(LUT_BINS - 1)
    }

    /// True when some value in `[a, b]` belongs to a material.
    fn any_in(&self, a: f32, b: f32) -> bool {
        let (ba, bb) = (self.bin(a), self.bin(b));
        self.occupied_prefix[bb + 1] > self.occupied_prefix[ba]
    }
}

/// Per-brick min/max of voxel values (each brick also covers the one-voxel seam to its neighbours, so
/// every trilinear cell starting inside a brick is bounded by it).
pub struct BrickMap {
    /// Edge in voxels, a power of two.
    pub size: usize,
    /// log2 of `size`.
    pub shift: u32,
    pub counts: [usize; 3],
    pub min: Vec<f32>,
    pub max: Vec<f32>,
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

/// The smooth gradient precomputed per voxel: central differences of the field shading normals come
/// from (`h` voxels either side: values for trilinear sampling, step-corrected total opacity for the label
/// modes), stored as `i16` triples scaled by `scale` (6 bytes a voxel: 50 MB for a 256×256×128 volume).
/// Shifting a trilinear interpolant by whole voxels keeps the sample's fractional position, so the
/// trilinear interpolation of this grid is the central difference of the interpolated field — the same
/// normal as six interpolated lookups, for one cell fetch. Built once per raycast (the transfer function
/// enters through the label modes' opacities), in parallel over z slices.
struct GradientGrid {
    data: Vec<[i16; 3]>,
    /// Field units per stored unit.
    scale: f32,
}

impl GradientGrid {
    fn new(volume: &Volume, classifier: &Classifier, interpolation: Interpolation) -> GradientGrid {
        let d = volume.dims;
        let labels = interpolation != Interpolation::Trilinear;
        let h = if labels { 2 } else { 1 };
        let opacities: Vec<f32>;
        let (field, span) = if labels {
            opacities = volume.data.par_iter().map(|v| classifier.alpha_of(*v)).collect();
            (opacities.as_slice(), 1.0f32)
        } else {
            let [lo, hi] = volume.value_range;
            (volume.data.as_slice(), (hi - lo).abs())
        };
        // A central difference is at most the field's span over 2h.
        let den = 2.0 * h as f32;
        let bound = span / den;
        let scale = if bound > 0.0 && bound.is_finite() { bound / f32::from(i16::MAX) } else { 1.0 };
        let inv = 1.0 / scale;
        let q = |c: f32| (c * inv).round().clamp(-f32::from(i16::MAX), f32::from(i16::MAX)) as i16;
        let at = |x: usize, y: usize, z: usize| field[x + d[0] * (y + d[1] * z)];
        let mut data = vec![[0i16; 3]; field.len()];
        data.par_chunks_mut(d[0] * d[1]).enumerate().for_each(|(z, slice)| {
            let (z0, z1) = (z.saturating_sub(h), (z + h).min(d[2] - 1));
            for y in 0..d[1] {
                let (y0, y1) = (y.saturating_sub(h), (y + h).min(d[1] - 1));
                for x in 0..d[0] {
                    let (x0, x1) = (x.saturating_sub(h), (x + h).min(d[0] - 1));
                    slice[x + d[0] * y] = [
                        q((at(x1, y, z) - at(x0, y, z)) / den),
                        q((at(x, y1, z) - at(x, y0, z)) / den),
                        q((at(x, y, z1) - at(x, y, z0)) / den),
                    ];
                }
            }
        });
        GradientGrid { data, scale }
    }
}

/// Index-space bounding box (inclusive voxel indices) of the voxels whose value belongs to a material,
/// or None when no voxel does.
fn material_bounds(volume: &Volume, classifier: &Classifier) -> Option<([usize; 3], [usize; 3])> {
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

/// Volume-space geometry of one view.
struct View {
    /// Ray direction in index space, scaled to one step.
    dir: [f64; 3],
    /// View direction in world space (unit), for shading.
    view_world: [f64; 3],
    /// Direction towards the shading light in world space (unit).
    light_world: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
    half_extent: f64,
    /// The world point the image centre looks through.
    centre_world: [f64; 3],
    /// Rays start this far before `centre_world` along the view direction.
    radius: f64,
    /// The most steps one ray takes: enough to cross the box's index-space diagonal at `dir`'s length
    /// (so no ray inside the box is cut short), at most `MAX_ANISOTROPY × diagonal / step` and never more
    /// than [`MAX_RAY_STEPS`], whatever the spacings (a spacing of 1e-308 beside 1 cannot make a ray spin).
    max_steps: f64,
    /// Index-space box the rays are clipped to.
    clip_lo: [f64; 3],
    clip_hi: [f64; 3],
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
    fn new(
        volume: &Volume,
        camera: &Camera,
        step: f64,
        shading: Shading,
        aspect: f64,
        bounds: Option<([usize; 3], [usize; 3])>,
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
        let (lo, hi) = if camera.fit_materials { bounds.unwrap_or(whole) } else { whole };
        // The box in world space (voxel centres at index × spacing, grown by the half voxel an
        // interpolated surface reaches past them), its centre and half diagonal.
        let lo_w = [0, 1, 2].map(|a| (lo[a] as f64 - 0.5).max(0.0) * volume.spacing[a]);
        let hi_w = [0, 1, 2].map(|a| (hi[a] as f64 + 0.5).min(d[a].saturating_sub(1) as f64) * volume.spacing[a]);
        let box_centre = [0, 1, 2].map(|a| 0.5 * (lo_w[a] + hi_w[a]));
        let half_diag = 0.5 * dot([0, 1, 2].map(|a| hi_w[a] - lo_w[a]), [0, 1, 2].map(|a| hi_w[a] - lo_w[a])).sqrt();
        let radius = half_diag.max(1e-9) + 2.0 * min_spacing;
        let (centre_world, half_extent) = if camera.fit_materials {
            // Project the eight corners onto the image plane: centre on their extent, fit the larger side.
            let (mut r0, mut r1, mut u0, mut u1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
            for c in 0..8 {
                let p = [0, 1, 2].map(|a| if c >> a & 1 == 1 { hi_w[a] } else { lo_w[a] } - box_centre[a]);
                let (r, u) = (dot(p, right), dot(p, up));
                (r0, r1, u0, u1) = (r0.min(r), r1.max(r), u0.min(u), u1.max(u));
            }
            let (cr, cu) = (0.5 * (r0 + r1), 0.5 * (u0 + u1));
            let centre = [0, 1, 2].map(|a| box_centre[a] + cr * right[a] + cu * up[a]);
            // 4% margin; the vertical half extent of the image is `half_extent · aspect` (height/width).
            let half = (0.5 * (r1 - r0)).max(0.5 * (u1 - u0) / aspect.max(1e-6)).max(min_spacing) * 1.04;
            (centre, half / zoom)
        } else {
            (box_centre, radius / zoom)
        };
        // Clip to the box grown by one voxel (interpolation reaches that far), within the grid.
        let clip_lo = [0, 1, 2].map(|a| (lo[a] as f64 - 1.0).max(0.0));
        let clip_hi = [0, 1, 2].map(|a| (hi[a] as f64 + 1.0).min(d[a].saturating_sub(1) as f64));
        let diagonal = volume.dims.iter().map(|&d| ((d.max(1) - 1) as f64).powi(2)).sum::<f64>().sqrt();
        let length = dir.iter().map(|v| v * v).sum::<f64>().sqrt();
        // With spacings at most MAX_ANISOTROPY apart (the readers' check) `length ≥ step / MAX_ANISOTROPY`,
        // so the second bound never cuts a ray of a valid volume; it stops one whose spacings are extreme.
        let max_steps = (diagonal / length).min(crate::volume::MAX_ANISOTROPY * diagonal / step).ceil() + 2.0;
        let max_steps = if max_steps.is_finite() { max_steps.min(MAX_RAY_STEPS) } else { MAX_RAY_STEPS };
        View { dir, view_world, light_world, right, up, half_extent, centre_world, radius, max_steps, clip_lo, clip_hi }
    }
}

/// Raycast `volume` with the given materials. Returns per-pixel material weights and counters.
pub fn raycast(
    volume: &Volume,
    materials: &[MaterialClass],
    bricks: Option<&BrickMap>,
    camera: &Camera,
    options: &RaycastOptions,
) -> (MaterialWeights, RaycastStats) {
    let n_mat = materials.len().min(MAX_MATERIALS);
    let materials = &materials[..n_mat];
    let (w, h) = (options.width.max(1), options.height.max(1));
    let step = options.step.clamp(0.05, 8.0);
    let classifier = Classifier::new(volume, materials, step);
    let own_bricks;
    let bricks = if options.empty_space_skipping {
        Some(match bricks {
            Some(b) => b,
            None => {
                own_bricks = BrickMap::new(volume, options.brick_size);
                &own_bricks
            }
        })
    } else {
        None
    };
    let empty: Vec<bool> = bricks
        .map(|b| b.min.iter().zip(&b.max).map(|(lo, hi)| !classifier.any_in(*lo, *hi)).collect())
        .unwrap_or_default();
    let bounds = if camera.fit_materials { material_bounds(volume, &classifier) } else { None };
    let view = View::new(volume, camera, step, options.shading, h as f64 / w as f64, bounds);
    let grid = (options.shading != Shading::Unshaded && options.gradient == Gradient::Smooth)
        .then(|| GradientGrid::new(volume, &classifier, options.interpolation));
    let ctx = RayContext {
        volume,
        classifier: &classifier,
        grid: grid.as_ref(),
        bricks: bricks.map(|b| (b, empty.as_slice())),
        view: &view,
        options,
        n_mat,
        width: w,
        height: h,
    };

    const TILE: usize = 16;
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let tiles: Vec<(Vec<f32>, RaycastStats)> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|t| {
            let (tx, ty) = (t % tiles_x, t / tiles_x);
            let mut stats = RaycastStats::default();
            let mut buf = vec![0f32; TILE * TILE * n_mat];
            for j in 0..TILE {
                let py = ty * TILE + j;
                if py >= h {
                    break;
                }
                for i in 0..TILE {
                    let px = tx * TILE + i;
                    if px >= w {
                        break;
                    }
                    let off = (j * TILE + i) * n_mat;
                    ctx.trace(px, py, &mut buf[off..off + n_mat], &mut stats);
                }
            }
            (buf, stats)
        })
        .collect();
    let mut data = vec![0f32; w * h * n_mat];
    let mut stats = RaycastStats::default();
    for (t, (buf, s)) in tiles.iter().enumerate() {
        stats.samples += s.samples;
        stats.skipped += s.skipped;
        stats.terminated += s.terminated;
        let (tx, ty) = (t % tiles_x, t / tiles_x);
        for j in 0..TILE {
            let py = ty * TILE + j;
            if py >= h {
                break;
            }
            let cols = TILE.min(w - tx * TILE);
            let src = &buf[j * TILE * n_mat..(j * TILE + cols) * n_mat];
            let dst0 = (py * w + tx * TILE) * n_mat;
            data[dst0..dst0 + cols * n_mat].copy_from_slice(src);
        }
    }
    (MaterialWeights { width: w, height: h, materials: n_mat, data }, stats)
}

/// Interleaved gradient noise (Jimenez 2014) of a pixel: a deterministic value in [0, 1) whose
/// neighbours differ strongly, so ray-start offsets show no structure at 1:1.
#[inline(always)]
pub fn interleaved_gradient_noise(px: usize, py: usize) -> f64 {
    let f = 0.06711056 * px as f64 + 0.00583715 * py as f64;
    (52.9829189 * f.fract()).fract()
}

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

    /// Trilinear weight of corner `c` (`x + 2y + 4z`).
    #[inline(always)]
    fn weight(&self, c: usize) -> f32 {
        let [fx, fy, fz] = self.f;
        let pick = |bit: bool, f: f32| if bit { f } else { 1.0 - f };
        pick(c & 1 == 1, fx) * pick(c & 2 == 2, fy) * pick(c & 4 == 4, fz)
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

struct RayContext<'a> {
    volume: &'a Volume,
    classifier: &'a Classifier,
    /// The precomputed smooth gradient (None when unshaded or with cell gradients).
    grid: Option<&'a GradientGrid>,
    bricks: Option<(&'a BrickMap, &'a [bool])>,
    view: &'a View,
    options: &'a RaycastOptions,
    n_mat: usize,
    width: usize,
    height: usize,
}

impl RayContext<'_> {
    #[inline(always)]
    fn voxel(&self, x: usize, y: usize, z: usize) -> f32 {
        let d = self.volume.dims;
        self.volume.data[x + d[0] * (y + d[1] * z)]
    }

    /// Where index-space point p (clamped into [0, dims−1]) falls: the index of its trilinear cell's first
    /// voxel, the strides to the next voxel along x, y and z (0 along an axis of one voxel) and the
    /// fractions along each axis.
    #[inline(always)]
    fn locate(&self, p: [f64; 3]) -> (usize, [usize; 3], [f32; 3]) {
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
        (b, [sx, sy, sz], f)
    }

    /// The trilinear cell around index-space point p (clamped into [0, dims−1]).
    #[inline(always)]
    fn cell(&self, p: [f64; 3]) -> Cell {
        let (b, [sx, sy, sz], f) = self.locate(p);
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

    /// The field shading normals come from at p: the interpolated value (trilinear mode) or the
    /// interpolated total opacity (label modes, where values are names rather than densities).
    #[inline(always)]
    fn field(&self, p: [f64; 3]) -> f32 {
        let mut c = self.cell(p);
        if self.options.interpolation != Interpolation::Trilinear {
            for v in &mut c.v {
                *v = self.classifier.alpha_of(*v);
            }
        }
        c.value()
    }

    /// The smooth gradient at p: the trilinear interpolation of the precomputed per-voxel central
    /// differences (the cell found by [`RayContext::locate`], as for [`RayContext::cell`]).
    #[inline(always)]
    fn grid_gradient(&self, p: [f64; 3]) -> [f32; 3] {
        let Some(grid) = self.grid else { return [0.0; 3] };
        let (b, [sx, sy, sz], f) = self.locate(p);
        let g = &grid.data;
        let corners = [b, b + sx, b + sy, b + sy + sx, b + sz, b + sz + sx, b + sz + sy, b + sz + sy + sx];
        let [fx, fy, fz] = f;
        let w = [
            (1.0 - fx) * (1.0 - fy) * (1.0 - fz),
            fx * (1.0 - fy) * (1.0 - fz),
            (1.0 - fx) * fy * (1.0 - fz),
            fx * fy * (1.0 - fz),
            (1.0 - fx) * (1.0 - fy) * fz,
            fx * (1.0 - fy) * fz,
            (1.0 - fx) * fy * fz,
            fx * fy * fz,
        ];
        let mut out = [0f32; 3];
        for (c, wc) in corners.iter().zip(w) {
            let v = g[*c];
            out[0] += wc * f32::from(v[0]);
            out[1] += wc * f32::from(v[1]);
            out[2] += wc * f32::from(v[2]);
        }
        out.map(|c| c * grid.scale)
    }

    /// Shading of the sample at p: `ambient + (1 − ambient)·max(n·l, 0)` with the normal turned to
    /// face the eye; 1 when unshaded or where the gradient vanishes.
    #[inline(always)]
    fn shade(&self, p: [f64; 3], cell: Option<&Cell>) -> f32 {
        if self.options.shading == Shading::Unshaded {
            return 1.0;
        }
        let g = match self.options.gradient {
            Gradient::Cell => match cell {
                Some(c) => c.gradient(),
                None => self.cell(p).gradient(),
            },
            Gradient::Smooth if self.grid.is_some() => self.grid_gradient(p),
            Gradient::Smooth => {
                // Label fields are steps between slices, so they are differenced over a wider stencil.
                let h = if self.options.interpolation == Interpolation::Trilinear { 1.0 } else { 2.0 };
                let mut g = [0f32; 3];
                for (a, ga) in g.iter_mut().enumerate() {
                    let (mut lo, mut hi) = (p, p);
                    lo[a] -= h;
                    hi[a] += h;
                    *ga = (self.field(hi) - self.field(lo)) / (2.0 * h as f32);
                }
                g
            }
        };
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

    /// March the ray of pixel (px, py), accumulating material weights into `out`.
    fn trace(&self, px: usize, py: usize, out: &mut [f32], stats: &mut RaycastStats) {
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
        let absorbs = &self.classifier.absorbs;
        while k + jitter <= t1 {
            let t = k + jitter;
            let p = [origin[0] + t * dir[0], origin[1] + t * dir[1], origin[2] + t * dir[2]];
            if let Some((bm, empty)) = self.bricks {
                let b = [0, 1, 2].map(|a| ((p[a].max(0.0) as usize) >> bm.shift).min(bm.counts[a] - 1));
                let bi = b[0] + bm.counts[0] * (b[1] + bm.counts[1] * b[2]);
                if empty[bi] {
                    // Jump to the first sample past this brick's far faces.
                    let mut exit = f64::INFINITY;
                    for a in 0..3 {
                        if dir[a] > 1e-12 {
                            exit = exit.min((((b[a] + 1) * bm.size) as f64 - origin[a]) / dir[a]);
                        } else if dir[a] < -1e-12 {
                            exit = exit.min(((b[a] * bm.size) as f64 - origin[a]) / dir[a]);
                        }
                    }
                    let next = (exit - jitter).floor() + 1.0;
                    let next = if next > k { next } else { k + 1.0 };
                    stats.skipped += (next - k) as u64;
                    k = next;
                    continue;
                }
            }
            stats.samples += 1;
            let absorbed = match self.options.interpolation {
                Interpolation::Trilinear | Interpolation::Nearest => {
                    let (v, cell) = if self.options.interpolation == Interpolation::Trilinear {
                        let c = self.cell(p);
                        (c.value(), Some(c))
                    } else {
                        (self.nearest(p), None)
                    };
                    let bin = self.classifier.bin(v);
                    let m = usize::from(self.classifier.material[bin]);
                    if m == 0 {
                        0.0
                    } else {
                        let alpha = self.classifier.alpha[bin];
                        out[m - 1] += transmittance * alpha * self.shade(p, cell.as_ref());
                        if absorbs[m - 1] { alpha } else { 0.0 }
                    }
                }
                Interpolation::Labels => {
                    let c = self.cell(p);
                    let (mut mats, mut wts, mut n) = ([0usize; 8], [0f32; 8], 0usize);
                    for corner in 0..8 {
                        let bin = self.classifier.bin(c.v[corner]);
                        let m = usize::from(self.classifier.material[bin]);
                        let w = c.weight(corner) * self.classifier.alpha[bin];
                        if m == 0 || w <= 0.0 {
                            continue;
                        }
                        match mats[..n].iter().position(|x| *x == m) {
                            Some(i) => wts[i] += w,
                            None => {
                                mats[n] = m;
                                wts[n] = w;
                                n += 1;
                            }
                        }
                    }
                    if n == 0 {
                        0.0
                    } else {
                        let shade = self.shade(p, Some(&c));
                        let mut absorbed = 0.0;
                        for (m, w) in mats[..n].iter().zip(&wts[..n]) {
                            out[m - 1] += transmittance * w * shade;
                            if absorbs[m - 1] {
                                absorbed += w;
                            }
                        }
                        absorbed
                    }
                }
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn cube(n: usize, inner: f32) -> Volume {
        let mut data = vec![0f32; n * n * n];
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let c = |v: usize| v >= n / 4 && v < 3 * n / 4;
                    if c(x) && c(y) && c(z) {
                        data[x + n * (y + n * z)] = inner;
                    }
                }
            }
        }
        Volume::new(Path::new("cube"), [n, n, n], [1.0; 3], data).unwrap()
    }

    #[test]
    fn opaque_cube_covers_its_silhouette_and_weights_stay_within_one() {
        let vol = cube(32, 100.0);
        let mats = [MaterialClass::new([50.0, 150.0], 0.9)];
        let opts = RaycastOptions { width: 64, height: 64, shading: Shading::Headlight, ..Default::default() };
        let cam = Camera { azimuth_deg: 0.0, elevation_deg: 0.0, ..Camera::default() };
        let (w, stats) = raycast(&vol, &mats, None, &cam, &opts);
        assert!(stats.samples > 0 && stats.terminated > 0);
        // The centre pixel sees the cube face-on: weight close to 1 (shade 1, opaque after a few steps).
        let centre = w.data[32 * 64 + 32];
        assert!(centre > 0.95 && centre <= 1.0, "{centre}");
        // A corner pixel misses it.
        assert_eq!(w.data[0], 0.0);
        assert!(w.data.iter().all(|v| (0.0..=1.0 + 1e-6).contains(v)));
    }

    #[test]
    fn skipping_and_termination_switches_keep_the_image() {
        let vol = crate::volume::generate::engine_like(48);
        let mats = [
            MaterialClass::new([18.0, 75.0], 0.05),
            MaterialClass::new([105.0, 175.0], 0.2),
            MaterialClass::new([200.0, 255.0], 0.8),
        ];
        let cam = Camera::default();
        let base = RaycastOptions { width: 48, height: 48, ..Default::default() };
        let (all_on, s_on) = raycast(&vol, &mats, None, &cam, &base);
        let no_skip = RaycastOptions { empty_space_skipping: false, ..base.clone() };
        let (a, s_a) = raycast(&vol, &mats, None, &cam, &no_skip);
        // Skipping only jumps over bricks with no material: identical samples where it matters
        // (tolerance: float summation order is the same, so differences are at rounding level).
        let max_diff = all_on.data.iter().zip(&a.data).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max);
        assert!(max_diff < 1e-5, "skipping changed the image by {max_diff}");
        assert!(s_on.skipped > 0 && s_on.samples < s_a.samples, "{s_on:?} {s_a:?}");
        // Termination leaves out at most the remaining transmittance (1%) per ray.
        let none = RaycastOptions { empty_space_skipping: false, early_termination: false, ..base };
        let (b, _) = raycast(&vol, &mats, None, &cam, &none);
        for (px_a, px_b) in a.data.chunks(3).zip(b.data.chunks(3)) {
            let (sa, sb): (f32, f32) = (px_a.iter().sum(), px_b.iter().sum());
            assert!((sb - sa) >= -1e-5 && (sb - sa) <= 0.01 + 1e-5, "{sa} vs {sb}");
        }
    }

    /// A 64³ volume with a small dense cube in one corner region.
    fn off_centre_cube() -> Volume {
        let n = 64;
        let mut data = vec![0f32; n * n * n];
        for z in 36..52 {
            for y in 8..20 {
                for x in 40..56 {
                    data[x + n * (y + n * z)] = 100.0;
                }
            }
        }
        Volume::new(Path::new("off"), [n, n, n], [1.0; 3], data).unwrap()
    }

    /// Coverage-weighted centroid of the image, in pixels, and the covered pixel count.
    fn centroid(w: &MaterialWeights) -> ((f64, f64), usize) {
        let (mut sx, mut sy, mut s, mut n) = (0.0, 0.0, 0.0, 0);
        for y in 0..w.height {
            for x in 0..w.width {
                let v: f32 = w.data[(y * w.width + x) * w.materials..][..w.materials].iter().sum();
                if v > 0.0 {
                    n += 1;
                }
                sx += f64::from(v) * x as f64;
                sy += f64::from(v) * y as f64;
                s += f64::from(v);
            }
        }
        ((sx / s, sy / s), n)
    }

    #[test]
    fn camera_fits_and_centres_the_materials_not_the_grid() {
        let vol = off_centre_cube();
        let mats = [MaterialClass::new([50.0, 150.0], 0.5)];
        let opts = RaycastOptions { width: 64, height: 64, ..Default::default() };
        // Looking along +y: image x is world x (the cube sits at x 40..56 of 0..63), image up is z.
        let fit = Camera { azimuth_deg: 0.0, elevation_deg: 0.0, ..Camera::default() };
        let grid = Camera { fit_materials: false, ..fit };
        let ((fx, fy), fit_n) = centroid(&raycast(&vol, &mats, None, &fit, &opts).0);
        let ((gx, gy), grid_n) = centroid(&raycast(&vol, &mats, None, &grid, &opts).0);
        // Fitted: centred within 3 px and much larger than when the whole grid is framed.
        assert!((fx - 31.5).abs() < 3.0 && (fy - 31.5).abs() < 3.0, "fitted centroid ({fx}, {fy})");
        assert!((gx - 31.5).abs() > 5.0 || (gy - 31.5).abs() > 5.0, "grid framing is off-centre ({gx}, {gy})");
        assert!(fit_n > 3 * grid_n, "fitted covers {fit_n} px, grid framing {grid_n}");
    }

    #[test]
    fn jitter_is_deterministic_and_spreads_ray_starts() {
        let vol = crate::volume::generate::engine_like(32);
        let mats = [MaterialClass::new([105.0, 175.0], 0.2)];
        let opts = RaycastOptions { width: 32, height: 32, ..Default::default() };
        let cam = Camera::default();
        let (a, _) = raycast(&vol, &mats, None, &cam, &opts);
        let (b, _) = raycast(&vol, &mats, None, &cam, &opts);
        assert_eq!(a, b, "the same pixel must jitter the same way");
        let (c, _) = raycast(&vol, &mats, None, &cam, &RaycastOptions { jitter: false, ..opts });
        assert_ne!(a, c, "jitter moved no sample");
        let offs: Vec<f64> = (0..16).flat_map(|y| (0..16).map(move |x| interleaved_gradient_noise(x, y))).collect();
        assert!(offs.iter().all(|o| (0.0..1.0).contains(o)));
        // Spread over the whole step: every tenth of [0, 1) is hit by some pixel of a 16×16 block.
        for d in 0..10 {
            assert!(offs.iter().any(|o| (*o * 10.0) as usize == d), "no offset in tenth {d}");
        }
    }

    #[test]
    fn emissive_only_material_hides_nothing_behind_it() {
        // Front slab (material 0) and back slab (material 1) along the view (+y at azimuth 0).
        let n = 32;
        let mut data = vec![0f32; n * n * n];
        for z in 8..24 {
            for y in 4..28 {
                for x in 8..24 {
                    data[x + n * (y + n * z)] = if y < 14 { 100.0 } else { 200.0 };
                }
            }
        }
        let vol = Volume::new(Path::new("slabs"), [n, n, n], [1.0; 3], data).unwrap();
        let cam = Camera { azimuth_deg: 0.0, elevation_deg: 0.0, ..Camera::default() };
        let opts =
            RaycastOptions { width: 16, height: 16, shading: Shading::Unshaded, jitter: false, ..Default::default() };
        let front = MaterialClass::new([50.0, 150.0], 0.3);
        let back = MaterialClass::new([150.5, 250.0], 0.3);
        let centre = |_: &MaterialWeights| (8 * 16 + 8) * 2;
        let (absorbing, _) = raycast(&vol, &[front.clone(), back.clone()], None, &cam, &opts);
        let (emissive, _) =
            raycast(&vol, &[MaterialClass { absorbs: false, ..front.clone() }, back.clone()], None, &cam, &opts);
        let (alone, _) = raycast(&vol, &[MaterialClass::new([1000.0, 1001.0], 0.3), back], None, &cam, &opts);
        let c = centre(&absorbing);
        assert!(absorbing.data[c + 1] < 0.2 * alone.data[c + 1], "an absorbing front slab must hide the back");
        assert!((emissive.data[c + 1] - alone.data[c + 1]).abs() < 1e-5, "emissive front hid the back");
        // Not attenuated by itself either: its own weight is the plain sum of its step opacities.
        assert!(emissive.data[c] > absorbing.data[c], "{} vs {}", emissive.data[c], absorbing.data[c]);
    }

    #[test]
    fn label_interpolation_blends_opacity_smoothly_and_stays_bounded() {
        let vol = cube(32, 7.0);
        let mats = [MaterialClass::new([7.0, 7.0], 0.6)];
        let cam = Camera { azimuth_deg: 20.0, elevation_deg: 10.0, ..Camera::default() };
        let base = RaycastOptions { width: 64, height: 64, ..Default::default() };
        let (near, _) =
            raycast(&vol, &mats, None, &cam, &RaycastOptions { interpolation: Interpolation::Nearest, ..base.clone() });
        let (labels, _) =
            raycast(&vol, &mats, None, &cam, &RaycastOptions { interpolation: Interpolation::Labels, ..base });
        assert!(labels.data.iter().all(|v| (0.0..=1.0 + 1e-6).contains(v)));
        // Partial-coverage (edge) pixels: interpolated opacity gives many more distinct levels.
        let levels = |w: &MaterialWeights| {
            let mut v: Vec<u32> = w.data.iter().filter(|x| **x > 0.0).map(|x| (x * 1000.0) as u32).collect();
            v.sort_unstable();
            v.dedup();
            v.len()
        };
        assert!(levels(&labels) > levels(&near), "{} vs {}", levels(&labels), levels(&near));
    }

    #[test]
    fn projection_is_the_weighted_sum() {
        let w = MaterialWeights { width: 2, height: 1, materials: 2, data: vec![0.5, 0.25, 0.0, 1.0] };
        let img = w.project(&[vec![1.0, 2.0, 3.0], vec![4.0, 0.0, -1.0]]);
        assert_eq!(img.channels, 3);
        assert_eq!(img.data, vec![1.5, 1.0, 1.25, 4.0, 0.0, -1.0]);
    }
}
