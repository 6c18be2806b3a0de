//! The raycaster: orthographic rays through the volume, trilinear, nearest or smoothed-label
//! sampling, a spectral transfer function of materials (value range → opacity), front-to-back
//! emission–absorption compositing under a flat white light with a scalar diffuse shading term, early
//! ray termination and empty-space skipping from min/max bricks (both switchable for benchmarking; a ray
//! jumps over a whole group of 8³, 4³ or 2³ empty bricks at once where the group is all empty, value
//! modes), rayon over 16×16 pixel tiles.
//!
//! Files: this one holds the public types and [`raycast`] (setup and tiles); `classify` the transfer
//! function's lookup tables, the min/max [`BrickMap`] and the framed voxels (their runs along x, which
//! the camera projects to fit their silhouette); `view` the camera
//! geometry; `fields` the per-brick fields built on demand, capped, the block whose rays end soonest
//! evicted first (smooth gradients, smoothed label occupancy);
//! `march` one ray's sampling, shading and compositing.
//!
//! Sampling quality (each switchable in [`RaycastOptions`], costs in `metamer bench render`):
//! - **jitter**: every ray starts a fraction of a step further in, given by interleaved gradient noise
//!   of the pixel (deterministic, so frames are reproducible). It turns the wood-grain banding of
//!   fixed-phase sampling into fine, unstructured noise that supersampling (`--ss 2`) averages away.
//! - **opacity correction**: a material's opacity is given per voxel step; a step of `s` voxels uses
//!   `1 − (1 − α)^s`, so changing the step does not change how dense a material looks.
//! - **boundary refinement** (`refine`): a step whose two ends differ (another material, not both as
//!   thin as smoke, and the step after entering a dense one; for labels a boundary within reach of
//!   either end's cell) is composited as substeps of [`REFINED_STEP`] voxels, opacity corrected for
//!   their length. A surface or a plate about a step thick is then
//!   integrated finely wherever the jittered samples fall, instead of getting 0, 1 or 2 samples by the
//!   pixel's jitter (a fine dither on thin plates and rims); steps inside one material or in empty
//!   space keep one sample.
//! - **smooth gradients**: shading normals are central differences of the interpolated field (value
//!   for CT, opacity for nearest sampling, smoothed total opacity for labels) one voxel either side,
//!   which is the gradient of a smoothed field: continuous across voxel cells, so no faceted terraces.
//!   They are precomputed per voxel (`i16` triples) only in the bricks rays reach, each brick's block
//!   built the first time a ray needs it (at most [`RaycastOptions::field_cache`] bytes resident, the
//!   one whose rays end soonest evicted, rebuilt if needed again), and interpolated trilinearly at
//!   shaded samples only.
//! - **shape-based labels** ([`Interpolation::Labels`]): for label volumes each material gets, per
//!   brick reached, the signed distance to its boundary within each z slice (a 2D distance transform,
//!   clamped at [`LABEL_REACH`] voxels), smoothed by a small Gaussian ([`LABEL_SIGMA`] voxels,
//!   truncated at [`LABEL_RADIUS`]) in-plane and across slices, stored as `u16`; the marcher
//!   interpolates the distance trilinearly and only then turns it into an occupancy (a smoothstep
//!   [`LABEL_RAMP`] voxels wide) that scales the material's opacity. Between slices the contours blend
//!   into each other, so surfaces that run almost parallel to the slices (the frog's liver from above)
//!   are smooth ramps instead of one-slice terraces, and each material is shaded by its own distance
//!   gradient (`labels`).
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
    /// Shape-based labels: each material's signed distance to its boundary within every slice,
    /// smoothed a little and interpolated trilinearly, becomes an occupancy that scales the material's
    /// opacity (label volumes without voxel staircases or slice terraces).
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
    pub(crate) opacity: f32,
    /// False for an emissive-only material: it adds its colour without attenuating the ray.
    pub absorbs: bool,
    /// A transfer function over value *and* gradient: the opacity falls linearly with the gradient
    /// magnitude of the trilinear interpolant (value units per voxel index), from the full `opacity`
    /// at 0 to 0 at this magnitude (None: the opacity depends on the value alone). Value classes only.
    pub max_gradient: Option<f32>,
}

impl MaterialClass {
    /// An absorbing material (the emission–absorption default).
    pub fn new(range: [f32; 2], opacity: f32) -> MaterialClass {
        MaterialClass { range, opacity, absorbs: true, max_gradient: None }
    }
}

/// The transmittance below which early ray termination stops a ray by default: what it leaves out is at
/// most this share of the pixel. Measured on the engine CT at 192² over a 9-frame sweep of 8-bit frames
/// against the unterminated ones (the test `skips_stay_within_half_a_delta_e_at_p99_*`): p99 ΔE00 0.85 at
/// 0.01, 0.64 at 0.005, 0.53 at 0.002, 0.46 at 0.001 (generated engine 0.94, 0.80, 0.60, 0.44), for
/// 0.93×, 0.96×, 1×, 1.02× the samples of 0.002; 0.001 is the first below the 0.5 aim.
pub const TERMINATION_TRANSMITTANCE: f64 = 0.001;

/// Most materials a transfer function may hold.
pub(crate) const MAX_MATERIALS: usize = 64;

/// View direction and framing of the orthographic camera. Azimuth turns about the volume's z axis
/// (0° looks along +y), elevation lifts the camera towards +z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Degrees about the volume's z axis; 0 looks along +y.
    pub azimuth_deg: f64,
    pub(crate) elevation_deg: f64,
    /// 1 frames the view's target (see `fit`) with a small margin; larger values magnify.
    pub(crate) zoom: f64,
    /// Frame the voxels that belong to a material (their projection, centred),
    /// instead of the bounding sphere of the whole grid.
    pub(crate) fit_materials: bool,
}

impl Default for Camera {
    fn default() -> Self {
        Camera { azimuth_deg: 30.0, elevation_deg: 20.0, zoom: 1.0, fit_materials: true }
    }
}

/// Raycasting settings.
#[derive(Clone, Debug, PartialEq)]
pub struct RaycastOptions {
    /// Image width in pixels (one ray per pixel).
    pub width: usize,
    /// Image height in pixels (one ray per pixel).
    pub height: usize,
    /// Distance between samples in voxels (of the smallest spacing).
    pub step: f64,
    /// Weight of the shading-independent part: `shade = ambient + (1 − ambient)·max(n·l, 0)`.
    pub ambient: f64,
    /// Which light the scalar shading term uses (key light, headlight, or none).
    pub shading: Shading,
    /// How shading normals are taken: central differences of the smoothed field, or the cell's own gradient.
    pub gradient: Gradient,
    /// Start every ray a pixel-dependent fraction of a step in (interleaved gradient noise).
    pub jitter: bool,
    /// Split a step that crosses a material boundary into substeps of about [`REFINED_STEP`] voxels
    /// (see the module docs).
    pub refine: bool,
    /// How a sample's value is reconstructed from the voxels (trilinear, nearest, or shape-based labels).
    pub interpolation: Interpolation,
    /// Stop a ray once its transmittance falls below `termination_transmittance`.
    pub early_termination: bool,
    /// Transmittance below which a ray stops (the remaining contribution is at most this share).
    pub termination_transmittance: f64,
    /// Skip bricks whose value range holds no material.
    pub empty_space_skipping: bool,
    /// Edge of a skipping brick in voxels (rounded up to a power of two).
    pub brick_size: usize,
    /// The most bytes of derived-field blocks (smooth gradients, label distances) kept resident; None:
    /// [`default_field_cache`] of the volume. The cap changes the time, never the frame.
    pub field_cache: Option<u64>,
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
            refine: true,
            interpolation: Interpolation::Trilinear,
            early_termination: true,
            termination_transmittance: TERMINATION_TRANSMITTANCE,
            empty_space_skipping: true,
            brick_size: 8,
            field_cache: None,
        }
    }
}

/// Per pixel, the composited weight of every material (row-major pixels, materials innermost).
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialWeights {
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Number of materials per pixel: the classes given to `raycast`, in their order.
    pub materials: usize,
    /// `width × height × materials` composited weights `Σ T·α·shade`, row-major pixels (the top row first),
    /// materials innermost.
    pub data: Vec<f32>,
}

/// A multi-channel image: per pixel `channels` values (row-major pixels, channels innermost).
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelImage {
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Values per pixel, K: the length of the colour vectors projected (m, 31 or 3 by the colour model).
    pub channels: usize,
    /// `width × height × channels` values, row-major pixels (the top row first), channels innermost.
    pub data: Vec<f32>,
}

impl MaterialWeights {
    /// Composite colour per pixel given each material's colour vector (all of the same length K):
    /// `c = Σ_materials w · colour`.
    pub fn project(&self, colours: &[Vec<f32>]) -> ChannelImage {
        let k = colours.first().map_or(0, Vec::len);
        debug_assert_eq!(colours.len(), self.materials);
        let mut data = vec![0f32; self.width * self.height * k];
        // Fresh and untouched: faulted in by huge pages where it holds whole ones.
        crate::region::advise_huge(&mut data);
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

/// Where a raycast kept its derived-field blocks (smooth gradients, label distances).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FieldStore {
    /// No derived field was needed (unshaded, or cell gradients in a value mode).
    #[default]
    None,
    /// Every block the raycast can build fits the cap: each built once, never evicted, read without a
    /// lock.
    Pinned,
    /// Capped, the block whose last pixel row comes soonest evicted first; bands of tile rows traced one
    /// after another, `least` to `most` pixel rows each, so an evicted block is one the rays have passed.
    Capped { least: usize, most: usize },
}

impl std::fmt::Display for FieldStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FieldStore::None => write!(f, "no store"),
            FieldStore::Pinned => write!(f, "pinned store"),
            FieldStore::Capped { least, most } if least == most => {
                write!(f, "capped store, bands of {most} px rows traced in turn")
            }
            FieldStore::Capped { least, most } => {
                write!(f, "capped store, bands of {least}–{most} px rows traced in turn")
            }
        }
    }
}

/// Counters of one raycast.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RaycastStats {
    /// Samples taken (whole steps and refinement substeps), including `uniform` ones.
    pub samples: u64,
    /// Of the samples, those in single-material bricks: classified by the brick table, with no value
    /// reconstructed and no transfer-function lookup.
    pub uniform: u64,
    /// Steps jumped over inside empty bricks (up to each ray's last step).
    pub skipped: u64,
    /// Jumps over empty space: each over one empty brick or one group of empty bricks
    /// ([`classify::Spans`]), one per ray and jump.
    pub skipped_bricks: u64,
    /// Rays stopped early by low transmittance.
    pub terminated: u64,
    /// The brick table: bricks, of which empty and single-material for this transfer function.
    pub bricks: u64,
    /// Of `bricks`, those whose value range meets no material: rays step over them.
    pub empty_bricks: u64,
    /// Of `bricks`, those whose value range lies within one material's: sampled without a lookup.
    pub uniform_bricks: u64,
    /// Per-brick field blocks built (smooth gradients, smoothed label occupancy; one evicted and needed
    /// again counts again) and their bytes.
    pub field_blocks: u64,
    /// Bytes of the field blocks counted in `field_blocks`.
    pub field_bytes: u64,
    /// Field blocks evicted to stay within the cap, the cap, and the most bytes resident at once.
    pub field_evicted: u64,
    /// The most bytes of field blocks kept resident: `RaycastOptions::field_cache`, or the volume's default.
    pub field_cap: u64,
    /// The most bytes held at one time by field blocks and their slot table during the raycast.
    pub field_peak: u64,
    /// Which store held the blocks.
    pub field_store: FieldStore,
}

impl RaycastStats {
    /// Add the per-ray counters of `o` (samples, skips, terminations).
    fn add(&mut self, o: &RaycastStats) {
        self.samples += o.samples;
        self.uniform += o.uniform;
        self.skipped += o.skipped;
        self.skipped_bricks += o.skipped_bricks;
        self.terminated += o.terminated;
    }
}

mod block;
mod classify;
mod fields;
mod labels;
#[cfg(target_arch = "x86_64")]
mod lanes;
mod march;
#[cfg(test)]
mod tests;
mod view;

pub use classify::BrickMap;
use classify::{BrickTable, Classifier, MaterialRows};
use fields::{Fields, Kind};
pub use fields::{MIN_FIELD_CACHE, default_field_cache};
pub use labels::{LABEL_RADIUS, LABEL_RAMP, LABEL_REACH, LABEL_SIGMA};
pub use march::REFINED_STEP;
use march::RayContext;
pub use view::MAX_RAY_STEPS;
use view::View;

/// Raycast `volume` with the given materials. Returns per-pixel material weights and counters.
pub fn raycast(
    volume: &Volume,
    materials: &[MaterialClass],
    bricks: Option<&BrickMap>,
    camera: &Camera,
    options: &RaycastOptions,
) -> (MaterialWeights, RaycastStats) {
    raycast_with(volume, materials, bricks, camera, options, lanes_detected(), true)
}

/// Whether this processor can take value samples several at a time (x86-64 with AVX2).
pub(super) fn lanes_detected() -> bool {
    #[cfg(target_arch = "x86_64")]
    return lanes::detected();
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Whether `volume` fits the lanes' 32-bit indices.
fn lanes_fit(volume: &Volume) -> bool {
    #[cfg(target_arch = "x86_64")]
    return crate::with_voxels!(&volume.voxels, d => lanes::fits(std::mem::size_of_val(&d[..]), volume.dims));
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// [`raycast`], with the value samples taken several at a time (`lanes`, only where
/// [`lanes_detected`]) or one by one, and empty space jumped over in groups of bricks where they are all
/// empty (`groups`, [`classify::Spans`]) or brick by brick: the same frame either way (tests compare them).
pub(super) fn raycast_with(
    volume: &Volume,
    materials: &[MaterialClass],
    bricks: Option<&BrickMap>,
    camera: &Camera,
    options: &RaycastOptions,
    lanes: bool,
    groups: bool,
) -> (MaterialWeights, RaycastStats) {
    let lanes = lanes && lanes_detected();
    let n_mat = materials.len().min(MAX_MATERIALS);
    let materials = &materials[..n_mat];
    let (w, h) = (options.width.max(1), options.height.max(1));
    let step = options.step.clamp(0.05, 8.0);
    let substeps = if options.refine { march::substeps(volume, step) } else { 1 };
    let classifier = Classifier::new(volume, materials, step, substeps);
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
    let labels = options.interpolation == Interpolation::Labels;
    // How far past a labelled voxel the smoothed occupancy a sample's cell reads can reach.
    let reach = if labels { labels::label_reach(volume) } else { 1 };
    let table =
        bricks.map(|b| BrickTable::new(b, &classifier, !labels, if labels { reach.div_ceil(b.size) } else { 0 }));
    let framed = camera.fit_materials.then(|| {
        MaterialRows::new(volume, &classifier, bricks.zip(table.as_ref()).map(|(b, t)| (b, t.class.as_slice())))
    });
    let view = View::new(volume, camera, step, options.shading, h as f64 / w as f64, framed.as_ref(), reach as f64);
    let gradients = options.shading != Shading::Unshaded && options.gradient == Gradient::Smooth;
    let kind = match options.interpolation {
        Interpolation::Trilinear => Kind::Values,
        Interpolation::Nearest => Kind::Opacity,
        Interpolation::Labels => Kind::Labels,
    };
    let cap = options.field_cache.unwrap_or_else(|| default_field_cache(volume.voxels.bytes() as u64));
    // Value modes fetch a gradient block only for a sample of a material, which an empty brick never
    // holds: with the skipping bricks the size of the field bricks, only the others can need a block.
    let reachable = bricks
        .zip(table.as_ref())
        .filter(|(b, _)| !labels && b.size == block::FIELD_BRICK)
        .map(|(_, t)| t.class.len() - t.empty);
    let mut fields = (gradients || labels).then(|| Fields::new(volume, &classifier, kind, gradients, cap, reachable));
    if let Some(f) = fields.as_mut() {
        f.avx2 = lanes;
    }
    if let Some(f) = fields.as_mut().filter(|f| f.room().is_some()) {
        let rows = last_rows(&view, volume, f.counts(), w, h);
        f.evict_by_rows(rows);
    }
    let ctx = RayContext {
        volume,
        classifier: &classifier,
        fields: fields.as_ref(),
        bricks: bricks.zip(table.as_ref()).map(|(b, t)| (b, t.class.as_slice())),
        spans: table.as_ref().map(|t| &t.spans).filter(|_| groups),
        view: &view,
        grid: march::Grid::new(volume),
        options,
        substeps,
        near_band: march::near_band(volume, step),
        ambient: options.ambient.clamp(0.0, 1.0) as f32,
        stop_below: if options.early_termination { options.termination_transmittance as f32 } else { 0.0 },
        n_mat,
        lanes: lanes && lanes_fit(volume),
        width: w,
        height: h,
    };

    // Tiles of TILE columns × `rows` rows. While field blocks may be evicted, bands of rows of tiles are
    // traced one after another (each band's tiles in parallel), so the blocks in use at once are those
    // under one band and the brick projections reaching into the next: a block leaves the cache once the
    // rays past it are done, and is not needed again. A band's height is set from the blocks built so far
    // ([`Bands`]).
    // The weights, written in place by the rays: each tile holds its rows' stretches of `data` (rows of
    // pixels split at the tiles' columns), so no tile needs a buffer of its own to be copied in after
    // (4 MiB of fresh pages and a serial copy at 384² with seven materials).
    // Not advised for huge pages (the projection's planes are): the rays of both cores now fault these
    // pages in while they trace, and with the advice the step-1 engine scene's raycast was 1.04 of the
    // advised-and-copied form's time with two threads against 1.01 without it (41 pairs, session 50).
    let mut data = vec![0f32; w * h * n_mat];
    let tiles_x = w.div_ceil(TILE);
    let split = |band, y0, rows| Tile::split(band, y0, rows, w, n_mat);
    let trace_tile = |Tile { tx, y0, rows, mut parts }: Tile<'_>| {
        let mut stats = RaycastStats::default();
        for j in 0..rows {
            let py = y0 + j;
            // Without materials there are no weights, but the rays are still traced (their counters).
            let part: &mut [f32] = match parts.get_mut(j) {
                Some(p) => p,
                None => &mut [],
            };
            for i in 0..TILE {
                let px = tx * TILE + i;
                if px >= w {
                    break;
                }
                ctx.trace(px, py, &mut part[i * n_mat..(i + 1) * n_mat], &mut stats);
            }
        }
        stats
    };
    // Bands of TILE rows, all traced at once when nothing is evicted; else each traced before the next is
    // sized.
    let mut bands = fields
        .as_ref()
        .filter(|f| f.room().is_some())
        .map(|f| (f, Bands::new(reachable.unwrap_or_else(|| fields::brick_count(volume)), &view, volume, w, h)));
    let mut tiles: Vec<RaycastStats> = Vec::with_capacity(tiles_x * h.div_ceil(TILE));
    let mut band_range: Option<(usize, usize)> = None;
    let (mut rest, mut y0, mut pending) = (&mut data[..], 0, Vec::new());
    while y0 < h {
        let rows = bands.as_mut().map_or(TILE, |(f, b)| b.next(f.room_now())).min(h - y0);
        let (band, tail) = std::mem::take(&mut rest).split_at_mut(rows * w * n_mat);
        rest = tail;
        pending.extend(split(band, y0, rows));
        if bands.is_some() {
            band_range = Some(band_range.map_or((rows, rows), |(lo, hi)| (lo.min(rows), hi.max(rows))));
            tiles.extend(std::mem::take(&mut pending).into_par_iter().map(trace_tile).collect::<Vec<_>>());
        }
        y0 += rows;
    }
    tiles.extend(pending.into_par_iter().map(trace_tile).collect::<Vec<_>>());
    let mut stats = RaycastStats::default();
    for s in &tiles {
        stats.add(s);
    }
    if let Some(f) = &fields {
        let u = f.usage();
        (stats.field_blocks, stats.field_bytes, stats.field_evicted, stats.field_cap, stats.field_peak) =
            (u.built, u.built_bytes, u.evicted, u.cap, u.peak);
        stats.field_store = match band_range {
            Some((least, most)) => FieldStore::Capped { least, most },
            None => FieldStore::Pinned,
        };
    }
    if let Some(t) = &table {
        (stats.bricks, stats.empty_bricks, stats.uniform_bricks) =
            (t.class.len() as u64, t.empty as u64, t.uniform as u64);
    }
    (MaterialWeights { width: w, height: h, materials: n_mat, data }, stats)
}

/// A tile's place (column of tiles `tx`, `rows` pixel rows from `y0`) and its rows' stretches of the
/// weights.
struct Tile<'d> {
    tx: usize,
    y0: usize,
    rows: usize,
    parts: Vec<&'d mut [f32]>,
}

impl<'d> Tile<'d> {
    /// The tiles of the `rows` pixel rows from `y0` of a `w`-pixel-wide image, `band` their weights.
    fn split(band: &'d mut [f32], y0: usize, rows: usize, w: usize, n_mat: usize) -> Vec<Tile<'d>> {
        let mut tiles: Vec<Tile<'d>> =
            (0..w.div_ceil(TILE)).map(|tx| Tile { tx, y0, rows, parts: Vec::with_capacity(rows) }).collect();
        if n_mat > 0 {
            for row in band.chunks_mut(w * n_mat) {
                for (tx, part) in row.chunks_mut(TILE * n_mat).enumerate() {
                    tiles[tx].parts.push(part);
                }
            }
        }
        tiles
    }
}

/// Tile edge in pixels (columns; rows too unless [`Bands`] makes them fewer).
const TILE: usize = 16;

/// The heights of the bands of tile rows traced in turn while field blocks may be evicted: per band, the
/// most of 16, 8, 4, 2, 1 rows whose blocks in use at once fit half the cap's room (in blocks, from the
/// blocks' mean size so far: [`Fields::room_now`]), and at most twice the band before. The blocks in use
/// are estimated as the `bricks` that can be reached, spread evenly over the image's height, that project
/// onto one band or reach into it from the next (a brick's projection is at most its diagonal). The other
/// half of the room is for bands that cross more bricks than the average; the doubling, for blocks that
/// grow larger than the first ones. Only the time depends on it: eviction counts the blocks' real bytes.
struct Bands {
    /// Reachable bricks per world unit of the image's height.
    per_height: f64,
    /// World units per pixel row; a brick's diagonal.
    pixel: f64,
    brick: f64,
    /// The band before's height (none yet: 1, so the first band may have 2 rows).
    last: usize,
}

impl Bands {
    fn new(bricks: usize, view: &View, volume: &Volume, w: usize, h: usize) -> Bands {
        let s = volume.spacing;
        let pixel = 2.0 * view.half_extent / w as f64;
        let image = pixel * h as f64;
        let brick = block::FIELD_BRICK as f64 * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        Bands { per_height: bricks as f64 / (image + brick), pixel, brick, last: 1 }
    }

    /// The next band's height for a cap of `room` blocks.
    fn next(&mut self, room: u64) -> usize {
        let mut rows = TILE.min(2 * self.last);
        while rows > 1 && self.per_height * (rows as f64 * self.pixel + self.brick) > room as f64 / 2.0 {
            rows /= 2;
        }
        self.last = rows;
        rows
    }
}

/// Per field brick (x fastest), the last pixel row whose ray can reach it: the lowest row its box
/// projects onto, grown by the voxel a trilinear cell reaches past it and by a row, within `0..=h`.
/// Rays of one pixel row share the image's `up` coordinate, so a ray of a later row never enters the
/// brick.
fn last_rows(view: &View, volume: &Volume, counts: [usize; 3], w: usize, h: usize) -> Vec<u32> {
    let s = volume.spacing;
    let n = block::FIELD_BRICK as f64;
    let up = view.up;
    let centre = (0..3).map(|a| view.centre_world[a] * up[a]).sum::<f64>();
    // Image rows per world unit along `up` (pixel rows are `2·half_extent·h/w / h` apart).
    let per_unit = w as f64 / (2.0 * view.half_extent);
    // Per axis and brick index, the least `up` coordinate of the brick's (grown) extent along that axis.
    let least = |a: usize, b: usize| {
        let (lo, hi) = ((b as f64 * n - 1.0) * s[a] * up[a], ((b + 1) as f64 * n + 1.0) * s[a] * up[a]);
        lo.min(hi)
    };
    let axis = |a: usize| (0..counts[a]).map(|b| least(a, b)).collect::<Vec<f64>>();
    let (ux, uy, uz) = (axis(0), axis(1), axis(2));
    let mut out = Vec::with_capacity(counts.iter().product());
    for z in &uz {
        for y in &uy {
            for x in &ux {
                // py + 0.5 = h/2 − (u − centre)·per_unit for the image's `up` coordinate u.
                let row = 0.5 * h as f64 - (x + y + z - centre) * per_unit - 0.5;
                out.push((row.ceil() + 1.0).clamp(0.0, h as f64) as u32);
            }
        }
    }
    out
}

/// Bricks within `k` bricks (along each axis) of an occupied one count as occupied: a label field
/// spreads a material past its bricks.
fn dilate_occupied(empty: &[bool], counts: [usize; 3], k: usize) -> Vec<bool> {
    let idx = |x: usize, y: usize, z: usize| x + counts[0] * (y + counts[1] * z);
    let mut out = empty.to_vec();
    // Separable: a brick stays empty only when every brick of its (2k+1)³ neighbourhood is empty.
    for axis in 0..3 {
        let src = out.clone();
        for z in 0..counts[2] {
            for y in 0..counts[1] {
                for x in 0..counts[0] {
                    let c = [x, y, z];
                    let (lo, hi) = (c[axis].saturating_sub(k), (c[axis] + k).min(counts[axis] - 1));
                    out[idx(x, y, z)] = (lo..=hi).all(|v| {
                        let mut q = c;
                        q[axis] = v;
                        src[idx(q[0], q[1], q[2])]
                    });
                }
            }
        }
    }
    out
}

/// Interleaved gradient noise (Jimenez 2014) of a pixel: a deterministic value in [0, 1) whose
/// neighbours differ strongly, so ray-start offsets show no structure at 1:1.
#[inline(always)]
pub(crate) fn interleaved_gradient_noise(px: usize, py: usize) -> f64 {
    let f = 0.06711056 * px as f64 + 0.00583715 * py as f64;
    (52.9829189 * f.fract()).fract()
}
