//! The update step: apply one [`Action`] to the [`State`] and say which side effects (a solve, a save)
//! the event loop must run. Nothing here draws or blocks.

use crate::colorimetry::{Colorimetry, hex_to_linear, linear_to_hex, srgb_decode, srgb_encode};
use crate::palette::{Bounds, Kind, Palette, Source};
use crate::spectrum::{Normalize, Spectrum};
use crate::tui::action::{Action, Direction};
use crate::tui::app::{
    EditKey, Focus, PickItem, Popup, Prompt, PromptPurpose, SettingField, Slider, SpectrumOp, State, Target,
};
use crate::tui::edits::{self, EditResult};
use nalgebra::Vector3;

/// Side effects the event loop runs after an update.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Effects {
    /// The palette changed: solve it again (cancelling any running solve).
    pub solve: bool,
    /// Write the palette to its file.
    pub save: bool,
    /// Quit once the save succeeded.
    pub quit_after_save: bool,
    /// Read the palette file again.
    pub reload: bool,
}

impl Effects {
    const NONE: Effects = Effects { solve: false, save: false, quit_after_save: false, reload: false };
    const SOLVE: Effects = Effects { solve: true, save: false, quit_after_save: false, reload: false };
}

/// Slider steps in display sRGB eighths of a byte: one step is 1/255.
const SMALL_STEP: f64 = 1.0 / 255.0;
const BIG_STEP: f64 = 16.0 / 255.0;

/// Apply one action.
pub fn update(state: &mut State, action: Action) -> Effects {
    state.message = None;
    let wanted = state.feasibility_cell();
    let mut effects = match state.popup.take() {
        Some(popup) => update_popup(state, popup, action),
        None => update_main(state, action),
    };
    // The mismatch-region overlay follows the selection: a new cell needs its region computed.
    let now = state.feasibility_cell();
    if now.is_some() && now != wanted {
        effects.solve = true;
    }
    effects
}

/// Make an edit on a copy of the palette; keep it (with an undo step) when it succeeds and changed something.
fn edit(state: &mut State, key: EditKey, f: impl FnOnce(&mut Palette, &Colorimetry) -> EditResult) -> Effects {
    let mut next = state.palette.clone();
    match f(&mut next, &state.colorimetry) {
        Err(reason) => {
            state.complain(reason);
            Effects::NONE
        }
        Ok(()) if next == state.palette => Effects::NONE,
        Ok(()) => {
            state.remember(key);
            state.palette = next;
            changed(state)
        }
    }
}

/// The palette changed (edit, undo, redo): new generation, new derived view, solve again.
fn changed(state: &mut State) -> Effects {
    state.solve.generation += 1;
    state.clamp_selection();
    state.refresh();
    Effects::SOLVE
}

fn update_main(state: &mut State, action: Action) -> Effects {
    if !matches!(action, Action::Move(_) | Action::BigStep { .. }) {
        state.history.last_edit = None;
    }
    match action {
        Action::Move(d) => move_in_focus(state, d),
        Action::BigStep { up } => step_slider(state, if up { 1.0 } else { -1.0 }, true),
        Action::FocusNext | Action::FocusPrev => {
            let order = [Focus::Matrix, Focus::Sliders, Focus::Settings];
            let at = order.iter().position(|f| *f == state.focus).unwrap_or(0);
            let step = if action == Action::FocusNext { 1 } else { order.len() - 1 };
            state.focus = order[(at + step) % order.len()];
            if state.focus == Focus::Sliders && !matches!(state.target(), Target::Cell { .. }) {
                state.focus = order[(at + 2 * step) % order.len()];
            }
            Effects::NONE
        }
        Action::Activate => activate(state),
        Action::Back => {
            if let Some(import) = state.import.take() {
                state.say(format!("import of {} cancelled", crate::fsio::escape(&import.path)));
                return Effects::NONE;
            }
            state.focus = Focus::Matrix;
            Effects::NONE
        }
        Action::HexEntry => with_cell(state, |state, light, reflectance| {
            let current = state.derived.cell(light, reflectance).and_then(|c| c.desired).unwrap_or_default();
            open_prompt(
                state,
                "target colour",
                "#rrggbb (display sRGB)",
                linear_to_hex(&current),
                PromptPurpose::Hex { light, reflectance },
            )
        }),
        Action::EditWeight => with_cell(state, |state, light, reflectance| {
            let w = state.palette.cell(light, reflectance).map_or(1.0, |c| c.weight);
            open_prompt(state, "weight", "a number ≥ 0", format!("{w}"), PromptPurpose::Weight { light, reflectance })
        }),
        Action::ToggleDesign => spectrum_op(state, SpectrumOp::ToggleDesign),
        Action::NormaliseLuminance => spectrum_op(state, SpectrumOp::NormaliseLuminance),
        Action::NormaliseL2 => spectrum_op(state, SpectrumOp::NormaliseL2),
        Action::Scale => spectrum_op(state, SpectrumOp::Scale),
        Action::Remove => spectrum_op(state, SpectrumOp::Remove),
        Action::Planck => spectrum_op(state, SpectrumOp::Planck),
        Action::ToggleUse => with_cell(state, |state, light, reflectance| {
            let now = current_colour(state, light, reflectance);
            edit(state, EditKey::Other, |p, _| edits::toggle_use(p, light, reflectance, now))
        }),
        Action::AssignFree => with_cell(state, |state, light, reflectance| {
            let now = state.palette.cell(light, reflectance).and_then(|c| c.free);
            let name = now.and_then(|g| state.palette.free.get(g)).map(|g| g.name.clone()).unwrap_or_default();
            open_prompt(
                state,
                "free-colour group",
                "a group name such as A; empty: not free",
                name,
                PromptPurpose::FreeGroup { light, reflectance },
            )
        }),
        Action::FreeBounds => with_cell(state, |state, light, reflectance| {
            match state.palette.cell(light, reflectance).and_then(|c| c.free) {
                None => {
                    state.complain("this cell is in no free-colour group (press f first)");
                    Effects::NONE
                }
                Some(group) => {
                    let g = &state.palette.free[group];
                    let text = format!(
                        "{} {} {}  {} {} {}",
                        g.lower[0], g.lower[1], g.lower[2], g.upper[0], g.upper[1], g.upper[2]
                    );
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
        }),
        Action::FitColour => with_cell(state, |state, light, reflectance| {
            let now = current_colour(state, light, reflectance);
            edit(state, EditKey::Other, |p, _| edits::set_target(p, light, reflectance, now))
        }),
        Action::FitAll => {
            let fits: Vec<(usize, usize, Vector3<f64>)> = state
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
        Action::AddLight => {
            let mut items: Vec<PickItem> = Spectrum::illuminant_names().map(PickItem::Illuminant).collect();
            items.push(PickItem::Planck);
            items.push(PickItem::Flat(1.0));
            items.push(PickItem::Csv);
            state.popup = Some(Popup::Pick { kind: Kind::Light, items, selected: 0 });
            Effects::NONE
        }
        Action::AddReflectance => {
            let mut items: Vec<PickItem> = Spectrum::colorchecker_names().map(PickItem::ColorChecker).collect();
            items.push(PickItem::Flat(0.5));
            items.push(PickItem::Csv);
            state.popup = Some(Popup::Pick { kind: Kind::Reflectance, items, selected: 0 });
            Effects::NONE
        }
        Action::ToggleBounds => toggle_bounds(state),
        Action::ToggleFitInSubspace => edit(state, EditKey::Other, |p, _| {
            p.settings.fit_in_subspace = !p.settings.fit_in_subspace;
            Ok(())
        }),
        Action::Undo => match state.history.undo.pop() {
            None => {
                state.say("nothing to undo");
                Effects::NONE
            }
            Some(previous) => {
                let now = std::mem::replace(&mut state.palette, previous);
                state.history.redo.push(now);
                state.history.last_edit = None;
                state.say("undone");
                changed(state)
            }
        },
        Action::Redo => match state.history.redo.pop() {
            None => {
                state.say("nothing to redo");
                Effects::NONE
            }
            Some(next) => {
                let now = std::mem::replace(&mut state.palette, next);
                state.history.undo.push(now);
                state.history.last_edit = None;
                state.say("redone");
                changed(state)
            }
        },
        Action::Save => Effects { save: true, ..Effects::NONE },
        Action::Reload => Effects { reload: true, ..Effects::NONE },
        Action::Help => {
            state.popup = Some(Popup::Help { scroll: 0 });
            Effects::NONE
        }
        Action::Feasibility => {
            state.show_feasibility = !state.show_feasibility;
            if state.show_feasibility && state.feasibility_cell().is_none() {
                state.say("mismatch region: select a cell with a colour criterion");
            }
            Effects::NONE
        }
        Action::Dial { forward } => {
            if !state.has_scene() {
                state.complain("no scene preview: start with --scene SCENE.toml");
            } else {
                let step = if forward { 0.05 } else { -0.05 };
                state.dial = ((state.dial + step) * 20.0).round().clamp(0.0, 20.0) / 20.0;
                state.show_preview = true;
                state.dial_state = state.scene().map(|s| s.dial.state_at(state.dial));
                state.relight();
            }
            Effects::NONE
        }
        Action::DialKeys => {
            if !state.has_scene() {
                state.complain("no scene preview: start with --scene SCENE.toml");
            } else {
                state.show_preview = true;
                state.dial_keys = true;
            }
            Effects::NONE
        }
        Action::DialSlide { .. }
        | Action::DialToggle(_)
        | Action::DialSelect { .. }
        | Action::DialIntensity { .. }
        | Action::DialKeyframe
        | Action::DialSaveScene
        | Action::DialLeave => {
            crate::tui::dial_keys::update(state, action);
            Effects::NONE
        }
        Action::TogglePreview => {
            if !state.has_scene() {
                state.complain("no scene preview: start with --scene SCENE.toml");
            } else {
                state.show_preview = !state.show_preview;
            }
            Effects::NONE
        }
        Action::Diagnostics => {
            if state.diagnostics().is_empty() {
                state.say("no diagnostics: every criterion is met");
            } else {
                state.popup = Some(Popup::Diagnostics { scroll: 0 });
            }
            Effects::NONE
        }
        Action::Quit => {
            if state.is_dirty() {
                state.popup = Some(Popup::ConfirmQuit);
            } else {
                state.quit = true;
            }
            Effects::NONE
        }
        // Popup-only actions do nothing on the main screen.
        Action::Input(_)
        | Action::Backspace
        | Action::ClearInput
        | Action::Submit
        | Action::ChooseLight
        | Action::ChooseReflectance
        | Action::Discard
        | Action::SaveAndQuit => Effects::NONE,
    }
}

/// The colour the cell has now (solved where solved), for fit colour and new criteria.
fn current_colour(state: &State, light: usize, reflectance: usize) -> Vector3<f64> {
    state.derived.cell(light, reflectance).map(|c| c.full).unwrap_or_default()
}

/// Run `f` on the selected cell, or say that a cell must be selected.
fn with_cell(state: &mut State, f: impl FnOnce(&mut State, usize, usize) -> Effects) -> Effects {
    match state.target() {
        Target::Cell { light, reflectance } => f(state, light, reflectance),
        _ => {
            state.complain("select a cell of the matrix first");
            Effects::NONE
        }
    }
}

fn open_prompt(state: &mut State, title: &str, hint: &str, input: String, purpose: PromptPurpose) -> Effects {
    state.popup =
        Some(Popup::Prompt(Prompt { title: title.to_string(), hint: hint.to_string(), input, purpose, error: None }));
    Effects::NONE
}

fn move_in_focus(state: &mut State, d: Direction) -> Effects {
    match state.focus {
        Focus::Matrix => {
            let (nl, nr) = (state.palette.lights.len(), state.palette.reflectances.len());
            let s = &mut state.selection;
            match d {
                Direction::Up if s.row > 1 || (s.row == 1 && s.col > 0) => s.row -= 1,
                Direction::Down if s.row < nr => s.row += 1,
                Direction::Left if s.col > 1 || (s.col == 1 && s.row > 0) => s.col -= 1,
                Direction::Right if s.col < nl => s.col += 1,
                _ => {}
            }
            Effects::NONE
        }
        Focus::Sliders => match d {
            Direction::Up => {
                state.slider = state.slider.saturating_sub(1);
                Effects::NONE
            }
            Direction::Down => {
                state.slider = (state.slider + 1).min(Slider::ALL.len() - 1);
                Effects::NONE
            }
            Direction::Left => step_slider(state, -1.0, false),
            Direction::Right => step_slider(state, 1.0, false),
        },
        Focus::Settings => {
            match d {
                Direction::Left => state.setting = state.setting.saturating_sub(1),
                Direction::Right => state.setting = (state.setting + 1).min(SettingField::ALL.len() - 1),
                Direction::Up | Direction::Down => {}
            }
            Effects::NONE
        }
    }
}

/// Move the focused slider of the selected cell by one small or big step in direction `sign`.
fn step_slider(state: &mut State, sign: f64, big: bool) -> Effects {
    if state.focus != Focus::Sliders {
        return Effects::NONE;
    }
    let Target::Cell { light, reflectance } = state.target() else {
        return Effects::NONE;
    };
    let slider = Slider::ALL[state.slider.min(Slider::ALL.len() - 1)];
    let key = EditKey::Slider { light, reflectance, slider: state.slider };
    let now = current_colour(state, light, reflectance);
    match slider {
        Slider::Weight => {
            let w = state.palette.cell(light, reflectance).map_or(1.0, |c| c.weight);
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
            let target = state.palette.cell(light, reflectance).map_or(now, |c| c.target);
            let display = srgb_encode(target[k]).clamp(0.0, 1.0);
            let step = if big { BIG_STEP } else { SMALL_STEP };
            let next = ((display + sign * step) * 255.0).round().clamp(0.0, 255.0) / 255.0;
            let mut rgb = target;
            rgb[k] = srgb_decode(next);
            edit(state, key, |p, _| edits::set_target(p, light, reflectance, rgb))
        }
    }
}

fn activate(state: &mut State) -> Effects {
    match state.focus {
        Focus::Matrix => match state.target() {
            Target::Cell { .. } => {
                state.focus = Focus::Sliders;
                Effects::NONE
            }
            Target::Light(_) | Target::Reflectance(_) => spectrum_op(state, SpectrumOp::ToggleDesign),
            Target::Nothing => Effects::NONE,
        },
        Focus::Sliders => {
            state.focus = Focus::Matrix;
            Effects::NONE
        }
        Focus::Settings => {
            let field = SettingField::ALL[state.setting.min(SettingField::ALL.len() - 1)];
            match field {
                SettingField::Bounds => toggle_bounds(state),
                SettingField::FitInSubspace => edit(state, EditKey::Other, |p, _| {
                    p.settings.fit_in_subspace = !p.settings.fit_in_subspace;
                    Ok(())
                }),
                other => {
                    let s = &state.palette.settings;
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

/// True when any bound is set.
pub fn bounds_on(palette: &Palette) -> bool {
    !(palette.settings.reflectance_bounds.is_unbounded() && palette.settings.light_bounds.is_unbounded())
}

fn toggle_bounds(state: &mut State) -> Effects {
    if bounds_on(&state.palette) {
        let s = &state.palette.settings;
        state.remembered_bounds = (s.reflectance_bounds, s.light_bounds);
        edit(state, EditKey::Other, |p, _| {
            p.settings.reflectance_bounds = Bounds::UNBOUNDED;
            p.settings.light_bounds = Bounds::UNBOUNDED;
            Ok(())
        })
    } else {
        let (r, l) = state.remembered_bounds;
        edit(state, EditKey::Other, |p, _| {
            p.settings.reflectance_bounds = r;
            p.settings.light_bounds = l;
            Ok(())
        })
    }
}

/// A spectrum operation on the selection: direct on a swatch, a choice on a cell (Planck: the cell's light).
fn spectrum_op(state: &mut State, op: SpectrumOp) -> Effects {
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
            state.popup = Some(Popup::ChooseSpectrum { op, light, reflectance });
            Effects::NONE
        }
        Target::Nothing => {
            state.complain("the palette is empty: add a light (L) or a reflectance (R)");
            Effects::NONE
        }
    }
}

fn apply_spectrum_op(state: &mut State, op: SpectrumOp, kind: Kind, index: usize) -> Effects {
    let Some(name) = state.palette.entries(kind).get(index).map(|e| e.name.clone()) else {
        return Effects::NONE;
    };
    match op {
        SpectrumOp::ToggleDesign => edit(state, EditKey::Other, |p, _| edits::toggle_design(p, kind, index)),
        SpectrumOp::NormaliseLuminance | SpectrumOp::NormaliseL2 if kind == Kind::Reflectance => {
            state.complain("reflectances are never normalised; scale them instead (s)");
            Effects::NONE
        }
        SpectrumOp::NormaliseLuminance => {
            edit(state, EditKey::Other, |p, c| edits::normalise(p, index, Normalize::Luminance, c))
        }
        SpectrumOp::NormaliseL2 => edit(state, EditKey::Other, |p, c| edits::normalise(p, index, Normalize::L2, c)),
        SpectrumOp::Planck if kind == Kind::Reflectance => {
            state.complain("Planck black bodies are lights: select a light");
            Effects::NONE
        }
        SpectrumOp::Planck => {
            let t = match state.palette.lights[index].source {
                Source::Planck(t) => t,
                _ => 6500.0,
            };
            let title = format!("make {name} a Planck black body");
            open_prompt(state, &title, "temperature in kelvin", format!("{t}"), PromptPurpose::Planck { light: index })
        }
        SpectrumOp::Scale => {
            let title = format!("scale of {name}");
            let now = num_text(state.palette.entries(kind)[index].scale);
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

fn update_popup(state: &mut State, popup: Popup, action: Action) -> Effects {
    match popup {
        Popup::Help { scroll } => {
            state.popup = match action {
                Action::Back => None,
                Action::Move(Direction::Up) => Some(Popup::Help { scroll: scroll.saturating_sub(1) }),
                Action::Move(Direction::Down) => Some(Popup::Help { scroll: scroll.saturating_add(1).min(200) }),
                other => return update_main(state, other),
            };
            Effects::NONE
        }
        Popup::Diagnostics { scroll } => {
            state.popup = match action {
                Action::Back => None,
                Action::Move(Direction::Up) => Some(Popup::Diagnostics { scroll: scroll.saturating_sub(1) }),
                Action::Move(Direction::Down) => Some(Popup::Diagnostics { scroll: scroll.saturating_add(1).min(500) }),
                other => return update_main(state, other),
            };
            Effects::NONE
        }
        Popup::Prompt(mut prompt) => match action {
            Action::Back => Effects::NONE,
            Action::Input(c) => {
                if prompt.input.chars().count() < 400 {
                    prompt.input.push(c);
                }
                prompt.error = None;
                state.popup = Some(Popup::Prompt(prompt));
                Effects::NONE
            }
            Action::Backspace => {
                prompt.input.pop();
                prompt.error = None;
                state.popup = Some(Popup::Prompt(prompt));
                Effects::NONE
            }
            Action::ClearInput => {
                prompt.input.clear();
                state.popup = Some(Popup::Prompt(prompt));
                Effects::NONE
            }
            Action::Submit => submit_prompt(state, prompt),
            _ => {
                state.popup = Some(Popup::Prompt(prompt));
                Effects::NONE
            }
        },
        Popup::ChooseSpectrum { op, light, reflectance } => match action {
            Action::ChooseLight => apply_spectrum_op(state, op, Kind::Light, light),
            Action::ChooseReflectance => apply_spectrum_op(state, op, Kind::Reflectance, reflectance),
            Action::Back => Effects::NONE,
            _ => {
                state.popup = Some(Popup::ChooseSpectrum { op, light, reflectance });
                Effects::NONE
            }
        },
        Popup::Pick { kind, items, selected } => {
            let last = items.len().saturating_sub(1);
            let selected = match action {
                Action::Back => return Effects::NONE,
                Action::Submit => return pick(state, kind, items.get(selected).cloned()),
                Action::Move(Direction::Up) => selected.saturating_sub(1),
                Action::Move(Direction::Down) => (selected + 1).min(last),
                Action::BigStep { up: true } => selected.saturating_sub(10),
                Action::BigStep { up: false } => (selected + 10).min(last),
                _ => selected,
            };
            state.popup = Some(Popup::Pick { kind, items, selected });
            Effects::NONE
        }
        Popup::ConfirmQuit => match action {
            Action::Discard => {
                state.quit = true;
                Effects::NONE
            }
            Action::SaveAndQuit => Effects { save: true, quit_after_save: true, ..Effects::NONE },
            Action::Back => Effects::NONE,
            _ => {
                state.popup = Some(Popup::ConfirmQuit);
                Effects::NONE
            }
        },
    }
}

fn pick(state: &mut State, kind: Kind, item: Option<PickItem>) -> Effects {
    let (base, source) = match item {
        None => return Effects::NONE,
        Some(PickItem::Illuminant(n)) => (n.to_string(), Source::Illuminant(n.to_string())),
        Some(PickItem::ColorChecker(n)) => (n.to_string(), Source::ColorChecker(n.to_string())),
        Some(PickItem::Flat(v)) => {
            (if kind == Kind::Light { "flat".into() } else { format!("flat_{v}") }, Source::Flat(v))
        }
        Some(PickItem::Planck) => {
            return open_prompt(
                state,
                "new Planck light",
                "temperature in kelvin",
                "6500".into(),
                PromptPurpose::NewPlanck,
            );
        }
        Some(PickItem::Csv) => {
            let title = format!("import a {} from CSV", kind.as_str());
            return open_prompt(
                state,
                &title,
                "path relative to the palette: rows of nm,value over 400–700 nm",
                String::new(),
                PromptPurpose::CsvPath(kind),
            );
        }
    };
    add_spectrum(state, kind, &base, source)
}

fn add_spectrum(state: &mut State, kind: Kind, base: &str, source: Source) -> Effects {
    let name = edits::unique_name(&state.palette, kind, base);
    let base_dir = state.base_dir();
    let effects = edit(state, EditKey::Other, |p, c| edits::add(p, kind, &name, source, &base_dir, c));
    if effects.solve {
        state.say(format!("added {} {name}", kind.as_str()));
        // Select the new spectrum's swatch.
        match kind {
            Kind::Light => state.selection = crate::tui::app::Selection { col: state.palette.lights.len(), row: 0 },
            Kind::Reflectance => {
                state.selection = crate::tui::app::Selection { col: 0, row: state.palette.reflectances.len() }
            }
        }
        state.clamp_selection();
    }
    effects
}

/// Start importing the CSV file `path` as a new spectrum of `kind` on a thread of its own: the UI stays
/// responsive, Esc cancels (the reply is dropped), [`poll_import`] applies the reply.
pub fn start_import(state: &mut State, kind: Kind, path: &str) -> Effects {
    let base = std::path::Path::new(path)
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "imported".into());
    let name = edits::unique_name(&state.palette, kind, &base);
    let base_dir = state.base_dir();
    let mut next = state.palette.clone();
    let colorimetry = state.colorimetry.clone();
    let source = Source::Csv(path.to_string());
    let (tx, rx) = std::sync::mpsc::channel();
    let spawned = std::thread::Builder::new().name("csv import".into()).spawn(move || {
        let result = edits::add(&mut next, kind, &name, source, &base_dir, &colorimetry).map(|()| next);
        let _ = tx.send(result);
    });
    if let Err(e) = spawned {
        state.complain(format!("not imported: cannot start the reader: {e}"));
        return Effects::NONE;
    }
    state.say(format!("reading {}… (Esc cancels)", crate::fsio::escape(path)));
    state.import =
        Some(crate::tui::app::Import { path: path.to_string(), kind, before: state.palette.clone(), reply: rx });
    Effects::NONE
}

/// Apply the reply of the running CSV import, if it came (waiting up to `wait` for it).
pub fn poll_import(state: &mut State, wait: std::time::Duration) -> Effects {
    let Some(import) = state.import.as_ref() else { return Effects::NONE };
    let reply = match import.reply.recv_timeout(wait) {
        Ok(reply) => reply,
        Err(std::sync::mpsc::RecvTimeoutError::Timeout) => return Effects::NONE,
        Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => Err("the reader stopped without a reply".into()),
    };
    let Some(import) = state.import.take() else { return Effects::NONE };
    let shown = crate::fsio::escape(&import.path).into_owned();
    match reply {
        Err(reason) => {
            state.complain(format!("not imported: {shown}: {reason}"));
            Effects::NONE
        }
        Ok(_) if state.palette != import.before => {
            state.complain(format!("not imported: the palette changed while {shown} was read; import it again"));
            Effects::NONE
        }
        Ok(next) => {
            let effects = edit(state, EditKey::Other, |p, _| {
                *p = next;
                Ok(())
            });
            if effects.solve {
                state.say(format!("added {} from {shown}", import.kind.as_str()));
                match import.kind {
                    Kind::Light => {
                        state.selection = crate::tui::app::Selection { col: state.palette.lights.len(), row: 0 }
                    }
                    Kind::Reflectance => {
                        state.selection = crate::tui::app::Selection { col: 0, row: state.palette.reflectances.len() }
                    }
                }
                state.clamp_selection();
            }
            effects
        }
    }
}

/// A number as prompts prefill it (shortest round-trip form).
fn num_text(v: f64) -> String {
    format!("{v}")
}

/// Parse a number the way prompts accept it (`inf`, `-inf` included; NaN refused).
fn parse_number(text: &str) -> Result<f64, String> {
    let t = text.trim();
    match t.parse::<f64>() {
        Ok(v) if !v.is_nan() => Ok(v),
        _ => Err(format!("'{t}' is not a number")),
    }
}

fn submit_prompt(state: &mut State, mut prompt: Prompt) -> Effects {
    let result: Result<Effects, String> = (|| {
        let input = prompt.input.trim().to_string();
        Ok(match prompt.purpose.clone() {
            PromptPurpose::Hex { light, reflectance } => {
                let hex = if input.starts_with('#') { input.clone() } else { format!("#{input}") };
                let rgb = hex_to_linear(&hex).ok_or(format!("'{input}' is not #rrggbb"))?;
                edit_or_err(state, |p, _| edits::set_target(p, light, reflectance, rgb))?
            }
            PromptPurpose::Weight { light, reflectance } => {
                let w = parse_number(&input)?;
                let now = current_colour(state, light, reflectance);
                edit_or_err(state, |p, _| edits::set_weight(p, light, reflectance, w, now))?
            }
            PromptPurpose::FreeGroup { light, reflectance } => {
                let now = current_colour(state, light, reflectance);
                let name = (!input.is_empty()).then_some(input.as_str());
                edit_or_err(state, |p, _| edits::set_free(p, light, reflectance, name, now))?
            }
            PromptPurpose::FreeBounds { group } => {
                let v: Vec<f64> = input
                    .split([' ', ',', '\t'])
                    .filter(|s| !s.is_empty())
                    .map(parse_number)
                    .collect::<Result<_, _>>()?;
                let (lower, upper) = match v.as_slice() {
                    [lo, hi] => (Vector3::repeat(*lo), Vector3::repeat(*hi)),
                    [a, b, c, d, e, f] => (Vector3::new(*a, *b, *c), Vector3::new(*d, *e, *f)),
                    _ => return Err("give 2 numbers (lower upper) or 6 (lower r g b, upper r g b)".into()),
                };
                edit_or_err(state, |p, _| edits::set_free_bounds(p, group, lower, upper))?
            }
            PromptPurpose::Planck { light } => {
                let t = parse_number(&input)?;
                if !(t.is_finite() && t > 0.0) {
                    return Err("the temperature must be a positive number of kelvin".into());
                }
                edit_or_err(state, |p, c| edits::make_planck(p, light, t, c))?
            }
            PromptPurpose::NewPlanck => {
                let t = parse_number(&input)?;
                if !(t.is_finite() && t > 0.0) {
                    return Err("the temperature must be a positive number of kelvin".into());
                }
                add_spectrum(state, Kind::Light, &format!("planck_{}K", t.round()), Source::Planck(t))
            }
            PromptPurpose::Scale { kind, index } => {
                let k = parse_number(&input)?;
                if !(k.is_finite() && k > 0.0) {
                    return Err("the scale must be a positive finite number".into());
                }
                edit_or_err(state, |p, c| edits::scale(p, kind, index, k, c))?
            }
            PromptPurpose::CsvPath(kind) => {
                if input.is_empty() {
                    return Err("give a path".into());
                }
                start_import(state, kind, &input)
            }
            PromptPurpose::Setting(field) => {
                let v = parse_number(&input)?;
                edit_or_err(state, |p, _| set_setting(p, field, v))?
            }
        })
    })();
    match result {
        Ok(effects) => effects,
        Err(reason) => {
            state.message = None;
            prompt.error = Some(reason);
            state.popup = Some(Popup::Prompt(prompt));
            Effects::NONE
        }
    }
}

/// Like [`edit`], but a refused edit is an error for the prompt to show.
fn edit_or_err(state: &mut State, f: impl FnOnce(&mut Palette, &Colorimetry) -> EditResult) -> Result<Effects, String> {
    let effects = edit(state, EditKey::Other, f);
    match state.message.take() {
        Some(m) if m.is_error => Err(m.text),
        other => {
            state.message = other;
            Ok(effects)
        }
    }
}

fn set_setting(p: &mut Palette, field: SettingField, v: f64) -> EditResult {
    let s = &mut p.settings;
    let nonneg = |v: f64| {
        if v.is_finite() && v >= 0.0 { Ok(v) } else { Err(format!("{v} is not a finite number ≥ 0")) }
    };
    let ordered =
        |b: Bounds| if b.lower <= b.upper { Ok(b) } else { Err("the lower bound is above the upper".to_string()) };
    match field {
        SettingField::ReflectanceLower => s.reflectance_bounds = ordered(Bounds::new(v, s.reflectance_bounds.upper))?,
        SettingField::ReflectanceUpper => s.reflectance_bounds = ordered(Bounds::new(s.reflectance_bounds.lower, v))?,
        SettingField::LightLower => s.light_bounds = ordered(Bounds::new(v, s.light_bounds.upper))?,
        SettingField::LightUpper => s.light_bounds = ordered(Bounds::new(s.light_bounds.lower, v))?,
        SettingField::Smoothness => s.smoothness = nonneg(v)?,
        SettingField::SubspaceError => s.subspace_error = nonneg(v)?,
        SettingField::BasisDimension => {
            if v.fract() != 0.0 || crate::basis::check_dimension(v as usize).is_err() {
                return Err("the basis dimension is an integer from 1 to 31".into());
            }
            s.basis_dimension = v as usize;
        }
        SettingField::Bounds | SettingField::FitInSubspace => {}
    }
    Ok(())
}
