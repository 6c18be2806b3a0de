//! Optimality of the design engine against an independent QP solver (clarabel) on random convex
//! palettes: the objective reaches the oracle's optimum within 1e-6 relative, the reported objective is
//! the sum of squares at the returned spectra (assembled here independently of the engine), and every
//! bound holds to 1e-9.

use crate::common;

use crate::common::random;
use common::{oracle, stack};
use metamer::colorimetry::Colorimetry;
use metamer::design::{self, SolveOptions};
use metamer::palette::Palette;
use nalgebra::DVector;
use proptest::prelude::*;

fn check(seed: u64) {
    check_palette(&random::convex_palette(seed, &Colorimetry::default()), seed);
}

fn check_palette(p: &Palette, seed: u64) {
    let p = p.clone();
    let col = Colorimetry::default();
    let sol = design::solve(&p, None, &col, &SolveOptions::default()).expect("solve");
    let st = stack(&p, &col);
    // Our solution as a stacked vector.
    let mut x = DVector::zeros(st.a.ncols());
    for (i, o) in st.light_off.iter().enumerate() {
        if let Some(o) = o {
            x.rows_mut(*o, 31).copy_from(&sol.palette.lights[i].spectrum.0);
        }
    }
    for (i, o) in st.refl_off.iter().enumerate() {
        if let Some(o) = o {
            x.rows_mut(*o, 31).copy_from(&sol.palette.reflectances[i].spectrum.0);
        }
    }
    for (g, o) in st.free_off.iter().enumerate() {
        x.rows_mut(*o, 3).copy_from(&sol.free[g]);
    }
    for i in 0..x.len() {
        assert!(x[i] >= st.lower[i] - 1e-9 && x[i] <= st.upper[i] + 1e-9, "seed {seed}: bound {i} violated");
    }
    let ours = (&st.a * &x - &st.b).norm_squared();
    assert!(
        (ours - sol.objective).abs() <= 1e-12 * (1.0 + ours),
        "seed {seed}: reported {} but sum of squares {ours}",
        sol.objective
    );
    let xo = oracle(&st);
    let best = (&st.a * &xo - &st.b).norm_squared();
    assert!(ours <= best * (1.0 + 1e-6) + 1e-12, "seed {seed}: ours {ours} oracle {best} ({})", p.name);
    assert!(sol.kkt_residual < 1e-6, "seed {seed}: kkt {}", sol.kkt_residual);
    assert!(sol.cells.iter().all(|c| c.rgb_full.iter().all(|v| v.is_finite())));
}

#[test]
fn fixed_seeds_match_the_oracle() {
    for seed in 0..40 {
        check(seed);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    #[test]
    fn random_convex_palettes_match_the_oracle(seed in any::<u64>()) {
        check(seed);
    }
}

/// Two similar lights, one designed reflectance, both cells in one bounded free group (a metamer pair).
#[test]
fn free_group_metamer_matches_the_oracle() {
    let c = Colorimetry::default();
    let lights = ["D65", "D50"]
        .iter()
        .map(|n| random::luminance_light(n, metamer::spectrum::Spectrum::illuminant(n).unwrap(), &c, false))
        .collect();
    let mut cells: Vec<_> = (0..2).map(|l| random::cell(l, 0, nalgebra::Vector3::zeros(), 1.0)).collect();
    for cell in &mut cells {
        cell.free = Some(0);
    }
    let p = Palette {
        name: "metamer pair".into(),
        settings: metamer::palette::Settings {
            reflectance_bounds: metamer::palette::Bounds::new(0.0, 1.0),
            ..Default::default()
        },
        lights,
        reflectances: vec![random::entry(
            "S",
            metamer::palette::Kind::Reflectance,
            metamer::spectrum::Spectrum::flat(0.5),
            true,
        )],
        colours: cells,
        free: vec![metamer::palette::FreeGroup {
            name: "G".into(),
            lower: nalgebra::Vector3::from_element(0.2),
            upper: nalgebra::Vector3::from_element(0.4),
        }],
        mixtures: Vec::new(),
        paths: Vec::new(),
    };
    check_palette(&p, 0);
}
