//! The light dial's keys (after `g`): the slider and the vertices move in small and large steps, number
//! keys switch lights, `+`/`-` change the selected light's intensity, `a` adds the dial as a keyframe
//! and Ctrl-s writes the keyframes into the scene file, which `metamer render` then sweeps
//! (the `[[dial.keyframes]]` format of `docs/formats/dial.md`). Every change relights the preview.

use crate::render::dial::DialState;
use crate::tui::action::Action;
use crate::tui::app::State;
use std::path::Path;
use toml_edit::{Array, ArrayOfTables, DocumentMut, InlineTable, Item, Table, value};

/// A small step of the slider or a vertex, as a fraction of the dial's extent; a large step is ten.
pub(crate) const SMALL_STEP: f64 = 0.02;
pub(crate) const LARGE_STEP: f64 = 0.2;
/// Intensity change per `+`/`-`, and its range.
pub(crate) const INTENSITY_STEP: f64 = 0.1;
pub(crate) const MAX_INTENSITY: f64 = 10.0;

/// Carry out a dial action (the caller routes only dial actions here).
pub fn update(state: &mut State, action: Action) {
    let Some(scene) = state.preview.scene() else {
        state.complain("no scene preview: start with --scene SCENE.toml");
        return;
    };
    let [[x0, y0], [x1, y1]] = scene.dial.base.bounds();
    let extent = (x1 - x0).max(y1 - y0).max(1e-3);
    let scene_path = scene.path.clone();
    let Some(dial) = state.preview.dial.as_mut().map(|d| &mut d.state) else { return };
    let n = dial.lights.len();
    let result: Result<(), String> = match action {
        Action::DialLeave => {
            state.preview.keys = false;
            return;
        }
        Action::DialSlide { dx, dy, big } => {
            let step = extent * if big { LARGE_STEP } else { SMALL_STEP };
            let (dx, dy) = (f64::from(dx) * step, f64::from(dy) * step);
            match state.preview.selected {
                None => dial.set_slider([dial.slider[0] + dx, dial.slider[1] + dy]),
                Some(i) => {
                    let p = dial.lights.get(i).map_or([0.0; 2], |l| l.position);
                    dial.move_vertex(i, [p[0] + dx, p[1] + dy])
                }
            }
            .map_err(|e| e.to_string())
        }
        Action::DialToggle(k) => {
            let i = usize::from(k).wrapping_sub(1);
            match dial.toggle(i) {
                Ok(on) => {
                    let name = dial.lights[i].name.clone();
                    state.say(format!("light {k} {name} {}", if on { "on" } else { "off" }));
                    Ok(())
                }
                Err(_) => Err(format!("there is no light {k} (the dial has {n})")),
            }
        }
        Action::DialSelect { forward } => {
            // Cycle: slider, vertex 1, …, vertex n.
            let at = state.preview.selected.map_or(0, |i| i + 1);
            let next = if forward { (at + 1) % (n + 1) } else { (at + n) % (n + 1) };
            state.preview.selected = next.checked_sub(1);
            Ok(())
        }
        Action::DialIntensity { up } => match state.preview.selected {
            None => Err("select a light with Tab first (the slider has no intensity)".to_string()),
            Some(i) => {
                let v = dial.lights.get(i).map_or(1.0, |l| l.intensity);
                let step = if up { INTENSITY_STEP } else { -INTENSITY_STEP };
                let next = ((v + step) * 10.0).round() / 10.0;
                dial.set_intensity(i, next.clamp(0.0, MAX_INTENSITY)).map_err(|e| e.to_string())
            }
        },
        Action::DialKeyframe => {
            if dial.lights.iter().all(|l| !l.on) {
                Err("every light is off: switch one on before adding a keyframe".to_string())
            } else {
                let mut k = dial.clone();
                k.fixed_weights = None;
                state.preview.keyframes.push(k);
                let count = state.preview.keyframes.len();
                state.say(format!("keyframe {count} added (Ctrl-s writes the keyframes into the scene)"));
                Ok(())
            }
        }
        Action::DialSaveScene => match scene_path {
            None => Err("the built-in scene has no file: open a scene file with --scene to save keyframes".to_string()),
            Some(_) if state.preview.keyframes.is_empty() => Err("no keyframes yet: `a` adds one".to_string()),
            Some(path) => match save_keyframes(&path, &state.preview.keyframes) {
                Ok(text) => {
                    // The saved sweep sets render's exposure: take it, so the preview stays what
                    // `metamer render` writes.
                    match crate::render::scene::Scene::load(&path) {
                        Ok(saved) => {
                            let colorimetry = state.colorimetry.clone();
                            if let Some(p) = state.preview.ready.as_mut() {
                                p.rescene(std::sync::Arc::new(saved), &colorimetry);
                            }
                            state.preview.keyframes.clear();
                            state.say(text);
                        }
                        Err(e) => state.complain(format!("{text}, but it does not load again: {e}")),
                    }
                    Ok(())
                }
                Err(e) => Err(format!("scene not saved: {e}")),
            },
        },
        _ => Ok(()),
    };
    if let Err(e) = result {
        state.complain(e);
    }
    state.relight();
}

/// One keyframe as a TOML table: the slider point and, explicitly, every light's state (so it does not
/// depend on the keyframes before it).
fn keyframe_table(k: &DialState) -> Table {
    let names = |on: bool| -> Array { k.lights.iter().filter(|l| l.on == on).map(|l| l.name.as_str()).collect() };
    let point = |p: [f64; 2]| -> Array { [round(p[0]), round(p[1])].into_iter().collect() };
    let mut t = Table::new();
    t["at"] = value(point(k.slider));
    t["off"] = value(names(false));
    t["on"] = value(names(true));
    let mut moves = InlineTable::new();
    let mut intensity = InlineTable::new();
    for l in &k.lights {
        moves.insert(&l.name, point(l.position).into());
        intensity.insert(&l.name, round(l.intensity).into());
    }
    t["move"] = value(moves);
    t["intensity"] = value(intensity);
    t
}

/// Six decimals: what a user would type, and stable across saves.
fn round(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}

/// Append `keyframes` to the scene file's `[[dial.keyframes]]`, keeping everything else of the file as
/// the user wrote it: every other key, comment and the order, the palette and volume paths, and keyframes
/// already there. A dial has either a `path` or keyframes, so a `path = [...]` sweep is taken out of
/// `[dial]` but kept, with the comments above it, as a comment over the saved keyframes (put it back to
/// sweep the path again). The write is atomic and keeps a symbolic link and the file's permissions
/// ([`crate::fsio::write_atomic`]).
pub fn save_keyframes(path: &Path, keyframes: &[DialState]) -> Result<String, String> {
    let show = crate::fsio::show(path);
    let text = crate::fsio::read_to_string(path, crate::fsio::Kind::Scene).map_err(|e| e.to_string())?;
    let mut doc: DocumentMut = text.parse().map_err(|e| format!("{show}: not TOML: {e}"))?;
    let dial = doc.entry("dial").or_insert(Item::Table(Table::new()));
    if let Some(inline) = dial.as_inline_table() {
        // `dial = { path = [...] }` becomes a `[dial]` table (keyframes are tables).
        *dial = Item::Table(inline.clone().into_table());
    }
    let Some(dial) = dial.as_table_mut() else {
        return Err(format!("{show}: dial: is not a table"));
    };
    // The path as written (with a trailing comment), and the comment lines above it.
    let old_path = dial.remove_entry("path").map(|(key, item)| {
        let above = key.leaf_decor().prefix().and_then(|p| p.as_str()).unwrap_or("").trim_start_matches('\n');
        let above: String =
            above.lines().filter(|l| l.trim_start().starts_with('#')).map(|l| format!("{}\n", l.trim())).collect();
        (above, item.to_string().trim().to_string())
    });
    let frames = dial.entry("keyframes").or_insert(Item::ArrayOfTables(ArrayOfTables::new()));
    let Some(frames) = frames.as_array_of_tables_mut() else {
        return Err(format!("{show}: dial.keyframes: is not an array of tables"));
    };
    let first = frames.len();
    for k in keyframes {
        frames.push(keyframe_table(k));
    }
    if let (Some((above, value)), Some(t)) = (&old_path, frames.get_mut(first)) {
        // A path written over several lines is commented out line by line.
        let value: String = value.lines().map(|l| format!("\n# {}", l.trim_end())).collect();
        let value = value.trim_start_matches("\n# ");
        t.decor_mut().set_prefix(format!(
            "\n# Keyframes saved from the designer replace the dial's sweep, which was:\n{above}# path = {value}\n"
        ));
    }
    let total = frames.len();
    // The one atomic writer: the scene keeps its mode (and owner where permitted); a FIFO is refused.
    crate::fsio::write_atomic(path, doc.to_string().as_bytes()).map_err(|e| e.to_string())?;
    let note = if old_path.is_some() { " (the dial's path is kept as a comment)" } else { "" };
    Ok(format!("saved {} keyframes into {show}: {total} in all{note}", keyframes.len()))
}
