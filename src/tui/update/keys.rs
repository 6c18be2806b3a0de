//! The main screen's actions: one handler per group of keys (moves, cell edits, spectrum operations,
//! history, panels), each returning what it [`Wants`] done.

use crate::colorimetry::{Colorimetry, linear_to_hex, srgb_decode, srgb_encode};
use crate::palette::{Bounds, Kind, Palette, Source};
use crate::spectrum::{Normalize, Spectrum};
use crate::tui::action::{Action, Direction};
use crate::tui::app::{
    EditKey, Focus, PickItem, Popup, Prompt, PromptPurpose, SettingField, Slider, SpectrumOp, State, Target,
};
use crate::tui::edits::{self, EditError, EditResult};
use nalgebra::Vector3;

/// What an action asks of the loop besides the state change (turned into [`crate::tui::msg::Effect`]s by
/// [`super::update`], which knows the tickets and the files).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Wants {
    /// The palette changed: solve it again (cancelling any running solve).
    pub(crate) solve: bool,
    /// Write the palette to its file.
    pub(crate) save: bool,
    /// Quit once the save succeeded.
    pub(crate) quit_after_save: bool,
    /// Read the palette file again.
    pub(crate) reload: bool,
    /// Save the palette to this path, which becomes the palette file.
    pub(crate) save_as: Option<std::path::PathBuf>,
    /// Start the CSV import recorded in `state.doc.import`.
    pub(crate) import: bool,
}

impl Wants {
    pub(super) const NONE: Wants =
        Wants { solve: false, save: false, quit_after_save: false, reload: false, save_as: None, import: false };
    pub(super) const SOLVE: Wants = Wants { solve: true, ..Wants::NONE };
}

/// Slider steps in display sRGB eighths of a byte: one step is 1/255.
const SMALL_STEP: f64 = 1.0 / 255.0;
const BIG_STEP: f64 = 16.0 / 255.0;

/// Make an edit on a copy of the palette; keep it (with an undo step) when it succeeds and changed something.
/// A refused edit is shown in the message line.
pub(super) fn edit(state: &mut State, key: EditKey, f: impl FnOnce(&mut Palette, &Colorimetry) -> EditResult) -> Wants {
    try_edit(state, key, f).unwrap_or_else(|reason| {
        state.complain(reason.to_string());
        Wants::NONE
    })
}

/// Like [`edit`], but a refused edit is returned (for a prompt to show) and the state is left as it was.
pub(super) fn try_edit(
    state: &mut State,
    key: EditKey,
    f: impl FnOnce(&mut Palette, &Colorimetry) -> EditResult,
) -> Result<Wants, EditError> {
    let mut next = state.doc.palette.clone();
    f(&mut next, &state.colorimetry)?;
    if next == state.doc.palette {
        return Ok(Wants::NONE);
    }
    state.doc.remember(key);
    state.doc.palette = next;
    Ok(changed(state))
}

/// The palette changed (edit, undo, redo): new generation, new derived view, solve again.
pub(super) fn changed(state: &mut State) -> Wants {
    state.solve.generation += 1;
    state.clamp_selection();
    state.refresh();
    Wants::SOLVE
}

/// An action on the main screen: one handler per group of keys.
pub(super) fn update_main(state: &mut State, action: Action) -> Wants {
    if !matches!(action, Action::Move(_) | Action::BigStep { .. }) {
        state.doc.history.last_edit = None;
    }
    match action {
        Action::Move(_)
        | Action::BigStep { .. }
        | Action::FocusNext
        | Action::FocusPrev
        | Action::Activate
        | Action::Back => on_navigation(state, action),
        Action::HexEntry
        | Action::EditWeight
        | Action::ToggleUse
        | Action::AssignFree
        | Action::FreeBounds
        | Action::FitColour
        | Action::FitAll => on_cell(state, action),
        Action::ToggleDesign => spectrum_op(state, SpectrumOp::ToggleDesign),
        Action::NormaliseLuminance => spectrum_op(state, SpectrumOp::NormaliseLuminance),
        Action::NormaliseL2 => spectrum_op(state, SpectrumOp::NormaliseL2),
        Action::Scale => spectrum_op(state, SpectrumOp::Scale),
        Action::Remove => spectrum_op(state, SpectrumOp::Remove),
        Action::Planck => spectrum_op(state, SpectrumOp::Planck),
        Action::AddLight | Action::AddReflectance => on_add(state, action),
        Action::ToggleBounds
        | Action::ToggleFitInSubspace
        | Action::Undo
        | Action::Redo
        | Action::Save
        | Action::SaveAs
        | Action::Reload
        | Action::Quit => on_palette(state, action),
        Action::Help
        | Action::Diagnostics
        | Action::Feasibility
        | Action::Dial { .. }
        | Action::DialKeys
        | Action::TogglePreview => on_view(state, action),
        Action::DialSlide { .. }
        | Action::DialToggle(_)
        | Action::DialSelect { .. }
        | Action::DialIntensity { .. }
        | Action::DialKeyframe
        | Action::DialSaveScene
        | Action::DialLeave => {
            crate::tui::dial_keys::update(state, action);
            Wants::NONE
        }
        // Popup-only actions do nothing on the main screen.
        Action::Input(_)
        | Action::Backspace
        | Action::ClearInput
        | Action::Submit
        | Action::ChooseLight
        | Action::ChooseReflectance
        | Action::Discard
        | Action::SaveAndQuit => Wants::NONE,
    }
}

/// Moves, focus, Enter and Esc.
fn on_navigation(state: &mut State, action: Action) -> Wants {
    match action {
        Action::Move(d) => move_in_focus(state, d),
        Action::BigStep { up } => step_slider(state, if up { 1.0 } else { -1.0 }, true),
        Action::FocusNext | Action::FocusPrev => {
            let order = [Focus::Matrix, Focus::Sliders, Focus::Settings];
            let at = order.iter().position(|f| *f == state.ui.focus).unwrap_or(0);
            let step = if action == Action::FocusNext { 1 } else { order.len() - 1 };
            state.ui.focus = order[(at + step) % order.len()];
            if state.ui.focus == Focus::Sliders && !matches!(state.target(), Target::Cell { .. }) {
                state.ui.focus = order[(at + 2 * step) % order.len()];
            }
            Wants::NONE
        }
        Action::Activate => activate(state),
        _ => {
            if let Some(import) = state.doc.import.take() {
                state.say(format!("import of {} cancelled", crate::fsio::escape(&import.path)));
                return Wants::NONE;
            }
            state.ui.focus = Focus::Matrix;
            Wants::NONE
        }
    }
}

/// The selected cell's criterion: target, weight, use, free group, fits.
fn on_cell(state: &mut State, action: Action) -> Wants {
    match action {
        Action::HexEntry => with_cell(state, |state, light, reflectance| {
            let current = state.solve.derived.cell(light, reflectance).and_then(|c| c.desired).unwrap_or_default();
            open_prompt(
                state,
                "target colour",
                "#rrggbb (display sRGB)",
                linear_to_hex(&current),
                PromptPurpose::Hex { light, reflectance },
            )
        }),
        Action::EditWeight => with_cell(state, |state, light, reflectance| {
            let w = state.doc.palette.cell(light, reflectance).map_or(1.0, |c| c.weight);
            open_prompt(state, "weight", "a number ≥ 0", format!("{w}"), PromptPurpose::Weight { light, reflectance })
        }),
        Action::ToggleUse => with_cell(state, |state, light, reflectance| {
            let now = current_colour(state, light, reflectance);
            edit(state, EditKey::Other, |p, _| edits::toggle_use(p, light, reflectance, now))
        }),
        Action::AssignFree => with_cell(state, |state, light, reflectance| {
            let now = state.doc.palette.cell(light, reflectance).and_then(|c| c.free);
            let name = now.and_then(|g| state.doc.palette.free.get(g)).map(|g| g.name.clone()).unwrap_or_default();
            open_prompt(
                state,
                "free-colour group",
                "a group name such as A; empty: not free",
                name,
                PromptPurpose::FreeGroup { light, reflectance },
            )
        }),
        Action::FreeBounds => with_cell(state, free_bounds),
        Action::FitColour => with_cell(state, |state, light, reflectance| {
            let now = current_colour(state, light, reflectance);
            edit(state, EditKey::Other, |p, _| edits::set_target(p, light, reflectance, now))
        }),
        _ => {
            let fits: Vec<(usize, usize, Vector3<f64>)> = state
                .doc
                .palette
                .colours
                .iter()
                .filter(|c| c.free.is_none())
                .map(|c| (c.light, c.reflectance, current_colour(state, c.light, c.reflectance)))
                .collect();
            edit(state, EditKey::Other, |p, _| {
                fits.iter().try_for_each(|(l, r, rgb)| edits::set_target(p, *l, *r, *rgb))
            })
        }
    }
}

/// `b`: the bounds of the selected cell's free-colour group.
fn free_bounds(state: &mut State, light: usize, reflectance: usize) -> Wants {
    match state.doc.palette.cell(light, reflectance).and_then(|c| c.free) {
        None => {
            state.complain("this cell is in no free-colour group (press f first)");
            Wants::NONE
        }
        Some(group) => {
            let g = &state.doc.palette.free[group];
            let text =
                format!("{} {} {}  {} {} {}", g.lower[0], g.lower[1], g.lower[2], g.upper[0], g.upper[1], g.upper[2]);
            let title = format!("bounds of free group {}", g.name);
            open_prompt(
                state,
                &title,
                "lower upper, or lower r g b then upper r g b (linear sRGB)",
                text,
                PromptPurpose::FreeBounds { group },
            )
        }
    }
}

/// `L`, `R`: the list of what can be added.
fn on_add(state: &mut State, action: Action) -> Wants {
    let (kind, mut items): (Kind, Vec<PickItem>) = if action == Action::AddLight {
        (Kind::Light, Spectrum::illuminant_names().map(PickItem::Illuminant).collect())
    } else {
        (Kind::Reflectance, Spectrum::colorchecker_names().map(PickItem::ColorChecker).collect())
    };
    if kind == Kind::Light {
        items.push(PickItem::Planck);
        items.push(PickItem::Flat(1.0));
    } else {
        items.push(PickItem::Flat(0.5));
    }
    items.push(PickItem::Csv);
    state.ui.popup = Some(Popup::Pick { kind, items, selected: 0 });
    Wants::NONE
}

/// The palette as a whole: settings toggles, history, file, quit.
fn on_palette(state: &mut State, action: Action) -> Wants {
    match action {
        Action::ToggleBounds => toggle_bounds(state),
        Action::ToggleFitInSubspace => edit(state, EditKey::Other, |p, _| {
            p.settings.fit_in_subspace = !p.settings.fit_in_subspace;
            Ok(())
        }),
        Action::Undo | Action::Redo => {
            let undo = action == Action::Undo;
            let (from, to) = if undo {
                (&mut state.doc.history.undo, &mut state.doc.history.redo)
            } else {
                (&mut state.doc.history.redo, &mut state.doc.history.undo)
            };
            match from.pop() {
                None => {
                    state.say(if undo { "nothing to undo" } else { "nothing to redo" });
                    Wants::NONE
                }
                Some(other) => {
                    let now = std::mem::replace(&mut state.doc.palette, other);
                    to.push(now);
                    state.doc.history.last_edit = None;
                    state.say(if undo { "undone" } else { "redone" });
                    changed(state)
                }
            }
        }
        Action::Save => Wants { save: true, ..Wants::NONE },
        Action::SaveAs => {
            let now = state.path().display().to_string();
            state.ui.popup = Some(Popup::Prompt(super::replies::save_as_prompt(now, None)));
            Wants::NONE
        }
        Action::Reload => Wants { reload: true, ..Wants::NONE },
        _ => {
            if state.is_dirty() {
                state.ui.popup = Some(Popup::ConfirmQuit);
            } else {
                state.ui.quit = true;
            }
            Wants::NONE
        }
    }
}

/// Popups that only show, the mismatch overlay and the scene preview.
fn on_view(state: &mut State, action: Action) -> Wants {
    const NO_SCENE: &str = "no scene preview: start with --scene SCENE.toml";
    match action {
        Action::Help => state.ui.popup = Some(Popup::Help { scroll: 0 }),
        Action::Diagnostics => {
            if state.diagnostics().is_empty() {
                state.say("no diagnostics: every criterion is met");
            } else {
                state.ui.popup = Some(Popup::Diagnostics { scroll: 0 });
            }
        }
        Action::Feasibility => {
            state.ui.show_feasibility = !state.ui.show_feasibility;
            if state.ui.show_feasibility && state.feasibility_cell().is_none() {
                state.say("mismatch region: select a cell with a colour criterion");
            }
        }
        _ if !state.preview.has_scene() => state.complain(NO_SCENE),
        Action::Dial { forward } => {
            let p = &mut state.preview;
            p.shown = true;
            let scene = p.ready.as_ref().map(|r| r.scene.clone()).or_else(|| p.waiting.clone());
            if let (Some(scene), Some(dial)) = (scene, p.dial.as_mut()) {
                dial.step_along(&scene, forward);
            }
            state.relight();
        }
        Action::DialKeys => {
            state.preview.shown = true;
            state.preview.keys = true;
        }
        _ => state.preview.shown = !state.preview.shown,
    }
    Wants::NONE
}

/// The colour the cell has now (solved where solved), for fit colour and new criteria.
pub(super) fn current_colour(state: &State, light: usize, reflectance: usize) -> Vector3<f64> {
    state.solve.derived.cell(light, reflectance).map(|c| c.full).unwrap_or_default()
}

/// Run `f` on the selected cell, or say that a cell must be selected.
pub(super) fn with_cell(state: &mut State, f: impl FnOnce(&mut State, usize, usize) -> Wants) -> Wants {
    match state.target() {
        Target::Cell { light, reflectance } => f(state, light, reflectance),
        _ => {
            state.complain("select a cell of the matrix first");
            Wants::NONE
        }
    }
}

pub(super) fn open_prompt(state: &mut State, title: &str, hint: &str, input: String, purpose: PromptPurpose) -> Wants {
    state.ui.popup =
        Some(Popup::Prompt(Prompt { title: title.to_string(), hint: hint.to_string(), input, purpose, error: None }));
    Wants::NONE
}

fn move_in_focus(state: &mut State, d: Direction) -> Wants {
    match state.ui.focus {
        Focus::Matrix => {
            let (nl, nr) = (state.doc.palette.lights.len(), state.doc.palette.reflectances.len());
            let s = &mut state.ui.selection;
            match d {
                Direction::Up if s.row > 1 || (s.row == 1 && s.col > 0) => s.row -= 1,
                Direction::Down if s.row < nr => s.row += 1,
                Direction::Left if s.col > 1 || (s.col == 1 && s.row > 0) => s.col -= 1,
                Direction::Right if s.col < nl => s.col += 1,
                _ => {}
            }
            Wants::NONE
        }
        Focus::Sliders => match d {
            Direction::Up => {
                state.ui.slider = state.ui.slider.saturating_sub(1);
                Wants::NONE
            }
            Direction::Down => {
                state.ui.slider = (state.ui.slider + 1).min(Slider::ALL.len() - 1);
                Wants::NONE
            }
            Direction::Left => step_slider(state, -1.0, false),
            Direction::Right => step_slider(state, 1.0, false),
        },
        Focus::Settings => {
            match d {
                Direction::Left => state.ui.setting = state.ui.setting.saturating_sub(1),
                Direction::Right => state.ui.setting = (state.ui.setting + 1).min(SettingField::ALL.len() - 1),
                Direction::Up | Direction::Down => {}
            }
            Wants::NONE
        }
    }
}

/// Move the focused slider of the selected cell by one small or big step in direction `sign`.
fn step_slider(state: &mut State, sign: f64, big: bool) -> Wants {
    if state.ui.focus != Focus::Sliders {
        return Wants::NONE;
    }
    let Target::Cell { light, reflectance } = state.target() else {
        return Wants::NONE;
    };
    let slider = Slider::ALL[state.ui.slider.min(Slider::ALL.len() - 1)];
    let key = EditKey::Slider { light, reflectance, slider: state.ui.slider };
    let now = current_colour(state, light, reflectance);
    match slider {
        Slider::Weight => {
            let w = state.doc.palette.cell(light, reflectance).map_or(1.0, |c| c.weight);
            let step = if big { 1.0 } else { 0.1 };
            let next = ((w + sign * step) * 10.0).round() / 10.0;
            edit(state, key, |p, _| edits::set_weight(p, light, reflectance, next.max(0.0), now))
        }
        channel => {
            let k = match channel {
                Slider::Red => 0,
                Slider::Green => 1,
                _ => 2,
            };
            let target = state.doc.palette.cell(light, reflectance).map_or(now, |c| c.target);
            let display = srgb_encode(target[k]).clamp(0.0, 1.0);
            let step = if big { BIG_STEP } else { SMALL_STEP };
            let next = ((display + sign * step) * 255.0).round().clamp(0.0, 255.0) / 255.0;
            let mut rgb = target;
            rgb[k] = srgb_decode(next);
            edit(state, key, |p, _| edits::set_target(p, light, reflectance, rgb))
        }
    }
}

fn activate(state: &mut State) -> Wants {
    match state.ui.focus {
        Focus::Matrix => match state.target() {
            Target::Cell { .. } => {
                state.ui.focus = Focus::Sliders;
                Wants::NONE
            }
            Target::Light(_) | Target::Reflectance(_) => spectrum_op(state, SpectrumOp::ToggleDesign),
            Target::Nothing => Wants::NONE,
        },
        Focus::Sliders => {
            state.ui.focus = Focus::Matrix;
            Wants::NONE
        }
        Focus::Settings => {
            let field = SettingField::ALL[state.ui.setting.min(SettingField::ALL.len() - 1)];
            match field {
                SettingField::Bounds => toggle_bounds(state),
                SettingField::FitInSubspace => edit(state, EditKey::Other, |p, _| {
                    p.settings.fit_in_subspace = !p.settings.fit_in_subspace;
                    Ok(())
                }),
                other => {
                    let s = &state.doc.palette.settings;
                    let value = match other {
                        SettingField::ReflectanceLower => s.reflectance_bounds.lower.to_string(),
                        SettingField::ReflectanceUpper => s.reflectance_bounds.upper.to_string(),
                        SettingField::LightLower => s.light_bounds.lower.to_string(),
                        SettingField::LightUpper => s.light_bounds.upper.to_string(),
                        SettingField::Smoothness => s.smoothness.to_string(),
                        SettingField::SubspaceError => s.subspace_error.to_string(),
                        _ => s.basis_dimension.to_string(),
                    };
                    let (title, hint) = setting_prompt_text(other);
                    open_prompt(state, title, hint, value, PromptPurpose::Setting(other))
                }
            }
        }
    }
}

fn setting_prompt_text(field: SettingField) -> (&'static str, &'static str) {
    match field {
        SettingField::ReflectanceLower => ("lower bound of designed reflectances", "a number or -inf"),
        SettingField::ReflectanceUpper => ("upper bound of designed reflectances", "a number or inf"),
        SettingField::LightLower => ("lower bound of designed lights", "a number or -inf"),
        SettingField::LightUpper => ("upper bound of designed lights", "a number or inf"),
        SettingField::Smoothness => ("smoothness weight ω_D", "a number ≥ 0 (0.001 is a good start)"),
        SettingField::SubspaceError => ("subspace-error weight ω_F", "a number ≥ 0 (0.1 is a good start)"),
        SettingField::BasisDimension => ("basis dimension m", "an integer from 1 to 31"),
        SettingField::Bounds | SettingField::FitInSubspace => ("", ""),
    }
}

fn toggle_bounds(state: &mut State) -> Wants {
    if state.doc.palette.settings.bounded() {
        let s = &state.doc.palette.settings;
        state.doc.remembered_bounds = (s.reflectance_bounds, s.light_bounds);
        edit(state, EditKey::Other, |p, _| {
            p.settings.reflectance_bounds = Bounds::UNBOUNDED;
            p.settings.light_bounds = Bounds::UNBOUNDED;
            Ok(())
        })
    } else {
        let (r, l) = state.doc.remembered_bounds;
        edit(state, EditKey::Other, |p, _| {
            p.settings.reflectance_bounds = r;
            p.settings.light_bounds = l;
            Ok(())
        })
    }
}

/// A spectrum operation on the selection: direct on a swatch, a choice on a cell (Planck: the cell's light).
fn spectrum_op(state: &mut State, op: SpectrumOp) -> Wants {
    match state.target() {
        Target::Light(l) => apply_spectrum_op(state, op, Kind::Light, l),
        Target::Reflectance(r) => apply_spectrum_op(state, op, Kind::Reflectance, r),
        Target::Cell { light, .. } if matches!(op, SpectrumOp::Planck | SpectrumOp::NormaliseL2) => {
            apply_spectrum_op(state, op, Kind::Light, light)
        }
        Target::Cell { light, .. } if op == SpectrumOp::NormaliseLuminance => {
            apply_spectrum_op(state, op, Kind::Light, light)
        }
        Target::Cell { light, reflectance } => {
            state.ui.popup = Some(Popup::ChooseSpectrum { op, light, reflectance });
            Wants::NONE
        }
        Target::Nothing => {
            state.complain("the palette is empty: add a light (L) or a reflectance (R)");
            Wants::NONE
        }
    }
}

pub(super) fn apply_spectrum_op(state: &mut State, op: SpectrumOp, kind: Kind, index: usize) -> Wants {
    let Some(name) = state.doc.palette.entries(kind).get(index).map(|e| e.name.clone()) else {
        return Wants::NONE;
    };
    match op {
        SpectrumOp::ToggleDesign => edit(state, EditKey::Other, |p, _| edits::toggle_design(p, kind, index)),
        SpectrumOp::NormaliseLuminance | SpectrumOp::NormaliseL2 if kind == Kind::Reflectance => {
            state.complain("reflectances are never normalised; scale them instead (s)");
            Wants::NONE
        }
        SpectrumOp::NormaliseLuminance => {
            edit(state, EditKey::Other, |p, c| edits::normalise(p, index, Normalize::Luminance, c))
        }
        SpectrumOp::NormaliseL2 => edit(state, EditKey::Other, |p, c| edits::normalise(p, index, Normalize::L2, c)),
        SpectrumOp::Planck if kind == Kind::Reflectance => {
            state.complain("Planck black bodies are lights: select a light");
            Wants::NONE
        }
        SpectrumOp::Planck => {
            let t = match state.doc.palette.lights[index].source {
                Source::Planck(t) => t,
                _ => 6500.0,
            };
            let title = format!("make {name} a Planck black body");
            open_prompt(state, &title, "temperature in kelvin", format!("{t}"), PromptPurpose::Planck { light: index })
        }
        SpectrumOp::Scale => {
            let title = format!("scale of {name}");
            let now = super::prompt::num_text(state.doc.palette.entries(kind)[index].scale);
            let hint = if kind == Kind::Light {
                "spectrum = normalised source × scale"
            } else {
                "spectrum = source × scale"
            };
            open_prompt(state, &title, hint, now, PromptPurpose::Scale { kind, index })
        }
        SpectrumOp::Remove => {
            let effects = edit(state, EditKey::Other, |p, _| edits::remove(p, kind, index));
            if effects.solve {
                state.say(format!("removed {} {name} (z undoes)", kind.as_str()));
            }
            effects
        }
    }
}
