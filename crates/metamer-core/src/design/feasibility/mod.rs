//! Feasibility regions (metamer mismatch regions): the set of colours one cell can still take while the
//! other cells of its designed spectrum keep their current colours.
//!
//! A cell whose reflectance is designed under a fixed light (or whose light is designed on a fixed
//! reflectance) has a colour linear in the designed spectrum x: `c = A_k x` with `A_k` the 3×31 operator
//! of [`Design::operator`] (the full colour, or the subspace form under `fit_in_subspace`). With x in
//! its bounds and every *partner* — another active cell on the same designed spectrum whose other side is
//! fixed — held near its current colour `c_j = A_j x₀`, the colours the cell can take form a convex set
//! (a polytope): the image under `A_k` of a polytope of spectra.
//!
//! **Tolerance, two regions.** Each region holds every partner in a box; they differ in the box.
//! - The *inner* region ([`Hold::Inner`]) holds a partner in CIELAB linearised at its current colour
//!   (under its own light): `|J_j (A_j x − c_j)|∞ ≤ τ/√3` per component of (L*, a*, b*), `J_j` the
//!   Jacobian of linear sRGB → CIELAB at `c_j`. The box is inscribed in the ΔE*ab ball of radius τ, so to
//!   first order every partner stays within τ of its colour: what lies inside is reachable without
//!   moving the others noticeably.
//! - The *outer* region ([`Hold::Outer`]) holds a partner in its [`met_box`] around its *target*: a box
//!   containing every colour within ΔE00 τ of the target, the solve's notion of "met" at tolerance τ
//!   ([`crate::design::report`]: ΔE00 of the full colour against the target; `MET_DELTA_E` is that
//!   notion at τ = 1). The box bound and how it is verified are stated at [`met_box`].
//!
//! A target is **inside** when the inner region holds it, **outside** when no colour of the cell's own
//! met box is in the outer region (one feasibility LP, [`Problem::may_meet`]: then no solution has this
//! cell and every partner within ΔE00 τ of their targets — a guarantee, up to the LP's accuracy and the
//! box bound), **on** within [`ON_BAND`] of the inner boundary, and **undecided** otherwise (between the
//! two regions; also, rarely, when the inner region holds it but a partner is far from its target).
//! With τ = 0 the partners are held exactly (`A_j x = c_j`, or `= t_j` for the outer region), the
//! classic metamer mismatch region.
//!
//! **Boundary.** The region is described by its support function `h(d) = max d·A_k x` over the
//! constraints, one linear program per direction (clarabel's interior-point solver, already used by the
//! tests as an independent QP solver, now a normal dependency: one maintained solver for both the LPs of
//! the support function and the QP of the distance). Directions are a Fibonacci sphere of `n` unit vectors
//! in CIELAB linearised at the cell's current colour, plus ±L*, so that the sampling is roughly uniform
//! perceptually; the region is then approximated from inside by the convex hull of the support points
//! and from outside by the intersection of the supporting half-spaces. The accuracy for `n` directions
//! is measured in the tests (the inner hull's support against the LP's in random directions).
//!
//! **Volume** is the convex hull's (the `chull` crate) of the support points, in linear sRGB and, mapped
//! point by point, in CIELAB (ΔE*ab³; the CIELAB image is not exactly convex, so that figure is the hull
//! of the mapped points).
//!
//! **Signed distance** of a target t to the inner region: outside it, the exact distance by a QP (`min ‖J_t (A_k x − t)‖²` over
//! the same constraints, `J_t` the CIELAB Jacobian at t), reported as the ΔE00 between t and the closest
//! reachable colour; inside, minus the ΔE00 from t to the nearest supporting plane (the half-space
//! approximation, measured in CIELAB linearised at t). Within [`ON_BAND`] ΔE00 of the boundary a target
//! is "on" it.
//!
//! **What inside and outside promise** (measured by `tests/it/feasibility.rs` on 30 random single-reflectance
//! designs under two or three lights, all cells first met, then one cell's target moved inside or up to
//! 6 CIELAB units beyond the inner boundary; τ = 0.5): every target placed inside was met by the next
//! solve with every cell within ΔE00 τ (116 of 116, worst cell 0.27); every target placed outside left
//! some cell beyond τ (42 of 42, the least worst cell 1.07); 78 targets were undecided, of which the solve
//! met 20 (it may trade the gap against the held cells), and 4 were on the boundary. Inside relies on the
//! solve finding the reachable solution (a least-squares solve does on these designs; designs with
//! smoothness, weights other than 1 or unmet partners trade differently); outside relies only on the
//! geometry and the box bound. Under `fit_in_subspace` the regions are of the factor-model colour while
//! "met" is judged on the full colour, so neither promise carries over exactly.
//!
//! **Cost.** The outer region reuses the inner one's directions: a region is 2·(n + 2) + 2 LPs; placing a
//! target adds one QP and one feasibility LP.
//!
//! **Cache.** [`RegionCache`] keys a region by everything it depends on: the designed unit, the cell, its
//! operator (the fixed partner spectrum), the bounds, the tolerance, every partner's operator, colour and
//! target, and the number of directions.

use super::DesignError;
use super::system::{Design, Form, Unit, Values};
use crate::basis::Basis;
use crate::colorimetry::{Colorimetry, Q31, delta_e00, xyz_to_lab};
use crate::palette::Palette;
use crate::spectrum::{SAMPLES, Spectrum};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, SupportedConeT, ZeroConeT,
};
use nalgebra::{Matrix3, RowVector3, Vector3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// The default tolerance on the partner cells, in ΔE (see the module docs for how it is modelled).
pub const DEFAULT_TOLERANCE: f64 = 0.5;

/// The default number of support directions (plus ±L*).
pub const DEFAULT_DIRECTIONS: usize = 160;

/// A target within this many ΔE00 of the region's boundary is "on" it.
pub const ON_BAND: f64 = 0.05;

/// The QP distance (CIELAB units, linearised) below which a target counts as reachable: well above
/// clarabel's accuracy (its objective is accurate to about 1e-8, a distance of 1e-4), far below a ΔE
/// anyone sees.
const REACH_EPS: f64 = 2e-3;

/// Directions of the a*–b* slice.
pub const SLICE_DIRECTIONS: usize = 72;

/// Why a region cannot be computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FeasibilityError {
    /// The index (the number) is past the end of `palette.colours`.
    #[error("colours[{0}] does not exist")]
    NoSuchCell(usize),
    /// The cell's colour is not linear in one designed spectrum: both of its sides are designed, or neither.
    #[error("cell {cell}: {why}")]
    NotLinear {
        /// The cell as `light × reflectance` (names escaped), or `colours[k]`.
        cell: String,
        /// Which of the two it is, as a sentence.
        why: &'static str,
    },
    /// The cell is not used (`use = false` or weight 0), so it has no region.
    #[error("cell {cell}: the cell is not used (disabled or weight 0)")]
    Inactive {
        /// The cell as `light × reflectance` (names escaped), or `colours[k]`.
        cell: String,
    },
    /// No spectrum within the bounds holds every partner at its colour: the region is empty.
    #[error(
        "cell {cell}: the other cells' current colours cannot be held within the bounds (the spectrum is outside its bounds?)"
    )]
    Infeasible {
        /// The cell as `light × reflectance` (names escaped), or `colours[k]`.
        cell: String,
    },
    /// The LP or QP solver failed to set up or stopped without an answer (iteration limit, numerical trouble).
    #[error("cell {cell}: the LP or QP solver (clarabel) stopped ({status})")]
    Solver {
        /// The cell as `light × reflectance` (names escaped), or `colours[k]`.
        cell: String,
        /// The solver's status or error, as its debug text (`MaxIterations`, `QP unbounded`, …).
        status: String,
    },
    /// The palette cannot be designed at all (see `DesignError`).
    #[error(transparent)]
    Design(#[from] DesignError),
}

/// "light × reflectance" of a cell, escaped.
pub fn cell_label(palette: &Palette, cell: usize) -> String {
    match palette.colours.get(cell) {
        Some(c) => super::cell_name(
            &crate::fsio::escape(&palette.lights[c.light].name),
            &crate::fsio::escape(&palette.reflectances[c.reflectance].name),
        ),
        None => format!("colours[{cell}]"),
    }
}

const LAB_EPS: f64 = 216.0 / 24389.0;
const LAB_KAPPA: f64 = 24389.0 / 27.0;

/// The Jacobian of linear sRGB → CIELAB at `rgb` against reference white `white` (XYZ).
pub(crate) fn lab_jacobian(rgb_to_xyz: &Matrix3<f64>, white: &Vector3<f64>, rgb: &Vector3<f64>) -> Matrix3<f64> {
    let xyz = rgb_to_xyz * rgb;
    let df = |v: f64, w: f64| {
        let t = if w.abs() > f64::MIN_POSITIVE { v / w } else { 0.0 };
        let d = if t > LAB_EPS { t.cbrt() / (3.0 * t) } else { LAB_KAPPA / 116.0 };
        if w.abs() > f64::MIN_POSITIVE { d / w } else { 0.0 }
    };
    let (fx, fy, fz) = (df(xyz[0], white[0]), df(xyz[1], white[1]), df(xyz[2], white[2]));
    let m = Matrix3::new(0.0, 116.0 * fy, 0.0, 500.0 * fx, -500.0 * fy, 0.0, 0.0, 200.0 * fy, -200.0 * fz);
    m * rgb_to_xyz
}

/// L* of a luminance Y against a white of luminance `yn`.
fn l_of_y(y: f64, yn: f64) -> f64 {
    let t = if yn > 0.0 { y / yn } else { 0.0 };
    let f = if t > LAB_EPS { t.cbrt() } else { (LAB_KAPPA * t + 16.0) / 116.0 };
    116.0 * f - 16.0
}

/// The luminance Y (against a white of luminance `yn`) whose L* is `l`.
fn y_of_l(l: f64, yn: f64) -> f64 {
    let f = (l + 16.0) / 116.0;
    let t = if f > 6.0 / 29.0 { f * f * f } else { (116.0 * f - 16.0) / LAB_KAPPA };
    t * yn
}

/// One partner cell: held within the tolerance box around its current colour.
#[derive(Clone, Debug)]
pub struct Partner {
    /// Index into `palette.colours`.
    pub(crate) cell: usize,
    /// Its 3×31 operator on the designed spectrum.
    pub op: Q31,
    /// Its current colour (linear sRGB).
    pub colour: Vector3<f64>,
    /// CIELAB Jacobian at that colour under its light.
    pub lab: Matrix3<f64>,
    /// Its target (what the solve's "met" criterion compares it with).
    pub(crate) target: Vector3<f64>,
    /// Its outer box around the target ([`met_box`]): contains every colour within ΔE00 τ of it.
    pub(crate) outer: MetBox,
}

/// The feasibility problem of one cell: its operator, the bounds of the designed spectrum and the
/// partners.
#[derive(Clone, Debug)]
pub struct Problem {
    /// Index into `palette.colours`.
    pub cell: usize,
    /// The designed spectrum.
    pub(crate) unit: Unit,
    /// x ↦ the cell's colour.
    pub op: Q31,
    /// The lower bound on every sample of the designed spectrum (its own, else the palette's; `-inf` if none).
    pub lower: f64,
    /// The upper bound on every sample of the designed spectrum (its own, else the palette's; `inf` if none).
    pub upper: f64,
    /// The designed spectrum now.
    pub current: Spectrum,
    /// The cell's colour now (`op · current`).
    pub achieved: Vector3<f64>,
    /// The cell's target (a free cell's target is its group's colour).
    pub target: Vector3<f64>,
    /// CIELAB reference white (XYZ) of the cell's light.
    pub(crate) white: Vector3<f64>,
    pub(crate) rgb_to_xyz: Matrix3<f64>,
    /// The other active cells on the same designed spectrum whose other side is fixed, held in their boxes.
    pub partners: Vec<Partner>,
    /// τ (ΔE): each partner's box has half-width τ/√3 per CIELAB component.
    pub tolerance: f64,
    /// Active cells on the same spectrum whose other side is designed too: not modelled (held nowhere).
    pub joint: Vec<usize>,
    label: String,
}

/// A support value and the colour attaining it.
pub(crate) type Support = (f64, Vector3<f64>);

/// The result of one LP or QP.
enum Outcome {
    Optimal(Vec<f64>),
    Unbounded,
    Infeasible,
}

/// How the partner cells are held.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Hold {
    /// In the box of half-width τ/√3 around the current colour (inscribed in the ΔE*ab ball of radius τ):
    /// what this region reaches is reached with every partner kept near where it is.
    Inner,
    /// In the box [`met_box`] around the partner's target: contains every colour the solve's "met"
    /// criterion (ΔE00 ≤ τ) accepts for that partner.
    Outer,
}

/// Safety factor on the sampled half-widths of [`met_box`].
pub const MET_BOX_MARGIN: f64 = 1.1;

/// Rays sampled by [`met_box`].
const MET_BOX_RAYS: usize = 240;

/// A box `|rows · (y − centre)|ᵢ ≤ halfᵢ` (y linear sRGB) around a colour.
#[derive(Clone, Debug, PartialEq)]
pub struct MetBox {
    /// CIELAB linearised at the centre, rotated to the centre's lightness, chroma and hue directions:
    /// rows L*, radial a*b* (chroma), tangential a*b* (hue).
    pub rows: Matrix3<f64>,
    /// Half-widths along those rows (CIELAB units); zero when τ = 0.
    pub half: Vector3<f64>,
}

/// A box containing every colour within ΔE00 τ of `centre` (the set the solve's "met" criterion accepts,
/// [`crate::design::report`] deciding "met" by ΔE00 of the full colour). Its axes are CIELAB linearised
/// at the centre and turned to the centre's L*, chroma and hue directions, along which CIEDE2000 weighs
/// differences (S_L, S_C, S_H; only the blue-region rotation term R_T couples chroma and hue), so the
/// box is close to the ΔE00 ball's bounding box. **The bound**: along each of [`MET_BOX_RAYS`] unit
/// directions u in that frame the first s with ΔE00(centre, centre + F⁻¹ u s) = τ is found by
/// stepping (τ/4) and bisection; the half-width along axis i is the largest `s·|uᵢ|` times
/// [`MET_BOX_MARGIN`]. At these radii the ΔE00 ball is star-shaped about its centre and smooth, so the
/// rays bound it up to the sampling gap, which the margin covers; `tests/it/feasibility.rs` checks the
/// containment on random colours with points drawn independently of the rays. τ = 0 gives zero
/// half-widths (the box is the point); a singular Jacobian (black) gives an unbounded box.
pub fn met_box(rgb_to_xyz: &Matrix3<f64>, white: &Vector3<f64>, centre: &Vector3<f64>, tau: f64) -> MetBox {
    let j = lab_jacobian(rgb_to_xyz, white, centre);
    let lab = |c: &Vector3<f64>| xyz_to_lab(&(rgb_to_xyz * c), white);
    let l0 = lab(centre);
    let hue = l0[2].atan2(l0[1]);
    let (sn, cs) = if l0[1].hypot(l0[2]) > 1e-9 { hue.sin_cos() } else { (0.0, 1.0) };
    let turn = Matrix3::new(1.0, 0.0, 0.0, 0.0, cs, sn, 0.0, -sn, cs);
    let rows = turn * j;
    if tau <= 0.0 {
        return MetBox { rows, half: Vector3::zeros() };
    }
    let Some(inv) = rows.try_inverse() else {
        return MetBox { rows, half: Vector3::repeat(f64::INFINITY) };
    };
    let de = |u: &Vector3<f64>, s: f64| delta_e00(l0, lab(&(centre + inv * (u * s))));
    let mut half: Vector3<f64> = Vector3::zeros();
    for u in sphere_directions(MET_BOX_RAYS) {
        let (mut lo, mut hi) = (0.0, tau / 4.0);
        let mut found = false;
        for _ in 0..400 {
            let v = de(&u, hi);
            if !v.is_finite() {
                break;
            }
            if v >= tau {
                found = true;
                break;
            }
            lo = hi;
            hi += tau / 4.0;
        }
        if !found {
            // No crossing within 100τ: leave that way open.
            return MetBox { rows, half: Vector3::repeat(f64::INFINITY) };
        }
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            if de(&u, mid) >= tau { hi = mid } else { lo = mid }
        }
        for i in 0..3 {
            half[i] = half[i].max(hi * u[i].abs());
        }
    }
    MetBox { rows, half: half * MET_BOX_MARGIN }
}

mod analysis;
mod problem;
mod region;

pub use analysis::*;
pub use region::*;
