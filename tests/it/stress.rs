//! Numerical stress for the design engine (issue 7): random palettes with weights from 1e-8 to 1e8,
//! near-identical lights, spiky lights (F11 resampled onto a 1 nm grid with emission lines added, then
//! sampled back onto the 10 nm grid), zero and negative spectra, bounds that pin everything, thousands of
//! cells, and the joint (bilinear) design.
//!
//! Every convex case is checked against an assembly of the objective made here, independently of the
//! engine (`tests/common`): results finite, every bound kept to 1e-9, the reported objective equal to the
//! sum of squares at the returned spectra (1e-9 relative), the scaled projected-gradient (KKT) residual
//! below 1e-6, and an objective no worse than clarabel's interior-point optimum (1e-6 relative). Joint
//! designs must improve monotonically: the engine's per-stage objective history never increases and the
//! final objective is at most the start's.
//!
//! The condition numbers met are printed (`cargo test --test it stress:: -- --nocapture`); `metamer bench
//! solve` tabulates them for representative palettes.

use crate::common;

use crate::common::random::{self, Rng};
use common::{Stacked, bound_violation, kkt_residual, objective, oracle_point, stack, stacked_solution};
use metamer::bench::summary::condition_number;
use metamer::colorimetry::Colorimetry;
use metamer::design::Design;
use metamer::design::JointLimits;
use metamer::design::{self, Solution, SolveOptions};
use metamer::palette::{Bounds, FreeGroup, Kind, Palette, Settings, SpectrumEntry};
use metamer::spectrum::{SAMPLES, Spectrum};
use nalgebra::Vector3;
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use std::time::{Duration, Instant};

/// The stress suite draws its cases from this fixed seed so `cargo test` is reproducible; `PROPTEST_RNG_SEED`
/// overrides it to explore (e.g. `PROPTEST_RNG_SEED=17760125983182809265`, which once found spiky F11 designs
/// 1.4e-4 above the optimum).
const STRESS_SEED: u64 = 20_261_122;

fn stress_seed() -> RngSeed {
    match std::env::var("PROPTEST_RNG_SEED").ok().and_then(|v| v.parse().ok()) {
        Some(seed) => RngSeed::Fixed(seed),
        None => RngSeed::Fixed(STRESS_SEED),
    }
}

/// Bounds must hold to this (absolute).
const BOUND_TOL: f64 = 1e-9;
/// The reported objective must equal the recomputed sum of squares to this, relative to `1 + f`, plus what
/// rounding alone can explain ([`objective_rounding`]).
const OBJECTIVE_TOL: f64 = 1e-9;
/// Scaled KKT residual (see `common::kkt_residual`) on well-conditioned systems …
const KKT_TOL: f64 = 1e-6;
/// … and on ill-conditioned ones `KKT_PER_CONDITION · ε · cond(A)`: the independent check evaluates the
/// gradient `2Aᵀ(Ax − b)` in double precision, whose rounding alone reaches that order when a nearly singular
/// unbounded design has huge samples (measured over 10 proptest seeds: at most 2.2·ε·cond(A), for the free
/// group under weights 1e-8 and 1e8 at cond 1.1e14; 0.66·ε·cond for lights within 1.2e-9).
const KKT_PER_CONDITION: f64 = 10.0;
/// Slack against the oracle's optimum, relative to it (issue 3: within 1e-6 of the exact optimum). Measured
/// over 10 proptest seeds: every case at most 1.1e-14 relative above the oracle.
const ORACLE_TOL: f64 = 1e-6;

fn col() -> Colorimetry {
    Colorimetry::default()
}

fn all_finite(sol: &Solution) -> bool {
    sol.palette.lights.iter().chain(&sol.palette.reflectances).all(|e| e.spectrum.is_finite())
        && sol.free.iter().all(|f| f.iter().all(|v| v.is_finite()))
        && sol.objective.is_finite()
        && sol.kkt_residual.is_finite()
        && sol.cells.iter().all(|c| c.rgb_full.iter().all(|v| v.is_finite()) && c.delta_e_full.is_finite())
        && sol.diagnostics.iter().all(|d| !d.message.contains("NaN"))
}

/// What a convex check measured.
#[derive(Debug)]
struct Checked {
    condition: f64,
    null_directions: usize,
    kkt: f64,
    /// `(f − f_oracle) / max(f_oracle, tiny)`: negative when the engine beats clarabel.
    gap: f64,
}

/// Solve `p` and check it against the independent assembly and the oracle; panics with `case` on failure.
fn check_convex(case: &str, p: &Palette) -> Checked {
    let c = col();
    let sol = design::solve(p, None, &c, &SolveOptions::default()).unwrap_or_else(|e| panic!("{case}: {e}"));
    assert!(all_finite(&sol), "{case}: non-finite result");
    let st = stack(p, &c);
    let x = stacked_solution(&st, &sol);
    assert!(bound_violation(&st, &x) <= BOUND_TOL, "{case}: bound violated by {}", bound_violation(&st, &x));
    let ours = objective(&st, &x);
    let kkt = kkt_residual(&st, &x);
    let (condition, null_directions) = condition_number(&st.a);
    let (best, status) = if st.a.ncols() == 0 {
        (ours, "empty".to_string())
    } else {
        let (xo, _, status) = oracle_point(&st);
        (objective(&st, &xo), status)
    };
    let gap = (ours - best) / best.max(1e-300);
    println!(
        "{case}: cond(A) {condition:.2e}, {null_directions} null, f {ours:.6e}, reported {:.6e}, oracle {best:.6e} \
         ({status}), gap {gap:.1e}, KKT {kkt:.1e} (engine {:.1e})",
        sol.objective, sol.kkt_residual
    );
    let rounding = objective_rounding(&st, &x);
    assert!(
        (ours - sol.objective).abs() <= OBJECTIVE_TOL * (1.0 + ours) + rounding,
        "{case}: reported objective {} but the sum of squares is {ours}",
        sol.objective
    );
    let kkt_tol = KKT_TOL.max(KKT_PER_CONDITION * f64::EPSILON * condition);
    assert!(
        kkt <= kkt_tol,
        "{case}: independent KKT residual {kkt:.3e} > {kkt_tol:.1e} (engine {:.3e})",
        sol.kkt_residual
    );
    assert!(ours <= best * (1.0 + ORACLE_TOL) + 1e-12, "{case}: ours {ours:.12e}, oracle {best:.12e} ({status})");
    Checked { condition, null_directions, kkt, gap }
}

/// How far two evaluations of `‖A x − b‖²` may differ by rounding alone: each residual carries an error up to
/// `δᵢ = 64 ε (|A||x| + |b|)ᵢ`, so the sum of squares up to `Σ 2|rᵢ|δᵢ + δᵢ²` (large when the spectra are
/// huge, as in unbounded near-singular designs).
fn objective_rounding(st: &Stacked, x: &nalgebra::DVector<f64>) -> f64 {
    let r = &st.a * x - &st.b;
    let mag = st.a.abs() * x.abs() + st.b.abs();
    r.iter()
        .zip(mag.iter())
        .map(|(r, m)| {
            let d = 64.0 * f64::EPSILON * m;
            2.0 * r.abs() * d + d * d
        })
        .sum()
}

/// The engine's objective is no worse than clarabel's (one-sided: an interior point stops a hair above).
fn agree_with_oracle(case: &str, st: &Stacked, ours: f64) {
    let (xo, _, status) = oracle_point(st);
    let best = objective(st, &xo);
    assert!(ours <= best * (1.0 + ORACLE_TOL) + 1e-12, "{case}: ours {ours:.12e}, oracle {best:.12e} ({status})");
}

/// The engine's objective on `p` and the oracle's, both evaluated on the independent assembly (for the
/// strict checks, which allow no absolute slack).
fn ours_and_oracle(p: &Palette) -> (f64, f64) {
    let c = col();
    let sol = design::solve(p, None, &c, &SolveOptions::default()).expect("solve");
    let st = stack(p, &c);
    let (xo, _, _) = oracle_point(&st);
    (objective(&st, &stacked_solution(&st, &sol)), objective(&st, &xo))
}

fn light(name: &str, s: Spectrum) -> SpectrumEntry {
    random::entry(name, Kind::Light, s, false)
}

fn designed_reflectance(name: &str) -> SpectrumEntry {
    random::entry(name, Kind::Reflectance, Spectrum::flat(0.5), true)
}

/// `n` designed reflectances under `lights`, every cell with a target drawn from `rng` and weight from
/// `weight`.
fn reflectance_palette(
    name: &str,
    lights: Vec<SpectrumEntry>,
    n: usize,
    bounds: Bounds,
    smoothness: f64,
    rng: &mut Rng,
    mut weight: impl FnMut(&mut Rng) -> f64,
) -> Palette {
    let mut colours = Vec::new();
    for r in 0..n {
        for l in 0..lights.len() {
            let t = Vector3::new(rng.range(-0.1, 1.1), rng.range(0.0, 1.0), rng.range(0.0, 1.0));
            colours.push(random::cell(l, r, t, weight(rng)));
        }
    }
    Palette {
        name: name.into(),
        settings: Settings { smoothness, reflectance_bounds: bounds, ..Settings::default() },
        lights,
        reflectances: (0..n).map(|r| designed_reflectance(&format!("R{r}"))).collect(),
        colours,
        free: vec![],
        mixtures: Vec::new(),
        paths: Vec::new(),
    }
}

fn standard_lights(c: &Colorimetry, names: &[&str]) -> Vec<SpectrumEntry> {
    names
        .iter()
        .map(|n| random::luminance_light(n, Spectrum::illuminant(n).unwrap_or(Spectrum::flat(1.0)), c, false))
        .collect()
}

fn bounds_of(choice: u8) -> Bounds {
    match choice % 3 {
        0 => Bounds::new(0.0, 1.0),
        1 => Bounds::new(0.0, f64::INFINITY),
        _ => Bounds::UNBOUNDED,
    }
}

fn smoothness_of(choice: u8) -> f64 {
    [0.0, 1e-3, 0.1, 1.0][usize::from(choice % 4)]
}

/// F11 as a 1 nm table: linear interpolation of the 10 nm samples, with narrow emission lines (1 nm wide)
/// of the given heights added at the given wavelengths.
fn f11_one_nm(lines: &[(usize, f64)]) -> Vec<(f64, f64)> {
    let f11 = Spectrum::illuminant("F11").unwrap_or(Spectrum::flat(1.0));
    let mut out: Vec<(f64, f64)> = (400..=700)
        .map(|nm| {
            let pos = (nm - 400) as f64 / 10.0;
            let (i, t) = (pos.floor() as usize, pos.fract());
            let v = if i + 1 < SAMPLES { f11.0[i] * (1.0 - t) + f11.0[i + 1] * t } else { f11.0[SAMPLES - 1] };
            (nm as f64, v)
        })
        .collect();
    for (nm, h) in lines {
        if let Some(p) = out.iter_mut().find(|p| p.0 as usize == *nm) {
            p.1 += h;
        }
    }
    out
}

/// A spiky light: the 1 nm F11 with lines, through the CSV importer (linear resampling onto the grid, which
/// point-samples a 1 nm table) when `shift` is 0, else point-sampled at `400 + 10k + shift` nm.
fn spiky_light(lines: &[(usize, f64)], shift: usize) -> Spectrum {
    let table = f11_one_nm(lines);
    if shift == 0 {
        let csv: String = table.iter().map(|(w, v)| format!("{w},{v}\n")).collect();
        metamer::spectrum::parse_spectrum_csv(&csv).unwrap_or_else(|e| panic!("CSV import of F11: {e}"))
    } else {
        let v: Vec<f64> = (0..SAMPLES).map(|k| table[(10 * k + shift).min(300)].1).collect();
        Spectrum::from_slice(&v).unwrap_or(Spectrum::flat(1.0))
    }
}

/// Three raw D65 lights differing by a relative `delta` times smooth bumps, 2 designed reflectances.
fn near_identical_palette(seed: u64, delta: f64, b: u8, s: u8) -> Palette {
    let mut rng = Rng::new(seed);
    let base = Spectrum::illuminant("D65").unwrap_or(Spectrum::flat(1.0));
    let lights: Vec<SpectrumEntry> = (0..3)
        .map(|k| {
            let bump = random::smooth_spectrum(&mut rng);
            let v: Vec<f64> = (0..SAMPLES).map(|i| base.0[i] * (1.0 + delta * k as f64 * bump.0[i])).collect();
            light(&format!("D65~{k}"), Spectrum::from_slice(&v).unwrap_or(base))
        })
        .collect();
    reflectance_palette("near-identical", lights, 2, bounds_of(b), smoothness_of(s), &mut rng, |_| 1.0)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, rng_seed: stress_seed(), ..ProptestConfig::default() })]

    /// Cell weights spread over 16 decades, with any bounds and smoothness.
    #[test]
    fn weights_across_sixteen_decades(seed in any::<u64>(), n in 1usize..4, b in any::<u8>(), s in any::<u8>()) {
        let mut rng = Rng::new(seed);
        let lights = standard_lights(&col(), &["D65", "A", "F11"]);
        let p = reflectance_palette("weights", lights, n, bounds_of(b), smoothness_of(s), &mut rng,
            |r| 10f64.powf(r.range(-8.0, 8.0)));
        let case = format!("weights 1e-8..1e8, seed {seed}, {n} refl., bounds {b}, smoothness {s}");
        check_convex(&case, &p);
    }

    /// Lights that differ by a relative 1e-12 … 1e-4 (nearly dependent rows, cond(A) up to ~1e14).
    #[test]
    fn near_identical_lights(seed in any::<u64>(), exponent in -12.0f64..-4.0, b in any::<u8>(), s in any::<u8>()) {
        let delta = 10f64.powf(exponent);
        let p = near_identical_palette(seed, delta, b, s);
        check_convex(&format!("near-identical lights δ = {delta:.1e}, seed {seed}"), &p);
    }

    /// F11 at 1 nm with extra emission lines, sampled back onto the grid (through the CSV importer or at
    /// shifted wavelengths), beside D65.
    #[test]
    fn spiky_lights(seed in any::<u64>(), shift in 0usize..10, b in any::<u8>(), s in any::<u8>()) {
        let c = col();
        let mut rng = Rng::new(seed);
        let mut lights = standard_lights(&c, &["D65"]);
        for k in 0..2 {
            let lines: Vec<(usize, f64)> = (0..1 + rng.index(4)).map(|_| (400 + rng.index(301), rng.range(10.0, 500.0))).collect();
            lights.push(light(&format!("spiky{k}"), spiky_light(&lines, shift)));
        }
        let p = reflectance_palette("spiky", lights, 2, bounds_of(b), smoothness_of(s), &mut rng, |r| r.range(0.1, 10.0));
        check_convex(&format!("spiky F11, shift {shift} nm, seed {seed}"), &p);
    }

    /// All-zero and negative lights, negative targets; a designed light under a zero and a negative
    /// reflectance.
    #[test]
    fn zero_and_negative_spectra(seed in any::<u64>(), b in any::<u8>(), s in any::<u8>()) {
        let mut rng = Rng::new(seed);
        let d65 = Spectrum::illuminant("D65").unwrap_or(Spectrum::flat(1.0));
        let lights = vec![
            light("zero", Spectrum::flat(0.0)),
            light("negative D65", d65.scaled(-rng.range(0.001, 0.02))),
            light("D65", d65.scaled(0.01)),
        ];
        let mut p = reflectance_palette("zero/negative", lights, 2, bounds_of(b), smoothness_of(s), &mut rng, |_| 1.0);
        p.colours[0].target = Vector3::new(-0.5, -0.2, 0.3);
        check_convex(&format!("zero and negative lights, seed {seed}"), &p);

        // A designed light over fixed zero, negative and ordinary reflectances.
        let mut q = p.clone();
        q.lights = vec![random::entry("L", Kind::Light, Spectrum::flat(1.0), true)];
        q.reflectances = vec![
            random::entry("zero", Kind::Reflectance, Spectrum::flat(0.0), false),
            random::entry("negative", Kind::Reflectance, Spectrum::flat(-0.3), false),
            random::entry("grey", Kind::Reflectance, Spectrum::flat(0.5), false),
        ];
        q.settings.light_bounds = bounds_of(b.wrapping_add(1));
        q.colours = (0..3).map(|r| random::cell(0, r, Vector3::new(rng.uniform(), rng.uniform(), rng.uniform()), 1.0)).collect();
        check_convex(&format!("designed light over zero/negative reflectances, seed {seed}"), &q);
    }

    /// Bounds with lower == upper on every designed spectrum and free colour: the solution is the pinned
    /// value exactly, and still optimal (trivially) and consistent.
    #[test]
    fn bounds_that_pin_everything(seed in 0u64..1_000_000, v in -1.0f64..2.0) {
        let c = col();
        let mut p = random::convex_palette(seed, &c);
        let pin = Bounds::new(v, v);
        p.settings.reflectance_bounds = pin;
        p.settings.light_bounds = pin;
        for e in p.lights.iter_mut().chain(p.reflectances.iter_mut()) {
            e.bounds = None;
        }
        for g in p.free.iter_mut() {
            g.lower = Vector3::from_element(v);
            g.upper = Vector3::from_element(v);
        }
        check_convex(&format!("pinned at {v}, convex seed {seed}"), &p);
        let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        for e in sol.palette.lights.iter().chain(&sol.palette.reflectances).filter(|e| e.design) {
            prop_assert!(e.spectrum.0.iter().all(|x| (x - v).abs() <= BOUND_TOL), "{} not pinned at {v}", e.name);
        }
        for f in &sol.free {
            prop_assert!(f.iter().all(|x| (x - v).abs() <= BOUND_TOL));
        }
    }
}

/// Thousands of cells: one light × 2000 designed reflectances (2000 independent blocks sharing one
/// factorisation), checked block by block against the oracle on a sample; and one designed light under
/// 2000 fixed reflectances (one block of 6000 colour rows).
#[test]
fn thousands_of_cells() {
    let c = col();
    let mut rng = Rng::new(7);
    let lights = standard_lights(&c, &["D65"]);
    let n = 2000;
    let p = reflectance_palette("2000 cells", lights, n, Bounds::new(0.0, 1.0), 1e-3, &mut rng, |r| r.range(0.5, 2.0));
    let sol = design::solve(&p, None, &c, &SolveOptions::default()).expect("solve");
    assert!(all_finite(&sol));
    for e in &sol.palette.reflectances {
        assert!(e.spectrum.0.iter().all(|x| (-BOUND_TOL..=1.0 + BOUND_TOL).contains(x)), "{}", e.name);
    }
    // Every 97th block on its own, against the oracle: the big solve's spectrum must be that block's optimum.
    let mut sum = 0.0;
    for k in (0..n).step_by(97) {
        let mut sub = p.clone();
        sub.reflectances = vec![p.reflectances[k].clone()];
        sub.colours = vec![random::cell(0, 0, p.colours[k].target, p.colours[k].weight)];
        let st = stack(&sub, &c);
        let x = nalgebra::DVector::from_column_slice(sol.palette.reflectances[k].spectrum.as_slice());
        assert!(kkt_residual(&st, &x) <= KKT_TOL, "block {k}: KKT {}", kkt_residual(&st, &x));
        agree_with_oracle(&format!("block {k} of 2000"), &st, objective(&st, &x));
        sum += objective(&st, &x);
    }
    assert!(sum <= sol.objective * (1.0 + 1e-9), "sampled blocks {sum} exceed the whole objective {}", sol.objective);

    // One designed light seen through 2000 fixed reflectances.
    let reflectances: Vec<SpectrumEntry> = (0..n)
        .map(|k| random::entry(&format!("S{k}"), Kind::Reflectance, random::smooth_spectrum(&mut rng), false))
        .collect();
    let colours = (0..n)
        .map(|k| random::cell(0, k, Vector3::new(rng.uniform(), rng.uniform(), rng.uniform()), rng.range(0.1, 10.0)))
        .collect();
    let q = Palette {
        name: "one light, 2000 cells".into(),
        settings: Settings { light_bounds: Bounds::new(0.0, f64::INFINITY), ..Settings::default() },
        lights: vec![random::entry("L", Kind::Light, Spectrum::flat(1.0), true)],
        reflectances,
        colours,
        free: vec![],
        mixtures: Vec::new(),
        paths: Vec::new(),
    };
    check_convex("one designed light under 2000 fixed reflectances", &q);
}

/// The joint design of n×n capacity palettes (every light and reflectance designed, bilinear cells): the
/// per-stage objective history never increases, and the final objective is at most the start's.
fn check_joint_monotone(n: usize, seed: u64, wide_weights: bool) {
    let c = col();
    let mut p = random::capacity_palette(n, seed, &c);
    if wide_weights {
        let mut rng = Rng::new(seed ^ 0xabc);
        for cell in p.colours.iter_mut() {
            cell.weight = 10f64.powf(rng.range(-4.0, 4.0));
        }
    }
    let design = Design::new(&p, None, &c).expect("design");
    let start = design.start_values();
    let f0 = design.objective(&start);
    let limits = JointLimits::new(Instant::now() + Duration::from_secs(2), None);
    let (values, blocks) = design::solve_all(&design, &start, &limits, false);
    let f1 = design.objective(&values);
    assert!(f1.is_finite() && f1 <= f0 * (1.0 + 1e-12), "n {n} seed {seed}: final {f1} > start {f0}");
    assert!(blocks.iter().any(|b| b.bilinear), "the capacity palette is joint");
    for b in blocks.iter().filter(|b| b.bilinear) {
        for w in b.history.windows(2) {
            assert!(w[1] <= w[0] * (1.0 + 1e-12) + 1e-300, "n {n} seed {seed}: history rose {} → {}", w[0], w[1]);
        }
        assert!(b.kkt.is_finite());
    }
    // Positivity (the capacity protocol's bounds) holds on every designed spectrum.
    for e in values.lights.iter().chain(&values.reflectances) {
        assert!(e.0.iter().all(|x| *x >= -BOUND_TOL && x.is_finite()), "a spectrum went negative or non-finite");
    }
    let hist: Vec<usize> = blocks.iter().map(|b| b.history.len()).collect();
    println!("joint {n}×{n} seed {seed} wide {wide_weights}: {f0:.4e} → {f1:.4e}, history lengths {hist:?}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 5, rng_seed: stress_seed(), ..ProptestConfig::default() })]

    #[test]
    fn joint_design_improves_monotonically(n in 2usize..4, seed in any::<u64>(), wide in any::<bool>()) {
        check_joint_monotone(n, seed, wide);
    }
}

/// Free colours under extreme weights: a free group shared by cells weighted 1e-8 and 1e8 stays inside
/// its box and the heavy cell wins.
#[test]
fn free_group_under_extreme_weights() {
    let c = col();
    let mut rng = Rng::new(3);
    let lights = standard_lights(&c, &["D65", "A"]);
    let mut p = reflectance_palette("free extreme", lights, 1, Bounds::new(0.0, 1.0), 1e-3, &mut rng, |_| 1.0);
    p.colours[0].weight = 1e-8;
    p.colours[1].weight = 1e8;
    for cell in p.colours.iter_mut() {
        cell.free = Some(0);
    }
    p.free = vec![FreeGroup { name: "G".into(), lower: Vector3::from_element(0.1), upper: Vector3::from_element(0.3) }];
    check_convex("free group, weights 1e-8 and 1e8", &p);
}

/// The condition numbers met by one representative of each generator, printed as a table (and checked
/// finite: the assembly never produces NaN/inf even for degenerate inputs).
#[test]
fn condition_numbers_met() {
    let c = col();
    let mut rng = Rng::new(11);
    let mut rows = Vec::new();
    let lights = standard_lights(&c, &["D65", "A", "F11"]);
    let wide = reflectance_palette("w", lights.clone(), 1, Bounds::UNBOUNDED, 0.0, &mut rng, |r| {
        10f64.powf(r.range(-8.0, 8.0))
    });
    rows.push(("weights 1e-8..1e8, no smoothness", check_convex("table: weights", &wide)));
    let base = Spectrum::illuminant("D65").unwrap_or(Spectrum::flat(1.0));
    let near: Vec<SpectrumEntry> =
        (0..3).map(|k| light(&format!("n{k}"), base.scaled(1.0 + 1e-10 * k as f64))).collect();
    let near = reflectance_palette("n", near, 1, Bounds::new(0.0, 1.0), 1e-3, &mut rng, |_| 1.0);
    rows.push(("near-identical lights (1e-10)", check_convex("table: near-identical", &near)));
    let spiky = vec![light("F11 + lines", spiky_light(&[(430, 300.0), (550, 300.0)], 0)), lights[0].clone()];
    let spiky = reflectance_palette("s", spiky, 1, Bounds::new(0.0, 1.0), 0.0, &mut rng, |_| 1.0);
    rows.push(("spiky F11 (CSV, 1 nm lines on the grid)", check_convex("table: spiky", &spiky)));
    let plain = reflectance_palette("p", lights, 1, Bounds::new(0.0, 1.0), 1e-3, &mut rng, |_| 1.0);
    rows.push(("D65, A, F11, weights 1", check_convex("table: plain", &plain)));
    println!("\n| case | cond(A) | null directions | KKT | gap to clarabel |\n|---|---|---|---|---|");
    for (name, r) in &rows {
        println!("| {name} | {:.2e} | {} | {:.1e} | {:.1e} |", r.condition, r.null_directions, r.kkt, r.gap);
        assert!(r.condition.is_finite() && r.condition >= 1.0, "{name}");
    }
    // Weights over 16 decades must show up as an ill-conditioned system, else the stress is not stressing.
    assert!(rows[0].1.condition > 1e6 * rows[3].1.condition);
}

/// Cell weights spread over 16 decades (cond(A) 1.4e10 over the three blocks, f(0) ≈ 2.9e14): the engine
/// once stopped at 1.93× the optimum (8.39e4) — its multipliers `Hx − Aᵀb` were rounding noise at the heavy
/// rows' scale. The optimum is 4.0640182e4 (scipy's BVLS 4.06401830e4 and TRF 4.06401825e4; the engine now
/// 4.06401824e4). Clarabel on the normal form stopped at 4.345e4 (6.9 % above); the oracle also solves the
/// residual form (see `common::oracle_point`), so the check is strict.
#[test]
fn sixteen_decades_of_weights_reach_the_oracle_optimum_exactly() {
    let seed = 2695476213412867642;
    let mut rng = Rng::new(seed);
    let lights = standard_lights(&col(), &["D65", "A", "F11"]);
    let p = reflectance_palette("weights", lights, 3, bounds_of(73), smoothness_of(98), &mut rng, |r| {
        10f64.powf(r.range(-8.0, 8.0))
    });
    let (ours, best) = ours_and_oracle(&p);
    assert!(ours <= best * (1.0 + ORACLE_TOL), "ours {ours:.6e}, oracle {best:.6e}");
}

/// Lights that differ by 1e-4 without smoothness, lower bounds only (the engine once stopped 8.2e-6 and
/// 1.9e-5 above the optimum), and lights within 1.6e-11 (once 55 % and 144 % above): the exact optimum, as
/// clarabel and scipy's BVLS agree to 1e-11.
#[test]
fn near_identical_lights_reach_the_oracle_optimum_exactly() {
    let cases = [
        (9002700489424282725, 1e-4, 136, 0),
        (9169635515590953349, 1e-4, 136, 0),
        (0, 10f64.powf(-10.912307284125163), 1, 28),
        (12531748448234519045, 1.6e-11, 34, 220),
        (12525438211119976054, 1.6e-11, 34, 220),
    ];
    for (seed, delta, b, s) in cases {
        let (ours, best) = ours_and_oracle(&near_identical_palette(seed, delta, b, s));
        assert!(ours <= best * (1.0 + ORACLE_TOL), "δ {delta:.1e}: ours {ours:.9e}, oracle {best:.9e}");
    }
}
