//! The main screen's actions: one handler per group of keys (moves, cell edits, spectrum operations,
//! history, panels). They change the state; only the file actions return effects (an edit needs none:
//! the update step solves every palette generation not asked for yet).

use crate::colorimetry::{Colorimetry, linear_to_hex, srgb_decode, srgb_encode};
use crate::palette::{Bounds, Kind, Palette};
use crate::spectrum::Spectrum;
use crate::tui::action::{Action, Direction};
use crate::tui::app::{
    EditKey, Focus, PickItem, Popup, PromptPurpose, SettingField, Slider, SpectrumOp, State, Target,
};
use crate::tui::edits;
use crate::tui::msg::Effect;
use nalgebra::Vector3;

use super::edit::{
    apply_spectrum_op, changed, current_colour, edit, open_prompt, reload, save, save_as_prompt, with_cell,
};

/// An edit whose outcome the handler does not need (a refusal is shown in the message line).
fn change(state: &mut State, key: EditKey, f: impl FnOnce(&mut Palette, &Colorimetry) -> edits::EditResult) {
    edit(state, key, f);
}

/// Slider steps in display sRGB eighths of a byte: one step is 1/255.
const SMALL_STEP: f64 = 1.0 / 255.0;
const BIG_STEP: f64 = 16.0 / 255.0;

/// An action on the main screen: one handler per group of keys.
pub(super) fn update_main(state: &mut State, action: Action) -> Vec<Effect> {
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
        Action::Rename => {
            let target = state.target();
            crate::tui::rename::start(&mut state.ui, &state.doc.palette, target)
        }
        Action::Planck => spectrum_op(state, SpectrumOp::Planck),
        Action::AddLight | Action::AddReflectance => on_add(state, action),
        Action::ToggleBounds
        | Action::ToggleFitInSubspace
        | Action::Undo
        | Action::Redo
        | Action::Save
        | Action::SaveAs
        | Action::Reload
        | Action::Quit => return on_palette(state, action),
        Action::Help
        | Action::Legend
        | Action::Find { .. }
        | Action::Diagnostics
        | Action::Feasibility
        | Action::DialKeys
        | Action::TogglePreview => on_view(state, action),
        // The dial's own keys are the preview's (routed to `PreviewState::update` before this); popup-only
        // actions do nothing on the main screen.
        Action::Dial { .. }
        | Action::DialSlide { .. }
        | Action::DialToggle(_)
        | Action::DialSelect { .. }
        | Action::DialIntensity { .. }
        | Action::DialKeyframe
        | Action::DialSaveScene
        | Action::DialLeave
        | Action::ListEnd { .. }
        | Action::Edit(_)
        | Action::Submit
        | Action::ChooseLight
        | Action::ChooseReflectance
        | Action::ChooseGroup
        | Action::Discard
        | Action::SaveAndQuit
        | Action::Restore => {}
    }
    Vec::new()
}

/// Moves, focus, Enter and Esc.
fn on_navigation(state: &mut State, action: Action) {
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
        }
        Action::Activate => activate(state),
        _ => {
            if let Some(import) = state.doc.import.take() {
                state.say(format!("import of {} cancelled", crate::fsio::escape(&import.path)));
                return;
            }
            state.ui.focus = Focus::Matrix;
        }
    }
}

/// The selected cell's criterion: target, weight, use, free group, fits.
fn on_cell(state: &mut State, action: Action) {
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
            change(state, EditKey::Other, |p, _| edits::toggle_use(p, light, reflectance, now))
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
            change(state, EditKey::Other, |p, _| edits::set_target(p, light, reflectance, now))
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
            change(state, EditKey::Other, |p, _| {
                fits.iter().try_for_each(|(l, r, rgb)| edits::set_target(p, *l, *r, *rgb))
            })
        }
    }
}

/// `b`: the bounds of the selected cell's free-colour group.
fn free_bounds(state: &mut State, light: usize, reflectance: usize) {
    match state.doc.palette.cell(light, reflectance).and_then(|c| c.free) {
        None => {
            state.complain("this cell is in no free-colour group (press f first)");
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
fn on_add(state: &mut State, action: Action) {
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
}

/// The palette as a whole: settings toggles, history, file, quit.
fn on_palette(state: &mut State, action: Action) -> Vec<Effect> {
    match action {
        Action::ToggleBounds => toggle_bounds(state),
        Action::ToggleFitInSubspace => change(state, EditKey::Other, |p, _| {
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
                None => state.say(if undo { "nothing to undo" } else { "nothing to redo" }),
                Some(other) => {
                    let now = std::mem::replace(&mut state.doc.palette, other);
                    to.push(now);
                    state.doc.history.last_edit = None;
                    state.say(if undo { "undone" } else { "redone" });
                    changed(state)
                }
            }
        }
        Action::Save => return save(state, false),
        Action::SaveAs => {
            let now = state.path().display().to_string();
            state.ui.popup = Some(Popup::Prompt(save_as_prompt(now, None)));
        }
        Action::Reload => return reload(state),
        _ => {
            if state.is_dirty() {
                state.ui.popup = Some(Popup::ConfirmQuit);
            } else {
                state.ui.quit = true;
            }
        }
    }
    Vec::new()
}

/// Popups that only show, the mismatch overlay and the scene preview.
fn on_view(state: &mut State, action: Action) {
    match action {
        Action::Help => state.ui.popup = Some(Popup::Help { scroll: 0 }),
        Action::Legend => state.ui.popup = Some(Popup::Legend { scroll: 0 }),
        Action::Find { commands } => {
            let kind = if commands {
                crate::tui::finder::FinderKind::Commands
            } else {
                crate::tui::finder::FinderKind::Search
            };
            state.ui.popup = Some(Popup::Find(crate::tui::finder::Finder::new(kind)))
        }
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
        _ if !state.preview.has_scene() => state.complain(crate::tui::model::NO_SCENE),
        Action::DialKeys => {
            state.preview.shown = true;
            state.preview.keys = true;
        }
        _ => state.preview.shown = !state.preview.shown,
    }
}

fn move_in_focus(state: &mut State, d: Direction) {
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
        }
        Focus::Sliders => match d {
            Direction::Up => {
                state.ui.slider = state.ui.slider.saturating_sub(1);
            }
            Direction::Down => {
                state.ui.slider = (state.ui.slider + 1).min(Slider::ALL.len() - 1);
            }
            Direction::Left => step_slider(state, -1.0, false),
            Direction::Right => step_slider(state, 1.0, false),
        },
        Focus::Settings => match d {
            Direction::Left => state.ui.setting = state.ui.setting.saturating_sub(1),
            Direction::Right => state.ui.setting = (state.ui.setting + 1).min(SettingField::ALL.len() - 1),
            // The settings row is the last: up goes back to the matrix above it (issue 30, defect 6: the
            // key did nothing and said nothing), down says where the row's keys are.
            Direction::Up => state.ui.focus = Focus::Matrix,
            Direction::Down => {
                state.say("settings is the last row: ←/→ choose a field, enter edits it, ↑ or tab leaves")
            }
        },
    }
}

/// Move the focused slider of the selected cell by one small or big step in direction `sign`.
fn step_slider(state: &mut State, sign: f64, big: bool) {
    if state.ui.focus != Focus::Sliders {
        return;
    }
    let Target::Cell { light, reflectance } = state.target() else {
        return;
    };
    let slider = Slider::ALL[state.ui.slider.min(Slider::ALL.len() - 1)];
    let key = EditKey::Slider { light, reflectance, slider: state.ui.slider };
    let now = current_colour(state, light, reflectance);
    match slider {
        Slider::Weight => {
            let w = state.doc.palette.cell(light, reflectance).map_or(1.0, |c| c.weight);
            let step = if big { 1.0 } else { 0.1 };
            let next = ((w + sign * step) * 10.0).round() / 10.0;
            change(state, key, |p, _| edits::set_weight(p, light, reflectance, next.max(0.0), now))
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
            change(state, key, |p, _| edits::set_target(p, light, reflectance, rgb))
        }
    }
}

fn activate(state: &mut State) {
    match state.ui.focus {
        Focus::Matrix => match state.target() {
            Target::Cell { .. } => {
                state.ui.focus = Focus::Sliders;
            }
            Target::Light(_) | Target::Reflectance(_) => spectrum_op(state, SpectrumOp::ToggleDesign),
            Target::Nothing => {}
        },
        Focus::Sliders => {
            state.ui.focus = Focus::Matrix;
        }
        Focus::Settings => {
            let field = SettingField::ALL[state.ui.setting.min(SettingField::ALL.len() - 1)];
            match field {
                SettingField::Bounds => toggle_bounds(state),
                SettingField::FitInSubspace => change(state, EditKey::Other, |p, _| {
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

fn toggle_bounds(state: &mut State) {
    if state.doc.palette.settings.bounded() {
        let s = &state.doc.palette.settings;
        state.doc.remembered_bounds = (s.reflectance_bounds, s.light_bounds);
        change(state, EditKey::Other, |p, _| {
            p.settings.reflectance_bounds = Bounds::UNBOUNDED;
            p.settings.light_bounds = Bounds::UNBOUNDED;
            Ok(())
        })
    } else {
        let (r, l) = state.doc.remembered_bounds;
        change(state, EditKey::Other, |p, _| {
            p.settings.reflectance_bounds = r;
            p.settings.light_bounds = l;
            Ok(())
        })
    }
}

/// A spectrum operation on the selection: direct on a swatch, a choice on a cell (Planck: the cell's light).
fn spectrum_op(state: &mut State, op: SpectrumOp) {
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
        }
        Target::Nothing => {
            state.complain("the palette is empty: add a light (L) or a reflectance (R)");
        }
    }
}
