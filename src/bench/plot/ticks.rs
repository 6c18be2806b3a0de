//! Axis ranges and tick positions of the bench plots, and their labels.

use super::Scale;

/// A tick label with at most three significant digits and no float noise (`0.001`, `2.5`, `1e-5`,
/// `3.2e6`), short enough never to be clipped.
pub(crate) fn tick_label(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if !v.is_finite() {
        return String::new();
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let digits = (2 - a.log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{v:.digits$}");
        let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
        if s == "-0" { "0".into() } else { s }
    } else {
        let s = format!("{v:.1e}");
        // 1.0e-5 → 1e-5
        s.replace(".0e", "e")
    }
}

/// The 1-2-5 value at or below `v` (> 0): 0.01, 0.02, 0.05, 0.1, …
fn snap125_down(v: f64) -> f64 {
    let d = 10f64.powf(v.log10().floor());
    let m = v / d;
    let k = if m >= 5.0 - 1e-9 {
        5.0
    } else if m >= 2.0 - 1e-9 {
        2.0
    } else {
        1.0
    };
    k * d
}

/// The 1-2-5 value at or above `v` (> 0).
fn snap125_up(v: f64) -> f64 {
    let d = 10f64.powf(v.log10().floor());
    let m = v / d;
    let k = if m <= 1.0 + 1e-9 {
        1.0
    } else if m <= 2.0 + 1e-9 {
        2.0
    } else if m <= 5.0 + 1e-9 {
        5.0
    } else {
        10.0
    };
    k * d
}

/// The plotted range of some values: padded, and on a log axis widened to 1-2-5 values so that both
/// ends can carry a label.
pub(crate) fn range(values: impl Iterator<Item = f64>, scale: Scale) -> Option<(f64, f64)> {
    let vals: Vec<f64> = values.filter(|v| v.is_finite() && (scale == Scale::Linear || *v > 0.0)).collect();
    let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() || !hi.is_finite() {
        return None;
    }
    Some(match scale {
        Scale::Log => {
            let (l, h) = (lo.log10(), hi.log10());
            let pad = ((h - l) * 0.05).max(0.05);
            (snap125_down(10f64.powf(l - pad)), snap125_up(10f64.powf(h + pad)))
        }
        Scale::Linear => {
            let pad = ((hi - lo) * 0.08).max(hi.abs().max(1e-12) * 0.05);
            (if lo >= 0.0 { (lo - pad).max(0.0) } else { lo - pad }, hi + pad)
        }
    })
}

/// Tick positions of one axis: `bold` are labelled (with a grid line), `light` are grid lines only.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Ticks {
    pub(crate) bold: Vec<f64>,
    pub(crate) light: Vec<f64>,
}

/// The smallest 1-2-5 step ≥ `raw` (> 0).
fn nice_step(raw: f64) -> f64 {
    snap125_up(raw)
}

/// Ticks for the range `lo..hi` with at most `max_labels` labels (≥ 2).
///
/// Linear: multiples of the smallest 1-2-5 step that keeps the count within `max_labels`, light lines
/// at a fifth of the step. Log spanning two decades or more: every whole decade (every second … when
/// too many), plus each end of the range when it is not within a label's width of a decade, so the
/// lowest and highest decades always carry a number; light lines at 2…9 × each decade. Log spanning less:
/// the 1-2-5 values inside (or 1…9 × when those are fewer than three).
pub(crate) fn axis_ticks(lo: f64, hi: f64, scale: Scale, max_labels: usize) -> Ticks {
    let max_labels = max_labels.max(2);
    let inside = |v: f64| v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9);
    match scale {
        Scale::Linear => {
            let span = (hi - lo).abs().max(1e-300);
            let mut step = nice_step(span / max_labels as f64);
            while (span / step).floor() as usize + 1 > max_labels {
                step = nice_step(step * 1.01);
            }
            let multiples = |step: f64| -> Vec<f64> {
                let (a, b) = ((lo / step).ceil() as i64, (hi / step).floor() as i64);
                (a..=b).map(|k| if k == 0 { 0.0 } else { k as f64 * step }).collect()
            };
            let bold = multiples(step);
            let light = multiples(step / 5.0).into_iter().filter(|v| !bold.iter().any(|b| close(*b, *v))).collect();
            Ticks { bold, light }
        }
        Scale::Log => {
            let (l, h) = (lo.log10(), hi.log10());
            let decades: Vec<i32> = ((l - 1e-9).ceil() as i32..=(h + 1e-9).floor() as i32).collect();
            let all_of = |ms: &[f64]| -> Vec<f64> {
                let mut v = Vec::new();
                for d in (l.floor() as i32)..=(h.ceil() as i32) {
                    for m in ms {
                        let x = m * 10f64.powi(d);
                        if inside(x) {
                            v.push(x);
                        }
                    }
                }
                v
            };
            if decades.len() >= 2 {
                let mut every = 1;
                while decades.len().div_ceil(every) > max_labels {
                    every += 1;
                }
                // Thinned decades keep the highest one.
                let top = decades[decades.len() - 1];
                let mut bold: Vec<f64> = decades
                    .iter()
                    .filter(|d| (top - **d).rem_euclid(every as i32) == 0)
                    .map(|d| 10f64.powi(*d))
                    .collect();
                // A label's width in decades: the axis shared among max_labels labels.
                let gap = (h - l) / max_labels as f64;
                for end in [lo, hi] {
                    if bold.iter().all(|b| (b.log10() - end.log10()).abs() >= gap.max(0.25)) {
                        bold.push(end);
                    }
                }
                bold.sort_by(f64::total_cmp);
                let light = if every == 1 && h - l <= 8.0 {
                    all_of(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
                } else {
                    decades.iter().map(|d| 10f64.powi(*d)).collect()
                };
                let light = light.into_iter().filter(|v| !bold.iter().any(|b| close(*b, *v))).collect();
                Ticks { bold, light }
            } else {
                let mut bold = all_of(&[1.0, 2.0, 5.0]);
                if bold.len() < 3 {
                    bold = all_of(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
                }
                let mut every = 1;
                while bold.len().div_ceil(every) > max_labels {
                    every += 1;
                }
                let bold: Vec<f64> = bold.into_iter().step_by(every).collect();
                let light = all_of(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
                    .into_iter()
                    .filter(|v| !bold.iter().any(|b| close(*b, *v)))
                    .collect();
                Ticks { bold, light }
            }
        }
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-300)
}
