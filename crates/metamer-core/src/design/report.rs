//! Per-cell colours at the solution and diagnostics: which cells cannot be met and why, and what is
//! degenerate about the input.
//!
//! Subspace colours are those of the spectral factor model the renderer uses: `Q_rgb,m (e ∘ s)` with
//! `e = B⁺E`, `s = B⁺S` ([`Basis::rgb_factor`], seed Eq. 15) — not the Λ-form used by
//! `fit_in_subspace`, which is what the design minimises but not what is displayed.

use super::lsq;
use super::system::{Design, Form, LinearSystem, Origin, Values};
use super::{CellResult, CellStatus, Criterion, Diagnostic, DiagnosticKind, PathResult};
use crate::basis::Basis;
use crate::colorimetry::Colorimetry;
use crate::colorimetry::Q31;
use crate::palette::mixing::{self, check_positions, light_of, mix_at, route_dial};
use crate::palette::{Bounds, Palette};
use crate::spectrum::{SAMPLES, Spectrum};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use rayon::prelude::*;
use std::collections::HashMap;

/// A cell counts as met when its full colour is within this CIEDE2000 of its target.
pub(crate) const MET_DELTA_E: f64 = 1.0;

/// Two lights count as nearly identical when `‖E_a − E_b‖ ≤ NEAR_IDENTICAL · max(‖E_a‖, ‖E_b‖)`.
pub(crate) const NEAR_IDENTICAL: f64 = 1e-3;

fn finite_or(v: f64, d: f64) -> f64 {
    if v.is_finite() { v } else { d }
}

/// The colour of light `e` on reflectance `s`: in the full 31-sample model, and in the spectral factor
/// model of `basis` when one is given. The one place a cell's colours are computed (the solve's cells,
/// and the designer's cells that have no solved result: cells without a criterion, edits not solved yet).
pub fn pair_colours(
    e: &Spectrum,
    s: &Spectrum,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
) -> (Vector3<f64>, Option<Vector3<f64>>) {
    (colorimetry.rgb(e, s), basis.map(|b| b.rgb_factor(e, s)))
}

impl CellResult {
    /// The colours and errors of cell `cell` (light `e` on reflectance `s`, aiming at `target`; `active`:
    /// the cell is used by the design).
    pub fn new(
        cell: usize,
        target: Vector3<f64>,
        (e, s): (&Spectrum, &Spectrum),
        active: bool,
        basis: Option<&Basis>,
        colorimetry: &Colorimetry,
    ) -> CellResult {
        CellResult::with_white(cell, target, (e, s), &colorimetry.reference_white(e), active, basis, colorimetry)
    }

    /// [`CellResult::new`] with the white of light `e` given (`colorimetry.reference_white(e)`).
    fn with_white(
        cell: usize,
        target: Vector3<f64>,
        (e, s): (&Spectrum, &Spectrum),
        white: &Vector3<f64>,
        active: bool,
        basis: Option<&Basis>,
        colorimetry: &Colorimetry,
    ) -> CellResult {
        let (rgb_full, _) = pair_colours(e, s, None, colorimetry);
        let delta_e_full = finite_or(colorimetry.delta_e00_against(&target, &rgb_full, white), f64::MAX);
        let status = match (active, delta_e_full > MET_DELTA_E) {
            (false, _) => CellStatus::NotUsed,
            (true, false) => CellStatus::Met,
            (true, true) => CellStatus::Unmet,
        };
        let mut r =
            CellResult { cell, target, rgb_full, rgb_subspace: None, delta_e_full, delta_e_subspace: None, status };
        r.set_subspace(basis, e, s, colorimetry);
        r
    }

    /// Set (or, without a basis, clear) the subspace colour and its ΔE00 for light `e` on reflectance `s`.
    pub fn set_subspace(&mut self, basis: Option<&Basis>, e: &Spectrum, s: &Spectrum, colorimetry: &Colorimetry) {
        self.rgb_subspace = basis.map(|b| b.rgb_factor(e, s));
        self.delta_e_subspace =
            self.rgb_subspace.map(|r| finite_or(colorimetry.delta_e00_under(&self.target, &r, e), f64::MAX));
    }
}

/// Colours and errors of every cell of the palette at `v`.
pub(crate) fn cell_results(
    palette: &Palette,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    v: &Values,
) -> Vec<CellResult> {
    // Each light's white once (a batch has thousands of cells under a few lights), not once a cell.
    let whites: Vec<Vector3<f64>> = v.lights.iter().map(|e| colorimetry.reference_white(e)).collect();
    palette
        .colours
        .par_iter()
        .enumerate()
        .map(|(k, c)| {
            let target = c.free.map(|g| v.free[g]).unwrap_or(c.target);
            let pair = (&v.lights[c.light], &v.reflectances[c.reflectance]);
            CellResult::with_white(k, target, pair, &whites[c.light], c.is_active(), basis, colorimetry)
        })
        .collect()
}

/// `x` with a fixed number of decimals, printed exactly as `format!("{:.*}", decimals, x)` prints it (width
/// and alignment apply as for strings), without the standard formatter's slow exact path in the common case:
/// tables of thousands of cells print tens of thousands of such numbers.
#[derive(Clone, Copy, Debug)]
pub struct Fixed(pub f64, pub usize);

impl Fixed {
    /// The text in the fast case, as a buffer whose text (ASCII) starts at the index returned and runs to its
    /// end: a finite `x` with at most 6 decimals, `y = |x|·10^d` below 2⁴⁰ and not within 10⁻³ of a half. y
    /// is then exact up to half an ulp, below 2⁻¹³, so its nearest integer is the correctly rounded one.
    /// `None` where the standard formatter's exact path decides. Writers that build long texts (the solve's
    /// table) take these bytes directly; [`Fixed`]'s `Display` pads them.
    pub fn fast_digits(self) -> Option<([u8; 24], usize)> {
        const TEN: [u64; 7] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000];
        let Fixed(x, decimals) = self;
        let &p = TEN.get(decimals)?;
        if !x.is_finite() {
            return None;
        }
        // Finite: x is, and p is at most 10⁶.
        let y = x.abs() * p as f64;
        if y >= (1u64 << 40) as f64 {
            return None;
        }
        // The floor by truncation (y ≥ 0), and y − floor(y) exact; away from a half, the nearest integer is
        // the floor or the next one (as `f64::round` gives it, without its call).
        let floor = y as u64;
        let frac = y - floor as f64;
        if (frac - 0.5).abs() <= 1e-3 {
            return None;
        }
        let n = floor + u64::from(frac > 0.5);
        // Written from the end: the decimals (zero-padded), the point, the integer part, the sign.
        let mut out = [0u8; 24];
        let mut at = out.len();
        let (mut whole, mut fraction) = (n / p, n % p);
        if decimals > 0 {
            for _ in 0..decimals {
                at -= 1;
                out[at] = b'0' + (fraction % 10) as u8;
                fraction /= 10;
            }
            at -= 1;
            out[at] = b'.';
        }
        loop {
            at -= 1;
            out[at] = b'0' + (whole % 10) as u8;
            whole /= 10;
            if whole == 0 {
                break;
            }
        }
        if x.is_sign_negative() {
            at -= 1;
            out[at] = b'-';
        }
        Some((out, at))
    }
}

impl std::fmt::Display for Fixed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some((bytes, at)) = self.fast_digits()
            && let Ok(s) = std::str::from_utf8(&bytes[at..])
        {
            return f.pad(s);
        }
        let Fixed(x, decimals) = *self;
        f.pad(&format!("{x:.decimals$}"))
    }
}

fn fmt_rgb(c: &Vector3<f64>) -> String {
    format!("[{}, {}, {}]", Fixed(c[0], 4), Fixed(c[1], 4), Fixed(c[2], 4))
}

fn is_zero(s: &Spectrum) -> bool {
    s.0.amax() <= 1e-12
}

/// What the closest-reachable check needs for the cells of one designed side under one fixed partner
/// (built once and shared by every such cell).
struct Reach {
    /// The 3×31 map from the designed spectrum to the cell's colour.
    op: Q31,
    /// `(op opᵀ)⁻¹` when op has full row rank.
    gram_inv: Option<Matrix3<f64>>,
    /// `AᵀA` of the ridge system `[op; RIDGE·I]`.
    h: DMatrix<f64>,
}

/// The colour rows plus a tiny ridge (1e-4·I) so the normal equations stay definite and the active-set
/// solve takes its fast path; the ridge moves the reachable colour by far less than a ΔE00 of 0.01.
const RIDGE: f64 = 1e-4;

impl Reach {
    fn new(design: &Design, form: Form, partner: &Spectrum) -> Reach {
        let op = design.operator(form, partner);
        let gram_inv = (op * op.transpose()).try_inverse().filter(|g| g.iter().all(|v| v.is_finite()));
        let mut h = DMatrix::from_fn(SAMPLES, SAMPLES, |r, c| op.column(r).dot(&op.column(c)));
        for i in 0..SAMPLES {
            h[(i, i)] += RIDGE * RIDGE;
        }
        Reach { op, gram_inv, h }
    }

    /// The closest colour the designed spectrum can produce within `bounds` with the partner fixed, ignoring
    /// every other criterion. First a walk from the solution `start` towards the target that stays in the
    /// bounds (below); when it does not arrive, a bounded least-squares solve of the colour rows alone (with
    /// the ridge), warm-started from `start`.
    fn closest(&self, start: &Spectrum, bounds: Bounds, target: &Vector3<f64>) -> Vector3<f64> {
        let op = &self.op;
        if let Some(x) = self.exact_hit(start, bounds, target) {
            return op * x.0;
        }
        // The solution may sit at many bounds; the middle of the box has room in every direction.
        let middle = Spectrum::flat(0.5 * (bounds.lower + bounds.upper));
        if middle.is_finite()
            && let Some(x) = self.exact_hit(&middle, bounds, target)
        {
            return op * x.0;
        }
        let a = DMatrix::from_fn(3 + SAMPLES, SAMPLES, |r, c| {
            if r < 3 {
                op[(r, c)]
            } else if r - 3 == c {
                RIDGE
            } else {
                0.0
            }
        });
        let mut b = DVector::zeros(3 + SAMPLES);
        b.rows_mut(0, 3).copy_from(target);
        let sys = LinearSystem {
            a: a.into(),
            b,
            lower: DVector::from_element(SAMPLES, bounds.lower),
            upper: DVector::from_element(SAMPLES, bounds.upper),
        };
        let out = lsq::solve_from(&sys, &self.h, &DVector::from_column_slice(start.as_slice()));
        op * nalgebra::SVector::<f64, SAMPLES>::from_column_slice(out.x.as_slice())
    }
}

impl Reach {
    /// A spectrum within `bounds` whose colour is exactly `target` (up to rounding), found by walking from
    /// `start` along the smallest change that removes the colour error, `d = op_Fᵀ (op_F op_Fᵀ)⁻¹ r` over
    /// the samples F still free to move, as far as the bounds allow; a sample that reaches a bound stays
    /// there. Each step either arrives or binds a sample, so there are at most 31 + 1 steps. `None` when the
    /// walk gets stuck (the target may still be reachable: the caller then solves the bounded problem).
    fn exact_hit(&self, start: &Spectrum, bounds: Bounds, target: &Vector3<f64>) -> Option<Spectrum> {
        self.gram_inv?;
        let op = &self.op;
        let (lo, hi) = (bounds.lower, bounds.upper);
        let mut x = start.0.map(|v| v.clamp(lo, hi));
        let mut free = [true; SAMPLES];
        // op_F op_Fᵀ, kept up to date as samples are bound.
        let mut gram = op * op.transpose();
        // The colour error; each step removes the fraction α of it (the samples it binds land exactly on
        // their bounds), so it is updated rather than recomputed; the end checks the colour itself.
        let mut r = target - op * x;
        for _ in 0..=SAMPLES {
            let y = gram.try_inverse()? * r;
            let d = op.transpose() * y;
            // The longest step (at most the whole one) that keeps every free sample in the bounds.
            let mut room = [f64::INFINITY; SAMPLES];
            for i in (0..SAMPLES).filter(|&i| free[i]) {
                if d[i] < 0.0 {
                    room[i] = ((lo - x[i]) / d[i]).max(0.0);
                } else if d[i] > 0.0 {
                    room[i] = ((hi - x[i]) / d[i]).max(0.0);
                }
            }
            let alpha = room.iter().fold(1.0f64, |a, r| a.min(*r));
            if !(alpha.is_finite() && d.iter().all(|v| v.is_finite())) {
                return None;
            }
            for i in 0..SAMPLES {
                if !free[i] {
                    continue;
                }
                if room[i] <= alpha {
                    // This sample reaches its bound: it stays there.
                    x[i] = if d[i] < 0.0 { lo } else { hi };
                    free[i] = false;
                    gram -= op.column(i) * op.column(i).transpose();
                } else {
                    x[i] = (x[i] + alpha * d[i]).clamp(lo, hi);
                }
            }
            r *= 1.0 - alpha;
            if alpha >= 1.0 {
                // Arrived, unless a nearly singular `op_F op_Fᵀ` spoiled the step: check the colour.
                let miss = (target - op * x).amax();
                return (miss <= EXACT_HIT_TOLERANCE * (1.0 + target.amax())).then_some(Spectrum(x));
            }
        }
        None
    }
}

/// A walk counts as arrived when its colour is within this (relative to the target's size) of the target:
/// far below a ΔE00 of 0.01.
const EXACT_HIT_TOLERANCE: f64 = 1e-9;

/// Which fixed partner a half-designed cell's colour is linear in: (the reflectance is designed, the
/// partner's index, the form).
type ReachKey = (bool, usize, Form);

/// Diagnostics about the palette and the solution.
pub(crate) fn diagnostics(
    design: &Design,
    colorimetry: &Colorimetry,
    v: &Values,
    cells: &[CellResult],
) -> Vec<Diagnostic> {
    let p = design.palette;
    let mut out = Vec::new();
    let say = |cell: Option<usize>, kind: DiagnosticKind, message: String| Diagnostic {
        cell,
        criterion: None,
        kind,
        message,
    };
    // Designed spectra without any colour criterion.
    let mut light_used = vec![false; p.lights.len()];
    let mut refl_used = vec![false; p.reflectances.len()];
    for t in &design.terms {
        for &(i, _) in &t.lights {
            light_used[i] = true;
        }
        refl_used[t.reflectance] = true;
    }
    for (kind, entries, used) in [("light", &p.lights, &light_used), ("reflectance", &p.reflectances, &refl_used)] {
        for (i, e) in entries.iter().enumerate() {
            if e.design && !used[i] {
                out.push(say(
                    None,
                    DiagnosticKind::Unused,
                    format!(
                        "{kind} \"{}\" is designed but no active colour cell uses it: only smoothness acts on it",
                        e.name
                    ),
                ));
            }
        }
    }
    // Duplicated cells: the active cells sorted by (reflectance, light, index), so each pair's first
    // cell leads its run (a sort, not a hash map: a batch has thousands of cells, usually in this order
    // already); the remarks come out in the cells' order, as a walk over the cells would give them.
    let mut pairs: Vec<(usize, usize, usize)> =
        p.colours.iter().enumerate().filter(|(_, c)| c.is_active()).map(|(k, c)| (c.reflectance, c.light, k)).collect();
    pairs.sort_unstable();
    let mut twice: Vec<(usize, usize)> = Vec::new();
    for run in pairs.chunk_by(|a, b| (a.0, a.1) == (b.0, b.1)) {
        twice.extend(run[1..].iter().map(|&(_, _, k)| (k, run[0].2)));
    }
    twice.sort_unstable();
    for (k, j) in twice {
        let c = &p.colours[k];
        out.push(say(
            Some(k),
            DiagnosticKind::Duplicate,
            format!(
                "cell {} × {} appears twice (colours[{j}] and colours[{k}]): both count, so the solution is their weighted compromise",
                p.lights[c.light].name, p.reflectances[c.reflectance].name
            ),
        ));
    }
    // Unmet cells, with a reason (in parallel: each may run a small bounded solve).
    // Cells under a zero light: black whatever the reflectance, and ΔE00 against a black white is meaningless.
    let zero_light: Vec<bool> = v.lights.iter().map(is_zero).collect();
    for r in cells {
        let c = &p.colours[r.cell];
        if c.is_active() && zero_light[c.light] {
            out.push(say(
                Some(r.cell),
                DiagnosticKind::Unmet,
                format!(
                    "cell {} × {} not met: light \"{}\" is zero, so every reflectance is black under it (target {})",
                    p.lights[c.light].name,
                    p.reflectances[c.reflectance].name,
                    p.lights[c.light].name,
                    fmt_rgb(&r.target)
                ),
            ));
        }
    }
    let unmet: Vec<&CellResult> =
        cells.iter().filter(|r| r.status == CellStatus::Unmet && !zero_light[p.colours[r.cell].light]).collect();
    if unmet.is_empty() {
        return out;
    }
    let mut by_reflectance: Vec<Vec<usize>> = vec![Vec::new(); p.reflectances.len()];
    for (k, c) in p.colours.iter().enumerate() {
        if c.is_active() {
            by_reflectance[c.reflectance].push(k);
        }
    }
    // The form of each cell's colour rows, and the reachability data of each fixed partner, built once.
    let mut form_of = vec![Form::Full; p.colours.len()];
    for t in &design.terms {
        if let Origin::Cell(k) = t.origin {
            form_of[k] = t.form;
        }
    }
    let mut keys: HashMap<ReachKey, usize> = HashMap::new();
    let mut wanted: Vec<ReachKey> = Vec::new();
    for r in &unmet {
        if let Some(k) = reach_key(p, &form_of, r.cell) {
            keys.entry(k).or_insert_with(|| {
                wanted.push(k);
                wanted.len() - 1
            });
        }
    }
    let reach: Vec<Reach> = wanted
        .par_iter()
        .map(|&(refl, partner, form)| {
            Reach::new(design, form, if refl { &v.lights[partner] } else { &v.reflectances[partner] })
        })
        .collect();
    let reach_of = |cell: usize| reach_key(p, &form_of, cell).and_then(|k| keys.get(&k)).map(|&i| &reach[i]);
    let reasons: Vec<Diagnostic> =
        unmet.par_iter().map(|r| unmet_reason(reach_of(r.cell), design, colorimetry, v, r, &by_reflectance)).collect();
    out.extend(reasons);
    out
}

/// The reachability key of a cell with exactly one designed side.
fn reach_key(p: &Palette, form_of: &[Form], cell: usize) -> Option<ReachKey> {
    let c = &p.colours[cell];
    match (p.lights[c.light].design, p.reflectances[c.reflectance].design) {
        (false, true) => Some((true, c.light, form_of[cell])),
        (true, false) => Some((false, c.reflectance, form_of[cell])),
        _ => None,
    }
}

/// Why one cell is not met.
fn unmet_reason(
    reach: Option<&Reach>,
    design: &Design,
    colorimetry: &Colorimetry,
    v: &Values,
    r: &CellResult,
    by_reflectance: &[Vec<usize>],
) -> Diagnostic {
    let p = design.palette;
    let say = |cell: Option<usize>, message: String| Diagnostic {
        cell,
        criterion: None,
        kind: DiagnosticKind::Unmet,
        message,
    };
    {
        let c = &p.colours[r.cell];
        let light = &p.lights[c.light];
        let refl = &p.reflectances[c.reflectance];
        let e = &v.lights[c.light];
        let s = &v.reflectances[c.reflectance];
        let head = format!(
            "cell {} × {} not met (ΔE00 {}: target {}, achieved {})",
            light.name,
            refl.name,
            Fixed(r.delta_e_full, 2),
            fmt_rgb(&r.target),
            fmt_rgb(&r.rgb_full)
        );
        let why = if !light.design && !refl.design {
            if c.free.is_some() {
                "neither side is designed, so this cell's colour is fixed and pulls its free group's colour".to_string()
            } else {
                "neither the light nor the reflectance is designed, so nothing can change this colour".to_string()
            }
        } else if !light.design && is_zero(e) {
            format!("light \"{}\" is zero, so every reflectance is black under it", light.name)
        } else if !refl.design && is_zero(s) {
            format!("reflectance \"{}\" is zero, so it is black under every light", refl.name)
        } else if let (true, Some(reach)) = (light.design != refl.design, reach) {
            let (what, under) = if refl.design {
                ("reflectance", format!("under light \"{}\"", light.name))
            } else {
                ("light", format!("on reflectance \"{}\"", refl.name))
            };
            let bounds = p.bounds_of(if refl.design { refl } else { light });
            let (lo, hi) = (bounds.lower, bounds.upper);
            let start = if refl.design { s } else { e };
            let best = reach.closest(start, bounds, &r.target);
            let de = colorimetry.delta_e00_under(&r.target, &best, e);
            // `closest` is closest in linear RGB; the achieved colour is reachable too (the solved spectrum
            // is within its bounds) and may be perceptually closer: report whichever is.
            let (best, de) = if r.delta_e_full < de { (r.rgb_full, r.delta_e_full) } else { (best, de) };
            if de > MET_DELTA_E {
                format!(
                    "the target is outside what a {what} within [{lo}, {hi}] can reach {under}: the closest reachable colour is {} (ΔE00 {})",
                    fmt_rgb(&best),
                    Fixed(de, 2)
                )
            } else {
                let mut msg = format!(
                    "a {what} alone could reach it (ΔE00 {}), so it conflicts with the other criteria on this {what} (other cells, smoothness, free colours)",
                    Fixed(de, 2)
                );
                if refl.design {
                    // Near-identical lights asked for different colours on this reflectance?
                    for d in by_reflectance[c.reflectance].iter().map(|&k| &p.colours[k]) {
                        if d.light != c.light {
                            let e2 = &v.lights[d.light];
                            let scale = e.l2_norm().max(e2.l2_norm());
                            if scale > 0.0 && (e.0 - e2.0).norm() <= NEAR_IDENTICAL * scale {
                                msg += &format!(
                                    "; light \"{}\" is nearly identical to \"{}\" yet asks for a different colour",
                                    p.lights[d.light].name, light.name
                                );
                            }
                        }
                    }
                }
                msg
            }
        } else {
            "light and reflectance are designed jointly; this cell conflicts with the other cells sharing them (or the smoothness)".to_string()
        };
        say(Some(r.cell), format!("{head}: {why}"))
    }
}

/// Colours and errors of every mixture cell at `v` (`CellResult::cell` indexes `palette.mixtures`); ΔE00
/// with the mixed light on a flat white as the reference white.
pub(crate) fn mixture_results(
    palette: &Palette,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    v: &Values,
) -> Vec<CellResult> {
    palette
        .mixtures
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let target = m.free.map(|g| v.free[g]).unwrap_or(m.target);
            let e = light_of(&m.mix, &v.lights);
            CellResult::new(k, target, (&e, &v.reflectances[m.reflectance]), m.is_active(), basis, colorimetry)
        })
        .collect()
}

/// (worst ΔE00, its t, its slider point, the colour there, the worst over the design samples alone).
type PathWorst = (f64, f64, [f64; 2], Vector3<f64>, f64);

/// The worst ΔE00 of `colour(e, s)` from `target` over a path's check positions: (worst, its t, its slider
/// point, the colour there, the worst over the design samples alone).
fn path_worst(
    palette: &Palette,
    k: usize,
    v: &Values,
    target: &Vector3<f64>,
    colour: impl Fn(&Spectrum, &Spectrum) -> Vector3<f64>,
    colorimetry: &Colorimetry,
) -> Option<PathWorst> {
    let q = &palette.paths[k];
    let dial = route_dial(&palette.lights, &q.route).ok()?;
    let s = &v.reflectances[q.reflectance];
    let positions = check_positions(q.samples);
    let every = mixing::CHECK_PER_INTERVAL;
    let mut worst = (f64::NEG_INFINITY, 0.0, [0.0; 2], Vector3::zeros(), f64::NEG_INFINITY);
    for (j, &t) in positions.iter().enumerate() {
        let state = dial.state_at(t);
        let e = light_of(&mix_at(&dial, t), &v.lights);
        let rgb = colour(&e, s);
        let de = finite_or(colorimetry.delta_e00_under(target, &rgb, &e), f64::MAX);
        if de > worst.0 {
            worst = (de, t, state.slider, rgb, worst.4);
        }
        if j % every == 0 {
            worst.4 = worst.4.max(de);
        }
    }
    Some(worst)
}

/// Every path's colour checked densely after the solve ([`check_positions`]: the design samples and
/// [`mixing::CHECK_PER_INTERVAL`] − 1 positions between each two).
pub(crate) fn path_results(
    palette: &Palette,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    v: &Values,
) -> Vec<PathResult> {
    (0..palette.paths.len())
        .map(|k| {
            let q = &palette.paths[k];
            let target = q.free.map(|g| v.free[g]).unwrap_or(q.target);
            let full = |e: &Spectrum, s: &Spectrum| colorimetry.rgb(e, s);
            let (worst, t, point, rgb, at_samples) = path_worst(palette, k, v, &target, full, colorimetry).unwrap_or((
                f64::MAX,
                0.0,
                [0.0; 2],
                Vector3::zeros(),
                f64::MAX,
            ));
            let status = match (q.is_active(), worst > q.tolerance) {
                (false, _) => CellStatus::NotUsed,
                (true, false) => CellStatus::Met,
                (true, true) => CellStatus::Unmet,
            };
            let mut r = PathResult {
                path: k,
                target,
                samples: q.samples,
                checked: check_positions(q.samples).len(),
                worst_delta_e: worst,
                worst_at_samples: at_samples,
                worst_t: t,
                worst_point: point,
                worst_rgb: rgb,
                worst_delta_e_subspace: None,
                tolerance: q.tolerance,
                status,
            };
            r.worst_delta_e_subspace = basis.and_then(|b| path_worst_subspace(palette, b, colorimetry, v, &r));
            r
        })
        .collect()
}

/// The worst ΔE00 of a path's factor-model colour (what the renderer's factor model shows).
pub(crate) fn path_worst_subspace(
    palette: &Palette,
    basis: &Basis,
    colorimetry: &Colorimetry,
    v: &Values,
    r: &PathResult,
) -> Option<f64> {
    let colour = |e: &Spectrum, s: &Spectrum| basis.rgb_factor(e, s);
    path_worst(palette, r.path, v, &r.target, colour, colorimetry).map(|w| w.0)
}

/// A path whose colour strays beyond its tolerance somewhere: where, and whether the samples are too few.
pub(crate) fn path_diagnostics(palette: &Palette, paths: &[PathResult]) -> Vec<Diagnostic> {
    paths
        .iter()
        .filter(|r| r.is_unmet())
        .map(|r| {
            let q = &palette.paths[r.path];
            let label = mixing::path_label(palette, q);
            let head = format!(
                "path {label} not kept: the worst ΔE00 over {} positions is {} (tolerance {}) at t = {} (dial [{}, {}]), \
                 colour {} against the target {}",
                r.checked,
                Fixed(r.worst_delta_e, 2),
                q.tolerance,
                Fixed(r.worst_t, 3),
                Fixed(r.worst_point[0], 3),
                Fixed(r.worst_point[1], 3),
                fmt_rgb(&r.worst_rgb),
                fmt_rgb(&r.target)
            );
            let why = if r.worst_at_samples <= q.tolerance {
                format!(
                    "the {} design samples are within it ({}), the colour between them is not: raise `samples`",
                    r.samples,
                    Fixed(r.worst_at_samples, 2)
                )
            } else {
                format!(
                    "already {} at the design samples: the spectra cannot keep this colour along the path together with the other criteria",
                    Fixed(r.worst_at_samples, 2)
                )
            };
            Diagnostic {
                cell: None,
                criterion: Some(Criterion::Path(r.path)),
                kind: DiagnosticKind::Unmet,
                message: format!("{head}: {why}"),
            }
        })
        .collect()
}

/// Why mixture cells are not met: the same reasons as for ordinary cells, with the mixed light as the
/// light (a colour under a fixed mixture is that of one light, `Σ wᵢ Eᵢ`).
pub(crate) fn mixture_diagnostics(
    design: &Design,
    colorimetry: &Colorimetry,
    v: &Values,
    results: &[CellResult],
) -> Vec<Diagnostic> {
    let p = design.palette;
    let form = if p.settings.fit_in_subspace { Form::Subspace } else { Form::Full };
    results
        .iter()
        .filter(|r| r.status == CellStatus::Unmet)
        .map(|r| {
            let m = &p.mixtures[r.cell];
            let refl = &p.reflectances[m.reflectance];
            let label = format!("{} × {}", refl.name, mixing::mix_label(p, &m.spec, &m.mix));
            let e = light_of(&m.mix, &v.lights);
            let s = &v.reflectances[m.reflectance];
            let light_designed = m.mix.iter().any(|&(i, _)| p.lights[i].design);
            let head = format!(
                "mixture {label} not met (ΔE00 {}: target {}, achieved {})",
                Fixed(r.delta_e_full, 2),
                fmt_rgb(&r.target),
                fmt_rgb(&r.rgb_full)
            );
            let why = if is_zero(&e) {
                "the mixed light is zero, so every reflectance is black under it".to_string()
            } else if !light_designed && !refl.design {
                if m.free.is_some() {
                    "neither its lights nor its reflectance is designed, so its colour is fixed and pulls its free group's colour".to_string()
                } else {
                    "neither its lights nor its reflectance is designed, so nothing can change this colour".to_string()
                }
            } else if refl.design && !light_designed {
                let bounds = p.bounds_of(refl);
                let best = Reach::new(design, form, &e).closest(s, bounds, &r.target);
                let de = colorimetry.delta_e00_under(&r.target, &best, &e);
                let (best, de) = if r.delta_e_full < de { (r.rgb_full, r.delta_e_full) } else { (best, de) };
                if de > MET_DELTA_E {
                    format!(
                        "the target is outside what a reflectance within [{}, {}] can reach under this mixture: the closest reachable colour is {} (ΔE00 {})",
                        bounds.lower,
                        bounds.upper,
                        fmt_rgb(&best),
                        Fixed(de, 2)
                    )
                } else {
                    format!(
                        "a reflectance alone could reach it (ΔE00 {}), so it conflicts with the other criteria on this reflectance (other cells, mixtures, paths, smoothness, free colours)",
                        Fixed(de, 2)
                    )
                }
            } else {
                "it conflicts with the other criteria on the designed spectra it shares (cells, mixtures, paths, smoothness)".to_string()
            };
            Diagnostic {
                cell: None,
                criterion: Some(Criterion::Mixture(r.cell)),
                kind: DiagnosticKind::Unmet,
                message: format!("{head}: {why}"),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests;
