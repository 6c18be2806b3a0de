//! A region from support points (inner hull, outer half-spaces, volumes), a target placed against it,
//! and constant-L* slices for the designer's panel.

use super::*;

/// `n` unit vectors spread over the sphere (Fibonacci lattice).
pub(crate) fn sphere_directions(n: usize) -> Vec<Vector3<f64>> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            Vector3::new(z, r * phi.cos(), r * phi.sin())
        })
        .collect()
}

/// The region of one cell: its supporting half-spaces `d·c ≤ h` (linear sRGB) and support points.
#[derive(Clone, Debug)]
pub struct Region {
    /// Index into `palette.colours`.
    pub cell: usize,
    /// Directions in linear sRGB.
    pub directions: Vec<Vector3<f64>>,
    /// Support values (`+∞` where unbounded).
    pub(crate) support: Vec<f64>,
    /// The support points (one per bounded direction).
    pub points: Vec<Vector3<f64>>,
    /// Support values of the outer region ([`Hold::Outer`]) in the same directions (`+∞` where
    /// unbounded, `−∞` everywhere when it is empty).
    pub outer_support: Vec<f64>,
    /// The outer region's support points.
    pub outer_points: Vec<Vector3<f64>>,
    /// The outer region is empty: no partner colours the met criterion accepts are reachable together.
    pub outer_empty: bool,
    /// True when every direction is bounded.
    pub bounded: bool,
    /// Convex-hull volume of the support points in linear sRGB (∞ when unbounded).
    pub volume_rgb: f64,
    /// Convex-hull volume of the support points mapped to CIELAB, ΔE*ab³ (∞ when unbounded).
    pub volume_lab: f64,
    /// L* range of the region under the cell's light.
    pub l_range: (f64, f64),
    /// Time to compute it.
    pub seconds: f64,
}

/// The convex-hull volume of points (0 when they are degenerate: fewer than 4 or flat).
pub fn hull_volume(points: &[Vector3<f64>]) -> f64 {
    let mut pts: Vec<Vec<f64>> = Vec::new();
    let scale = points.iter().map(|p| p.amax()).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    for p in points {
        if !pts.iter().any(|q| (q[0] - p[0]).abs() + (q[1] - p[1]).abs() + (q[2] - p[2]).abs() <= 1e-9 * scale) {
            pts.push(vec![p[0], p[1], p[2]]);
        }
    }
    if pts.len() < 4 {
        return 0.0;
    }
    match chull::ConvexHullWrapper::try_new(&pts, None) {
        Ok(h) => h.volume().abs(),
        Err(_) => 0.0,
    }
}

/// Compute the region of `problem` from `n` directions (plus ±L*), the LPs in parallel.
pub fn region(problem: &Problem, n: usize) -> Result<Region, FeasibilityError> {
    let started = Instant::now();
    let lp = problem.lp(&[]);
    let j = problem.jacobian(&problem.achieved);
    let mut unit_dirs = sphere_directions(n);
    unit_dirs.push(Vector3::new(1.0, 0.0, 0.0));
    unit_dirs.push(Vector3::new(-1.0, 0.0, 0.0));
    // d·c = u·(J c): the half-space u·y ≤ h in linearised CIELAB is d·c ≤ h in linear sRGB.
    let directions: Vec<Vector3<f64>> = unit_dirs.iter().map(|u| j.transpose() * u).collect();
    let results: Vec<Result<Option<Support>, FeasibilityError>> =
        directions.par_iter().map(|d| problem.support_with(&lp, d)).collect();
    // The outer region in the same directions; empty when the partners' targets cannot all be met
    // within their outer boxes.
    let outer_lp = problem.lp_held(Hold::Outer, &[], &[]);
    let outer: Vec<Result<Option<Option<Support>>, FeasibilityError>> =
        directions.par_iter().map(|d| problem.support_outcome(&outer_lp, d)).collect();
    let mut outer_support = Vec::with_capacity(directions.len());
    let mut outer_points = Vec::with_capacity(directions.len());
    let mut outer_empty = false;
    for r in outer {
        match r? {
            Some(Some((h, c))) => {
                outer_support.push(h);
                outer_points.push(c);
            }
            Some(None) => outer_support.push(f64::INFINITY),
            None => {
                outer_empty = true;
                outer_support.push(f64::NEG_INFINITY);
            }
        }
    }
    if outer_empty {
        outer_points.clear();
        outer_support.iter_mut().for_each(|h| *h = f64::NEG_INFINITY);
    }
    let mut support = Vec::with_capacity(directions.len());
    let mut points = Vec::with_capacity(directions.len());
    for r in results {
        match r? {
            Some((h, c)) => {
                support.push(h);
                points.push(c);
            }
            None => support.push(f64::INFINITY),
        }
    }
    let bounded = support.iter().all(|h| h.is_finite());
    // L* range from the extremes of Y.
    let yrow = problem.rgb_to_xyz.row(1).transpose();
    let ymax = problem.support_with(&lp, &yrow)?.map(|(h, _)| h).unwrap_or(f64::INFINITY);
    let ymin = problem.support_with(&lp, &-yrow)?.map(|(h, _)| -h).unwrap_or(f64::NEG_INFINITY);
    let yn = problem.white[1];
    let l_range = (
        if ymin.is_finite() { l_of_y(ymin, yn) } else { f64::NEG_INFINITY },
        if ymax.is_finite() { l_of_y(ymax, yn) } else { f64::INFINITY },
    );
    let (volume_rgb, volume_lab) = if bounded {
        let lab: Vec<Vector3<f64>> = points.iter().map(|p| Vector3::from(problem.lab(p))).collect();
        (hull_volume(&points), hull_volume(&lab))
    } else {
        (f64::INFINITY, f64::INFINITY)
    };
    Ok(Region {
        cell: problem.cell,
        directions,
        support,
        points,
        outer_support,
        outer_points,
        outer_empty,
        bounded,
        volume_rgb,
        volume_lab,
        l_range,
        seconds: started.elapsed().as_secs_f64(),
    })
}

impl Region {
    /// The inner approximation's support value in direction `d`: the largest `d·p` over the support
    /// points.
    pub fn inner_support(&self, d: &Vector3<f64>) -> f64 {
        self.points.iter().map(|p| d.dot(p)).fold(f64::NEG_INFINITY, f64::max)
    }
}

/// Where a target lies relative to a region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placement {
    /// In the inner region: reachable with every partner kept within its inscribed box.
    Inside,
    /// Within [`ON_BAND`] of the inner region's boundary (either side), and not outside.
    On,
    /// Outside the inner region but not provably unmeetable: the met criterion may still accept it.
    Undecided,
    /// Outside the outer region: no solution meets this cell and every partner within ΔE00 τ.
    Outside,
}

impl Placement {
    /// The placement's word in the JSON report's `feasibility` entries: `inside`, `on`, `undecided` or `outside`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Placement::Inside => "inside",
            Placement::On => "on",
            Placement::Undecided => "undecided",
            Placement::Outside => "outside",
        }
    }
}

/// A target against a region.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    /// Where the target lies: inside, on the boundary, undecided, or provably outside.
    pub placement: Placement,
    /// ΔE00 to the boundary: negative inside, positive outside (−∞ inside an unbounded region).
    pub signed_delta_e: f64,
    /// The closest reachable colour (the target itself when inside), linear sRGB.
    pub closest: Vector3<f64>,
    /// The nearest boundary point found (linear sRGB): the closest colour outside, the foot on the
    /// nearest supporting plane inside.
    pub(crate) boundary: Vector3<f64>,
}

/// Place `target` against the region of `problem`.
pub fn place(problem: &Problem, region: &Region, target: &Vector3<f64>) -> Result<Verdict, FeasibilityError> {
    let (closest, dist) = problem.closest(target)?;
    let may_meet = region.outer_empty.then_some(false).map_or_else(|| problem.may_meet(target), Ok)?;
    if dist > REACH_EPS {
        let de = problem.delta_e(target, &closest);
        let placement = if !may_meet {
            Placement::Outside
        } else if de <= ON_BAND {
            Placement::On
        } else {
            Placement::Undecided
        };
        return Ok(Verdict { placement, signed_delta_e: de, closest, boundary: closest });
    }
    if !may_meet {
        // Reached with the partners in their inscribed boxes yet not with them near their targets: a
        // partner is far from its target (unmet). Neither promise holds.
        return Ok(Verdict {
            placement: Placement::Undecided,
            signed_delta_e: 0.0,
            closest: *target,
            boundary: *target,
        });
    }
    // Inside: the nearest supporting plane in CIELAB linearised at the target.
    let j = problem.jacobian(target);
    let Some(jinv) = j.try_inverse() else {
        return Ok(Verdict { placement: Placement::On, signed_delta_e: 0.0, closest: *target, boundary: *target });
    };
    let mut best: Option<(f64, Vector3<f64>)> = None;
    for (d, h) in region.directions.iter().zip(&region.support) {
        if !h.is_finite() {
            continue;
        }
        // In y = J c the plane is u'·y = h with u' = J⁻ᵀ d.
        let u = jinv.transpose() * d;
        let norm = u.norm();
        if norm <= 0.0 {
            continue;
        }
        let depth = (h - d.dot(target)) / norm;
        if best.is_none_or(|(b, _)| depth < b) {
            let foot = target + jinv * (u / norm) * depth;
            best = Some((depth, foot));
        }
    }
    let Some((_, foot)) = best else {
        return Ok(Verdict {
            placement: Placement::Inside,
            signed_delta_e: f64::NEG_INFINITY,
            closest: *target,
            boundary: *target,
        });
    };
    let de = problem.delta_e(target, &foot);
    let placement = if de <= ON_BAND { Placement::On } else { Placement::Inside };
    Ok(Verdict { placement, signed_delta_e: -de, closest: *target, boundary: foot })
}

/// The region's slice at one L*: a polygon in the a*–b* plane.
#[derive(Clone, Debug, PartialEq)]
pub struct Slice {
    pub(crate) l_star: f64,
    /// Polygon vertices in CIELAB (L*, a*, b*), in angular order.
    pub lab: Vec<[f64; 3]>,
}

/// The slice of the region at `l_star` (under the cell's light) from `n` directions in the a*–b* plane
/// (CIELAB linearised at `centre`); `None` when the region does not reach that L*.
pub fn slice(
    problem: &Problem,
    l_star: f64,
    centre: &Vector3<f64>,
    n: usize,
) -> Result<Option<Slice>, FeasibilityError> {
    slice_held(problem, Hold::Inner, l_star, centre, n)
}

/// [`slice`] of the inner or the outer region.
pub(crate) fn slice_held(
    problem: &Problem,
    hold: Hold,
    l_star: f64,
    centre: &Vector3<f64>,
    n: usize,
) -> Result<Option<Slice>, FeasibilityError> {
    let y = y_of_l(l_star, problem.white[1]);
    let yrow = problem.rgb_to_xyz.row(1).into_owned();
    let lp = problem.lp_held(hold, &[(yrow, y)], &[]);
    let j = problem.jacobian(centre);
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        let d = j.transpose() * Vector3::new(0.0, a.cos(), a.sin());
        let g = problem.op.transpose() * d;
        let q: Vec<f64> = g.iter().map(|v| -v).collect();
        match problem.run(&lp, &CscMatrix::zeros((SAMPLES, SAMPLES)), &q)? {
            Outcome::Optimal(x) => {
                let x = nalgebra::SVector::<f64, SAMPLES>::from_column_slice(&x);
                out.push(problem.lab(&(problem.op * x)));
            }
            Outcome::Infeasible => return Ok(None),
            // Unbounded that way: leave the direction out (the canvas clips anyway).
            Outcome::Unbounded => {}
        }
    }
    Ok(Some(Slice { l_star, lab: out }))
}
