//! The spectral factor model against the full-spectrum reference (issue 5's outside check): the engine
//! with four ColorChecker materials swept across D65 → A → F11; the factor-model frames must stay within
//! mean ΔE00 1.5 of the `--mode full` frames over non-black pixels. The RGB factor model's error is
//! printed beside it (it is expected to be worse, but is not bounded here).

use metamer::colorimetry::Colorimetry;
use metamer::render::accuracy::compare_models;
use metamer::render::scene::{Scene, engine_check_scene, generated_check_scene};
use metamer::volume::Volume;

fn check(scene: &Scene, size: usize, frames: usize, what: &str) {
    let col = Colorimetry::default();
    let r = compare_models(scene, &col, size, frames).expect("render");
    println!(
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

#[test]
fn factor_model_tracks_full_spectra_on_the_generated_engine() {
    check(&generated_check_scene(96), 96, 9, "generated engine");
}

#[test]
fn factor_model_tracks_full_spectra_on_the_shared_engine() {
    let Some(dir) =
        crate::common::data::volumes_or_skip("render_accuracy::factor_model_tracks_full_spectra_on_the_shared_engine")
    else {
        return;
    };
    let vol = Volume::open(&dir.join("engine.nhdr")).expect("engine.nhdr reads");
    check(&engine_check_scene(vol), 128, 9, "shared engine");
}
