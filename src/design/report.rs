//! Per-cell colours at the solution and diagnostics: which cells cannot be met and why, and what is
//! degenerate about the input.
//!
//! Subspace colours are those of the spectral factor model the renderer uses: `Q_rgb,m (e ∘ s)` with
//! `e = B⁺E`, `s = B⁺S` ([`Basis::rgb_factor`], seed Eq. 15) — not the Λ-form used by
//! `fit_in_subspace`, which is what the design minimises but not what is displayed.

use super::joint::NormalCache as FactorCache;
use super::lsq;
use super::system::{Design, LinearSystem, Values};
use super::{CellResult, Diagnostic};
use crate::basis::Basis;
use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use crate::spectrum::{SAMPLES, Spectrum};
use nalgebra::{DMatrix, DVector, Vector3};
use rayon::prelude::*;

/// A cell counts as met when its full colour is within this CIEDE2000 of its target.
pub const MET_DELTA_E: f64 = 1.0;

/// Two lights count as nearly identical when `‖E_a − E_b‖ ≤ NEAR_IDENTICAL · max(‖E_a‖, ‖E_b‖)`.
pub const NEAR_IDENTICAL: f64 = 1e-3;

fn finite_or(v: f64, d: f64) -> f64 {
    if v.is_finite() { v } else { d }
}

/// Colours and errors of every cell of the palette at `v`.
pub fn cell_results(
    palette: &Palette,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    v: &Values,
) -> Vec<CellResult> {
    palette
        .colours
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let e = &v.lights[c.light];
            let s = &v.reflectances[c.reflectance];
            let target = c.free.map(|g| v.free[g]).unwrap_or(c.target);
            let rgb_full = colorimetry.rgb(e, s);
            let rgb_subspace = basis.map(|b| b.rgb_factor(e, s));
            let delta_e_full = finite_or(colorimetry.delta_e00_under(&target, &rgb_full, e), f64::MAX);
            let delta_e_subspace =
                rgb_subspace.map(|r| finite_or(colorimetry.delta_e00_under(&target, &r, e), f64::MAX));
            CellResult { cell: k, target, rgb_full, rgb_subspace, delta_e_full, delta_e_subspace }
        })
        .collect()
}

fn fmt_rgb(c: &Vector3<f64>) -> String {
    format!("[{:.4}, {:.4}, {:.4}]", c[0], c[1], c[2])
}

fn is_zero(s: &Spectrum) -> bool {
    s.0.amax() <= 1e-12
}

/// The closest colour a designed spectrum within its bounds can produce with `partner` fixed, ignoring
/// every other criterion: a bounded least-squares solve of the 3 colour rows alone, warm-started from the
/// designed spectrum's solution.
fn closest_reachable(
    cache: &FactorCache,
    design: &Design,
    form: super::system::Form,
    partner: &Spectrum,
    start: &Spectrum,
    bounds: (Vec<f64>, Vec<f64>),
    target: &Vector3<f64>,
) -> Vector3<f64> {
    let op = design.operator(form, partner);
    // The colour rows plus a tiny ridge (1e-4·I) so the normal equations stay definite and the active-set
    // solve takes its fast path; the ridge moves the reachable colour by far less than a ΔE00 of 0.01.
    const RIDGE: f64 = 1e-4;
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
    let sys = LinearSystem { a, b, lower: DVector::from_vec(bounds.0), upper: DVector::from_vec(bounds.1) };
    let h = cache.get(&sys.a);
    let out = lsq::solve_from(&sys, &h, &DVector::from_column_slice(start.as_slice()));
    op * nalgebra::SVector::<f64, SAMPLES>::from_column_slice(out.x.as_slice())
}

/// Diagnostics about the palette and the solution.
pub fn diagnostics(design: &Design, colorimetry: &Colorimetry, v: &Values, cells: &[CellResult]) -> Vec<Diagnostic> {
    let p = design.palette;
    let mut out = Vec::new();
    let say = |cell: Option<usize>, message: String| Diagnostic { cell, message };
    // Designed spectra without any colour criterion.
    let mut light_used = vec![false; p.lights.len()];
    let mut refl_used = vec![false; p.reflectances.len()];
    for t in &design.terms {
        light_used[t.light] = true;
        refl_used[t.reflectance] = true;
    }
    for (kind, entries, used) in [("light", &p.lights, &light_used), ("reflectance", &p.reflectances, &refl_used)] {
        for (i, e) in entries.iter().enumerate() {
            if e.design && !used[i] {
                out.push(say(
                    None,
                    format!(
                        "{kind} \"{}\" is designed but no active colour cell uses it: only smoothness acts on it",
                        e.name
                    ),
                ));
            }
        }
    }
    // Duplicated cells.
    let mut first: std::collections::HashMap<(usize, usize), usize> = std::collections::HashMap::new();
    for (k, c) in p.colours.iter().enumerate() {
        if !c.is_active() {
            continue;
        }
        if let Some(&j) = first.get(&(c.light, c.reflectance)) {
            out.push(say(
                Some(k),
                format!(
                    "cell {} × {} appears twice (colours[{j}] and colours[{k}]): both count, so the solution is their weighted compromise",
                    p.lights[c.light].name, p.reflectances[c.reflectance].name
                ),
            ));
        } else {
            first.insert((c.light, c.reflectance), k);
        }
    }
    // Unmet cells, with a reason (in parallel: each may run a small bounded solve).
    let mut by_reflectance: Vec<Vec<usize>> = vec![Vec::new(); p.reflectances.len()];
    for (k, c) in p.colours.iter().enumerate() {
        if c.is_active() {
            by_reflectance[c.reflectance].push(k);
        }
    }
    // Cells under a zero light: black whatever the reflectance, and ΔE00 against a black white is meaningless.
    for r in cells {
        let c = &p.colours[r.cell];
        if c.is_active() && is_zero(&v.lights[c.light]) {
            out.push(say(
                Some(r.cell),
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
    let unmet: Vec<&CellResult> = cells
        .iter()
        .filter(|r| {
            let c = &p.colours[r.cell];
            c.is_active() && r.delta_e_full > MET_DELTA_E && !is_zero(&v.lights[c.light])
        })
        .collect();
    let cache = FactorCache::default();
    let reasons: Vec<Diagnostic> =
        unmet.par_iter().map(|r| unmet_reason(&cache, design, colorimetry, v, r, &by_reflectance)).collect();
    out.extend(reasons);
    out
}

/// Why one cell is not met.
fn unmet_reason(
    cache: &FactorCache,
    design: &Design,
    colorimetry: &Colorimetry,
    v: &Values,
    r: &CellResult,
    by_reflectance: &[Vec<usize>],
) -> Diagnostic {
    let p = design.palette;
    let say = |cell: Option<usize>, message: String| Diagnostic { cell, message };
    {
        let c = &p.colours[r.cell];
        let light = &p.lights[c.light];
        let refl = &p.reflectances[c.reflectance];
        let e = &v.lights[c.light];
        let s = &v.reflectances[c.reflectance];
        let head = format!(
            "cell {} × {} not met (ΔE00 {:.2}: target {}, achieved {})",
            light.name,
            refl.name,
            r.delta_e_full,
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
        } else if light.design != refl.design {
            let (partner, unit, what, under) = if refl.design {
                (
                    e,
                    super::system::Unit::Reflectance(c.reflectance),
                    "reflectance",
                    format!("under light \"{}\"", light.name),
                )
            } else {
                (s, super::system::Unit::Light(c.light), "light", format!("on reflectance \"{}\"", refl.name))
            };
            let bounds = design.bounds_of(unit);
            let (lo, hi) = (bounds.0[0], bounds.1[0]);
            let form =
                design.terms.iter().find(|t| t.cell == r.cell).map(|t| t.form).unwrap_or(super::system::Form::Full);
            let start = if refl.design { s } else { e };
            let best = closest_reachable(cache, design, form, partner, start, bounds, &r.target);
            let de = colorimetry.delta_e00_under(&r.target, &best, e);
            if de > MET_DELTA_E {
                format!(
                    "the target is outside what a {what} within [{lo}, {hi}] can reach {under}: the closest reachable colour is {} (ΔE00 {:.2})",
                    fmt_rgb(&best),
                    de
                )
            } else {
                let mut msg = format!(
                    "a {what} alone could reach it (ΔE00 {de:.2}), so it conflicts with the other criteria on this {what} (other cells, smoothness, free colours)"
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
