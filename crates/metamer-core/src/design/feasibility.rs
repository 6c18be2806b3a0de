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
    #[error("colours[{0}] does not exist")]
    NoSuchCell(usize),
    #[error("cell {cell}: {why}")]
    NotLinear { cell: String, why: &'static str },
    #[error("cell {cell}: the cell is not used (disabled or weight 0)")]
    Inactive { cell: String },
    #[error(
        "cell {cell}: the other cells' current colours cannot be held within the bounds (the spectrum is outside its bounds?)"
    )]
    Infeasible { cell: String },
    #[error("cell {cell}: the LP solver stopped ({status})")]
    Solver { cell: String, status: String },
    #[error(transparent)]
    Design(#[from] DesignError),
}

/// `name` with control characters escaped (names come from user files).
fn escaped(name: &str) -> String {
    name.chars().map(|c| if c.is_control() { c.escape_default().to_string() } else { c.to_string() }).collect()
}

/// "light × reflectance" of a cell, escaped.
pub fn cell_label(palette: &Palette, cell: usize) -> String {
    match palette.colours.get(cell) {
        Some(c) => format!(
            "{} × {}",
            escaped(&palette.lights[c.light].name),
            escaped(&palette.reflectances[c.reflectance].name)
        ),
        None => format!("colours[{cell}]"),
    }
}

const LAB_EPS: f64 = 216.0 / 24389.0;
const LAB_KAPPA: f64 = 24389.0 / 27.0;

/// The Jacobian of linear sRGB → CIELAB at `rgb` against reference white `white` (XYZ).
pub fn lab_jacobian(rgb_to_xyz: &Matrix3<f64>, white: &Vector3<f64>, rgb: &Vector3<f64>) -> Matrix3<f64> {
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
    pub cell: usize,
    /// Its 3×31 operator on the designed spectrum.
    pub op: Q31,
    /// Its current colour (linear sRGB).
    pub colour: Vector3<f64>,
    /// CIELAB Jacobian at that colour under its light.
    pub lab: Matrix3<f64>,
    /// Its target (what the solve's "met" criterion compares it with).
    pub target: Vector3<f64>,
    /// Its outer box around the target ([`met_box`]): contains every colour within ΔE00 τ of it.
    pub outer: MetBox,
}

/// The feasibility problem of one cell: its operator, the bounds of the designed spectrum and the
/// partners.
#[derive(Clone, Debug)]
pub struct Problem {
    /// Index into `palette.colours`.
    pub cell: usize,
    /// The designed spectrum.
    pub unit: Unit,
    /// x ↦ the cell's colour.
    pub op: Q31,
    pub lower: f64,
    pub upper: f64,
    /// The designed spectrum now.
    pub current: Spectrum,
    /// The cell's colour now (`op · current`).
    pub achieved: Vector3<f64>,
    /// The cell's target (a free cell's target is its group's colour).
    pub target: Vector3<f64>,
    /// CIELAB reference white (XYZ) of the cell's light.
    pub white: Vector3<f64>,
    pub rgb_to_xyz: Matrix3<f64>,
    pub partners: Vec<Partner>,
    /// τ (ΔE): each partner's box has half-width τ/√3 per CIELAB component.
    pub tolerance: f64,
    /// Active cells on the same spectrum whose other side is designed too: not modelled (held nowhere).
    pub joint: Vec<usize>,
    label: String,
}

/// A support value and the colour attaining it.
pub type Support = (f64, Vector3<f64>);

/// The result of one LP or QP.
enum Outcome {
    Optimal(Vec<f64>),
    Unbounded,
    Infeasible,
}

/// How the partner cells are held.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hold {
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

/// The constraint part of the LPs, assembled once per problem: `A x + s = b`, `s` in the cones.
struct Lp {
    a: CscMatrix<f64>,
    b: Vec<f64>,
    cones: Vec<SupportedConeT<f64>>,
}

impl Problem {
    /// The problem of `cell` with the palette's spectra at `values`. `tolerance` is τ in ΔE (≥ 0).
    pub fn new(
        palette: &Palette,
        basis: Option<&Basis>,
        colorimetry: &Colorimetry,
        values: &Values,
        cell: usize,
        tolerance: f64,
    ) -> Result<Problem, FeasibilityError> {
        let c = palette.colours.get(cell).ok_or(FeasibilityError::NoSuchCell(cell))?;
        let label = cell_label(palette, cell);
        let design = Design::new(palette, basis, colorimetry)?;
        let form = if palette.settings.fit_in_subspace { Form::Subspace } else { Form::Full };
        let (ld, rd) = (palette.lights[c.light].design, palette.reflectances[c.reflectance].design);
        if ld == rd {
            let why = if ld {
                "light and reflectance are both designed: the colour is bilinear, not linear, in the unknowns"
            } else {
                "neither side is designed: the colour is fixed (a single point)"
            };
            return Err(FeasibilityError::NotLinear { cell: label, why });
        }
        if !c.is_active() {
            return Err(FeasibilityError::Inactive { cell: label });
        }
        let (unit, current, entry) = if rd {
            (Unit::Reflectance(c.reflectance), values.reflectances[c.reflectance], &palette.reflectances[c.reflectance])
        } else {
            (Unit::Light(c.light), values.lights[c.light], &palette.lights[c.light])
        };
        let bounds = palette.bounds_of(entry);
        // The fixed side of cell `j` of this spectrum.
        let partner_side = |j: usize| {
            let cj = &palette.colours[j];
            if rd { values.lights[cj.light] } else { values.reflectances[cj.reflectance] }
        };
        let op = design.operator(form, &partner_side(cell));
        let achieved = op * current.0;
        let mut partners = Vec::new();
        let mut joint = Vec::new();
        for (j, cj) in palette.colours.iter().enumerate() {
            let same = if rd { cj.reflectance == c.reflectance } else { cj.light == c.light };
            if j == cell || !same || !cj.is_active() {
                continue;
            }
            let other_designed =
                if rd { palette.lights[cj.light].design } else { palette.reflectances[cj.reflectance].design };
            if other_designed {
                joint.push(j);
                continue;
            }
            let opj = design.operator(form, &partner_side(j));
            let colour = opj * current.0;
            let white = colorimetry.reference_white(&values.lights[cj.light]);
            let lab = lab_jacobian(&colorimetry.rgb_to_xyz, &white, &colour);
            let target = cj.free.map(|g| values.free[g]).unwrap_or(cj.target);
            let outer = met_box(&colorimetry.rgb_to_xyz, &white, &target, tolerance.max(0.0));
            partners.push(Partner { cell: j, op: opj, colour, lab, target, outer });
        }
        let target = c.free.map(|g| values.free[g]).unwrap_or(c.target);
        Ok(Problem {
            cell,
            unit,
            op,
            lower: bounds.lower,
            upper: bounds.upper,
            current,
            achieved,
            target,
            white: colorimetry.reference_white(&values.lights[c.light]),
            rgb_to_xyz: colorimetry.rgb_to_xyz,
            partners,
            tolerance: tolerance.max(0.0),
            joint,
            label,
        })
    }

    /// The same problem without partners: what the bounds alone allow.
    pub fn alone(&self) -> Problem {
        Problem { partners: Vec::new(), ..self.clone() }
    }

    /// The same problem without the partner at index `i` of [`Problem::partners`].
    pub fn without(&self, i: usize) -> Problem {
        let mut p = self.clone();
        if i < p.partners.len() {
            p.partners.remove(i);
        }
        p
    }

    /// The cell's label, "light × reflectance".
    pub fn label(&self) -> &str {
        &self.label
    }

    /// CIELAB of a linear sRGB colour under the cell's light.
    pub fn lab(&self, rgb: &Vector3<f64>) -> [f64; 3] {
        xyz_to_lab(&(self.rgb_to_xyz * rgb), &self.white)
    }

    /// CIEDE2000 between two colours under the cell's light.
    pub fn delta_e(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        delta_e00(self.lab(a), self.lab(b))
    }

    /// The CIELAB Jacobian at `rgb` under the cell's light.
    pub fn jacobian(&self, rgb: &Vector3<f64>) -> Matrix3<f64> {
        lab_jacobian(&self.rgb_to_xyz, &self.white, rgb)
    }

    /// Half-width of each partner's box per CIELAB component.
    pub fn half_width(&self) -> f64 {
        self.tolerance / 3f64.sqrt()
    }

    /// What the region depends on, as numbers (the cache key).
    pub fn key(&self, directions: usize) -> Vec<u64> {
        let unit = match self.unit {
            Unit::Light(i) => i as u64,
            Unit::Reflectance(i) => (1 << 32) | i as u64,
            Unit::Free(g) => (2 << 32) | g as u64,
        };
        let mut k = vec![unit, self.cell as u64, directions as u64];
        k.extend([self.lower, self.upper, self.tolerance].iter().map(|v| v.to_bits()));
        k.extend(self.op.iter().map(|v| v.to_bits()));
        k.extend(self.achieved.iter().map(|v| v.to_bits()));
        for p in &self.partners {
            k.push(p.cell as u64);
            k.extend(p.op.iter().chain(p.colour.iter()).chain(p.target.iter()).map(|v| v.to_bits()));
        }
        k
    }

    /// The constraints: bounds, partner boxes (or equalities when τ = 0) and optional extra equalities.
    fn lp(&self, extra: &[(RowVector3<f64>, f64)]) -> Lp {
        self.lp_held(Hold::Inner, extra, &[])
    }

    /// The constraints with the partners held by `hold`, extra equalities on the cell's colour and extra
    /// inequalities `row · (A_k x) ≤ rhs`.
    fn lp_held(&self, hold: Hold, extra: &[(RowVector3<f64>, f64)], extra_le: &[(RowVector3<f64>, f64)]) -> Lp {
        // Rows as dense 31-vectors with their right-hand sides: equalities first, then inequalities.
        let mut eq: Vec<([f64; SAMPLES], f64)> = Vec::new();
        let mut le: Vec<([f64; SAMPLES], f64)> = Vec::new();
        for (row, rhs) in extra {
            let r = row * self.op;
            eq.push((std::array::from_fn(|i| r[i]), *rhs));
        }
        for (row, rhs) in extra_le {
            let r = row * self.op;
            le.push((std::array::from_fn(|i| r[i]), *rhs));
        }
        for p in &self.partners {
            let (half, colour, lab) = match hold {
                Hold::Inner => (Vector3::repeat(self.half_width()), p.colour, p.lab),
                Hold::Outer => (p.outer.half, p.target, p.outer.rows),
            };
            if half == Vector3::zeros() {
                for ch in 0..3 {
                    eq.push((std::array::from_fn(|i| p.op[(ch, i)]), colour[ch]));
                }
            } else {
                let m = lab * p.op;
                let centre = lab * colour;
                for ch in 0..3 {
                    if !half[ch].is_finite() {
                        continue;
                    }
                    let row: [f64; SAMPLES] = std::array::from_fn(|i| m[(ch, i)]);
                    le.push((row, centre[ch] + half[ch]));
                    le.push((row.map(|v| -v), -centre[ch] + half[ch]));
                }
            }
        }
        for i in 0..SAMPLES {
            let mut e = [0.0; SAMPLES];
            if self.upper.is_finite() {
                e[i] = 1.0;
                le.push((e, self.upper));
            }
            if self.lower.is_finite() {
                e[i] = -1.0;
                le.push((e, -self.lower));
            }
        }
        let rows: Vec<&([f64; SAMPLES], f64)> = eq.iter().chain(&le).collect();
        let mut colptr = vec![0];
        let mut rowval = Vec::new();
        let mut nzval = Vec::new();
        for col in 0..SAMPLES {
            for (r, (row, _)) in rows.iter().enumerate() {
                if row[col] != 0.0 {
                    rowval.push(r);
                    nzval.push(row[col]);
                }
            }
            colptr.push(rowval.len());
        }
        let mut cones = Vec::new();
        if !eq.is_empty() {
            cones.push(ZeroConeT(eq.len()));
        }
        if !le.is_empty() {
            cones.push(NonnegativeConeT(le.len()));
        }
        Lp {
            a: CscMatrix::new(rows.len(), SAMPLES, colptr, rowval, nzval),
            b: rows.iter().map(|(_, b)| *b).collect(),
            cones,
        }
    }

    /// Minimise `½ xᵀ P x + qᵀ x` under `lp`.
    fn run(&self, lp: &Lp, p: &CscMatrix<f64>, q: &[f64]) -> Result<Outcome, FeasibilityError> {
        let settings =
            DefaultSettingsBuilder::default().verbose(false).max_iter(200).build().map_err(|e| {
                FeasibilityError::Solver { cell: self.label.clone(), status: format!("settings: {e:?}") }
            })?;
        if lp.b.is_empty() {
            // No constraint at all (unbounded spectrum, no partner): only a QP with P ≠ 0 has an optimum,
            // and clarabel needs at least one row; x = 0 with a trivially true row.
            let a = CscMatrix::new(1, SAMPLES, vec![0; SAMPLES + 1], Vec::new(), Vec::new());
            let lp1 = Lp { a, b: vec![1.0], cones: vec![NonnegativeConeT(1)] };
            return self.run(&lp1, p, q);
        }
        let mut solver = DefaultSolver::new(p, q, &lp.a, &lp.b, &lp.cones, settings)
            .map_err(|e| FeasibilityError::Solver { cell: self.label.clone(), status: format!("{e:?}") })?;
        solver.solve();
        let s = &solver.solution;
        match s.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => Ok(Outcome::Optimal(s.x.clone())),
            SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => Ok(Outcome::Unbounded),
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => Ok(Outcome::Infeasible),
            other => Err(FeasibilityError::Solver { cell: self.label.clone(), status: format!("{other:?}") }),
        }
    }

    /// The support value `max d·(A_k x)` and a maximiser's colour; `None` when unbounded in `d`.
    fn support_with(&self, lp: &Lp, d: &Vector3<f64>) -> Result<Option<Support>, FeasibilityError> {
        let g = self.op.transpose() * d;
        let q: Vec<f64> = g.iter().map(|v| -v).collect();
        match self.run(lp, &CscMatrix::zeros((SAMPLES, SAMPLES)), &q)? {
            Outcome::Optimal(x) => {
                let x = nalgebra::SVector::<f64, SAMPLES>::from_column_slice(&x);
                let c = self.op * x;
                Ok(Some((d.dot(&c), c)))
            }
            Outcome::Unbounded => Ok(None),
            Outcome::Infeasible => Err(FeasibilityError::Infeasible { cell: self.label.clone() }),
        }
    }

    /// Like [`Problem::support_with`], with infeasibility as `None` instead of an error.
    fn support_outcome(&self, lp: &Lp, d: &Vector3<f64>) -> Result<Option<Option<Support>>, FeasibilityError> {
        match self.support_with(lp, d) {
            Ok(s) => Ok(Some(s)),
            Err(FeasibilityError::Infeasible { .. }) => Ok(None),
            Err(e) => Err(e),
        }
    }

    /// The outer region's support value in direction `d`: `None` when unbounded that way, an
    /// [`FeasibilityError::Infeasible`] error when the outer region is empty.
    pub fn outer_support(&self, d: &Vector3<f64>) -> Result<Option<Support>, FeasibilityError> {
        self.support_with(&self.lp_held(Hold::Outer, &[], &[]), d)
    }

    /// Could the solve's "met" criterion accept `target` at all? True when some x within the bounds
    /// puts the cell in the [`met_box`] of the target (which contains every colour within ΔE00 τ
    /// of it) and every partner in its outer box. False is a
    /// guarantee: no solution has this cell and every partner within ΔE00 τ of their targets.
    pub fn may_meet(&self, target: &Vector3<f64>) -> Result<bool, FeasibilityError> {
        let b = met_box(&self.rgb_to_xyz, &self.white, target, self.tolerance);
        let centre = b.rows * target;
        let lp = if b.half == Vector3::zeros() {
            let eq: Vec<(RowVector3<f64>, f64)> = (0..3).map(|ch| (b.rows.row(ch).into_owned(), centre[ch])).collect();
            self.lp_held(Hold::Outer, &eq, &[])
        } else {
            let mut le = Vec::with_capacity(6);
            for ch in 0..3 {
                if b.half[ch].is_finite() {
                    let row = b.rows.row(ch).into_owned();
                    le.push((row, centre[ch] + b.half[ch]));
                    le.push((-row, -centre[ch] + b.half[ch]));
                }
            }
            self.lp_held(Hold::Outer, &[], &le)
        };
        let zero = vec![0.0; SAMPLES];
        match self.run(&lp, &CscMatrix::zeros((SAMPLES, SAMPLES)), &zero)? {
            Outcome::Infeasible => Ok(false),
            Outcome::Optimal(_) | Outcome::Unbounded => Ok(true),
        }
    }

    /// The support value in direction `d` (linear sRGB): `None` when the region is unbounded that way.
    pub fn support(&self, d: &Vector3<f64>) -> Result<Option<Support>, FeasibilityError> {
        self.support_with(&self.lp(&[]), d)
    }

    /// The reachable colour closest to `target` in CIELAB linearised at the target, and that distance.
    pub fn closest(&self, target: &Vector3<f64>) -> Result<(Vector3<f64>, f64), FeasibilityError> {
        let j = self.jacobian(target);
        let m = j * self.op;
        let h = m.transpose() * m * 2.0;
        let mut colptr = vec![0];
        let mut rowval = Vec::new();
        let mut nzval = Vec::new();
        for col in 0..SAMPLES {
            for row in 0..=col {
                rowval.push(row);
                nzval.push(h[(row, col)]);
            }
            colptr.push(rowval.len());
        }
        let p = CscMatrix::new(SAMPLES, SAMPLES, colptr, rowval, nzval);
        let y = j * target;
        let q: Vec<f64> = (m.transpose() * y * -2.0).iter().copied().collect();
        match self.run(&self.lp(&[]), &p, &q)? {
            Outcome::Optimal(x) => {
                let x = nalgebra::SVector::<f64, SAMPLES>::from_column_slice(&x);
                let c = self.op * x;
                Ok((c, (j * (c - target)).norm()))
            }
            Outcome::Unbounded => {
                Err(FeasibilityError::Solver { cell: self.label.clone(), status: "QP unbounded".into() })
            }
            Outcome::Infeasible => Err(FeasibilityError::Infeasible { cell: self.label.clone() }),
        }
    }

    /// Can the cell reach `target` exactly (within the QP's accuracy)?
    pub fn reaches(&self, target: &Vector3<f64>) -> Result<bool, FeasibilityError> {
        Ok(self.closest(target)?.1 <= REACH_EPS)
    }
}

/// `n` unit vectors spread over the sphere (Fibonacci lattice).
pub fn sphere_directions(n: usize) -> Vec<Vector3<f64>> {
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
    pub support: Vec<f64>,
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
    pub placement: Placement,
    /// ΔE00 to the boundary: negative inside, positive outside (−∞ inside an unbounded region).
    pub signed_delta_e: f64,
    /// The closest reachable colour (the target itself when inside), linear sRGB.
    pub closest: Vector3<f64>,
    /// The nearest boundary point found (linear sRGB): the closest colour outside, the foot on the
    /// nearest supporting plane inside.
    pub boundary: Vector3<f64>,
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
    pub l_star: f64,
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
pub fn slice_held(
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

/// Regions shared between requests with the same problem (see the module docs for the key).
#[derive(Default)]
pub struct RegionCache {
    map: Mutex<HashMap<Vec<u64>, Arc<Region>>>,
}

impl RegionCache {
    /// The region of `problem` with `n` directions, computed once per key.
    pub fn get(&self, problem: &Problem, n: usize) -> Result<Arc<Region>, FeasibilityError> {
        let key = problem.key(n);
        if let Ok(map) = self.map.lock()
            && let Some(r) = map.get(&key)
        {
            return Ok(r.clone());
        }
        let r = Arc::new(region(problem, n)?);
        if let Ok(mut map) = self.map.lock() {
            map.insert(key, r.clone());
        }
        Ok(r)
    }

    /// Number of regions held.
    pub fn len(&self) -> usize {
        self.map.lock().map(|m| m.len()).unwrap_or(0)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The feasibility of one cell's target.
#[derive(Clone, Debug)]
pub struct CellFeasibility {
    pub cell: usize,
    pub target: Vector3<f64>,
    pub achieved: Vector3<f64>,
    pub verdict: Verdict,
    /// Can the bounds alone (no partner held) reach the target?
    pub reachable_alone: bool,
    /// Partner cells that must move for the target to be reached: each one, released alone, makes the
    /// target reachable (empty when the target is reachable, or unreachable even alone, or only when
    /// several partners move together — then [`CellFeasibility::together`] is true).
    pub blockers: Vec<usize>,
    /// Reachable alone, but no single partner's release suffices.
    pub together: bool,
    /// Active cells on the spectrum not modelled (their other side is designed too).
    pub joint: Vec<usize>,
    pub region: Arc<Region>,
}

/// Analyse one cell: its region (through `cache`), where its target lies, and who blocks it.
pub fn analyse(problem: &Problem, cache: &RegionCache, directions: usize) -> Result<CellFeasibility, FeasibilityError> {
    let region = cache.get(problem, directions)?;
    let verdict = place(problem, &region, &problem.target)?;
    let (reachable_alone, blockers, together) =
        if matches!(verdict.placement, Placement::Outside | Placement::Undecided) {
            let alone = problem.alone().reaches(&problem.target)?;
            let mut blockers = Vec::new();
            if alone {
                for i in 0..problem.partners.len() {
                    if problem.without(i).reaches(&problem.target)? {
                        blockers.push(problem.partners[i].cell);
                    }
                }
            }
            let together = alone && blockers.is_empty();
            (alone, blockers, together)
        } else {
            (true, Vec::new(), false)
        };
    Ok(CellFeasibility {
        cell: problem.cell,
        target: problem.target,
        achieved: problem.achieved,
        verdict,
        reachable_alone,
        blockers,
        together,
        joint: problem.joint.clone(),
        region,
    })
}

fn fmt_rgb(c: &Vector3<f64>) -> String {
    use super::report::Fixed;
    format!("[{}, {}, {}]", Fixed(c[0], 4), Fixed(c[1], 4), Fixed(c[2], 4))
}

/// One line about a cell's feasibility, for the solve table.
pub fn describe(palette: &Palette, f: &CellFeasibility, tolerance: f64) -> String {
    use super::report::Fixed;
    let label = cell_label(palette, f.cell);
    let held = format!("the other cells of its spectrum held within ΔE {tolerance}");
    // What keeps an unmet target out of reach (undecided and outside targets); `together` also names the
    // case where only several cells moving at once would help.
    let why_not = |together: bool| -> String {
        if !f.reachable_alone {
            "; out of reach of the bounds even alone".into()
        } else if !f.blockers.is_empty() {
            let names: Vec<String> = f.blockers.iter().map(|&b| cell_label(palette, b)).collect();
            format!("; reachable only if {} moves", names.join(" or "))
        } else if together && f.together {
            "; reachable only if several of the other cells move together".into()
        } else {
            String::new()
        }
    };
    let mut s = match f.verdict.placement {
        Placement::Inside => format!(
            "cell {label}: target reachable with {held} (inside the region, ΔE00 {} from its boundary)",
            Fixed(-f.verdict.signed_delta_e, 2)
        ),
        Placement::On => format!("cell {label}: target on the boundary of what is reachable with {held}"),
        Placement::Undecided => {
            let s = format!(
                "cell {label}: target undecided: ΔE00 {} outside what is reachable with {held}, closest such colour {}, \
                 but not provably out of reach of the solve's ΔE00 {tolerance} criterion",
                Fixed(f.verdict.signed_delta_e, 2),
                fmt_rgb(&f.verdict.closest)
            );
            s + &why_not(false)
        }
        Placement::Outside => {
            let s = format!(
                "cell {label}: target not reachable with {held}: ΔE00 {} outside, closest reachable colour {}",
                Fixed(f.verdict.signed_delta_e, 2),
                fmt_rgb(&f.verdict.closest)
            );
            s + &why_not(true)
        }
    };
    let r = &f.region;
    s += &format!(
        " [region L* {}…{}, volume {} ΔE³]",
        Fixed(r.l_range.0, 1),
        Fixed(r.l_range.1, 1),
        if r.volume_lab.is_finite() { format!("{}", Fixed(r.volume_lab, 1)) } else { "unbounded".into() }
    );
    if !f.joint.is_empty() {
        let names: Vec<String> = f.joint.iter().map(|&b| cell_label(palette, b)).collect();
        s += &format!(" (not held: {}, designed jointly)", names.join(", "));
    }
    s
}

/// What the designer draws for one cell: the region's slice at the target's L*, the marks, the numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    pub cell: usize,
    /// "light × reflectance".
    pub label: String,
    pub tolerance: f64,
    /// The slice at the target's L* (`None` when the region does not reach it).
    pub slice: Option<Slice>,
    /// The outer region's slice at the same L* (`None` when it does not reach it or is empty).
    pub outer_slice: Option<Slice>,
    pub target_lab: [f64; 3],
    pub achieved_lab: [f64; 3],
    pub l_range: (f64, f64),
    pub placement: Placement,
    pub signed_delta_e: f64,
    pub volume_lab: f64,
    /// Partner cells held.
    pub held: usize,
}

/// The [`Panel`] of `cell` with the palette's spectra at `values` (through `cache`).
pub fn panel(
    palette: &Palette,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    values: &Values,
    cell: usize,
    tolerance: f64,
    cache: &RegionCache,
) -> Result<Panel, FeasibilityError> {
    let problem = Problem::new(palette, basis, colorimetry, values, cell, tolerance)?;
    let region = cache.get(&problem, DEFAULT_DIRECTIONS)?;
    let verdict = place(&problem, &region, &problem.target)?;
    let target_lab = problem.lab(&problem.target);
    let slice = slice(&problem, target_lab[0], &problem.target, SLICE_DIRECTIONS)?;
    let outer_slice = if region.outer_empty {
        None
    } else {
        slice_held(&problem, Hold::Outer, target_lab[0], &problem.target, SLICE_DIRECTIONS)?
    };
    Ok(Panel {
        cell,
        label: problem.label().to_string(),
        tolerance,
        slice,
        outer_slice,
        target_lab,
        achieved_lab: problem.lab(&problem.achieved),
        l_range: region.l_range,
        placement: verdict.placement,
        signed_delta_e: verdict.signed_delta_e,
        volume_lab: region.volume_lab,
        held: problem.partners.len(),
    })
}
