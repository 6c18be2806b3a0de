//! Mixtures of the palette's lights, for `[[mixtures]]` cells and `[[paths]]` constancies.
//!
//! There is one dial model: a mixture written as a dial position, and every position of a path, takes its
//! weights from [`crate::render::dial`] — the very [`DialState`] and [`Dial`] the renderer lights its
//! frames with, over the same vertices (every palette light at its `dial = [x, y]`, lights without one on
//! the regular polygon, [`default_position`]). The light of a mixture is `Σ wᵢ Eᵢ`; a colour under it is
//! linear in every spectrum, so mixture rows join the stacked least squares as they are.

use super::{Mix, MixSpec, Palette, PathConstancy, Route, SpectrumEntry};
use crate::render::dial::{Dial, DialError, DialLight, DialState, default_position};
use crate::spectrum::Spectrum;

/// How many positions the solve checks a path at for every design sample interval.
pub const CHECK_PER_INTERVAL: usize = 16;

/// The palette's lights as the renderer's dial: every light at its `dial` vertex (lights without one on a
/// regular polygon of the unit circle), all on, intensity 1.
pub fn dial_lights(lights: &[SpectrumEntry]) -> Vec<DialLight> {
    let n = lights.len();
    lights
        .iter()
        .enumerate()
        .map(|(i, l)| DialLight::new(l.name.clone(), l.spectrum, l.dial.unwrap_or_else(|| default_position(i, n))))
        .collect()
}

/// The dial over `lights` with the lights at indices `off` switched off.
fn dial_state(lights: &[SpectrumEntry], off: &[usize]) -> Result<DialState, DialError> {
    let mut state = DialState::new(dial_lights(lights))?;
    for &i in off {
        state.set_on(i, false)?;
    }
    Ok(state)
}

/// The nonzero weights as a [`Mix`].
pub fn mix_of(weights: &[f64]) -> Mix {
    weights.iter().enumerate().filter(|(_, w)| **w != 0.0).map(|(i, w)| (i, *w)).collect()
}

/// The dial's Shepard weights at `at` with the lights `off` switched off (the renderer's
/// [`DialState::weights`] with the slider there).
pub fn dial_mix(lights: &[SpectrumEntry], at: [f64; 2], off: &[usize]) -> Result<Mix, DialError> {
    let mut state = dial_state(lights, off)?;
    state.set_slider(at)?;
    Ok(mix_of(&state.weights()))
}

/// The renderer's [`Dial`] that sweeps `route`: keyframes at the `through` points (lights `off` switched
/// off), or a path of lights mixed pairwise.
pub fn route_dial(lights: &[SpectrumEntry], route: &Route) -> Result<Dial, DialError> {
    match route {
        Route::Dial { through, off } => {
            let base = dial_state(lights, off)?;
            let keys = through
                .iter()
                .map(|&p| {
                    let mut k = base.clone();
                    k.set_slider(p)?;
                    Ok(k)
                })
                .collect::<Result<Vec<_>, DialError>>()?;
            Dial::keyframes(base, keys)
        }
        Route::Lights(order) => Dial::path(dial_state(lights, &[])?, order.clone()),
    }
}

/// The mixture at `t` ∈ [0, 1] along a dial's sweep (by arc length, as the renderer's frames move).
pub fn mix_at(dial: &Dial, t: f64) -> Mix {
    mix_of(&dial.state_at(t).weights())
}

/// The positions `t` a path's design samples: `samples` evenly over [0, 1], both ends included.
pub fn sample_positions(samples: usize) -> Vec<f64> {
    let n = samples.max(2);
    (0..n).map(|k| k as f64 / (n - 1) as f64).collect()
}

/// The positions a path's colour is checked at after the solve: [`CHECK_PER_INTERVAL`] per design interval.
pub fn check_positions(samples: usize) -> Vec<f64> {
    sample_positions((samples.max(2) - 1) * CHECK_PER_INTERVAL + 1)
}

/// The mixed light `Σ wᵢ Eᵢ` over `lights` (the spectra, indexed as the palette's lights).
pub fn light_of(mix: &[(usize, f64)], lights: &[Spectrum]) -> Spectrum {
    let mut s = Spectrum::flat(0.0);
    for &(i, w) in mix {
        s.0 += lights[i].0 * w;
    }
    s
}

fn num(x: f64) -> String {
    let r = (x * 1e3).round() / 1e3;
    if r == 0.0 { "0".into() } else { format!("{r}") }
}

fn off_label(p: &Palette, off: &[usize]) -> String {
    if off.is_empty() {
        String::new()
    } else {
        let names: Vec<&str> = off.iter().map(|&i| p.lights[i].name.as_str()).collect();
        format!(", off {}", names.join(" "))
    }
}

/// A readable name of a mixture: `dial(0.3, 0.5)`, `dial(0.3, 0.5, off glow)` or `mix(hide 0.3, glow 0.7)`.
pub fn mix_label(p: &Palette, spec: &MixSpec, mix: &Mix) -> String {
    match spec {
        MixSpec::Dial { at, off } => format!("dial({}, {}{})", num(at[0]), num(at[1]), off_label(p, off)),
        MixSpec::Weights => {
            let parts: Vec<String> = mix.iter().map(|&(i, w)| format!("{} {}", p.lights[i].name, num(w))).collect();
            format!("mix({})", parts.join(", "))
        }
    }
}

/// A readable name of a path's route: `path(hide → glow)` (lights mixed pairwise) or `dial path(hide →
/// [0.5, 0.2] → glow, off purple)` (points at a vertex named by their light).
pub fn route_label(p: &Palette, route: &Route) -> String {
    match route {
        Route::Lights(order) => {
            let names: Vec<&str> = order.iter().map(|&i| p.lights[i].name.as_str()).collect();
            format!("path({})", names.join(" → "))
        }
        Route::Dial { through, off } => {
            // A point at a light's vertex is named by the light.
            let vertices = dial_lights(&p.lights);
            let name = |q: &[f64; 2]| vertices.iter().find(|l| l.position == *q).map(|l| l.name.clone());
            let pts: Vec<String> =
                through.iter().map(|q| name(q).unwrap_or_else(|| format!("[{}, {}]", num(q[0]), num(q[1])))).collect();
            format!("dial path({}{})", pts.join(" → "), off_label(p, off))
        }
    }
}

/// The name of a path for tables and messages: `REFLECTANCE along ROUTE`.
pub fn path_label(p: &Palette, path: &PathConstancy) -> String {
    format!("{} along {}", p.reflectances[path.reflectance].name, route_label(p, &path.route))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::palette::{Kind, Source};
    use crate::spectrum::Normalize;

    fn light(name: &str, v: f64, dial: Option<[f64; 2]>) -> SpectrumEntry {
        SpectrumEntry {
            name: name.into(),
            kind: Kind::Light,
            source: Source::Flat(v),
            normalize: Normalize::None,
            scale: 1.0,
            design: false,
            bounds: None,
            dial,
            spectrum: Spectrum::flat(v),
        }
    }

    #[test]
    fn a_dial_mixture_is_the_renderers_light_at_that_point() {
        let lights = vec![light("a", 1.0, Some([0.0, 0.0])), light("b", 2.0, Some([1.0, 0.0])), light("c", 3.0, None)];
        let at = [0.3, 0.4];
        let mix = dial_mix(&lights, at, &[]).unwrap();
        let mut state = DialState::new(dial_lights(&lights)).unwrap();
        state.set_slider(at).unwrap();
        let spectra: Vec<Spectrum> = lights.iter().map(|l| l.spectrum).collect();
        assert!((light_of(&mix, &spectra).0 - state.light().0).norm() < 1e-12);
        // Switching a light off removes it and renormalises the others.
        let off = dial_mix(&lights, at, &[2]).unwrap();
        assert!(off.iter().all(|&(i, _)| i != 2));
        assert!((off.iter().map(|m| m.1).sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn path_positions_follow_the_renderers_sweep() {
        let lights = vec![light("a", 1.0, Some([0.0, 0.0])), light("b", 2.0, Some([1.0, 0.0]))];
        let dial = route_dial(&lights, &Route::Lights(vec![0, 1])).unwrap();
        let m = mix_at(&dial, 0.25);
        assert_eq!(m, vec![(0, 0.75), (1, 0.25)]);
        assert_eq!(check_positions(3).len(), 2 * CHECK_PER_INTERVAL + 1);
    }
}
