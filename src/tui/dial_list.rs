//! The criteria along the light dial (`M`): every `[[mixtures]]` and `[[paths]]` entry of the palette, with
//! its target, its solved colours and errors ([`crate::tui::dial_results`]) and its status, and the edits
//! of the selected one — target (`#`, or `F` the colour it has now), weight, use, free group, a path's
//! samples and tolerance, delete — each an undo step of the document. `m` in the light dial adds a
//! target for the selected reflectance at the slider ([`add_at_slider`]). A popup component: its state and
//! update here, its keys in [`crate::tui::keymap::DIAL_LIST`], its view in `ui/dial_list.rs`.

use crate::colorimetry::{Colorimetry, hex_to_linear, linear_to_hex};
use crate::palette::mixing::{dial_lights, light_of};
use crate::palette::{DialEntry, MixSpec, Palette, Route};
use crate::tui::action::{Action, Direction};
use crate::tui::app::{EditKey, Popup, PromptPurpose, Target};
use crate::tui::edits::{EditError, EditResult};
use crate::tui::model::{Document, PreviewState, SolveState, UiState};
use nalgebra::Vector3;

/// The list's state: which entry is selected (mixtures first, then paths).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DialList {
    pub selected: usize,
}

impl DialList {
    /// The selected entry of `palette`, if it has any.
    pub fn entry(&self, palette: &Palette) -> Option<DialEntry> {
        let entries = palette.dial_entries();
        entries.get(self.selected.min(entries.len().saturating_sub(1))).copied()
    }
}

/// Which value of an entry a prompt edits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DialField {
    Target,
    Weight,
    Free,
    Samples,
    Tolerance,
}

/// A prompt's answer for an entry of the list (the list opens again after it).
#[derive(Clone, Debug, PartialEq)]
pub struct DialPrompt {
    pub(crate) entry: DialEntry,
    pub(crate) field: DialField,
    pub(crate) list: DialList,
}

fn num(x: f64) -> String {
    let r = (x * 1e3).round() / 1e3;
    if r == 0.0 { "0".into() } else { format!("{r}") }
}

fn off_text(p: &Palette, off: &[usize]) -> String {
    if off.is_empty() {
        return String::new();
    }
    let names: Vec<&str> = off.iter().filter_map(|&i| p.lights.get(i)).map(|l| l.name.as_str()).collect();
    format!(" (off: {})", names.join(", "))
}

/// An entry as the list names it: `petal × dial [0.45, 0.6] (off: lamp)`, `petal × mix {daylight 0.5,
/// lamp 0.5}` or `leaf along daylight → reveal (off: lamp) (9 samples, tol 1.0)`.
pub fn label(p: &Palette, entry: DialEntry) -> String {
    let refl = |r: usize| p.reflectances.get(r).map_or("?", |e| e.name.as_str());
    let light = |i: usize| p.lights.get(i).map_or("?", |e| e.name.as_str());
    match entry {
        DialEntry::Mixture(k) => {
            let Some(m) = p.mixtures.get(k) else { return String::new() };
            match &m.spec {
                MixSpec::Dial { at, off } => {
                    format!(
                        "{} × dial [{}, {}]{}",
                        refl(m.reflectance),
                        num(at[0]),
                        num(at[1]),
                        off_text(p, off.as_slice())
                    )
                }
                MixSpec::Weights => {
                    let parts: Vec<String> = m.mix.iter().map(|&(i, w)| format!("{} {}", light(i), num(w))).collect();
                    format!("{} × mix {{{}}}", refl(m.reflectance), parts.join(", "))
                }
            }
        }
        DialEntry::Path(k) => {
            let Some(q) = p.paths.get(k) else { return String::new() };
            let (points, off) = match q.route() {
                Route::Lights(order) => {
                    (order.iter().map(|&i| light(i).to_string()).collect::<Vec<_>>(), String::new())
                }
                Route::Dial { through, off } => {
                    let vertices = dial_lights(&p.lights);
                    let name = |pt: &[f64; 2]| {
                        vertices
                            .iter()
                            .find(|l| l.position == *pt)
                            .map(|l| l.name.clone())
                            .unwrap_or_else(|| format!("[{}, {}]", num(pt[0]), num(pt[1])))
                    };
                    (through.iter().map(name).collect(), off_text(p, off))
                }
            };
            format!(
                "{} along {}{} ({} samples, tol {})",
                refl(q.reflectance),
                points.join(" → "),
                off,
                q.samples,
                num(q.tolerance)
            )
        }
    }
}

/// What an action in the list did: handled (the list stays or closed itself), or an action for the main
/// screen (undo, redo, save…), the list put back first.
pub(crate) enum Outcome {
    Done,
    Main(Action),
}

/// An action while the list is open.
pub(crate) fn on_action(
    doc: &mut Document,
    ui: &mut UiState,
    solve: &SolveState,
    c: &Colorimetry,
    mut list: DialList,
    action: Action,
) -> Outcome {
    let count = doc.palette.dial_entries().len();
    list.selected = list.selected.min(count.saturating_sub(1));
    let entry = list.entry(&doc.palette);
    let reopen = |ui: &mut UiState, list: DialList| ui.popup = Some(Popup::DialList(list));
    match action {
        Action::Back | Action::DialList => return Outcome::Done,
        Action::Move(Direction::Up) => list.selected = list.selected.saturating_sub(1),
        Action::Move(Direction::Down) => list.selected = (list.selected + 1).min(count.saturating_sub(1)),
        Action::Undo | Action::Redo | Action::Save | Action::SaveAs | Action::Quit | Action::Help => {
            reopen(ui, list);
            return Outcome::Main(action);
        }
        _ => {}
    }
    let Some(entry) = entry else {
        reopen(ui, list);
        return Outcome::Done;
    };
    let p = &doc.palette;
    let name = label(p, entry);
    let (target, weight, free, enabled) = match entry {
        DialEntry::Mixture(k) => {
            let m = &p.mixtures[k];
            (m.target, m.weight, m.free, m.enabled)
        }
        DialEntry::Path(k) => {
            let q = &p.paths[k];
            (q.target, q.weight, q.free, q.enabled)
        }
    };
    let prompt = |ui: &mut UiState, field: DialField, title: String, hint: &str, input: String| {
        ui.open_prompt(&title, hint, input, PromptPurpose::Dial(DialPrompt { entry, field, list: list.clone() }))
    };
    match action {
        Action::HexEntry => {
            prompt(
                ui,
                DialField::Target,
                format!("target of {name}"),
                "#rrggbb (display sRGB)",
                linear_to_hex(&target),
            );
            return Outcome::Done;
        }
        Action::EditWeight => {
            prompt(
                ui,
                DialField::Weight,
                format!("weight of {name}"),
                "a number ≥ 0 (0 leaves it out of the design)",
                format!("{weight}"),
            );
            return Outcome::Done;
        }
        Action::AssignFree => {
            let now = free.and_then(|g| p.free.get(g)).map(|g| g.name.clone()).unwrap_or_default();
            prompt(
                ui,
                DialField::Free,
                format!("free-colour group of {name}"),
                "a group name (new: bounds [0, 1]); empty: its own target",
                now,
            );
            return Outcome::Done;
        }
        Action::DialSamples | Action::DialTolerance => match entry {
            DialEntry::Path(k) => {
                let q = &p.paths[k];
                if action == Action::DialSamples {
                    prompt(
                        ui,
                        DialField::Samples,
                        format!("design samples of {name}"),
                        "positions the design uses along the path, 2 to 1024",
                        q.samples.to_string(),
                    )
                } else {
                    prompt(
                        ui,
                        DialField::Tolerance,
                        format!("tolerance of {name}"),
                        "the largest ΔE00 allowed anywhere along the path, > 0",
                        format!("{}", q.tolerance),
                    )
                }
                return Outcome::Done;
            }
            DialEntry::Mixture(_) => ui.complain("samples and tolerance are a path's: select a path"),
        },
        Action::ToggleUse if edit(doc, ui, c, |p, _| set(p.set_dial_enabled(entry, !enabled))) => {
            ui.say(format!("{name}: {}", if enabled { "not used (kept in the file)" } else { "in use" }));
        }
        Action::FitColour => match solved_colour(solve, entry) {
            Some(rgb) => {
                if edit(doc, ui, c, |p, _| set(p.set_dial_target(entry, rgb))) {
                    ui.say(format!("{name}: target := its colour now {} (z undoes)", linear_to_hex(&rgb)));
                }
            }
            None => ui.complain("not solved yet: wait for the solve, then F takes its colour"),
        },
        Action::Remove if edit(doc, ui, c, |p, _| set(p.remove_dial_entry(entry))) => {
            ui.say(format!("deleted {name} (z undoes)"));
            list.selected = list.selected.min(count.saturating_sub(2));
        }
        _ => {}
    }
    reopen(ui, list);
    Outcome::Done
}

/// Make an edit of the document (an undo step); a refusal is shown in the message line.
fn edit(
    doc: &mut Document,
    ui: &mut UiState,
    c: &Colorimetry,
    f: impl FnOnce(&mut Palette, &Colorimetry) -> EditResult,
) -> bool {
    doc.edit(EditKey::Other, c, f).unwrap_or_else(|reason| {
        ui.complain(reason.to_string());
        false
    })
}

fn set(r: Result<(), crate::palette::EditError>) -> EditResult {
    r.map_err(EditError::Palette)
}

/// The full colour the solve gives an entry (a path's at its worst position), when solved.
fn solved_colour(solve: &SolveState, entry: DialEntry) -> Option<Vector3<f64>> {
    match entry {
        DialEntry::Mixture(k) => solve.dial.mixtures.get(k).map(|r| r.rgb_full),
        DialEntry::Path(k) => solve.dial.paths.get(k).map(|r| r.worst_rgb),
    }
}

/// A submitted prompt for an entry: the edit made and the list open again, or the reason.
pub(crate) fn submit(doc: &mut Document, ui: &mut UiState, c: &Colorimetry, p: DialPrompt, input: &str) -> EditResult {
    let entry = p.entry;
    let number = |t: &str| t.trim().parse::<f64>().ok().filter(|v| !v.is_nan());
    let result = match p.field {
        DialField::Target => {
            let hex = if input.starts_with('#') { input.to_string() } else { format!("#{input}") };
            let rgb = hex_to_linear(&hex).ok_or_else(|| EditError::NotHex(input.to_string()))?;
            doc.edit(EditKey::Other, c, |pal, _| set(pal.set_dial_target(entry, rgb)))
        }
        DialField::Weight => {
            let w = number(input).ok_or_else(|| EditError::NotANumber(input.to_string()))?;
            doc.edit(EditKey::Other, c, |pal, _| set(pal.set_dial_weight(entry, w)))
        }
        DialField::Free => {
            let name = input.trim().to_string();
            doc.edit(EditKey::Other, c, |pal, _| {
                if name.is_empty() {
                    return set(pal.set_dial_free(entry, None));
                }
                if name.chars().any(|ch| ch.is_whitespace() || ch.is_control() || ch == '"') {
                    return Err(EditError::GroupName(name.clone()));
                }
                let g = match pal.free.iter().position(|g| g.name == name) {
                    Some(g) => g,
                    None => pal.add_free_group(&name, Vector3::zeros(), Vector3::repeat(1.0))?,
                };
                set(pal.set_dial_free(entry, Some(g)))
            })
        }
        DialField::Samples => {
            let n = input.trim().parse::<usize>().map_err(|_| EditError::NotANumber(input.to_string()))?;
            let DialEntry::Path(k) = entry else { return Ok(()) };
            doc.edit(EditKey::Other, c, |pal, _| set(pal.set_path_samples(k, n)))
        }
        DialField::Tolerance => {
            let t = number(input).ok_or_else(|| EditError::NotANumber(input.to_string()))?;
            let DialEntry::Path(k) = entry else { return Ok(()) };
            doc.edit(EditKey::Other, c, |pal, _| set(pal.set_path_tolerance(k, t)))
        }
    };
    result?;
    ui.popup = Some(Popup::DialList(p.list));
    Ok(())
}

/// `m` in the light dial: a target for the selected reflectance (the matrix's cell or swatch) under the
/// light the live dial gives now — the palette's own dial position (`dial = [x, y]`, the lights switched
/// off as `off`) when the live dial is the palette's (same lights at the same vertices, intensity 1), else
/// the live dial's weights as explicit weights — its target the colour it has there now (the shown,
/// solved spectra), so the user then edits it. The new entry is selected in the list, which opens.
pub(crate) fn add_at_slider(
    doc: &mut Document,
    ui: &mut UiState,
    solve: &SolveState,
    preview: &PreviewState,
    c: &Colorimetry,
) {
    let Some(dial) = preview.dial_state() else {
        return ui.complain(crate::tui::model::NO_SCENE);
    };
    let reflectance = match ui.target(&doc.palette) {
        Target::Cell { reflectance, .. } | Target::Reflectance(reflectance) => reflectance,
        _ => return ui.complain("select a reflectance first (a cell of its row, or its swatch)"),
    };
    let p = &doc.palette;
    let index = |name: &str| p.lights.iter().position(|l| l.name == name);
    let vertices = dial_lights(&p.lights);
    let is_palettes = dial.fixed_weights.is_none()
        && dial.lights.len() == p.lights.len()
        && dial
            .lights
            .iter()
            .all(|l| index(&l.name).is_some_and(|i| vertices[i].position == l.position) && l.intensity == 1.0)
        && p.lights.iter().any(|l| l.dial.is_some());
    let weights = dial.weights();
    let mut mix = Vec::new();
    for (l, w) in dial.lights.iter().zip(&weights) {
        if *w > 0.0 && l.intensity > 0.0 {
            match index(&l.name) {
                Some(i) => mix.push((i, w * l.intensity)),
                None => {
                    return ui.complain(format!(
                        "light {} of the scene's dial is not in the palette: a target here cannot be designed",
                        l.name
                    ));
                }
            }
        }
    }
    let off: Vec<usize> = dial.lights.iter().filter(|l| !l.on).filter_map(|l| index(&l.name)).collect();
    let slider = dial.slider;
    let lights = solve.derived.light_spectra.clone();
    let Some(s) = solve.derived.reflectance_spectra.get(reflectance).copied() else { return };
    let mut added = None;
    let changed = edit(doc, ui, c, |pal, c| {
        let k = if is_palettes {
            pal.add_dial_mixture(reflectance, slider, off, Vector3::zeros())
        } else {
            pal.add_weighted_mixture(reflectance, &mix, Vector3::zeros())
        }
        .map_err(EditError::Palette)?;
        let rgb = c.rgb(&light_of(&pal.mixtures[k].mix, &lights), &s);
        added = Some(k);
        set(pal.set_dial_target(DialEntry::Mixture(k), rgb))
    });
    if let (true, Some(k)) = (changed, added) {
        let name = label(&doc.palette, DialEntry::Mixture(k));
        let rgb = doc.palette.mixtures[k].target;
        ui.say(format!("added {name}, target its colour now {} (# edits it, z undoes)", linear_to_hex(&rgb)));
        ui.popup = Some(Popup::DialList(DialList { selected: k }));
    }
}
