//! Unit tests of `lsq.rs` (a sibling file to keep `lsq.rs` about the code).

use super::*;

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64) / ((1u64 << 53) as f64)
}

/// A matrix or vector entry for the products' bit tests: one of `specials` (each with chance 1/16, by the
/// first draw), else a value of mixed sign and a magnitude from 10⁻⁶ to 10⁶.
fn entry(seed: &mut u64, specials: &[f64]) -> f64 {
    let u = lcg(seed);
    match specials.get((u * 16.0) as usize) {
        Some(&v) => v,
        None => (lcg(seed) - 0.5) * 10f64.powi((lcg(seed) * 12.0) as i32 - 6),
    }
}

/// Brute force over all 3^n active sets for tiny n: the exact optimum of a bounded LS.
fn brute_force(sys: &LinearSystem) -> f64 {
    let n = sys.a.ncols();
    let mut best = f64::INFINITY;
    for code in 0..3usize.pow(n as u32) {
        let mut c = code;
        let mut x = DVector::zeros(n);
        let mut free = Vec::new();
        for i in 0..n {
            match c % 3 {
                0 => free.push(i),
                1 => x[i] = sys.lower[i],
                _ => x[i] = sys.upper[i],
            }
            c /= 3;
        }
        if !free.is_empty() {
            // The free columns' least squares by nalgebra's SVD, independently of the engine.
            let af = DMatrix::from_fn(sys.a.nrows(), free.len(), |r, c| sys.a[(r, free[c])]);
            let rb = &sys.b - &*sys.a * &x;
            let z = af.svd(true, true).solve(&rb, 1e-14).expect("svd solve");
            for (k, &i) in free.iter().enumerate() {
                x[i] = z[k];
            }
        }
        if (0..n).all(|i| x[i] >= sys.lower[i] - 1e-12 && x[i] <= sys.upper[i] + 1e-12) {
            best = best.min((&*sys.a * &x - &sys.b).norm_squared());
        }
    }
    best
}

#[test]
fn matches_brute_force_on_small_random_systems() {
    let mut seed = 7u64;
    for _ in 0..40 {
        let (m, n) = (4 + (lcg(&mut seed) * 4.0) as usize, 2 + (lcg(&mut seed) * 4.0) as usize);
        let a = DMatrix::from_fn(m, n, |_, _| lcg(&mut seed) * 2.0 - 1.0);
        let b = DVector::from_fn(m, |_, _| lcg(&mut seed) * 4.0 - 2.0);
        let lower = DVector::from_fn(n, |_, _| -lcg(&mut seed) * 0.5);
        let upper = DVector::from_fn(n, |_, _| lcg(&mut seed) * 0.5);
        let sys = LinearSystem { a: a.into(), b, lower, upper };
        let out = solve_system(&sys);
        let best = brute_force(&sys);
        assert!(out.objective <= best * (1.0 + 1e-9) + 1e-14, "{} vs {best}", out.objective);
        assert!((0..n).all(|i| out.x[i] >= sys.lower[i] && out.x[i] <= sys.upper[i]));
        assert!(out.kkt < 1e-9, "kkt {}", out.kkt);
    }
}

#[test]
fn qr_path_matches_brute_force_on_wide_and_graded_systems() {
    // Fewer rows than unknowns (cond = ∞) and rows weighted over 10 decades (cond ≫ 1e6): both take the
    // QR path; the brute force (normwise SVD per active set) can only be worse, so the check is one-sided.
    let mut seed = 11u64;
    for case in 0..40 {
        let graded = case % 2 == 1;
        let n = 2 + (lcg(&mut seed) * 4.0) as usize;
        let m = if graded {
            n + 2 + (lcg(&mut seed) * 3.0) as usize
        } else {
            1 + (lcg(&mut seed) * (n - 1) as f64) as usize
        };
        // Graded: n − 1 rows of weight ~1e7, the rest 1e-3…1 (only they determine the last direction).
        let w: Vec<f64> = (0..m)
            .map(|r| match (graded, r + 1 < n) {
                (false, _) => 1.0,
                (true, true) => 1e7 * (1.0 + lcg(&mut seed)),
                (true, false) => 10f64.powf(-3.0 * lcg(&mut seed)),
            })
            .collect();
        let a = DMatrix::from_fn(m, n, |r, _| w[r] * (lcg(&mut seed) * 2.0 - 1.0));
        let b = DVector::from_fn(m, |r, _| w[r] * (lcg(&mut seed) * 4.0 - 2.0));
        let lower = DVector::from_fn(n, |_, _| -lcg(&mut seed) * 0.5);
        let upper = DVector::from_fn(n, |_, _| lcg(&mut seed) * 0.5);
        let sys = LinearSystem { a: a.into(), b, lower, upper };
        assert!(Factor::new(&sys.a).needs_qr(), "case {case} should take the QR path");
        let out = solve_system(&sys);
        let best = brute_force(&sys);
        assert!(out.objective <= best * (1.0 + 1e-9) + 1e-14, "case {case}: {} vs {best}", out.objective);
        assert!((0..n).all(|i| out.x[i] >= sys.lower[i] && out.x[i] <= sys.upper[i]));
        assert!(out.kkt < 1e-9, "case {case}: kkt {}", out.kkt);
    }
}

#[test]
fn feasible_unconstrained_solution_is_returned_directly() {
    let a = DMatrix::identity(3, 3);
    let b = DVector::from_vec(vec![0.1, 0.2, 0.3]);
    let sys =
        LinearSystem { a: a.into(), b: b.clone(), lower: DVector::zeros(3), upper: DVector::from_element(3, 1.0) };
    let out = solve_system(&sys);
    assert!(!out.bounds_active);
    assert!((out.x - b).amax() < 1e-15);
}

#[test]
fn rank_deficient_gives_minimum_norm() {
    // Two identical columns: the minimum-norm solution splits evenly.
    let a = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
    let b = DVector::from_vec(vec![2.0, 2.0]);
    let inf = f64::INFINITY;
    let sys =
        LinearSystem { a: a.into(), b, lower: DVector::from_element(2, -inf), upper: DVector::from_element(2, inf) };
    let out = solve_system(&sys);
    assert!((out.x[0] - 1.0).abs() < 1e-12 && (out.x[1] - 1.0).abs() < 1e-12);
}

/// The batch designs' systems (bounded single reflectances under 3 fixed lights), as the solve assembles them.
fn batch_systems(count: usize, seed: u64) -> Vec<LinearSystem> {
    let col = crate::colorimetry::Colorimetry::default();
    systems_of(&crate::palette::random::batch_palette(count, seed, &col))
}

/// The same with every target reachable (the designs press on fewer bounds).
fn reachable_systems(count: usize, seed: u64) -> Vec<LinearSystem> {
    let col = crate::colorimetry::Colorimetry::default();
    systems_of(&crate::palette::random::reachable_batch_palette(count, seed, &col))
}

fn systems_of(p: &crate::palette::Palette) -> Vec<LinearSystem> {
    use crate::design::system::{Design, Layout};
    let col = crate::colorimetry::Colorimetry::default();
    let design = Design::new(p, None, &col).expect("the batch palette is valid");
    let v = design.start_values();
    design.blocks().iter().map(|b| design.linear_system(&Layout::new(&b.units), &b.terms, &v)).collect()
}

#[test]
fn both_starts_end_at_the_same_bits_and_the_optimum() {
    // The finish from the clamped SVD solution and from L-BFGS-B's point end at the same active set, and the
    // fresh solve of that set makes the result the same to the bit.
    let mut bounded = 0;
    for sys in batch_systems(300, 5) {
        let factor = Factor::new(&sys.a);
        assert!(!factor.needs_qr(), "the batch designs take the normal-equations path");
        let a = solve_from_start(&sys, &factor, Start::Clamped);
        let b = solve_from_start(&sys, &factor, Start::Lbfgsb);
        let bits = |x: &DVector<f64>| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.x), bits(&b.x));
        assert_eq!(a.objective.to_bits(), b.objective.to_bits());
        assert!(a.kkt < 1e-12, "kkt {}", a.kkt);
        assert!((0..a.x.len()).all(|i| a.x[i] >= sys.lower[i] && a.x[i] <= sys.upper[i]));
        bounded += a.bounds_active as usize;
    }
    assert!(bounded > 200, "most batch designs press against the bounds ({bounded} of 300)");
}

#[test]
fn clamped_start_matches_brute_force_on_small_random_systems() {
    let mut seed = 23u64;
    for _ in 0..40 {
        let (m, n) = (4 + (lcg(&mut seed) * 4.0) as usize, 2 + (lcg(&mut seed) * 4.0) as usize);
        let a = DMatrix::from_fn(m, n, |_, _| lcg(&mut seed) * 2.0 - 1.0);
        let b = DVector::from_fn(m, |_, _| lcg(&mut seed) * 4.0 - 2.0);
        let lower = DVector::from_fn(n, |_, _| -lcg(&mut seed) * 0.3);
        let upper = DVector::from_fn(n, |_, _| lcg(&mut seed) * 0.3);
        let sys = LinearSystem { a: a.into(), b, lower, upper };
        let factor = Factor::new(&sys.a);
        if factor.needs_qr() {
            continue;
        }
        let out = solve_from_start(&sys, &factor, Start::Clamped);
        let best = brute_force(&sys);
        assert!(out.objective <= best * (1.0 + 1e-9) + 1e-14, "{} vs {best}", out.objective);
        assert!(out.kkt < 1e-9, "kkt {}", out.kkt);
    }
}

#[test]
fn a_factor_copied_from_the_free_sets_gives_the_bits_of_one_built_afresh() {
    // Every design is solved twice with one shared factorisation (whose factors by free set fill as the
    // designs go: the second solve finds its sets) and once with a fresh one holding nothing: the same bits.
    let systems = batch_systems(200, 11);
    let shared = Factor::new(&systems[0].a);
    let bits = |x: &DVector<f64>| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    for sys in &systems {
        assert_eq!(sys.a.shape(), systems[0].a.shape());
        assert!(sys.a.iter().zip(systems[0].a.iter()).all(|(x, y)| x.to_bits() == y.to_bits()), "one A");
        let once = solve(sys, &shared);
        let again = solve(sys, &shared);
        let fresh = solve(sys, &Factor::new(&sys.a));
        assert_eq!(bits(&once.x), bits(&fresh.x));
        assert_eq!(bits(&again.x), bits(&fresh.x));
        assert_eq!(once.kkt.to_bits(), fresh.kkt.to_bits());
    }
    // Random targets press on most bounds: many free sets are too short to be shared (`Sets::FIRST_ROW`).
    assert!(shared.free_sets.hits() >= 50, "{} lookups found rows", shared.free_sets.hits());
    // Reachable targets: fewer bounds, free sets that share their leading variables more than their whole.
    let systems = reachable_systems(300, 11);
    let shared = Factor::new(&systems[0].a);
    for sys in &systems {
        let once = solve(sys, &shared);
        let fresh = solve(sys, &Factor::new(&sys.a));
        assert_eq!(bits(&once.x), bits(&fresh.x));
        assert_eq!(once.kkt.to_bits(), fresh.kkt.to_bits());
    }
    assert!(shared.free_sets.hits() >= 20, "{} lookups found rows", shared.free_sets.hits());
}

/// A free set that shares only its leading variables with one factored before takes their rows from
/// `FreeSets` and builds the rest: every row the bits of a factor built afresh, row by row, and the lookup
/// counted as a hit (a row kept under the wrong set, e.g. without its own last variable, fails this).
#[test]
fn rows_shared_by_leading_variables_are_a_fresh_factors_bits() {
    let sys = &reachable_systems(5, 3)[0];
    let factor = Factor::new(&sys.a);
    let (m, n) = sys.a.shape();
    assert!(n > 24);
    let sets = FreeSets::default();
    let factor_of = |bound: &[usize], sets: Option<&FreeSets>| {
        let mut work = Work::new(m, n, false);
        work.is_free.iter_mut().enumerate().for_each(|(i, f)| *f = !bound.contains(&i));
        work.factor_free_set(&factor.h, sets, finish::Rows::None);
        assert!(work.chol.ok);
        let nf = work.free.len();
        (0..nf).flat_map(|k| work.chol.l[k * n..k * n + k + 1].to_vec()).map(f64::to_bits).collect::<Vec<_>>()
    };
    // Kept: rows from the 9th on of the set without variables 2 and 20.
    assert_eq!(factor_of(&[2, 20], Some(&sets)), factor_of(&[2, 20], None));
    assert_eq!(sets.hits(), 0);
    // Without 2 and 23: the rows up to variable 19 (its 18 first after 2's gap) are the first set's.
    assert_eq!(factor_of(&[2, 23], Some(&sets)), factor_of(&[2, 23], None));
    assert_eq!(sets.hits(), 1);
    // Without 2, 20 and 27: every row up to 26 is held; the rest built.
    assert_eq!(factor_of(&[2, 20, 27], Some(&sets)), factor_of(&[2, 20, 27], None));
    assert_eq!(sets.hits(), 2);
    // A set sharing nothing past the short rows: nothing found.
    assert_eq!(factor_of(&[1, 5], Some(&sets)), factor_of(&[1, 5], None));
    assert_eq!(sets.hits(), 2);
}

#[test]
fn hand_products_give_nalgebras_bits() {
    // `kernels::gemv` / `gemv_tr` against `&a * &x` and `a.tr_mul(&v)`, bit for bit: every shape up to
    // 19 × 19 (the remainders of both kernels' unrolling) and the batch's 40 × 31 and 31 × 40, with
    // entries of mixed signs and magnitudes, exact zeros of both signs, and a few entries that cancel.
    let mut seed = 27;
    let value = |seed: &mut u64| entry(seed, &[0.0, -0.0, 1.0]);
    let bits = |v: &DVector<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let shapes = (0..20).flat_map(|m| (0..20).map(move |n| (m, n))).chain([(40, 31), (31, 40), (9, 31)]);
    for (m, n) in shapes {
        for _ in 0..3 {
            let a = DMatrix::from_fn(m, n, |_, _| value(&mut seed));
            let x = DVector::from_fn(n, |_, _| value(&mut seed));
            let v = DVector::from_fn(m, |_, _| value(&mut seed));
            for y in both(|| {
                let mut y = DVector::from_element(m, f64::NAN);
                kernels::gemv(&a, x.as_slice(), y.as_mut_slice());
                y
            }) {
                assert_eq!(bits(&y), bits(&(&a * &x)), "A x, {m} × {n}");
            }
            let mut t = DVector::from_element(n, f64::NAN);
            kernels::gemv_tr(&a, v.as_slice(), t.as_mut_slice());
            assert_eq!(bits(&t), bits(&a.tr_mul(&v)), "Aᵀ v, {m} × {n}");
            // The same vectors ending in zeros of both signs from every cut on (the products that leave the
            // trailing zeros out), and a row or column of A zero so that a kept sum is exactly zero.
            let mut az = a.clone();
            if m > 0 && n > 0 && lcg(&mut seed) < 0.3 {
                let (r, c) = ((lcg(&mut seed) * m as f64) as usize, (lcg(&mut seed) * n as f64) as usize);
                az.row_mut(r).fill(if c % 2 == 0 { 0.0 } else { -0.0 });
                az.column_mut(c).fill(0.0);
            }
            for cut in 0..=n {
                let xz = DVector::from_fn(n, |j, _| {
                    if j < cut {
                        x[j]
                    } else if j % 3 == 0 {
                        -0.0
                    } else {
                        0.0
                    }
                });
                for y in both(|| {
                    let mut y = DVector::from_element(m, f64::NAN);
                    kernels::gemv_trailing_zeros(&az, xz.as_slice(), y.as_mut_slice());
                    y
                }) {
                    assert_eq!(bits(&y), bits(&(&az * &xz)), "A x with zeros from {cut} on, {m} × {n}");
                }
            }
            for cut in 0..=m {
                let vz = DVector::from_fn(m, |i, _| {
                    if i < cut {
                        v[i]
                    } else if i % 3 == 0 {
                        -0.0
                    } else {
                        0.0
                    }
                });
                let mut t = DVector::from_element(n, f64::NAN);
                kernels::gemv_tr_trailing_zeros(&az, vz.as_slice(), t.as_mut_slice());
                assert_eq!(bits(&t), bits(&az.tr_mul(&vz)), "Aᵀ v with zeros from {cut} on, {m} × {n}");
            }
        }
    }
}

fn bits(x: &DVector<f64>) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn products_without_the_zero_chunks_give_nalgebras_bits() {
    // `kernels::gemv_tr_zero_chunks` against `a.tr_mul(&v)`, bit for bit: dense rows over sparse ones (up
    // to three entries a row, as a design's smoothness rows, with zeros of both signs), every number of
    // dense rows around the partial sums' chunks of eight and shapes with a remainder after them, vectors
    // with zeros of both signs, v zero on the sparse rows (a right-hand side), and v not finite (the dense
    // product's NaN).
    let mut seed = 48;
    let value = |seed: &mut u64| entry(seed, &[0.0, -0.0, 1.0, -1.0]);
    let zero = |seed: &mut u64| if lcg(seed) < 0.5 { 0.0 } else { -0.0 };
    for (m, n) in [(40, 31), (12, 9), (17, 16), (24, 5), (33, 8), (9, 31), (48, 40), (7, 3)] {
        for dense in 0..m {
            // Row i ≥ dense: entries near column i − dense only (a band of three), most of them nonzero.
            let in_band = |i: usize, j: usize| i < dense || (j + 1 >= i - dense && j <= i - dense + 1);
            let a = DMatrix::from_fn(m, n, |i, j| {
                if in_band(i, j) && (i < dense || lcg(&mut seed) < 0.9) { value(&mut seed) } else { zero(&mut seed) }
            });
            let chunks = kernels::ZeroChunks::of(&a).expect("a finite matrix");
            for case in 0..4 {
                let mut v = DVector::from_fn(m, |_, _| value(&mut seed));
                match case {
                    1 => v.rows_mut(dense, m - dense).iter_mut().for_each(|t| *t = zero(&mut seed)),
                    2 => v[m - 1] = f64::NAN,
                    3 => v.fill(-0.0),
                    _ => {}
                }
                for t in both(|| {
                    let mut t = DVector::from_element(n, f64::NAN);
                    kernels::gemv_tr_zero_chunks(&a, &chunks, v.as_slice(), t.as_mut_slice());
                    t
                }) {
                    assert_eq!(bits(&t), bits(&a.tr_mul(&v)), "Aᵀ v, {m} × {n}, {dense} dense rows, case {case}");
                }
            }
        }
    }
    // A batch design's own A and right-hand side, and a residual-like v.
    let sys = &reachable_systems(1, 3)[0];
    let chunks = kernels::ZeroChunks::of(&sys.a).expect("a finite matrix");
    let v = DVector::from_fn(sys.a.nrows(), |_, _| value(&mut seed));
    for v in [&sys.b, &v] {
        for t in both(|| {
            let mut t = DVector::from_element(sys.a.ncols(), f64::NAN);
            kernels::gemv_tr_zero_chunks(&sys.a, &chunks, v.as_slice(), t.as_mut_slice());
            t
        }) {
            assert_eq!(bits(&t), bits(&sys.a.tr_mul(v)));
        }
    }
}

/// `f` run with the kernels' AVX2 build (where the processor has it) and with their portable build.
fn both<R>(f: impl Fn() -> R) -> [R; 2] {
    [f(), kernels::portable(&f)]
}

#[test]
fn the_kernels_avx2_build_gives_the_portable_builds_bits_on_whole_solves() {
    // Every batch design (random targets, most pressing on the bounds, and reachable ones) solved with the
    // kernels built for AVX2 and for the baseline processor: the same solution, objective and KKT residual
    // to the bit (the guess's steps, the factors' rows and the products all run in both builds). Where the
    // processor has no AVX2 both runs are the portable build's.
    let mut bounded = 0;
    for sys in batch_systems(40, 11).iter().chain(&reachable_systems(40, 12)) {
        let [wide, portable] = both(|| solve_system(sys));
        assert_eq!(bits(&wide.x), bits(&portable.x));
        assert_eq!(wide.objective.to_bits(), portable.objective.to_bits());
        assert_eq!(wide.kkt.to_bits(), portable.kkt.to_bits());
        bounded += usize::from(wide.bounds_active);
    }
    assert!(bounded >= 40, "{bounded} designs pressed on their bounds");
}

/// The guessed start against the finish's own steps from the clamped solution (`Start::ClampedUnguessed`,
/// the path before the guess) and the optimum's conditions: the same bits when the optimum's active set is
/// unique. Returns whether the two differ at all (allowed only where the caller says the set is degenerate:
/// then both must be optimal and agree to rounding).
fn guessed_against_unguessed(sys: &LinearSystem, factor: &Factor) -> bool {
    let a = solve_from_start(sys, factor, Start::Clamped);
    let b = solve_from_start(sys, factor, Start::ClampedUnguessed);
    let n = sys.a.ncols();
    for out in [&a, &b] {
        assert!((0..n).all(|i| out.x[i] >= sys.lower[i] && out.x[i] <= sys.upper[i]), "inside the box");
        assert!(out.kkt < 1e-12, "kkt {}", out.kkt);
    }
    let same = bits(&a.x) == bits(&b.x);
    if same {
        assert_eq!(a.objective.to_bits(), b.objective.to_bits());
        assert_eq!(a.kkt.to_bits(), b.kkt.to_bits());
    } else {
        assert!((a.objective - b.objective).abs() <= 1e-12 * (1.0 + b.objective), "{} vs {}", a.objective, b.objective);
        assert!((&a.x - &b.x).amax() < 1e-9, "max |Δx| {}", (&a.x - &b.x).amax());
    }
    !same
}

#[test]
fn the_guessed_active_set_gives_the_bits_of_the_finish_on_batch_designs() {
    // Reachable and random targets (the guess hands over to the finish when more than half the samples
    // bind, most random targets): the same bits as the finish's own path from the clamped solution.
    for (systems, what) in [(reachable_systems(400, 3), "reachable"), (batch_systems(300, 9), "random")] {
        let factor = Factor::new(&systems[0].a);
        assert!(!factor.needs_qr());
        let mut bounded = 0;
        for sys in &systems {
            assert!(!guessed_against_unguessed(sys, &factor), "{what}: the bits differ");
            bounded += solve(sys, &factor).bounds_active as usize;
        }
        assert!(bounded > 100, "{what}: {bounded} designs press on the bounds");
    }
}

#[test]
fn the_guessed_active_set_on_degenerate_designs() {
    // Targets scaled far outside the reachable colours (every sample clamped, or all but a few), the
    // unconstrained solution's samples put exactly on a bound (a bound with a zero multiplier: the active
    // set is not unique there), two identical lights (collinear rows), and bounds that pin samples
    // (lower = upper). Every result inside the box with KKT ≤ 1e-12 against the finish's own path, the same
    // bits when the set is unique.
    let base = reachable_systems(60, 17);
    let factor = Factor::new(&base[0].a);
    let mut seed = 5u64;
    let (mut differed, mut on_bound) = (0, 0);
    for (k, sys) in base.iter().enumerate() {
        let mut far = sys.clone();
        far.b *= 40.0 + 200.0 * lcg(&mut seed);
        assert!(!guessed_against_unguessed(&far, &factor), "design {k} scaled");
        // A sample of the unconstrained solution made a bound, and its neighbour the other bound.
        let mut xu = DVector::zeros(sys.a.ncols());
        kernels::gemv(&factor.pinv, sys.b.as_slice(), xu.as_mut_slice());
        let mut at = sys.clone();
        let inside = |i: usize| xu[i] > sys.lower[i] && xu[i] < sys.upper[i];
        let from = (lcg(&mut seed) * (xu.len() - 1) as f64) as usize;
        if let Some(i) = (from..xu.len() - 1).chain(0..from).find(|&i| inside(i) && inside(i + 1)) {
            at.lower[i] = xu[i];
            at.upper[i + 1] = xu[i + 1];
            differed += guessed_against_unguessed(&at, &factor) as usize;
            on_bound += 1;
        }
        let mut pinned = sys.clone();
        let j = (lcg(&mut seed) * xu.len() as f64) as usize;
        pinned.lower[j] = 0.25;
        pinned.upper[j] = 0.25;
        assert!(!guessed_against_unguessed(&pinned, &factor), "design {k} pinned");
    }
    assert!(on_bound > 40, "{on_bound} designs with samples put on a bound");
    assert!(differed <= 3, "{differed} of {on_bound} designs with a sample on a bound differ in the last bits");
    // Two identical lights: the first light's rows repeated over the second's.
    let sys = &base[0];
    let mut a = (*sys.a).clone();
    let mut b = sys.b.clone();
    for r in 3..6 {
        let row = a.row(r - 3).clone_owned();
        a.set_row(r, &row);
        b[r] = b[r - 3];
    }
    let twin = LinearSystem { a: a.into(), b, lower: sys.lower.clone(), upper: sys.upper.clone() };
    let twin_factor = Factor::new(&twin.a);
    assert!(!twin_factor.needs_qr());
    for scale in [1.0, 3.0, 30.0] {
        let mut s = twin.clone();
        s.b *= scale;
        assert!(!guessed_against_unguessed(&s, &twin_factor), "twin lights, targets × {scale}");
    }
}

#[test]
fn the_guessed_start_matches_brute_force_on_small_random_systems() {
    // Small systems (2–5 unknowns, so the guess works on one or two bound variables) against the brute
    // force over every active set, which solves each by nalgebra's SVD, independently of the engine.
    let mut seed = 41u64;
    let mut tried = 0;
    for _ in 0..200 {
        let (m, n) = (4 + (lcg(&mut seed) * 4.0) as usize, 2 + (lcg(&mut seed) * 4.0) as usize);
        let a = DMatrix::from_fn(m, n, |_, _| lcg(&mut seed) * 2.0 - 1.0);
        let b = DVector::from_fn(m, |_, _| lcg(&mut seed) * 4.0 - 2.0);
        let lower = DVector::from_fn(n, |_, _| -lcg(&mut seed) * 0.6);
        let upper = DVector::from_fn(n, |_, _| lcg(&mut seed) * 0.6);
        let sys = LinearSystem { a: a.into(), b, lower, upper };
        let factor = Factor::new(&sys.a);
        if factor.needs_qr() {
            continue;
        }
        tried += 1;
        let out = solve_from_start(&sys, &factor, Start::Clamped);
        let best = brute_force(&sys);
        assert!(out.objective <= best * (1.0 + 1e-9) + 1e-14, "{} vs {best}", out.objective);
        assert!(out.kkt < 1e-9, "kkt {}", out.kkt);
        guessed_against_unguessed(&sys, &factor);
    }
    assert!(tried > 150, "{tried} systems on the normal-equations path");
}
