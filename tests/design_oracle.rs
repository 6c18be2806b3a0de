//! Optimality of the design engine against an independent QP solver (clarabel) on random convex
//! palettes: the objective reaches the oracle's optimum within 1e-6 relative, the reported objective is
//! the sum of squares at the returned spectra (assembled here independently of the engine), and every
//! bound holds to 1e-9.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};
use metamer::colorimetry::Colorimetry;
use metamer::design::{self, SolveOptions, random};
use metamer::palette::Palette;
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

/// An independent assembly of DESIGN_SPEC §2 (full colour rows only): returns (A, b, lower, upper,
/// unknowns) where unknowns lists (kind, index) per 31- or 3-block.
struct Stacked {
    a: DMatrix<f64>,
    b: DVector<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    /// Offsets: lights, reflectances (None when fixed), free groups.
    light_off: Vec<Option<usize>>,
    refl_off: Vec<Option<usize>>,
    free_off: Vec<usize>,
}

fn stack(p: &Palette, col: &Colorimetry) -> Stacked {
    let mut n = 0;
    let mut lower = Vec::new();
    let mut upper = Vec::new();
    let mut offs = |entries: &[metamer::palette::SpectrumEntry], lower: &mut Vec<f64>, upper: &mut Vec<f64>| {
        entries
            .iter()
            .map(|e| {
                e.design.then(|| {
                    let b = p.bounds_of(e);
                    lower.extend(std::iter::repeat_n(b.lower, 31));
                    upper.extend(std::iter::repeat_n(b.upper, 31));
                    n += 31;
                    n - 31
                })
            })
            .collect::<Vec<_>>()
    };
    let light_off = offs(&p.lights, &mut lower, &mut upper);
    let refl_off = offs(&p.reflectances, &mut lower, &mut upper);
    let free_off: Vec<usize> = p
        .free
        .iter()
        .map(|g| {
            lower.extend(g.lower.iter());
            upper.extend(g.upper.iter());
            n += 3;
            n - 3
        })
        .collect();
    let mut rows: Vec<(Vec<(usize, f64)>, f64)> = Vec::new();
    for c in &p.colours {
        if !c.enabled || c.weight == 0.0 {
            continue;
        }
        let (lo, ro) = (light_off[c.light], refl_off[c.reflectance]);
        if lo.is_none() && ro.is_none() && c.free.is_none() {
            continue;
        }
        assert!(lo.is_none() || ro.is_none(), "convex palettes have no bilinear cells");
        let w = c.weight / 3f64.sqrt();
        let e = &p.lights[c.light].spectrum.0;
        let s = &p.reflectances[c.reflectance].spectrum.0;
        for ch in 0..3 {
            let mut row = Vec::new();
            let mut rhs = 0.0;
            match (lo, ro) {
                (Some(o), None) => (0..31).for_each(|k| row.push((o + k, w * col.q_rgb[(ch, k)] * s[k]))),
                (None, Some(o)) => (0..31).for_each(|k| row.push((o + k, w * col.q_rgb[(ch, k)] * e[k]))),
                _ => rhs -= w * (0..31).map(|k| col.q_rgb[(ch, k)] * e[k] * s[k]).sum::<f64>(),
            }
            match c.free {
                Some(g) => row.push((free_off[g] + ch, -w)),
                None => rhs += w * c.target[ch],
            }
            rows.push((row, rhs));
        }
    }
    let wd = p.settings.smoothness / (31f64.sqrt() * 6f64.sqrt());
    if wd > 0.0 {
        for o in light_off.iter().chain(&refl_off).flatten() {
            for i in 0..31 {
                let mut row = vec![(o + i, 2.0 * wd)];
                if i > 0 {
                    row.push((o + i - 1, -wd));
                }
                if i < 30 {
                    row.push((o + i + 1, -wd));
                }
                rows.push((row, 0.0));
            }
        }
    }
    let mut a = DMatrix::zeros(rows.len(), n);
    let mut b = DVector::zeros(rows.len());
    for (r, (row, rhs)) in rows.iter().enumerate() {
        for (c, v) in row {
            a[(r, *c)] += v;
        }
        b[r] = *rhs;
    }
    Stacked { a, b, lower, upper, light_off, refl_off, free_off }
}

/// The oracle: clarabel on ½xᵀ(2AᵀA)x − 2bᵀAx with the box as linear inequalities.
fn oracle(s: &Stacked) -> DVector<f64> {
    let n = s.a.ncols();
    let h = s.a.tr_mul(&s.a) * 2.0;
    let mut colptr = vec![0];
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    for j in 0..n {
        for i in 0..=j {
            if h[(i, j)] != 0.0 {
                rowval.push(i);
                nzval.push(h[(i, j)]);
            }
        }
        colptr.push(rowval.len());
    }
    let p = CscMatrix::new(n, n, colptr, rowval, nzval);
    let q: Vec<f64> = (s.a.tr_mul(&s.b) * -2.0).iter().copied().collect();
    let mut cons: Vec<(usize, f64, f64)> = Vec::new(); // (var, sign, rhs): sign·x ≤ rhs
    for i in 0..n {
        if s.upper[i].is_finite() {
            cons.push((i, 1.0, s.upper[i]));
        }
        if s.lower[i].is_finite() {
            cons.push((i, -1.0, -s.lower[i]));
        }
    }
    let m = cons.len();
    let mut colptr = vec![0];
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    for j in 0..n {
        for (r, (v, sign, _)) in cons.iter().enumerate() {
            if *v == j {
                rowval.push(r);
                nzval.push(*sign);
            }
        }
        colptr.push(rowval.len());
    }
    let acon = CscMatrix::new(m, n, colptr, rowval, nzval);
    let bcon: Vec<f64> = cons.iter().map(|c| c.2).collect();
    let cones = [NonnegativeConeT(m)];
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-12)
        .tol_gap_rel(1e-12)
        .tol_feas(1e-12)
        .max_iter(500)
        .build()
        .unwrap();
    let mut solver = DefaultSolver::new(&p, &q, &acon, &bcon, &cones, settings).unwrap();
    solver.solve();
    assert!(
        matches!(solver.solution.status, SolverStatus::Solved | SolverStatus::AlmostSolved),
        "oracle status {:?}",
        solver.solution.status
    );
    // Clarabel's interior point stays a hair inside or outside the box: clamp to compare objectives.
    DVector::from_fn(n, |i, _| solver.solution.x[i].max(s.lower[i]).min(s.upper[i]))
}

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
    };
    check_palette(&p, 0);
}
