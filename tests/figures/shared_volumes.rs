//! The public volumes themselves (`$METAMER_DATA` or `../shared`): every CT and the frog labels read with
//! their documented grids, and the engine's factor model tracks its 31-sample reference along a sweep.

use metamer::colorimetry::Colorimetry;
use metamer::volume::Volume;

/// The engine swept D65 → A → F11 with four ColorChecker materials: the factor model within mean ΔE00
/// 1.5 of the full-spectrum frames.
pub(crate) fn engine_sweep_factor_mode_tracks_full_mode() {
    use metamer::render::compare_models;
    let volumes = crate::data::volumes();
    let volume = Volume::open(&volumes.join("engine.nhdr")).expect("engine.nhdr reads");
    let materials = [
        ("smoke", "cyan", [20.0, 90.0], 0.02),
        ("inner", "orange", [91.0, 127.0], 0.1),
        ("block", "green", [128.0, 175.0], 0.3),
        ("hot", "red", [176.0, 255.0], 0.6),
    ];
    let scene = metamer::render::colorchecker_scene("issue11", volume, &["D65", "A", "F11"], &materials)
        .expect("built-in lights and patches");
    let r = compare_models(&scene, &Colorimetry::default(), 128, 9).expect("renders");
    note!(
        "engine sweep D65 → A → F11, 4 ColorChecker materials, m = {}: factor vs full mean ΔE00 {:.3} p95 {:.3} \
         (unquantised mean {:.3}); RGB model mean {:.3} p95 {:.3}; {} px over {} frames",
        r.dimension,
        r.factor.mean,
        r.factor.p95,
        r.factor_unquantised.mean,
        r.rgb.mean,
        r.rgb.p95,
        r.pixels,
        r.frames
    );
    assert!(r.pixels > 128 * 128 / 20, "too few non-black pixels ({})", r.pixels);
    assert!(r.factor.mean <= 1.5, "factor mode {:.3} mean ΔE00 from full mode", r.factor.mean);
}

/// Each public CT volume and the frog's tissue labels read with their documented grid, spacing and range.
pub(crate) fn every_public_volume_reads() {
    let dir = crate::data::volumes();
    for (name, dims) in [
        ("engine.nhdr", [256, 256, 128]),
        ("lobster.nhdr", [301, 324, 56]),
        ("fuel.nhdr", [64, 64, 64]),
        ("bonsai.nhdr", [256, 256, 256]),
    ] {
        let vol = Volume::open(&dir.join(name)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(vol.dims, dims, "{name}");
        assert!(vol.value_range[0] >= 0.0 && vol.value_range[1] <= 255.0 && vol.value_range[1] > 100.0, "{name}");
    }
    let frog = Volume::open(&dir.join("frog_tissues.vti")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(frog.dims, [500, 470, 136]);
    assert_eq!(frog.spacing, [1.0, 1.0, 1.5]);
    assert_eq!(frog.value_range, [0.0, 29.0]);
    // Labels are whole numbers, and many of the 30 tissues occur.
    let mut seen = [false; 30];
    for v in frog.voxels.to_f32_vec() {
        assert_eq!(v.fract(), 0.0);
        seen[v as usize] = true;
    }
    assert!(seen.iter().filter(|s| **s).count() >= 20);
}
