//! The spectral factor model against the full-spectrum reference (issue 5's outside check): the engine
//! with four ColorChecker materials swept across D65 → A → F11; the factor-model frames must stay within
//! mean ΔE00 1.5 of the `--mode full` frames over non-black pixels. The RGB factor model's error is
//! printed beside it (it is expected to be worse, but is not bounded here).

use metamer::colorimetry::Colorimetry;
use metamer::render::{Scene, engine_check_scene, generated_check_scene};
use metamer::render::{compare_models, compare_views};
use metamer::volume::Volume;

fn check(scene: &Scene, size: usize, frames: usize, what: &str) {
    let col = Colorimetry::default();
    let r = compare_models(scene, &col, size, frames).expect("render");
    note!(
        "{what}: {} frames, {} px, m = {}: factor ΔE00 mean {:.3} p95 {:.3} max {:.3} (unquantised mean {:.4}) | rgb ΔE00 mean {:.3} p95 {:.3} max {:.3}",
        r.frames,
        r.pixels,
        r.dimension,
        r.factor.mean,
        r.factor.p95,
        r.factor.max,
        r.factor_unquantised.mean,
        r.rgb.mean,
        r.rgb.p95,
        r.rgb.max
    );
    assert!(r.pixels > size * size / 20, "{what}: too few non-black pixels ({}) for a meaningful check", r.pixels);
    assert!(r.factor.mean <= 1.5, "{what}: factor model mean ΔE00 {:.3} exceeds 1.5", r.factor.mean);
}

pub(crate) fn factor_model_tracks_full_spectra_on_the_generated_engine() {
    check(&generated_check_scene(96), 96, 9, "generated engine");
}

pub(crate) fn factor_model_tracks_full_spectra_on_the_shared_engine() {
    let dir = crate::data::volumes();
    let vol = Volume::open(&dir.join("engine.nhdr")).expect("engine.nhdr reads");
    check(&engine_check_scene(vol), 128, 9, "shared engine");
}

/// What the skips change (issue 24): empty bricks stepped over, single-material bricks taken from the
/// brick table, rays stopped at transmittance 0.01, against the same raycast with both switches off.
fn skips_against_reference(scene: &Scene, size: usize, what: &str) {
    use metamer::render::Mode;
    use metamer::render::{Acceleration, colour_model, render_views};
    let col = Colorimetry::default();
    let model = colour_model(scene, Mode::Factor, &col).expect("model");
    let view = |accel| render_views(scene, vec![model.clone()], size, size, accel, None).pop().expect("view");
    let off = Acceleration { early_termination: false, empty_space_skipping: false, ..Acceleration::default() };
    let reference = view(off);
    let skipping = view(Acceleration { empty_space_skipping: true, ..off });
    // The default threshold, and the cost and error of others (printed).
    for t in [0.01, 0.005, 0.002] {
        let v = view(Acceleration { termination_transmittance: t, ..Acceleration::default() });
        let e = compare_views(scene, &col, &reference, &v, 9);
        note!(
            "{what}: termination at transmittance {t}: {} samples, ΔE00 p99 {:.3} max {:.3}",
            v.stats.samples,
            e.p99,
            e.max
        );
    }
    let both = view(Acceleration::default());
    let s = both.stats;
    assert!(s.skipped > 0 && s.uniform > 0 && s.terminated > 0, "{what}: nothing skipped: {s:?}");
    assert!(s.samples < reference.stats.samples, "{what}: {s:?} vs {:?}", reference.stats);
    let (e_skip, e_both) =
        (compare_views(scene, &col, &reference, &skipping, 9), compare_views(scene, &col, &reference, &both, 9));
    note!(
        "{what}: default termination {}: samples {} → {} ({} in single-material bricks, {} steps skipped, {} rays stopped); ΔE00 skipping only: \
         mean {:.4} p99 {:.3} max {:.3}; with early termination: mean {:.4} p99 {:.3} max {:.3} over {} px",
        Acceleration::default().termination_transmittance,
        reference.stats.samples,
        s.samples,
        s.uniform,
        s.skipped,
        s.terminated,
        e_skip.mean,
        e_skip.p99,
        e_skip.max,
        e_both.mean,
        e_both.p99,
        e_both.max,
        e_both.pixels
    );
    assert!(e_both.pixels > size * size / 20, "{what}: too few pixels compared ({})", e_both.pixels);
    // Skipping empty and single-material bricks reconstructs the same samples: at most 8-bit rounding.
    assert!(e_skip.p99 < 0.05 && e_skip.max < 1.0, "{what}: skipping changed the frames: {e_skip:?}");
    assert!(e_both.p99 < 0.5, "{what}: early termination p99 ΔE00 {:.3} ≥ 0.5", e_both.p99);
}

pub(crate) fn skips_stay_within_half_a_delta_e_at_p99_on_the_generated_engine() {
    skips_against_reference(&generated_check_scene(96), 128, "generated engine");
}

pub(crate) fn skips_stay_within_half_a_delta_e_at_p99_on_the_shared_engine() {
    let dir = crate::data::volumes();
    let vol = Volume::open(&dir.join("engine.nhdr")).expect("engine.nhdr reads");
    skips_against_reference(&engine_check_scene(vol), 192, "shared engine");
}
