//! Time per feasibility region (metamer mismatch region): one designed reflectance under D65, A and F11,
//! the F11 cell's region with the other two cells held within ΔE 0.5, at several numbers of support
//! directions (each direction one LP for the inner region and one for the outer region), plus placing a
//! target (one QP and one feasibility LP), one outer support LP and one a*–b* slice.
//! Run: `cargo bench --bench feasibility`.

use metamer::palette::random;

use criterion::{Criterion, criterion_group, criterion_main};
use metamer::colorimetry::Colorimetry;
use metamer::design::Values;
use metamer::design::feasibility::{self, DEFAULT_TOLERANCE, Problem};
use metamer::design::{self, SolveOptions};
use std::hint::black_box;

fn problem() -> Problem {
    let col = Colorimetry::default();
    let palette = random::batch_palette(1, 3, &col);
    let solved = design::solve(&palette, None, &col, &SolveOptions::default()).expect("the batch palette solves");
    let values = Values {
        lights: solved.palette.lights.iter().map(|e| e.spectrum).collect(),
        reflectances: solved.palette.reflectances.iter().map(|e| e.spectrum).collect(),
        free: solved.free.clone(),
    };
    Problem::new(&solved.palette, None, &col, &values, 2, DEFAULT_TOLERANCE).expect("a half-designed cell")
}

fn regions(c: &mut Criterion) {
    let p = problem();
    let mut group = c.benchmark_group("feasibility region of one cell (2 partners held)");
    group.sample_size(10);
    for n in [40usize, 160, 640] {
        group.bench_function(format!("{n} directions"), |b| {
            b.iter(|| feasibility::region(black_box(&p), n).map(|r| r.volume_lab))
        });
    }
    let region = feasibility::region(&p, feasibility::DEFAULT_DIRECTIONS).expect("region");
    group.bench_function("place the target (one QP)", |b| {
        b.iter(|| feasibility::place(black_box(&p), &region, &p.target).map(|v| v.signed_delta_e))
    });
    let d = p.jacobian(&p.achieved).transpose() * nalgebra::Vector3::new(0.0, 1.0, 0.0);
    group.bench_function("one inner support LP", |b| b.iter(|| black_box(&p).support(&d).map(|s| s.is_some())));
    group.bench_function("one outer support LP", |b| b.iter(|| black_box(&p).outer_support(&d).map(|s| s.is_some())));
    let l = p.lab(&p.target)[0];
    group.bench_function("a*-b* slice at the target's L*", |b| {
        b.iter(|| feasibility::slice(black_box(&p), l, &p.target, feasibility::SLICE_DIRECTIONS).map(|s| s.is_some()))
    });
    group.finish();
}

criterion_group!(benches, regions);
criterion_main!(benches);
