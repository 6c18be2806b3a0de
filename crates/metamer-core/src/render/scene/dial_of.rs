//! A scene's light dial: the palette's lights as dial vertices, and the `[dial]` table as a path or
//! keyframes.

use super::*;
use crate::fsio::escape;

/// The dial's lights: every palette light, at its `dial = [x, y]` vertex (lights without one on a regular
/// polygon of the unit circle), all on with intensity 1 — the same lights a palette's mixtures use.
fn dial_lights(palette: &Palette) -> Vec<DialLight> {
    crate::palette::mixing::dial_lights(&palette.lights)
}

pub(crate) use crate::render::dial::MAX_DIAL_COORDINATE;

/// `p` when both coordinates are finite and within ±[`MAX_DIAL_COORDINATE`], else an error naming `key`.
fn check_point(path: &Path, key: String, p: [f64; 2]) -> Result<[f64; 2], RenderError> {
    if !(p[0].is_finite() && p[1].is_finite()) {
        return Err(scene_err(path, key, format!("[{}, {}] is not a pair of finite numbers", p[0], p[1])));
    }
    if p.iter().any(|c| c.abs() > MAX_DIAL_COORDINATE) {
        return Err(scene_err(
            path,
            key,
            format!(
                "[{:e}, {:e}] is outside the dial (coordinates within ±{MAX_DIAL_COORDINATE:e}; the light mix's \
                 distances would overflow)",
                p[0], p[1]
            ),
        ));
    }
    Ok(p)
}

/// The palette's dial positions, checked as the scene's own points are.
fn check_palette_positions(path: &Path, lights: &[DialLight]) -> Result<(), RenderError> {
    for l in lights {
        check_point(path, format!("palette light `{}` dial", escape(&l.name)), l.position)?;
    }
    Ok(())
}

/// The dial: the named path, else the lights with `dial` positions in angular order, else all lights.
pub(super) fn dial_of(path: &Path, palette: &Palette, names: Option<&[String]>) -> Result<Dial, RenderError> {
    let lights = dial_lights(palette);
    check_palette_positions(path, &lights)?;
    let base = DialState::new(lights).map_err(|e| scene_err(path, "dial", e.to_string()))?;
    path_dial(path, palette, base, names)
}

/// A path dial over `base`'s lights (indices as in the palette).
fn path_dial(path: &Path, palette: &Palette, base: DialState, names: Option<&[String]>) -> Result<Dial, RenderError> {
    let order: Vec<usize> = match names {
        Some(names) => {
            let all = || palette.lights.iter().map(|l| l.name.as_str()).collect::<Vec<_>>().join(", ");
            names
                .iter()
                .enumerate()
                .map(|(i, n)| {
                    palette.light_index(n).ok_or_else(|| {
                        scene_err(
                            path,
                            format!("dial.path[{i}]"),
                            format!("`{}` is not a light of the palette ({})", escape(n), all()),
                        )
                    })
                })
                .collect::<Result<_, _>>()?
        }
        None => {
            let placed: Vec<(usize, [f64; 2])> =
                palette.lights.iter().enumerate().filter_map(|(i, l)| l.dial.map(|d| (i, d))).collect();
            if placed.len() >= 2 {
                let n = placed.len() as f64;
                let cx = placed.iter().map(|(_, d)| d[0]).sum::<f64>() / n;
                let cy = placed.iter().map(|(_, d)| d[1]).sum::<f64>() / n;
                let mut placed = placed;
                placed.sort_by(|a, b| (a.1[1] - cy).atan2(a.1[0] - cx).total_cmp(&(b.1[1] - cy).atan2(b.1[0] - cx)));
                placed.into_iter().map(|(i, _)| i).collect()
            } else {
                (0..palette.lights.len()).collect()
            }
        }
    };
    Dial::path(base, order).map_err(|e| scene_err(path, "dial.path", e.to_string()))
}

/// The dial of a scene's `[dial]` table: vertex overrides, then either `path` (today's meaning) or
/// `keyframes` (DESIGN_SPEC §4, docs/formats/dial.md).
pub(super) fn dial_of_file(path: &Path, palette: &Palette, d: &DialFile) -> Result<Dial, RenderError> {
    let all = || palette.lights.iter().map(|l| l.name.as_str()).collect::<Vec<_>>().join(", ");
    let light = |key: String, name: &str| {
        palette.light_index(name).ok_or_else(|| {
            scene_err(path, key, format!("`{}` is not a light of the palette ({})", escape(name), all()))
        })
    };
    let point = |key: String, p: [f64; 2]| check_point(path, key, p);
    let mut lights = dial_lights(palette);
    check_palette_positions(path, &lights)?;
    for (name, p) in d.vertices.iter().flatten() {
        let i = light(format!("dial.vertices.{}", escape(name)), name)?;
        lights[i].position = point(format!("dial.vertices.{}", escape(name)), *p)?;
    }
    let base = DialState::new(lights).map_err(|e| scene_err(path, "dial", e.to_string()))?;
    let Some(frames) = &d.keyframes else {
        return path_dial(path, palette, base, d.path.as_deref());
    };
    if d.path.is_some() {
        return Err(scene_err(path, "dial", "give either `path` or `keyframes`, not both"));
    }
    if frames.is_empty() {
        return Err(scene_err(path, "dial.keyframes", "the list is empty (give at least one keyframe)"));
    }
    let mut state = base.clone();
    let mut states = Vec::with_capacity(frames.len());
    for (k, f) in frames.iter().enumerate() {
        let key = |rest: &str| format!("dial.keyframes[{k}].{rest}");
        for (name, p) in f.moves.iter().flatten() {
            let i = light(key(&format!("move.{}", escape(name))), name)?;
            let p = point(key(&format!("move.{}", escape(name))), *p)?;
            state.lights[i].position = p;
        }
        for (j, name) in f.off.iter().enumerate() {
            let i = light(key(&format!("off[{j}]")), name)?;
            state.lights[i].on = false;
        }
        for (j, name) in f.on.iter().enumerate() {
            let i = light(key(&format!("on[{j}]")), name)?;
            state.lights[i].on = true;
        }
        for (name, v) in f.intensity.iter().flatten() {
            let i = light(key(&format!("intensity.{}", escape(name))), name)?;
            if !(v.is_finite() && *v >= 0.0) {
                return Err(scene_err(
                    path,
                    key(&format!("intensity.{}", escape(name))),
                    format!("{v} is not a finite number ≥ 0"),
                ));
            }
            state.lights[i].intensity = *v;
        }
        if state.lights.iter().all(|l| !l.on) {
            return Err(scene_err(
                path,
                key("off"),
                "this keyframe switches every light off (the frames would be black)",
            ));
        }
        // The same for intensities: lights that are on but all at 0 light nothing.
        if state.lights.iter().all(|l| !l.on || l.intensity == 0.0) {
            return Err(scene_err(
                path,
                key("intensity"),
                "this keyframe leaves every light that is on at intensity 0 (the frames would be black)",
            ));
        }
        let at = match &f.at {
            AtFile::Light(name) => state.lights[light(key("at"), name)?].position,
            AtFile::Point(p) => point(key("at"), *p)?,
        };
        state.slider = at;
        state.fixed_weights = None;
        states.push(state.clone());
    }
    Dial::keyframes(base, states).map_err(|e| scene_err(path, "dial.keyframes", e.to_string()))
}
