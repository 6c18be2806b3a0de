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
    assert!(s_on.skipped_bricks > 0 && s_a.uniform == 0, "{s_on:?} {s_a:?}");
    // Termination leaves out at most the remaining transmittance (1%) per ray.
    let none = RaycastOptions { empty_space_skipping: false, early_termination: false, ..base };
    let (b, _) = raycast(&vol, &mats, None, &cam, &none);
    for (px_a, px_b) in a.data.chunks(3).zip(b.data.chunks(3)) {
        let (sa, sb): (f32, f32) = (px_a.iter().sum(), px_b.iter().sum());
        assert!((sb - sa) >= -1e-5 && (sb - sa) <= 0.01 + 1e-5, "{sa} vs {sb}");
    }
}

#[test]
fn single_material_bricks_are_sampled_from_the_brick_table_with_the_same_image() {
    // A translucent cube (rays cross its inside) holding a denser core: empty, single-material and
    // mixed bricks.
    let n = 64;
    let mut vol = cube(n, 100.0);
    let mut data = vol.voxels.to_f32_vec();
    for z in 28..36 {
        for y in 28..36 {
            for x in 28..36 {
                data[x + n * (y + n * z)] = 200.0;
            }
        }
    }
    vol = Volume::new(Path::new("cube"), [n, n, n], [1.0; 3], data).unwrap();
    let mats = [MaterialClass::new([50.0, 150.0], 0.03), MaterialClass::new([180.0, 255.0], 0.5)];
    let cam = Camera { azimuth_deg: 20.0, elevation_deg: 15.0, ..Camera::default() };
    for gradient in [Gradient::Smooth, Gradient::Cell] {
        let on = RaycastOptions { width: 48, height: 48, gradient, ..Default::default() };
        let off = RaycastOptions { empty_space_skipping: false, ..on.clone() };
        let ((a, s), (b, s_off)) = (raycast(&vol, &mats, None, &cam, &on), raycast(&vol, &mats, None, &cam, &off));
        assert!(s.empty_bricks > 0 && s.uniform_bricks > 0 && s.empty_bricks + s.uniform_bricks < s.bricks, "{s:?}");
        assert!(s.uniform > s.samples / 4 && s_off.uniform == 0, "{s:?}");
        let max_diff = a.data.iter().zip(&b.data).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max);
        assert!(max_diff < 1e-5, "{gradient:?}: the brick table changed the image by {max_diff}");
        assert!(a.data.iter().any(|v| *v > 0.1));
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

/// An `n × n × nz` label volume (slices `dz` apart) holding label 3 below the plane `z < slope·x + offset`
/// (in voxels): a voxel staircase whose treads are `1 / slope` voxels wide.
fn plane_labels(n: usize, nz: usize, dz: f64, slope: f64, offset: f64) -> Volume {
    let mut data = vec![0f32; n * n * nz];
    for z in 0..nz {
        for y in 0..n {
            for x in 0..n {
                if (z as f64) < slope * x as f64 + offset {
                    data[x + n * (y + n * z)] = 3.0;
                }
            }
        }
    }
    Volume::new(Path::new("plane"), [n, n, nz], [1.0, 1.0, dz], data).unwrap()
}

/// A tilted plane `z < 0.25·x + 12`: a staircase of four-voxel treads.
fn tilted_plane(n: usize) -> Volume {
    plane_labels(n, n, 1.0, 0.25, 12.0)
}

/// Slices 1.5 apart and the shallow plane `z < 0.1·x + 6`: a staircase of ten-voxel treads, wider than any
/// small blur (the frog's liver seen from above).
fn shallow_plane(n: usize) -> Volume {
    plane_labels(n, n / 2, 1.5, 0.1, 6.0)
}

/// Spread of the weights over the image's central block (where the plane fills every pixel).
fn central_spread(w: &MaterialWeights) -> (f32, f32) {
    let mut v = Vec::new();
    for y in w.height / 4..3 * w.height / 4 {
        for x in w.width / 4..3 * w.width / 4 {
            v.push(w.data[(y * w.width + x) * w.materials]);
        }
    }
    let mean = v.iter().sum::<f32>() / v.len() as f32;
    let var = v.iter().map(|a| (a - mean).powi(2)).sum::<f32>() / v.len() as f32;
    (mean, var.sqrt())
}

/// One material (label 3) of `vol` seen from above (a plane seen face-on, a staircase's treads and risers
/// alternating along x) under a headlight: raycast with shape-based labels, and with nearest sampling and
/// cell gradients (the staircase as stored).
fn labels_and_nearest(vol: &Volume) -> (MaterialWeights, RaycastStats, MaterialWeights) {
    let mats = [MaterialClass::new([3.0, 3.0], 0.9)];
    let cam = Camera { azimuth_deg: 0.0, elevation_deg: 89.0, fit_materials: false, zoom: 2.0 };
    let base =
        RaycastOptions { width: 64, height: 64, shading: Shading::Headlight, ambient: 0.0, ..Default::default() };
    let labels = RaycastOptions { interpolation: Interpolation::Labels, ..base.clone() };
    let (smooth, stats) = raycast(vol, &mats, None, &cam, &labels);
    let nearest = RaycastOptions { interpolation: Interpolation::Nearest, gradient: Gradient::Cell, ..base };
    let (stairs, _) = raycast(vol, &mats, None, &cam, &nearest);
    (smooth, stats, stairs)
}

#[test]
fn smoothed_labels_shade_a_staircase_as_a_smooth_plane() {
    let vol = tilted_plane(48);
    let (smooth, stats, stairs) = labels_and_nearest(&vol);
    let (ms, ss) = central_spread(&smooth);
    let (mn, sn) = central_spread(&stairs);
    assert!(ms > 0.5 && mn > 0.3, "the plane must show: {ms} {mn}");
    // A smooth plane under a headlight has one shade; the staircase flickers between tread and riser.
    assert!(ss < 0.02 && ss < 0.25 * sn, "smoothed spread {ss} vs staircase {sn}");
    assert!(stats.field_blocks > 0 && stats.field_bytes > 0);
    assert!(smooth.data.iter().all(|v| (0.0..=1.0 + 1e-6).contains(v)));
}

#[test]
fn shape_based_labels_shade_wide_slice_terraces_as_a_smooth_plane() {
    let vol = shallow_plane(64);
    let (smooth, _, stairs) = labels_and_nearest(&vol);
    let (ms, ss) = central_spread(&smooth);
    let (_, sn) = central_spread(&stairs);
    assert!(ms > 0.5, "the plane must show: {ms}");
    // Between two slices the contours blend, so the treads and their one-slice risers become one plane.
    assert!(ss < 0.02 && ss < 0.25 * sn, "smoothed spread {ss} vs staircase {sn}");
    // Along x (across the treads) the shade has no steps: neighbouring columns differ by little.
    let row = smooth.height / 2;
    let col = |x: usize| smooth.data[(row * smooth.width + x) * smooth.materials];
    let jump = (smooth.width / 4..3 * smooth.width / 4 - 1).map(|x| (col(x + 1) - col(x)).abs()).fold(0.0, f32::max);
    assert!(jump < 0.02, "largest step between neighbouring columns {jump}");
}

#[test]
fn fields_are_built_only_where_rays_reach() {
    // An opaque cube in a large empty grid: rays stop at its front faces, so few bricks are built.
    let vol = cube(64, 100.0);
    let mats = [MaterialClass::new([50.0, 150.0], 1.0)];
    let opts = RaycastOptions { width: 64, height: 64, ..Default::default() };
    let (_, stats) = raycast(&vol, &mats, None, &Camera::default(), &opts);
    let bricks = 8u64 * 8 * 8;
    assert!(stats.field_blocks > 0 && stats.field_blocks < bricks / 2, "{} of {bricks} blocks", stats.field_blocks);
    // Skipping inside empty bricks is exact for smoothed labels too (the skipping map is dilated).
    let labels = RaycastOptions { interpolation: Interpolation::Labels, ..opts };
    let (a, _) = raycast(&vol, &mats, None, &Camera::default(), &labels);
    let (b, _) =
        raycast(&vol, &mats, None, &Camera::default(), &RaycastOptions { empty_space_skipping: false, ..labels });
    let max_diff = a.data.iter().zip(&b.data).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max);
    assert!(max_diff < 1e-5, "skipping changed the smoothed-label image by {max_diff}");
}

#[test]
fn a_field_cache_that_evicts_keeps_the_frames_byte_identical() {
    // Thin materials let rays reach most bricks; a cap of a few blocks evicts nearly every block many
    // times over (rebuilt on the next visit, on whichever thread), and the image must not change by a bit.
    let engine = crate::volume::generate::engine_like(64);
    let thin = [
        MaterialClass::new([18.0, 75.0], 0.02),
        MaterialClass::new([105.0, 175.0], 0.03),
        MaterialClass::new([200.0, 255.0], 0.2),
    ];
    let plane = tilted_plane(48);
    let label = [MaterialClass::new([3.0, 3.0], 0.9)];
    let cam = Camera { azimuth_deg: 20.0, elevation_deg: 60.0, ..Camera::default() };
    for (vol, mats, interpolation) in [
        (&engine, &thin[..], Interpolation::Trilinear),
        (&engine, &thin[..], Interpolation::Nearest),
        (&plane, &label[..], Interpolation::Labels),
    ] {
        let base = RaycastOptions { width: 64, height: 64, interpolation, ..Default::default() };
        let (whole, s_whole) = raycast(vol, mats, None, &cam, &base);
        assert_eq!(s_whole.field_evicted, 0, "{interpolation:?}: the default cap holds a small volume's blocks");
        assert_eq!(s_whole.field_cap, MIN_FIELD_CACHE);
        // Room for the slots and about four blocks.
        let slots = s_whole.field_peak - s_whole.field_bytes;
        let one = s_whole.field_bytes / s_whole.field_blocks;
        let cap = slots + 4 * one;
        let tiny = RaycastOptions { field_cache: Some(cap), ..base };
        for run in 0..2 {
            let (capped, s) = raycast(vol, mats, None, &cam, &tiny);
            assert!(capped.data == whole.data, "{interpolation:?} run {run}: the cap changed the image");
            assert!(
                s.field_evicted > s_whole.field_blocks / 2 && s.field_blocks > s_whole.field_blocks,
                "{interpolation:?}: {s:?} vs {s_whole:?}"
            );
            // Resident after each admission: within the cap, or the one block just built beyond it (at
            // most 8 bytes an entry per material in label mode, a gradient triple otherwise).
            let largest = if interpolation == Interpolation::Labels { mats.len() * 8 } else { 6 } * 729 + 128;
            assert!(s.field_peak <= cap + largest as u64, "{interpolation:?}: {} resident, cap {cap}", s.field_peak);
            assert_eq!(s.samples, s_whole.samples);
        }
    }
}

#[test]
fn a_capped_field_cache_traced_in_bands_builds_each_block_about_once() {
    // Thin materials: rays reach most bricks. With a cap of half the blocks, the rows of tiles are traced
    // one after another and the block evicted first is the one whose last pixel row comes soonest, so a
    // block evicted is one the rays have passed: none is built twice.
    let engine = crate::volume::generate::engine_like(96);
    let thin = [MaterialClass::new([18.0, 75.0], 0.02), MaterialClass::new([105.0, 175.0], 0.03)];
    let cam = Camera { azimuth_deg: 20.0, elevation_deg: 60.0, ..Camera::default() };
    let base = RaycastOptions { width: 96, height: 96, ..Default::default() };
    let (whole, s_whole) = raycast(&engine, &thin, None, &cam, &base);
    assert_eq!(s_whole.field_evicted, 0);
    let capped = RaycastOptions { field_cache: Some(s_whole.field_peak / 2), ..base };
    let (img, s) = raycast(&engine, &thin, None, &cam, &capped);
    assert!(img.data == whole.data, "the cap changed the image");
    assert!(s.field_evicted > s_whole.field_blocks / 4, "the cap evicts: {s:?}");
    assert_eq!(s.field_blocks, s_whole.field_blocks, "a block was built twice: {s:?} vs {s_whole:?}");
    // The stats name the store: pinned when everything fits, capped (rows traced in turn) otherwise, none
    // when no field is needed.
    assert_eq!(s_whole.field_store, FieldStore::Pinned);
    assert!(
        matches!(s.field_store, FieldStore::Capped { least, most } if 1 <= least && least <= most && most <= 16),
        "{s:?}"
    );
    let (_, s_flat) = raycast(&engine, &thin, None, &cam, &RaycastOptions { shading: Shading::Unshaded, ..base });
    assert_eq!((s_flat.field_store, s_flat.field_blocks), (FieldStore::None, 0));
}

/// A horizontal plate `slices` slices thick through the middle of an `n × n × nz` grid (slices `dz`
/// apart), `value` in 0.
fn thin_plate(n: usize, nz: usize, dz: f64, value: f32, slices: usize) -> Volume {
    let mut data = vec![0f32; n * n * nz];
    data[n * n * (nz / 2)..n * n * (nz / 2 + slices)].iter_mut().for_each(|v| *v = value);
    Volume::new(Path::new("plate"), [n, n, nz], [1.0, 1.0, dz], data).unwrap()
}

/// The plate seen obliquely, unshaded (so only sampling shows): the central block's mean weight and
/// spread with and without boundary refinement, and the mean of a fine reference (step 1/20, no jitter).
fn plate_sampling(vol: &Volume, mats: &[MaterialClass], interpolation: Interpolation) -> [(f32, f32); 3] {
    let cam = Camera { azimuth_deg: 20.0, elevation_deg: 50.0, fit_materials: false, zoom: 2.0 };
    let base = RaycastOptions {
        width: 64,
        height: 64,
        shading: Shading::Unshaded,
        interpolation,
        early_termination: false,
        ..Default::default()
    };
    let run = |o: &RaycastOptions| central_spread(&raycast(vol, mats, None, &cam, o).0);
    let reference = RaycastOptions { step: 0.05, jitter: false, refine: false, ..base.clone() };
    [run(&base), run(&RaycastOptions { refine: false, ..base.clone() }), run(&reference)]
}

#[test]
fn refinement_integrates_a_thin_plate_finely_wherever_the_jittered_samples_fall() {
    // Without refinement a plate about one step thick gets 0, 1 or 2 samples depending on each pixel's
    // jitter: a fine dither over a surface that should look even. Refined steps (substeps of
    // REFINED_STEP voxels where a step crosses the boundary) integrate it as a fine step would.
    // One voxel of values; two slices of labels (the smoothing across slices thins a one-slice plate
    // below the occupancy ramp).
    let values = thin_plate(48, 48, 1.0, 100.0, 1);
    let labels = thin_plate(48, 32, 1.5, 3.0, 2);
    let cases = [
        ("values", values, [50.0, 150.0], Interpolation::Trilinear),
        ("labels", labels, [3.0, 3.0], Interpolation::Labels),
    ];
    for (name, vol, range, interpolation) in cases {
        let mats = [MaterialClass::new(range, 0.4)];
        let [(m_ref, s_ref), (m_plain, s_plain), (m_fine, _)] = plate_sampling(&vol, &mats, interpolation);
        assert!(m_fine > 0.1, "{name}: the plate must show ({m_fine})");
        assert!(s_plain > 0.02, "{name}: one sample per step should dither ({s_plain})");
        assert!(s_ref < 0.3 * s_plain, "{name}: refined spread {s_ref} vs {s_plain}");
        // Refinement moves the mean toward the fine reference (within 3 % of it).
        assert!((m_ref - m_fine).abs() < 0.03 * m_fine, "{name}: refined mean {m_ref}, fine {m_fine}, plain {m_plain}");
    }
}

#[test]
fn refinement_keeps_a_thick_material_as_dense_as_whole_steps_do() {
    // Substep opacities are corrected for their length, so where a ray crosses a thick slab the
    // refined entry step absorbs what a whole step would: the slab's total weight is unchanged up
    // to the entry step's finer sampling.
    let vol = cube(32, 100.0);
    let mats = [MaterialClass::new([50.0, 150.0], 0.1)];
    let cam = Camera { azimuth_deg: 0.0, elevation_deg: 0.0, ..Camera::default() };
    let base =
        RaycastOptions { width: 32, height: 32, shading: Shading::Unshaded, jitter: false, ..Default::default() };
    let (a, sa) = raycast(&vol, &mats, None, &cam, &base);
    let (b, sb) = raycast(&vol, &mats, None, &cam, &RaycastOptions { refine: false, ..base.clone() });
    assert!(sa.samples > sb.samples, "refinement must add samples at the faces: {} vs {}", sa.samples, sb.samples);
    let centre = 16 * 32 + 16;
    // 16 voxels of α = 0.1 per voxel: 1 − 0.9^16 ≈ 0.815, whichever way the steps are cut.
    let want = 1.0 - 0.9f32.powi(16);
    for (name, w) in [("refined", &a), ("whole steps", &b)] {
        assert!((w.data[centre] - want).abs() < 0.03, "{name}: {} vs {want}", w.data[centre]);
    }
    // A smoke-thin material (step opacity below the refinement's minimum) is never refined.
    let smoke = [MaterialClass::new([50.0, 150.0], 0.03)];
    let (_, sa) = raycast(&vol, &smoke, None, &cam, &base);
    let (_, sb) = raycast(&vol, &smoke, None, &cam, &RaycastOptions { refine: false, ..base });
    assert_eq!(sa.samples, sb.samples, "smoke boundaries must not be refined");
}

#[test]
fn framing_centres_the_silhouette_not_the_bounding_box() {
    // A flat base with a pole at one corner, seen from above at an angle: the bounding box's far top
    // corners are empty, so centring the box's projection would leave the image top-heavy. Framing by
    // the framed voxels' own projection leaves equal margins.
    let n = 64;
    let mut data = vec![0f32; n * n * n];
    for z in 4..60 {
        for y in 8..56 {
            for x in 8..56 {
                let base = z < 7;
                let pole = x < 14 && y < 14;
                if base || pole {
                    data[x + n * (y + n * z)] = 100.0;
                }
            }
        }
    }
    let vol = Volume::new(Path::new("pole"), [n, n, n], [1.0; 3], data).unwrap();
    let mats = [MaterialClass::new([50.0, 150.0], 0.9)];
    let cam = Camera { azimuth_deg: 30.0, elevation_deg: 60.0, ..Camera::default() };
    let opts = RaycastOptions { width: 96, height: 96, ..Default::default() };
    let (w, _) = raycast(&vol, &mats, None, &cam, &opts);
    let covered = |x: usize, y: usize| w.data[(y * w.width + x) * w.materials] > 0.0;
    let cols: Vec<usize> = (0..w.width).filter(|&x| (0..w.height).any(|y| covered(x, y))).collect();
    let rows: Vec<usize> = (0..w.height).filter(|&y| (0..w.width).any(|x| covered(x, y))).collect();
    let (left, right) = (cols[0], w.width - 1 - cols[cols.len() - 1]);
    let (top, bottom) = (rows[0], w.height - 1 - rows[rows.len() - 1]);
    assert!(left.abs_diff(right) <= 2 && top.abs_diff(bottom) <= 2, "margins l {left} r {right} t {top} b {bottom}");
    // Fitted: the larger side fills the frame up to the 4% margin (and a voxel's rim).
    assert!(left.min(top) <= 4, "margins l {left} r {right} t {top} b {bottom}");
}

/// `max_gradient` (a transfer function over value and gradient): a thin material keeps its opacity
/// where the field is flat and loses it where the field crosses its range steeply (the skin a smoke
/// range would otherwise leave on every surface of a denser material).
#[test]
fn max_gradient_keeps_flat_smoke_and_drops_the_skin_of_steep_boundaries() {
    let smoke = MaterialClass::new([5.0, 20.0], 0.05);
    let fading = MaterialClass { max_gradient: Some(6.0), ..smoke.clone() };
    let cam = Camera { azimuth_deg: 0.0, elevation_deg: 0.0, ..Camera::default() };
    let opts = RaycastOptions { width: 32, height: 32, shading: Shading::Unshaded, ..Default::default() };
    let total = |w: &MaterialWeights, m: usize| w.data.iter().skip(m).step_by(w.materials).sum::<f32>();
    // A flat cube of smoke (gradient 0 inside): nearly all its weight is kept.
    let flat = cube(32, 10.0);
    let (plain, _) = raycast(&flat, std::slice::from_ref(&smoke), None, &cam, &opts);
    let (faded, _) = raycast(&flat, std::slice::from_ref(&fading), None, &cam, &opts);
    let (p, f) = (total(&plain, 0), total(&faded, 0));
    assert!(p > 0.0 && f > 0.8 * p && f <= p, "flat smoke {f} of {p}");
    // A dense cube: its surface (0 → 200 within a voxel) passes the smoke's range with a gradient of
    // about 200 per voxel, so the faded smoke leaves no skin there; without the limit it does.
    let steep = cube(32, 200.0);
    let block = MaterialClass::new([100.0, 255.0], 0.02);
    let (skin, _) = raycast(&steep, &[smoke, block.clone()], None, &cam, &opts);
    let (none, _) = raycast(&steep, &[fading, block], None, &cam, &opts);
    assert!(total(&skin, 0) > 0.0, "the plain smoke range leaves a skin");
    assert_eq!(total(&none, 0), 0.0, "no skin with max_gradient");
    assert!((total(&skin, 1) - total(&none, 1)).abs() < 0.01 * total(&skin, 1));
}

/// The value loop taking its samples several at a time (AVX2 lanes, where the processor has them) gives
/// the portable loop's frame and counters bit for bit: on every voxel type, shaded by the smooth or the
/// cell gradient or unshaded, trilinear or nearest, with a gradient-dependent material, at steps that put
/// samples anywhere in their cells and refine a step into one or several substeps, and on volumes where
/// rays graze the last cells (values up to the far faces, axis-aligned views, cells clamped at dims − 2)
/// or whose first voxels the lanes read near (a grid two voxels wide, a grid one voxel thick), with rays
/// stopped early within a batch, a material that does not absorb, and bricks small enough to be
/// single-material or empty for a few lanes of a batch.
#[test]
fn samples_taken_in_lanes_give_the_portable_frame_bit_for_bit() {
    if !lanes_detected() {
        eprintln!("no AVX2 on this processor: the lanes are never taken, nothing to compare");
        return;
    }
    let engine = crate::volume::generate::engine_like_u16([37, 30, 26]);
    let u16s = engine.voxels.to_f32_vec();
    let dims = engine.dims;
    let as_type =
        |name: &str, data: crate::volume::Voxels| Volume::new(Path::new(name), dims, [1.0, 1.2, 0.9], data).unwrap();
    let u8s: Vec<u8> = u16s.iter().map(|v| (v / 257.0) as u8).collect();
    let i8s: Vec<i8> = u8s.iter().map(|v| (i16::from(*v) - 128) as i8).collect();
    let i16s: Vec<i16> = u16s.iter().map(|v| (*v as i32 - 32768) as i16).collect();
    let f32s: Vec<f32> = u16s.iter().map(|v| v / 257.0 + 0.25).collect();
    // Values rising towards the far corner (and a few spikes): material up to the last cells.
    let n = [19, 17, 23];
    let ramp: Vec<f32> = (0..n[0] * n[1] * n[2])
        .map(|i| {
            let (x, y, z) = (i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1]));
            (x + y + z) as f32 * 4.0 + if i % 37 == 0 { 60.0 } else { 0.0 }
        })
        .collect();
    let ramp = Volume::new(Path::new("ramp"), n, [1.0; 3], ramp).unwrap();
    let ramp_u8 = Volume::new(
        Path::new("ramp_u8"),
        n,
        [1.0; 3],
        ramp.voxels.to_f32_vec().iter().map(|v| *v as u8).collect::<Vec<_>>(),
    )
    .unwrap();
    let thin: Vec<u8> = (0..2 * 9 * 11).map(|i| (i * 7 % 200) as u8).collect();
    let thin = Volume::new(Path::new("thin"), [2, 9, 11], [1.0; 3], thin).unwrap();
    let sheet: Vec<u16> = (0..12 * 10 * 2).map(|i| (i * 977 % 50_000) as u16).collect();
    let sheet = Volume::new(Path::new("sheet"), [12, 10, 2], [1.0; 3], sheet).unwrap();
    let volumes = [
        (as_type("u8", u8s.into()), [18.0f32, 75.0, 105.0, 175.0, 200.0, 255.0]),
        (as_type("i8", i8s.into()), [-110.0, -53.0, -23.0, 47.0, 72.0, 127.0]),
        (engine, [18.0 * 257.0, 75.0 * 257.0, 105.0 * 257.0, 175.0 * 257.0, 200.0 * 257.0, 65535.0]),
        (as_type("i16", i16s.into()), [-28000.0, -13000.0, -6000.0, 12000.0, 18000.0, 32767.0]),
        (as_type("f32", f32s.into()), [18.0, 75.0, 105.0, 175.0, 200.0, 256.0]),
        (ramp, [20.0, 60.0, 61.0, 120.0, 121.0, 300.0]),
        (ramp_u8, [20.0, 60.0, 61.0, 120.0, 121.0, 255.0]),
        (thin, [10.0, 60.0, 61.0, 120.0, 121.0, 200.0]),
        (sheet, [1000.0, 15000.0, 15001.0, 30000.0, 30001.0, 50000.0]),
    ];
    let cameras = [
        Camera::default(),
        Camera { azimuth_deg: 0.0, elevation_deg: 0.0, zoom: 1.0, fit_materials: false },
        Camera { azimuth_deg: 90.0, elevation_deg: 0.0, zoom: 0.8, fit_materials: false },
        Camera { azimuth_deg: 37.0, elevation_deg: -61.0, zoom: 1.7, fit_materials: true },
    ];
    let base = RaycastOptions { width: 40, height: 34, shading: Shading::Headlight, ..Default::default() };
    let settings = [
        RaycastOptions { step: 0.5, ..base.clone() },
        RaycastOptions { step: 0.37, shading: Shading::Key, ..base.clone() },
        RaycastOptions { step: 1.3, gradient: Gradient::Cell, ..base.clone() },
        // Refined steps of several substeps (five and twelve on most of these grids) between samples
        // taken in lanes and shaded there by the smooth gradient.
        RaycastOptions { step: 1.3, ..base.clone() },
        RaycastOptions { step: 3.1, shading: Shading::Key, ..base.clone() },
        RaycastOptions { step: 0.5, shading: Shading::Unshaded, jitter: false, ..base.clone() },
        RaycastOptions { step: 0.5, interpolation: Interpolation::Nearest, ..base.clone() },
        RaycastOptions { step: 0.7, empty_space_skipping: false, refine: false, ..base.clone() },
        RaycastOptions { step: 0.5, early_termination: false, brick_size: 16, ..base.clone() },
        // Rays stopped early inside a batch, small bricks (single-material ones among them, and empty ones
        // entered and left within a batch), with and without substeps.
        RaycastOptions { step: 0.5, termination_transmittance: 0.4, brick_size: 2, ..base.clone() },
        RaycastOptions { step: 1.3, termination_transmittance: 0.6, brick_size: 4, ..base.clone() },
    ];
    let mut compared = 0;
    for (vol, r) in &volumes {
        assert!(lanes_fit(vol));
        let mut mats = vec![
            MaterialClass::new([r[0], r[1]], 0.05),
            MaterialClass::new([r[2], r[3]], 0.3),
            MaterialClass::new([r[4], r[5]], 0.9),
        ];
        // Plain, with a gradient-dependent material, with a material that does not absorb.
        for (fading, emissive) in [(false, false), (true, false), (false, true)] {
            mats[0].max_gradient = fading.then_some(0.2 * (r[1] - r[0]));
            mats[1].absorbs = !emissive;
            for cam in &cameras {
                for opts in &settings {
                    let (lanes, s_lanes) = raycast_with(vol, &mats, None, cam, opts, true, true);
                    let (portable, s_portable) = raycast_with(vol, &mats, None, cam, opts, false, true);
                    let what =
                        format!("{:?} {cam:?} {opts:?} fading {fading} emissive {emissive}", vol.voxels.scalar_type());
                    assert!(lanes.data.iter().zip(&portable.data).all(|(a, b)| a.to_bits() == b.to_bits()), "{what}");
                    assert_eq!(s_lanes, s_portable, "{what}");
                    compared += usize::from(portable.data.iter().any(|v| *v > 0.0));
                }
            }
        }
    }
    assert!(
        compared >= volumes.len() * 3 * cameras.len() * settings.len() * 9 / 10,
        "{compared} frames showed a material"
    );
}

/// The lanes' trilinear bins (`lanes::classify`: one- and two-byte voxels read as x-neighbour pairs in
/// four gathers, the others and the cells whose pair words would end past the voxels in eight) equal the
/// scalar reconstruction's at every cell of small grids of each voxel type, the first and the last cells
/// included, on grids one or two voxels wide along an axis.
#[test]
fn lanes_classify_every_cell_as_the_scalar_reconstruction_does() {
    if !lanes_detected() {
        eprintln!("no AVX2 on this processor: the lanes are never taken, nothing to compare");
        return;
    }
    let mut checked = 0;
    for dims in [[5usize, 4, 3], [2, 3, 2], [7, 1, 3], [1, 4, 3], [9, 2, 1]] {
        let n = dims.iter().product::<usize>();
        let raw: Vec<f32> = (0..n).map(|i| ((i * 73 + 11) % 251) as f32).collect();
        for vol in volumes_of_every_type(dims, &raw) {
            let [lo, hi] = vol.value_range;
            let mats = [MaterialClass::new([lo, 0.5 * (lo + hi)], 0.5), MaterialClass::new([0.5 * (lo + hi), hi], 0.5)];
            let classifier = classify::Classifier::new(&vol, &mats, 0.5, 2);
            let grid = march::Grid::new(&vol);
            let [sx, sy, sz] = grid.strides;
            // Every cell start: 0 ..= dims − 2 along each axis (0 along an axis of one voxel).
            let starts = |a: usize| 0..=dims[a].saturating_sub(2);
            let cells: Vec<usize> = starts(2)
                .flat_map(|z| starts(1).flat_map(move |y| starts(0).map(move |x| x + dims[0] * (y + dims[1] * z))))
                .collect();
            crate::with_voxels!(&vol.voxels, data => {
                for (c, chunk) in cells.chunks(lanes::LANES).enumerate() {
                    let mut batch = lanes::Batch::default();
                    for l in 0..lanes::LANES {
                        // Short chunks repeat their last cell.
                        batch.b[l] = chunk[l.min(chunk.len() - 1)] as u32;
                        for a in 0..3 {
                            batch.f[a][l] = ((c * 31 + l * 7 + a * 13) % 17) as f32 / 16.0;
                        }
                    }
                    // SAFETY: AVX2 was detected above; the volume fits the lanes (a few bytes).
                    unsafe { lanes::classify(&mut batch, &grid, &classifier, data) };
                    for l in 0..lanes::LANES {
                        let b = batch.b[l] as usize;
                        let v = |o: usize| data[b + o].to_f32();
                        let [fx, fy, fz] = [batch.f[0][l], batch.f[1][l], batch.f[2][l]];
                        // Cell::value's lerps, in its order.
                        let c00 = v(0) + fx * (v(sx) - v(0));
                        let c10 = v(sy) + fx * (v(sy + sx) - v(sy));
                        let c01 = v(sz) + fx * (v(sz + sx) - v(sz));
                        let c11 = v(sz + sy) + fx * (v(sz + sy + sx) - v(sz + sy));
                        let c0 = c00 + fy * (c10 - c00);
                        let c1 = c01 + fy * (c11 - c01);
                        let value = c0 + fz * (c1 - c0);
                        assert_eq!(batch.bin[l] as usize, classifier.bin(value), "{dims:?} {:?} cell {b}", vol.voxels.scalar_type());
                        checked += 1;
                    }
                }
            });
        }
    }
    assert!(checked > 5 * 40, "{checked} cells");
}

/// The min/max bricks (`BrickMap::new`, built a slab of bricks at a time) hold, for every brick, the
/// extremes of the voxels of its cells: those from its first voxel to the one past its last along each
/// axis (its upper seam), clamped to the grid. Compared with the extremes read brick by brick, on grids
/// whose sides are not multiples of the brick edge (and one voxel wide along an axis), every voxel type,
/// bricks of 1 to 16 voxels.
#[test]
fn brick_extremes_are_those_of_each_bricks_voxels_and_seam() {
    let mut checked = 0;
    for dims in [[11usize, 7, 5], [1, 9, 4], [17, 3, 1], [8, 8, 8]] {
        let n = dims.iter().product::<usize>();
        // Scattered values, so that a brick's extremes sit anywhere in it, its seam included.
        let raw: Vec<f32> = (0..n).map(|i| ((i * 7919 + 13) % 253) as f32).collect();
        for vol in volumes_of_every_type(dims, &raw) {
            let values = vol.voxels.to_f32_vec();
            for size in [1, 2, 4, 8, 16] {
                let bm = BrickMap::new(&vol, size);
                let counts = [0, 1, 2].map(|a| dims[a].div_ceil(size));
                assert_eq!(bm.counts, counts);
                assert_eq!(bm.min.len(), counts.iter().product::<usize>());
                for bz in 0..counts[2] {
                    for by in 0..counts[1] {
                        for bx in 0..counts[0] {
                            let span = |b: usize, a: usize| b * size..=((b + 1) * size).min(dims[a] - 1);
                            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                            for z in span(bz, 2) {
                                for y in span(by, 1) {
                                    for x in span(bx, 0) {
                                        let v = values[x + dims[0] * (y + dims[1] * z)];
                                        lo = lo.min(v);
                                        hi = hi.max(v);
                                    }
                                }
                            }
                            let i = bx + counts[0] * (by + counts[1] * bz);
                            let what =
                                format!("{:?} {dims:?} size {size} brick {:?}", vol.voxels.scalar_type(), [bx, by, bz]);
                            assert_eq!((bm.min[i], bm.max[i]), (lo, hi), "{what}");
                            checked += 1;
                        }
                    }
                }
            }
        }
    }
    assert!(checked > 1000, "{checked} bricks");
}

/// The same values (whole numbers below 256, as `f32`) as a volume of each voxel type, spread over its range.
fn volumes_of_every_type(dims: [usize; 3], raw: &[f32]) -> Vec<Volume> {
    let volume = |name: &str, voxels: crate::volume::Voxels| {
        Volume::new(Path::new(name), dims, [1.0; 3], voxels).expect("a valid test volume")
    };
    vec![
        volume("u8", raw.iter().map(|v| *v as u8).collect::<Vec<_>>().into()),
        volume("i8", raw.iter().map(|v| (*v as i16 - 125) as i8).collect::<Vec<_>>().into()),
        volume("u16", raw.iter().map(|v| (*v as u16) * 250 + 7).collect::<Vec<_>>().into()),
        volume("i16", raw.iter().map(|v| (*v as i32 * 250 - 30_000) as i16).collect::<Vec<_>>().into()),
        volume("f32", raw.iter().map(|v| v * 0.37 - 20.0).collect::<Vec<_>>().into()),
    ]
}

/// A 128³ scene of large empty regions and scattered ones: a ball, a plate far from it and single voxels of
/// smoke spread through the box, 30 of them (a linear congruential sequence, so the test is the same every run).
fn sparse_scene() -> Volume {
    let n = 128;
    Volume::new(Path::new("sparse"), [n, n, n], [1.0; 3], sparse_values(n)).unwrap()
}

/// The values of [`sparse_scene`], `n`³ of them (x fastest).
fn sparse_values(n: usize) -> Vec<f32> {
    let mut data = vec![0f32; n * n * n];
    let at = |x: usize, y: usize, z: usize| x + n * (y + n * z);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let d2 = |c: [f64; 3]| (0..3).map(|a| ([x, y, z][a] as f64 - c[a]).powi(2)).sum::<f64>();
                if d2([40.0, 70.0, 60.0]) < 18.0 * 18.0 {
                    data[at(x, y, z)] = 120.0;
                }
                if (100..103).contains(&z) && (80..120).contains(&x) && (10..60).contains(&y) {
                    data[at(x, y, z)] = 220.0;
                }
            }
        }
    }
    let mut seed = 12345u64;
    for _ in 0..30 {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let i = (seed >> 33) as usize % (n * n * n);
        data[i] = 70.0;
    }
    data
}

/// [`sparse_scene`] as labels (smoke 1, the ball 2, the plate 3) in one-byte voxels, and its materials.
fn sparse_labels() -> (Volume, [MaterialClass; 3]) {
    let n = 128;
    let label = |v: &f32| match *v as u32 {
        70 => 1u8,
        120 => 2,
        220 => 3,
        _ => 0,
    };
    let voxels: Vec<u8> = sparse_values(n).iter().map(label).collect();
    let vol = Volume::new(Path::new("sparse labels"), [n, n, n], [1.0; 3], voxels).unwrap();
    let mats = [
        MaterialClass::new([1.0, 1.0], 0.05),
        MaterialClass::new([2.0, 2.0], 0.3),
        MaterialClass::new([3.0, 3.0], 0.8),
    ];
    (vol, mats)
}

#[test]
fn groups_of_empty_bricks_are_jumped_with_the_frame_of_brick_by_brick_skipping() {
    let vol = sparse_scene();
    let mats = [
        MaterialClass::new([50.0, 90.0], 0.05),
        MaterialClass::new([100.0, 150.0], 0.3),
        MaterialClass::new([200.0, 255.0], 0.8),
    ];
    // Half the jumps at most.
    groups_against_bricks(&vol, &mats, Interpolation::Trilinear, 0.5);
}

/// Label mode jumps over groups of empty bricks as the value loop does (its own loop, `march`).
#[test]
fn label_mode_jumps_groups_of_empty_bricks_with_the_frame_of_brick_by_brick_skipping() {
    let (vol, mats) = sparse_labels();
    // Fewer groups are empty here: a label field spreads a material, so bricks near the smoke's single voxels
    // count as occupied, and a sample whose field block holds no material jumps one block (not grouped).
    // 572 080 jumps against 831 898 when written.
    groups_against_bricks(&vol, &mats, Interpolation::Labels, 0.75);
}

/// The frames and counts of a raycast jumping groups of empty bricks against one jumping brick by brick, over
/// several views; the grouped jumps must be at most `most` of the others.
fn groups_against_bricks(vol: &Volume, mats: &[MaterialClass], interpolation: Interpolation, most: f64) {
    let (mut jumps_grouped, mut jumps_brick) = (0, 0);
    // Face-on (rays along an axis: two direction components zero), oblique from above and below, and
    // almost straight down; the framed box and the whole box.
    for (azimuth_deg, elevation_deg, fit_materials) in
        [(0.0, 0.0, true), (90.0, 0.0, false), (30.0, 20.0, true), (135.0, -40.0, false), (10.0, 80.0, true)]
    {
        let cam = Camera { azimuth_deg, elevation_deg, zoom: 1.0, fit_materials };
        let opts = RaycastOptions { width: 96, height: 80, interpolation, ..Default::default() };
        for lanes in [true, false] {
            let (grouped, s_grouped) = raycast_with(vol, mats, None, &cam, &opts, lanes, true);
            let (brick, s_brick) = raycast_with(vol, mats, None, &cam, &opts, lanes, false);
            let what = format!("azimuth {azimuth_deg}, elevation {elevation_deg}, lanes {lanes}");
            assert!(
                grouped.data.iter().zip(&brick.data).all(|(a, b)| a.to_bits() == b.to_bits()),
                "the frame changed: {what}"
            );
            assert!(grouped.data.iter().any(|v| *v > 0.0), "nothing drawn: {what}");
            // The same samples taken and the same steps jumped over, in fewer jumps.
            assert_eq!(
                (s_grouped.samples, s_grouped.skipped, s_grouped.terminated),
                (s_brick.samples, s_brick.skipped, s_brick.terminated),
                "{what}"
            );
            assert!(s_grouped.skipped_bricks <= s_brick.skipped_bricks, "{what}");
            jumps_grouped += s_grouped.skipped_bricks;
            jumps_brick += s_brick.skipped_bricks;
        }
    }
    eprintln!("{jumps_grouped} jumps grouped against {jumps_brick} brick by brick");
    assert!(
        (jumps_grouped as f64) < most * jumps_brick as f64,
        "{jumps_grouped} jumps grouped against {jumps_brick} brick by brick"
    );
}

#[test]
fn a_group_is_empty_only_when_all_its_bricks_are_and_the_largest_is_found_first() {
    use classify::{SPAN_SHIFTS, Spans};
    // 20 × 9 × 5 bricks (groups at the far faces hold fewer), all empty but two.
    let counts = [20, 9, 5];
    let mut class = vec![classify::EMPTY; counts.iter().product()];
    let at = |b: [usize; 3]| b[0] + counts[0] * (b[1] + counts[1] * b[2]);
    class[at([3, 1, 1])] = classify::MIXED;
    class[at([19, 8, 4])] = 1;
    let spans = Spans::new(&class, counts);
    assert_eq!(SPAN_SHIFTS.map(|s| 1 << s), [8, 4, 2]);
    // The brick's own 8-group holds [3, 1, 1]: its 4-group too; its 2-group [1, 0, 0] (bricks 2–3, 0–1,
    // 0–1) too; so no empty group holds it.
    assert_eq!(spans.empty_around([2, 0, 0]), None);
    // [5, 0, 0]: 8-group 0 is not empty, 4-group [1, 0, 0] (bricks 4–7, 0–3, 0–3) is.
    assert_eq!(spans.empty_around([5, 0, 0]), Some(([1, 0, 0], 4)));
    // [0, 2, 2]: 4-group [0, 0, 0] holds [3, 1, 1]; 2-group [0, 1, 1] (bricks 0–1, 2–3, 2–3) is empty.
    assert_eq!(spans.empty_around([0, 2, 2]), Some(([0, 1, 1], 2)));
    // [10, 0, 0]: the 8-group [1, 0, 0] (bricks 8–15, 0–7, 0–4) is empty.
    assert_eq!(spans.empty_around([10, 0, 0]), Some(([1, 0, 0], 8)));
    // The far corner's partial groups hold [19, 8, 4]; its neighbour [18, 8, 4] shares the 2-group.
    assert_eq!(spans.empty_around([19, 8, 4]), None);
    assert_eq!(spans.empty_around([18, 8, 4]), None);
    // [16, 8, 4]: the 8-group [2, 1, 0] and the 4-group [4, 2, 1] hold [19, 8, 4]; the 2-group [8, 4, 2] is empty.
    assert_eq!(spans.empty_around([16, 8, 4]), Some(([8, 4, 2], 2)));
}

#[test]
fn capped_label_blocks_are_traced_in_bands_sized_by_the_blocks_built() {
    // Eight labels in slabs of the x axis: a block holds one or two of them, while the store's worst case
    // (the one it must assume before any is built) holds all eight. A cap that fits an eighth of the
    // blocks of that worst case starts with bands of one pixel row; the blocks built show they are far
    // smaller, so the bands grow, and no block is built twice, and the image is the pinned store's.
    let n = 64;
    let mut data = vec![0f32; n * n * n];
    for (i, v) in data.iter_mut().enumerate() {
        *v = (1 + (i % n) / 8) as f32;
    }
    let vol = Volume::new(Path::new("slabs"), [n, n, n], [1.0; 3], data).unwrap();
    let mats: Vec<_> = (1..=8).map(|k| MaterialClass::new([k as f32, k as f32], 0.01)).collect();
    let cam = Camera { azimuth_deg: 30.0, elevation_deg: 40.0, ..Camera::default() };
    let base = RaycastOptions { width: 96, height: 96, interpolation: Interpolation::Labels, ..Default::default() };
    let (whole, s_whole) = raycast(&vol, &mats, None, &cam, &base);
    assert_eq!((s_whole.field_store, s_whole.field_evicted), (FieldStore::Pinned, 0));
    let slots = s_whole.field_peak - s_whole.field_bytes;
    let largest = (8 * 8 * 729 + 8 + 128) as u64;
    let cap = slots + s_whole.field_blocks * largest / 8;
    let (img, s) = raycast(&vol, &mats, None, &cam, &RaycastOptions { field_cache: Some(cap), ..base });
    assert!(img.data == whole.data, "the cap changed the image");
    assert!(matches!(s.field_store, FieldStore::Capped { least: 1, most } if most > 2), "{s:?}");
    assert_eq!(s.field_blocks, s_whole.field_blocks, "a block was built twice: {s:?}");
    assert!(s.field_peak <= cap + largest, "{} resident, cap {cap}", s.field_peak);
}
