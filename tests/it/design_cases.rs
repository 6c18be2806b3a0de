//! Degenerate and infeasible designs, joint (bilinear) design, gradient checks and the subspace rows.

use crate::common::random;
use metamer::basis::Basis;
use metamer::colorimetry::Colorimetry;
use metamer::design::NonlinearProblem;
use metamer::design::{self, DesignError, SolveOptions};
use metamer::design::{Design, Layout};
use metamer::palette::{Bounds, FreeGroup, Kind, Palette, Settings};
use metamer::spectrum::Spectrum;
use nalgebra::{DMatrix, DVector, Vector3};

fn col() -> Colorimetry {
    Colorimetry::default()
}

fn d65(c: &Colorimetry) -> metamer::palette::SpectrumEntry {
    random::luminance_light("D65", Spectrum::illuminant("D65").unwrap(), c, false)
}

fn finite(sol: &design::Solution) -> bool {
    sol.palette.lights.iter().chain(&sol.palette.reflectances).all(|e| e.spectrum.is_finite())
        && sol.objective.is_finite()
        && sol.cells.iter().all(|c| c.rgb_full.iter().all(|v| v.is_finite()) && c.delta_e_full.is_finite())
}

/// One designed reflectance under the given lights with the given targets.
fn single(lights: Vec<metamer::palette::SpectrumEntry>, targets: &[Vector3<f64>], weights: &[f64]) -> Palette {
    let colours = targets.iter().enumerate().map(|(l, t)| random::cell(l, 0, *t, weights[l])).collect();
    Palette {
        name: "single".into(),
        settings: Settings { reflectance_bounds: Bounds::new(0.0, 1.0), ..Settings::default() },
        lights,
        reflectances: vec![random::entry("S", Kind::Reflectance, Spectrum::flat(0.5), true)],
        colours,
        free: vec![],
        mixtures: Vec::new(),
        paths: Vec::new(),
    }
}

#[test]
fn reachable_target_is_met_and_bounds_hold() {
    let c = col();
    let truth = Spectrum::colorchecker("moderate_red").unwrap();
    let l = d65(&c);
    let t = c.rgb(&l.spectrum, &truth);
    let p = single(vec![l], &[t], &[1.0]);
    let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap();
    assert!(sol.cells[0].delta_e_full < 0.5, "ΔE {}", sol.cells[0].delta_e_full);
    assert!(sol.palette.reflectances[0].spectrum.0.iter().all(|v| (0.0..=1.0).contains(v)));
    assert!(sol.diagnostics.iter().all(|d| d.cell.is_none()), "{:?}", sol.diagnostics);
}

#[test]
fn all_zero_light_gives_finite_spectra_and_a_reason() {
    let c = col();
    let zero = random::entry("dark", Kind::Light, Spectrum::flat(0.0), false);
    let p = single(vec![d65(&c), zero], &[Vector3::new(0.2, 0.2, 0.2), Vector3::new(0.5, 0.1, 0.1)], &[1.0, 1.0]);
    let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap();
    assert!(finite(&sol));
    let d = sol.diagnostics.iter().find(|d| d.cell == Some(1)).expect("a diagnostic for the dark cell");
    assert!(d.message.contains("zero"), "{}", d.message);
}

#[test]
fn unreachable_target_is_explained() {
    let c = col();
    // Brighter than a reflectance ≤ 1 can be under D65 (luminance 1).
    let p = single(vec![d65(&c)], &[Vector3::new(3.0, 3.0, 3.0)], &[1.0]);
    let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap();
    assert!(finite(&sol));
    let d = sol.diagnostics.iter().find(|d| d.cell == Some(0)).expect("unmet cell diagnostic");
    assert!(d.message.contains("outside what a reflectance within [0, 1] can reach"), "{}", d.message);
    // The solution is the brightest reachable: every sample at the upper bound (smoothness agrees).
    assert!(sol.palette.reflectances[0].spectrum.0.iter().all(|v| *v > 0.99));
}

#[test]
fn contradictory_duplicated_targets_compromise() {
    let c = col();
    let l = d65(&c);
    let mut p = single(vec![l], &[Vector3::new(0.1, 0.1, 0.1)], &[1.0]);
    p.colours.push(random::cell(0, 0, Vector3::new(0.5, 0.5, 0.5), 1.0));
    let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap();
    assert!(finite(&sol));
    assert!(sol.diagnostics.iter().any(|d| d.message.contains("appears twice")));
    // Equal weights: the achieved colour is about the mean target.
    let got = sol.cells[0].rgb_full;
    assert!((got - Vector3::new(0.3, 0.3, 0.3)).amax() < 0.01, "{got}");
    assert!(sol.diagnostics.iter().any(|d| d.cell.is_some() && d.message.contains("conflicts")));
}

/// Each repeated cell gets one remark naming the pair's first cell, in the cells' order, whatever the
/// order of the repeats; a cell that is not used is no repeat.
#[test]
fn duplicated_cells_are_named_in_order() {
    let c = col();
    let mut a = d65(&c);
    a.name = "A".into();
    let mut b = d65(&c);
    b.name = "B".into();
    let t = Vector3::new(0.2, 0.2, 0.2);
    let mut p = single(vec![a, b], &[t, t], &[1.0, 1.0]);
    // colours: A×S, B×S, then A×S, B×S, an unused B×S and A×S again.
    for (light, weight) in [(0, 1.0), (1, 1.0), (1, 0.0), (0, 1.0)] {
        p.colours.push(random::cell(light, 0, t, weight));
    }
    let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap();
    let dups: Vec<(Option<usize>, &str)> = sol
        .diagnostics
        .iter()
        .filter(|d| d.kind == design::DiagnosticKind::Duplicate)
        .map(|d| (d.cell, d.message.as_str()))
        .collect();
    let pair = |j: usize, k: usize| format!("appears twice (colours[{j}] and colours[{k}])");
    assert_eq!(dups.len(), 3, "{dups:?}");
    for ((cell, message), (j, k, name)) in dups.iter().zip([(0, 2, "A × S"), (1, 3, "B × S"), (0, 5, "A × S")]) {
        assert_eq!(*cell, Some(k), "{message}");
        assert!(message.starts_with(&format!("cell {name} ")) && message.contains(&pair(j, k)), "{message}");
    }
}

#[test]
fn extreme_weights_stay_finite_and_optimal() {
    let c = col();
    let lights = vec![
        d65(&c),
        random::luminance_light("A", Spectrum::illuminant("A").unwrap(), &c, false),
        random::luminance_light("F11", Spectrum::illuminant("F11").unwrap(), &c, false),
    ];
    let targets = [Vector3::new(0.3, 0.2, 0.1), Vector3::new(0.05, 0.4, 0.2), Vector3::new(0.6, 0.6, 0.0)];
    for w in [[1e-8, 1.0, 1e8], [1e8, 1e8, 1e-8], [1e-8, 1e-8, 1e-8]] {
        let p = single(lights.clone(), &targets, &w);
        let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap();
        assert!(finite(&sol), "weights {w:?}");
        assert!(sol.palette.reflectances[0].spectrum.0.iter().all(|v| (0.0..=1.0).contains(v)));
        assert!(sol.kkt_residual < 1e-6, "weights {w:?}: kkt {}", sol.kkt_residual);
    }
}

#[test]
fn near_identical_lights_with_different_targets() {
    let c = col();
    let a = d65(&c);
    let mut b = a.clone();
    b.name = "D65'".into();
    b.spectrum = b.spectrum.scaled(1.0 + 1e-9);
    let p = single(vec![a, b], &[Vector3::new(0.2, 0.2, 0.2), Vector3::new(0.4, 0.1, 0.1)], &[1.0, 1.0]);
    let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap();
    assert!(finite(&sol));
    assert!(sol.diagnostics.iter().any(|d| d.message.contains("nearly identical")), "{:?}", sol.diagnostics);
}

#[test]
fn invalid_input_is_an_error_not_a_panic() {
    let c = col();
    let mut p = single(vec![d65(&c)], &[Vector3::new(0.2, 0.2, 0.2)], &[1.0]);
    p.colours[0].weight = f64::NAN;
    assert!(matches!(design::solve(&p, None, &c, &SolveOptions::default()), Err(DesignError::Invalid(_))));
    let mut p = single(vec![d65(&c)], &[Vector3::new(0.2, 0.2, 0.2)], &[1.0]);
    p.settings.reflectance_bounds = Bounds::new(1.0, 0.0);
    assert!(matches!(design::solve(&p, None, &c, &SolveOptions::default()), Err(DesignError::Invalid(_))));
    let mut p = single(vec![d65(&c)], &[Vector3::new(0.2, 0.2, 0.2)], &[1.0]);
    p.settings.fit_in_subspace = true;
    let err = design::solve(&p, None, &c, &SolveOptions::default()).unwrap_err();
    assert!(err.to_string().contains("basis"), "{err}");
}

#[test]
fn free_colour_group_is_shared_and_bounded() {
    let c = col();
    let lights = vec![d65(&c), random::luminance_light("D50", Spectrum::illuminant("D50").unwrap(), &c, false)];
    let mut p = single(lights, &[Vector3::zeros(), Vector3::zeros()], &[1.0, 1.0]);
    p.free = vec![FreeGroup { name: "G".into(), lower: Vector3::from_element(0.2), upper: Vector3::from_element(0.4) }];
    for cell in &mut p.colours {
        cell.free = Some(0);
    }
    let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap();
    let g = sol.free[0];
    assert!(g.iter().all(|v| (0.2..=0.4).contains(v)), "{g}");
    // For the returned reflectance the group colour must be optimal: the equal-weight mean of its cells'
    // colours, clamped to the group's box.
    let (a, b) = (sol.cells[0].rgb_full, sol.cells[1].rgb_full);
    let want = ((a + b) / 2.0).map(|v| v.clamp(0.2, 0.4));
    assert!((g - want).amax() < 1e-9, "group {g}, cells {a} {b}");
}

/// Palette with bilinear cells for the joint tests.
fn joint_palette(n: usize, seed: u64) -> Palette {
    random::capacity_palette(n, seed, &col())
}

#[test]
fn joint_design_decreases_monotonically_and_is_deterministic() {
    let c = col();
    let p = joint_palette(4, 3);
    let design = Design::new(&p, None, &c).unwrap();
    let start = design.start_values();
    let limits =
        metamer::design::JointLimits::new(std::time::Instant::now() + std::time::Duration::from_secs(20), None);
    let (_, reports) = metamer::design::solve_all(&design, &start, &limits, false);
    assert_eq!(reports.len(), 1);
    let h = &reports[0].history;
    assert!(h.len() > 2);
    assert!(h.windows(2).all(|w| w[1] <= w[0]), "history not monotone: {h:?}");
    assert!(h.last().unwrap() < &(0.05 * h[0]), "little progress: {h:?}");
    // Determinism is asked of runs that end by convergence: a time limit that cannot bind (the default 10 s
    // could, on a machine loaded enough to starve the test's threads, and then two runs stop at different
    // iterations).
    let unbound = SolveOptions { time_limit: std::time::Duration::from_secs(3600), ..SolveOptions::default() };
    let a = design::solve(&p, None, &c, &unbound).unwrap();
    let b = design::solve(&p, None, &c, &unbound).unwrap();
    assert_eq!(a.objective, b.objective);
    assert_eq!(a.palette, b.palette);
    assert!(a.palette.lights.iter().chain(&a.palette.reflectances).all(|e| e.spectrum.0.min() >= 0.0));
}

#[test]
fn joint_design_respects_cancel_and_time_limit() {
    let c = col();
    let p = joint_palette(8, 1);
    let flag = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true));
    let r = design::solve(
        &p,
        None,
        &c,
        &SolveOptions { time_limit: std::time::Duration::from_secs(5), cancel: Some(flag) },
    );
    assert_eq!(r.unwrap_err(), DesignError::Cancelled);
    let t = std::time::Instant::now();
    let sol =
        design::solve(&p, None, &c, &SolveOptions { time_limit: std::time::Duration::from_millis(1), cancel: None })
            .unwrap();
    assert!(t.elapsed().as_secs_f64() < 2.0);
    assert!(finite(&sol));
    assert!(sol.diagnostics.iter().any(|d| d.message.contains("stopped early")));
}

fn small_basis(c: &Colorimetry, m: usize) -> Basis {
    // First m left singular vectors of ColorChecker × illuminant colour signals.
    let lights = ["D65", "A", "F11"];
    let mut cols = Vec::new();
    for l in lights {
        let e = Spectrum::illuminant(l).unwrap();
        for name in Spectrum::colorchecker_names() {
            cols.push(e.product(&Spectrum::colorchecker(name).unwrap()));
        }
    }
    let a = DMatrix::from_fn(31, cols.len(), |i, j| cols[j].0[i]);
    let u = a.svd(true, false).u.unwrap();
    Basis::from_matrix(u.columns(0, m).into_owned(), c).unwrap()
}

#[test]
fn gradient_matches_finite_differences_with_every_row_kind() {
    let c = col();
    let basis = small_basis(&c, 6);
    let mut p = joint_palette(3, 5);
    p.settings.subspace_error = 0.7;
    p.settings.fit_in_subspace = true;
    p.free = vec![FreeGroup {
        name: "G".into(),
        lower: Vector3::from_element(f64::NEG_INFINITY),
        upper: Vector3::from_element(f64::INFINITY),
    }];
    p.colours[1].free = Some(0);
    p.colours[4].free = Some(0);
    p.colours[2].weight = 3.0;
    let design = Design::new(&p, Some(&basis), &c).unwrap();
    let base = design.start_values();
    let units = design.units();
    let layout = Layout::new(&units);
    let terms: Vec<usize> = (0..design.terms.len()).collect();
    let prob = NonlinearProblem { design: &design, layout: &layout, terms: &terms, base: &base };
    let x = layout.gather(&base);
    let g = prob.grad(&x);
    assert!((prob.value(&x) - design.objective(&base)).abs() <= 1e-12 * design.objective(&base));
    let mut worst: f64 = 0.0;
    for i in (0..x.len()).step_by(7) {
        let h = 1e-6 * (1.0 + x[i].abs());
        let mut xp = x.clone();
        let mut xm = x.clone();
        xp[i] += h;
        xm[i] -= h;
        let fd = (prob.value(&xp) - prob.value(&xm)) / (2.0 * h);
        worst = worst.max((fd - g[i]).abs() / (1.0 + g[i].abs()));
    }
    assert!(worst < 1e-6, "gradient mismatch {worst}");
}

#[test]
fn linear_assembly_matches_the_objective() {
    // ‖A x − b‖² of the assembled system equals the objective at x (subspace rows included).
    let c = col();
    let basis = small_basis(&c, 5);
    let mut p = random::convex_palette(11, &c);
    p.settings.subspace_error = 0.5;
    p.settings.fit_in_subspace = true;
    let design = Design::new(&p, Some(&basis), &c).unwrap();
    let v = design.start_values();
    let layout = Layout::new(&design.units());
    let terms: Vec<usize> = (0..design.terms.len()).collect();
    let sys = design.linear_system(&layout, &terms, &v);
    let x: DVector<f64> = layout.gather(&v);
    let f = (&*sys.a * &x - &sys.b).norm_squared();
    assert!((f - design.objective(&v)).abs() <= 1e-12 * (1.0 + f), "{f} vs {}", design.objective(&v));
    // And the solve with a basis reports subspace colours.
    let sol = design::solve(&p, Some(&basis), &c, &SolveOptions::default()).unwrap();
    assert!(sol.cells.iter().all(|c| c.rgb_subspace.is_some() && c.delta_e_subspace.is_some()));
}

/// The test palettes themselves (`palette::random`).
#[test]
fn capacity_variants_share_targets_and_differ_in_starts() {
    let col = metamer::colorimetry::Colorimetry::default();
    let base = random::capacity_palette(6, 3, &col);
    assert_eq!(base, random::capacity_palette_with(6, 3, &col, &random::CapacityOptions::default()));
    for options in [
        random::CapacityOptions { start: random::CapacityStart::Flat, ..Default::default() },
        random::CapacityOptions {
            start: random::CapacityStart::Random,
            light_scale: random::CapacityLightScale::L2,
            ..Default::default()
        },
        random::CapacityOptions {
            light_scale: random::CapacityLightScale::Raw,
            reflectances_below_one: true,
            ..Default::default()
        },
    ] {
        let p = random::capacity_palette_with(6, 3, &col, &options);
        assert_eq!(p.colours, base.colours, "{options:?}");
        assert_ne!(p.lights, base.lights, "{options:?}");
        assert_eq!(p.settings.reflectance_bounds.upper == 1.0, options.reflectances_below_one);
        assert!(p.lights.iter().chain(&p.reflectances).all(|e| e.design && e.spectrum.0.min() >= 0.0));
    }
    // Luminance-normalised lights have Y = 1.
    for l in &base.lights {
        assert!((col.luminance().dot(&l.spectrum.0) - 1.0).abs() < 1e-12);
    }
}
