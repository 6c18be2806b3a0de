//! Criterion benches of the renderer's kernels: the raycast of the generated engine (256² image) with
//! the acceleration switches, and relighting one frame (3×K matrix per pixel + sRGB table) for the
//! factor, full and RGB models at 384². Run: `cargo bench --bench render`.

use criterion::{Criterion, criterion_group, criterion_main};
use metamer::colorimetry::Colorimetry;
use metamer::render::BrickMap;
use metamer::render::generated_check_scene;
use metamer::render::{Acceleration, colour_model, render_views};
use metamer::render::{ColourModel, Mode, SrgbLut, relight_srgb8};
use std::hint::black_box;

fn raycast(c: &mut Criterion) {
    let scene = generated_check_scene(192);
    let col = Colorimetry::default();
    let model = ColourModel::full(col);
    let bricks = BrickMap::new(&scene.volume, 8);
    let mut group = c.benchmark_group("raycast_256");
    group.sample_size(10);
    for (name, et, ess) in [
        ("both_on", true, true),
        ("no_skipping", true, false),
        ("no_termination", false, true),
        ("both_off", false, false),
    ] {
        let accel = Acceleration { early_termination: et, empty_space_skipping: ess, ..Acceleration::default() };
        group.bench_function(name, |b| {
            b.iter(|| render_views(black_box(&scene), vec![model.clone()], 256, 256, accel, Some(&bricks)))
        });
    }
    group.finish();
}

fn relight(c: &mut Criterion) {
    let scene = generated_check_scene(128);
    let col = Colorimetry::default();
    let factor = colour_model(&scene, Mode::Factor, &col).expect("trained basis");
    let models = vec![factor, ColourModel::full(col.clone()), ColourModel::rgb(col)];
    let views = render_views(&scene, models, 384, 384, Acceleration::default(), None);
    let lut = SrgbLut::new();
    let light = scene.dial.light_at(0.5);
    let mut group = c.benchmark_group("relight_384");
    for v in &views {
        let m = v.model.frame_matrix(&light, 1.0);
        let mut out = vec![0u8; 384 * 384 * 3];
        group.bench_function(v.model.mode.as_str(), |b| {
            b.iter(|| relight_srgb8(black_box(&v.image), &m, &lut, &mut out))
        });
    }
    group.finish();
}

criterion_group!(benches, raycast, relight);
criterion_main!(benches);
