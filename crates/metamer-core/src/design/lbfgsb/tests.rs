//! Unit tests of `lbfgsb.rs` (a sibling file to keep `lbfgsb.rs` about the code).

use super::*;

/// f(x) = ½ xᵀ H x − cᵀ x.
struct Quadratic {
    h: DMatrix<f64>,
    c: DVector<f64>,
}
impl CostFunction for Quadratic {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, x: &DVector<f64>) -> Result<f64, Error> {
        Ok(0.5 * x.dot(&(&self.h * x)) - self.c.dot(x))
    }
}
impl Gradient for Quadratic {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;
    fn gradient(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        Ok(&self.h * x - &self.c)
    }
}

struct Rosenbrock;
impl CostFunction for Rosenbrock {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, x: &DVector<f64>) -> Result<f64, Error> {
        Ok((0..x.len() - 1).map(|i| 100.0 * (x[i + 1] - x[i] * x[i]).powi(2) + (1.0 - x[i]).powi(2)).sum())
    }
}
impl Gradient for Rosenbrock {
    type Param = DVector<f64>;
    type Gradient = DVector<f64>;
    fn gradient(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        let n = x.len();
        let mut g = DVector::zeros(n);
        for i in 0..n - 1 {
            let t = x[i + 1] - x[i] * x[i];
            g[i] += -400.0 * x[i] * t - 2.0 * (1.0 - x[i]);
            g[i + 1] += 200.0 * t;
        }
        Ok(g)
    }
}

#[test]
fn separable_quadratic_hits_the_clamped_minimiser() {
    // Diagonal H: the bounded minimiser is the unconstrained one clamped, componentwise.
    let n = 12;
    let h = DMatrix::from_diagonal(&DVector::from_fn(n, |i, _| 1.0 + i as f64));
    let c = DVector::from_fn(n, |i, _| if i % 2 == 0 { 5.0 * (i as f64 + 1.0) } else { -3.0 });
    let lo = DVector::from_element(n, -1.0);
    let hi = DVector::from_element(n, 2.0);
    let want = DVector::from_fn(n, |i, _| (c[i] / h[(i, i)]).clamp(-1.0, 2.0));
    let solver = LBfgsB::new(lo.clone(), hi.clone()).with_f_tol(0.0, 0.0).with_pg_tol(1e-12);
    let (x, _, g) = minimize(Quadratic { h, c }, solver, DVector::zeros(n), 200).unwrap();
    // Function values limit the line search to about √ε relative accuracy in x.
    assert!((&x - &want).amax() < 1e-6, "x = {x}, want {want}");
    assert!(projected_gradient_norm(&x, &g, &lo, &hi) < 1e-6);
    // The active set is exact: every clamped component sits exactly on its bound.
    for i in 0..n {
        if want[i] == 2.0 || want[i] == -1.0 {
            assert_eq!(x[i], want[i]);
        }
    }
}

#[test]
fn coupled_quadratic_satisfies_kkt() {
    // H = tridiagonal (ill-conditioned chain), bounds active on part of the variables.
    let n = 30;
    let h = DMatrix::from_fn(n, n, |i, j| {
        if i == j {
            2.01
        } else if i.abs_diff(j) == 1 {
            -1.0
        } else {
            0.0
        }
    });
    let c = DVector::from_fn(n, |i, _| ((i as f64) * 0.7).sin());
    let lo = DVector::from_element(n, -0.5);
    let hi = DVector::from_element(n, 0.5);
    let (x, _, g) = minimize(Quadratic { h, c }, LBfgsB::new(lo.clone(), hi.clone()), DVector::zeros(n), 5000).unwrap();
    assert!(x.iter().all(|v| (-0.5..=0.5).contains(v)));
    let kkt = projected_gradient_norm(&x, &g, &lo, &hi);
    assert!(kkt < 1e-7, "projected gradient {kkt}");
    assert!(x.iter().any(|v| *v == 0.5 || *v == -0.5), "some bound should be active");
}

#[test]
fn bounded_rosenbrock() {
    // Minimum of Rosenbrock in [-2, 0.5]² with x1 ≤ 0.5: on the boundary x0 = 0.5, x1 = 0.25.
    let lo = DVector::from_vec(vec![-2.0, -2.0]);
    let hi = DVector::from_vec(vec![0.5, 2.0]);
    let (x, f, g) =
        minimize(Rosenbrock, LBfgsB::new(lo.clone(), hi.clone()), DVector::from_vec(vec![-1.2, 1.0]), 2000).unwrap();
    assert!((x[0] - 0.5).abs() < 1e-7 && (x[1] - 0.25).abs() < 1e-6, "x = {x}");
    assert!((f - 0.25).abs() < 1e-10);
    assert!(projected_gradient_norm(&x, &g, &lo, &hi) < 1e-6);
}

#[test]
fn unbounded_rosenbrock_in_10d() {
    let n = 10;
    let lo = DVector::from_element(n, f64::NEG_INFINITY);
    let hi = DVector::from_element(n, f64::INFINITY);
    let x0 = DVector::from_fn(n, |i, _| if i % 2 == 0 { -1.2 } else { 1.0 });
    let (x, f, _) = minimize(Rosenbrock, LBfgsB::new(lo, hi), x0, 5000).unwrap();
    assert!(f < 1e-12, "f = {f}");
    assert!((x - DVector::from_element(n, 1.0)).amax() < 1e-5);
}

#[test]
fn iterates_never_leave_the_box() {
    // A start far outside is projected; every accepted point stays inside.
    let n = 5;
    let h = DMatrix::identity(n, n);
    let c = DVector::from_element(n, 10.0);
    let lo = DVector::from_element(n, 0.0);
    let hi = DVector::from_element(n, 1.0);
    let (x, _, _) = minimize(Quadratic { h, c }, LBfgsB::new(lo, hi), DVector::from_element(n, -7.0), 100).unwrap();
    assert!(x.iter().all(|v| *v == 1.0), "x = {x}");
}
