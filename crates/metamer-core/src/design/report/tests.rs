//! Unit tests of `report.rs` (a sibling file to keep `report.rs` about the code).

use super::*;

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64) / ((1u64 << 53) as f64)
}

/// Reachable targets are hit (colour within the walk's tolerance); for the others the closest colour is
/// no farther than the bounded least-squares solve of the colour rows finds.
#[test]
fn closest_reachable_colours() {
    let col = Colorimetry::default();
    let palette = crate::palette::random::batch_palette(1, 3, &col);
    let design = Design::new(&palette, None, &col).unwrap();
    let bounds = Bounds::new(0.0, 1.0);
    let mut seed = 5u64;
    let (mut hits, mut misses) = (0, 0);
    for light in &palette.lights {
        let reach = Reach::new(&design, Form::Full, &light.spectrum);
        for k in 0..60 {
            let truth = Spectrum(crate::spectrum::Samples::from_fn(|_, _| lcg(&mut seed)));
            let start = Spectrum(crate::spectrum::Samples::from_fn(|_, _| lcg(&mut seed).round()));
            // Every third target is pushed out of reach (scaled past what [0, 1] allows, or negative).
            let mut target = reach.op * truth.0;
            if k % 3 == 1 {
                target *= 2.5;
            } else if k % 3 == 2 {
                target[1] = -0.1;
            }
            let got = reach.closest(&start, bounds, &target);
            if k % 3 == 0 {
                assert!((got - target).amax() <= EXACT_HIT_TOLERANCE * (1.0 + target.amax()), "{got} vs {target}");
                hits += 1;
            } else {
                let sys = LinearSystem {
                    a: DMatrix::from_fn(3, SAMPLES, |r, c| reach.op[(r, c)]).into(),
                    b: DVector::from_column_slice(target.as_slice()),
                    lower: DVector::zeros(SAMPLES),
                    upper: DVector::from_element(SAMPLES, 1.0),
                };
                let best = lsq::solve_system(&sys);
                let reference = reach.op * nalgebra::SVector::<f64, SAMPLES>::from_column_slice(best.x.as_slice());
                // The ridge (1e-4) may cost a little distance; far less than a ΔE00 of 0.01.
                assert!((got - target).norm() <= (reference - target).norm() + 1e-6, "{got} vs {reference}");
                misses += 1;
            }
        }
    }
    assert!(hits > 50 && misses > 100);
}

#[test]
fn fixed_prints_as_the_standard_formatter() {
    let mut seed = 11u64;
    let mut next = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        seed
    };
    let mut values = vec![0.0, -0.0, 0.5, -0.5, 0.125, 2.675, 1e-9, -1e-9, 0.00005, 0.99995, 1e12, 123.456, f64::NAN];
    values.extend([f64::INFINITY, f64::NEG_INFINITY, 0.015, 0.025, -0.005, 1.0 / 3.0, 5e-5, 4.99995]);
    for _ in 0..20000 {
        let bits = next();
        let scale = 10f64.powi((next() % 14) as i32 - 6);
        values.push(((bits >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * scale);
        values.push(f64::from_bits(next()));
    }
    for x in values {
        for d in 0..8 {
            assert_eq!(Fixed(x, d).to_string(), format!("{x:.d$}"), "{x:e} with {d} decimals");
        }
        assert_eq!(format!("{:>9}", Fixed(x, 2)), format!("{x:>9.2}"));
    }
}

/// The cells' colours with each light's white found once are each cell's own [`CellResult::new`], to the
/// bit, on a palette whose cells sit under three different lights (a white taken from the wrong light
/// changes their ΔE00).
#[test]
fn cell_results_with_the_whites_once_are_each_cells_own() {
    let col = Colorimetry::default();
    let palette = crate::palette::random::batch_palette(40, 9, &col);
    assert!(palette.colours.iter().any(|c| c.light != palette.colours[0].light), "cells under several lights");
    let design = Design::new(&palette, None, &col).expect("valid");
    let v = design.start_values();
    let cells = cell_results(&palette, None, &col, &v);
    assert_eq!(cells.len(), palette.colours.len());
    for (k, (got, c)) in cells.iter().zip(&palette.colours).enumerate() {
        let pair = (&v.lights[c.light], &v.reflectances[c.reflectance]);
        let own = CellResult::new(k, c.target, pair, c.is_active(), None, &col);
        assert_eq!(got.delta_e_full.to_bits(), own.delta_e_full.to_bits(), "cell {k}");
        assert_eq!(got, &own, "cell {k}");
    }
}

/// The objective taking the cells' full colours from the cells' pass is the objective's own to the bit —
/// at the start and at the solution, on the pool and off it, on batches whose cells include some with no
/// term (a fixed reflectance's) and some of another weight — and it does use them: colours taken from the
/// neighbouring cell change it.
#[test]
fn the_objective_with_the_cells_colours_is_the_objectives_own() {
    let col = Colorimetry::default();
    let mut mixed = crate::palette::random::reachable_batch_palette(200, 12, &col);
    mixed.reflectances[5].design = false;
    mixed.colours[7].weight = 3.0;
    for palette in [crate::palette::random::batch_palette(200, 11, &col), mixed] {
        let design = Design::new(&palette, None, &col).expect("valid");
        let start = design.start_values();
        let options = crate::design::SolveOptions::default();
        let solved = crate::design::solve_with(&palette, None, &col, &options, true).expect("solved");
        let mut at_solution = start.clone();
        for (to, from) in at_solution.reflectances.iter_mut().zip(&solved.palette.reflectances) {
            *to = from.spectrum;
        }
        for v in [&start, &at_solution] {
            let cells = cell_results(&palette, None, &col, v);
            for parallel in [false, true] {
                let own = design.objective_with(v, parallel);
                let taken = design.objective_with_colours(v, parallel, &|k| cells.get(k).map(|c| c.rgb_full));
                assert_eq!(taken.to_bits(), own.to_bits());
                let shifted = design.objective_with_colours(v, parallel, &|k| cells.get(k + 1).map(|c| c.rgb_full));
                assert_ne!(shifted.to_bits(), own.to_bits(), "the colours given are used");
            }
        }
        assert_eq!(solved.objective.to_bits(), design.objective_with(&at_solution, true).to_bits());
    }
}
