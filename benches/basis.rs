//! Training time of the spectral factor basis on the reference set (24 ColorChecker × 7 lights), m = 7:
//! the whole default training, and its stages up to the T refinement.
//! Run: `cargo bench --bench basis`.

use criterion::{Criterion, criterion_group, criterion_main};
use metamer::basis::{self, TrainOptions, TrainingSet};
use metamer::colorimetry::Colorimetry;
use std::hint::black_box;
use std::time::Duration;

fn training(c: &mut Criterion) {
    let colorimetry = Colorimetry::default();
    let set = TrainingSet::colorchecker_seven_lights(&colorimetry);
    let mut group = c.benchmark_group("basis training, ColorChecker x 7 lights, m = 7");
    group.sample_size(10).measurement_time(Duration::from_secs(20));
    for (name, options) in [
        ("pca", TrainOptions::pca_only()),
        ("pca + sharpening + T", TrainOptions::transform_only()),
        ("full (default)", TrainOptions::default()),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| basis::train(black_box(&set), 7, &colorimetry, &options).map(|t| t.basis.b[(0, 0)]))
        });
    }
    group.finish();
}

criterion_group!(benches, training);
criterion_main!(benches);
