//! The spectral factor model against the full-spectrum reference (issue 5's outside check): the engine
//! with four ColorChecker materials swept across D65 → A → F11; the factor-model frames must stay within
//! mean ΔE00 1.5 of the `--mode full` frames over non-black pixels. The RGB factor model's error is
//! printed beside it (it is expected to be worse, but is not bounded here).

use metamer::colorimetry::Colorimetry;
use metamer::render::accuracy::compare_models;
use metamer::render::dial::{Dial, DialStop};
use metamer::render::raycast::{Camera, MaterialClass};
use metamer::render::scene::{Material, Scene, SceneSettings, colorchecker_palette};
use metamer::volume::{Volume, generate};
use std::path::{Path, PathBuf};

fn shared_dir() -> Option<PathBuf> {
    let beside = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared");
    [beside, PathBuf::from("/work/shared")].into_iter().find(|p| p.join("volumes").is_dir())
}

/// Four ColorChecker materials over value ranges of `volume`, dial D65 → A → F11.
fn four_material_scene(volume: Volume, ranges: [[f32; 2]; 4], opacities: [f32; 4]) -> Scene {
    let names = [("m1", "dark_skin"), ("m2", "foliage"), ("m3", "orange"), ("m4", "purplish_blue")];
    let palette = colorchecker_palette("check", &["D65", "A", "F11"], &names).expect("built-in spectra exist");
    let materials = palette
        .reflectances
        .iter()
        .zip(ranges.iter().zip(opacities))
        .map(|(r, (range, opacity))| Material {
            reflectance: r.name.clone(),
            spectrum: r.spectrum,
            class: MaterialClass { range: *range, opacity },
        })
        .collect();
    let dial =
        Dial::new(palette.lights.iter().map(|l| DialStop { name: l.name.clone(), spectrum: l.spectrum }).collect())
            .expect("three lights");
    Scene {
        path: None,
        palette,
        volume,
        materials,
        camera: Camera::default(),
        dial,
        settings: SceneSettings::default(),
    }
}

fn check(scene: &Scene, size: usize, frames: usize, what: &str) {
    let col = Colorimetry::default();
    let r = compare_models(scene, &col, size, frames).expect("render");
    println!(
        "{what}: {} frames, {} px, m = {}: factor ΔE00 mean {:.3} p95 {:.3} max {:.3} | rgb ΔE00 mean {:.3} p95 {:.3} max {:.3}",
        r.frames, r.pixels, r.dimension, r.factor.mean, r.factor.p95, r.factor.max, r.rgb.mean, r.rgb.p95, r.rgb.max
    );
    assert!(r.pixels > size * size / 20, "{what}: too few non-black pixels ({}) for a meaningful check", r.pixels);
    assert!(r.factor.mean <= 1.5, "{what}: factor model mean ΔE00 {:.3} exceeds 1.5", r.factor.mean);
}

#[test]
fn factor_model_tracks_full_spectra_on_the_generated_engine() {
    let vol = generate::engine_like(96);
    let s = generate::SMOKE_RANGE;
    let b = generate::BLOCK_RANGE;
    let i = generate::INNER_RANGE;
    let scene = four_material_scene(vol, [s, b, [i[0], 230.0], [230.5, i[1]]], [0.05, 0.15, 0.6, 0.6]);
    check(&scene, 96, 9, "generated engine");
}

#[test]
fn factor_model_tracks_full_spectra_on_the_shared_engine() {
    let Some(shared) = shared_dir() else {
        eprintln!("skipping: ../shared/volumes not found (looked beside the crate and in /work/shared)");
        return;
    };
    let vol = Volume::open(&shared.join("volumes/engine.nhdr")).expect("engine.nhdr reads");
    let scene =
        four_material_scene(vol, [[30.0, 80.0], [81.0, 160.0], [161.0, 200.0], [201.0, 255.0]], [0.02, 0.08, 0.3, 0.8]);
    check(&scene, 128, 9, "shared engine");
}
