//! Solver speed (DESIGN_SPEC §2 designs): a single bounded reflectance design under 3 lights, batches of
//! independent bounded and unbounded designs, blocks against one dense stacked system, and n×n joint
//! palettes (TOG 2009 Fig. 3 protocol). Errors for the same cases: `metamer::bench::solve::run`.
//! Run: `cargo bench --bench solve`. The scipy BVLS baseline: `benches/scipy_bvls.py`.

use metamer::palette::random;

use criterion::{Criterion, criterion_group, criterion_main};
use metamer::colorimetry::Colorimetry;
use metamer::design::{self, Design, SolveOptions};
use metamer::palette::Bounds;
use std::hint::black_box;

fn single_and_batches(c: &mut Criterion) {
    let col = Colorimetry::default();
    let options = SolveOptions::default();
    let mut group = c.benchmark_group("independent reflectance designs, 3 lights");
    group.sample_size(20);
    for n in [1usize, 100, 1200] {
        let bounded = random::batch_palette(n, 1, &col);
        let mut unbounded = bounded.clone();
        unbounded.settings.reflectance_bounds = Bounds::UNBOUNDED;
        group.bench_function(format!("{n} bounded [0,1]"), |b| {
            b.iter(|| design::solve(black_box(&bounded), None, &col, &options).map(|s| s.objective))
        });
        group.bench_function(format!("{n} unbounded"), |b| {
            b.iter(|| design::solve(black_box(&unbounded), None, &col, &options).map(|s| s.objective))
        });
    }
    group.finish();
}

fn blocks_vs_dense(c: &mut Criterion) {
    let col = Colorimetry::default();
    let p = random::batch_palette(20, 2, &col);
    let mut group = c.benchmark_group("20 bounded designs: blocks vs one dense system");
    group.sample_size(10);
    group.bench_function("blocks (parallel)", |b| {
        b.iter(|| design::solve_with(black_box(&p), None, &col, &SolveOptions::default(), true).map(|s| s.objective))
    });
    group.bench_function("blocks (one thread)", |b| {
        b.iter(|| design::solve_with(black_box(&p), None, &col, &SolveOptions::default(), false).map(|s| s.objective))
    });
    let d = Design::new(&p, None, &col).expect("valid palette");
    let start = d.start_values();
    group.bench_function("one dense system", |b| b.iter(|| design::solve_dense(black_box(&d), &start).map(|r| r.1)));
    group.finish();
}

fn joint(c: &mut Criterion) {
    let col = Colorimetry::default();
    let mut group = c.benchmark_group("joint n×n palettes, positivity, smoothness 0.001");
    group.sample_size(10);
    for n in [3usize, 5, 10] {
        let p = random::capacity_palette(n, 0, &col);
        group.bench_function(format!("{n}x{n}"), |b| {
            b.iter(|| design::solve(black_box(&p), None, &col, &SolveOptions::default()).map(|s| s.objective))
        });
    }
    group.finish();
}

criterion_group!(benches, single_and_batches, blocks_vs_dense, joint);
criterion_main!(benches);
