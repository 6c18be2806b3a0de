//! The main screen's actions: one handler per group of keys (moves, cell edits, spectrum operations,
//! history, panels). They change the state; only the file actions return effects (an edit needs none:
//! the update step solves every palette generation not asked for yet).

use crate::colorimetry::{Colorimetry, linear_to_hex, srgb_decode, srgb_encode};
use crate::palette::{Bounds, Kind, Palette};
use crate::spectrum::Spectrum;
use crate::tui::action::{Action, Direction};
use crate::tui::app::{EditKey, Focus, PickItem, Popup, PromptPurpose, SettingField, Slider, SpectrumOp, Target};
use crate::tui::edits;
use crate::tui::model::{Document, PreviewState, SolveState, UiState};
use crate::tui::msg::Effect;
use nalgebra::Vector3;

use super::edit::{apply_spectrum_op, current_colour, edit, save_as_prompt};

/// An edit whose outcome the handler does not need (a refusal is shown in the message line).
fn change(
    doc: &mut Document,
    ui: &mut UiState,
    c: &Colorimetry,
    key: EditKey,
    f: impl FnOnce(&mut Palette, &Colorimetry) -> edits::EditResult,
) {
    edit(doc, ui, c, key, f);
}

/// Slider steps in display sRGB eighths of a byte: one step is 1/255.
const SMALL_STEP: f64 = 1.0 / 255.0;
const BIG_STEP: f64 = 16.0 / 255.0;

/// An action on the main screen: one handler per group of keys, each taking the sub-models it needs.
pub(super) fn update_main(
    doc: &mut Document,
    ui: &mut UiState,
    solve: &SolveState,
    preview: &mut PreviewState,
    c: &Colorimetry,
    action: Action,
) -> Vec<Effect> {
    if !matches!(action, Action::Move(_) | Action::BigStep { .. }) {
        doc.history.last_edit = None;
    }
    match action {
        Action::Move(_)
        | Action::BigStep { .. }
        | Action::FocusNext
        | Action::FocusPrev
        | Action::Activate
        | Action::Back => on_navigation(doc, ui, solve, c, action),
        Action::HexEntry
        | Action::EditWeight
        | Action::ToggleUse
        | Action::AssignFree
        | Action::FreeBounds
        | Action::FitColour
        | Action::FitAll => on_cell(doc, ui, solve, c, action),
        Action::ToggleDesign => spectrum_op(doc, ui, c, SpectrumOp::ToggleDesign),
        Action::NormaliseLuminance => spectrum_op(doc, ui, c, SpectrumOp::NormaliseLuminance),
        Action::NormaliseL2 => spectrum_op(doc, ui, c, SpectrumOp::NormaliseL2),
        Action::Scale => spectrum_op(doc, ui, c, SpectrumOp::Scale),
        Action::Remove => spectrum_op(doc, ui, c, SpectrumOp::Remove),
        Action::Rename => {
            let target = ui.target(&doc.palette);
            crate::tui::rename::start(ui, &doc.palette, target)
        }
        Action::Planck => spectrum_op(doc, ui, c, SpectrumOp::Planck),
        Action::DialKeyframes => ui.popup = Some(Popup::Keyframes(Default::default())),
        Action::AddLight | Action::AddReflectance => on_add(ui, action),
        Action::ToggleBounds
        | Action::ToggleFitInSubspace
        | Action::Undo
        | Action::Redo
        | Action::Save
        | Action::SaveAs
        | Action::Reload
        | Action::Quit => return on_palette(doc, ui, solve, c, action),
        Action::Help
        | Action::Legend
        | Action::Find { .. }
        | Action::Diagnostics
        | Action::Feasibility
        | Action::DialKeys
        | Action::TogglePreview => on_view(doc, ui, solve, preview, action),
        Action::DialList => ui.popup = Some(crate::tui::app::Popup::DialList(Default::default())),
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
        | Action::DialAddMixture
        | Action::PreviewFull
        | Action::DialSamples
        | Action::DialTolerance
        | Action::ListEnd { .. }
        | Action::Edit(_)
        | Action::Complete
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
fn on_navigation(doc: &mut Document, ui: &mut UiState, solve: &SolveState, c: &Colorimetry, action: Action) {
    match action {
        Action::Move(d) => move_in_focus(doc, ui, solve, c, d),
        Action::BigStep { up } => step_slider(doc, ui, solve, c, if up { 1.0 } else { -1.0 }, true),
        Action::FocusNext | Action::FocusPrev => {
            let order = [Focus::Matrix, Focus::Sliders, Focus::Settings];
            let at = order.iter().position(|f| *f == ui.focus).unwrap_or(0);
            let step = if action == Action::FocusNext { 1 } else { order.len() - 1 };
            ui.focus = order[(at + step) % order.len()];
            if ui.focus == Focus::Sliders && !matches!(ui.target(&doc.palette), Target::Cell { .. }) {
                ui.focus = order[(at + 2 * step) % order.len()];
            }
        }
        Action::Activate => activate(doc, ui, c),
        _ => {
            if let Some(import) = doc.import.take() {
                ui.say(format!("import of {} cancelled", crate::fsio::escape(&import.path)));
                return;
            }
            ui.focus = Focus::Matrix;
        }
    }
}

/// The selected cell's criterion: target, weight, use, free group, fits.
fn on_cell(doc: &mut Document, ui: &mut UiState, solve: &SolveState, c: &Colorimetry, action: Action) {
    if action == Action::FitAll {
        let fits: Vec<(usize, usize, Vector3<f64>)> = doc
            .palette
            .colours
            .iter()
            .filter(|c| c.free.is_none())
            .map(|c| (c.light, c.reflectance, current_colour(solve, c.light, c.reflectance)))
            .collect();
        return change(doc, ui, c, EditKey::Other, |p, _| {
            fits.iter().try_for_each(|(l, r, rgb)| edits::set_target(p, *l, *r, *rgb))
        });
    }
    let Some((light, reflectance)) = ui.selected_cell(&doc.palette) else { return };
    match action {
        Action::HexEntry => {
            let current = solve.derived.cell(light, reflectance).and_then(|c| c.desired).unwrap_or_default();
            ui.open_prompt(
                "target colour",
                "#rrggbb (display sRGB)",
                linear_to_hex(&current),
                PromptPurpose::Hex { light, reflectance },
            )
        }
        Action::EditWeight => {
            let w = doc.palette.cell(light, reflectance).map_or(1.0, |c| c.weight);
            ui.open_prompt("weight", "a number ≥ 0", format!("{w}"), PromptPurpose::Weight { light, reflectance })
        }
        Action::ToggleUse => {
            let now = current_colour(solve, light, reflectance);
            change(doc, ui, c, EditKey::Other, |p, _| edits::toggle_use(p, light, reflectance, now))
        }
        Action::AssignFree => {
            let now = doc.palette.cell(light, reflectance).and_then(|c| c.free);
            let name = now.and_then(|g| doc.palette.free.get(g)).map(|g| g.name.clone()).unwrap_or_default();
            ui.open_prompt(
                "free-colour group",
                "a group name such as A; empty: not free",
                name,
                PromptPurpose::FreeGroup { light, reflectance },
            )
        }
        Action::FreeBounds => free_bounds(doc, ui, light, reflectance),
        _ => {
            let now = current_colour(solve, light, reflectance);
            change(doc, ui, c, EditKey::Other, |p, _| edits::set_target(p, light, reflectance, now))
        }
    }
}

/// `b`: the bounds of the selected cell's free-colour group.
fn free_bounds(doc: &Document, ui: &mut UiState, light: usize, reflectance: usize) {
    match doc.palette.cell(light, reflectance).and_then(|c| c.free) {
        None => {
            ui.complain("this cell is in no free-colour group (press f first)");
        }
        Some(group) => {
            let g = &doc.palette.free[group];
            let text =
                format!("{} {} {}  {} {} {}", g.lower[0], g.lower[1], g.lower[2], g.upper[0], g.upper[1], g.upper[2]);
            let title = format!("bounds of free group {}", g.name);
            ui.open_prompt(
                &title,
                "lower upper, or lower r g b then upper r g b (linear sRGB)",
                text,
                PromptPurpose::FreeBounds { group },
            )
        }
    }
}

/// `L`, `R`: the list of what can be added.
fn on_add(ui: &mut UiState, action: Action) {
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
    ui.popup = Some(Popup::Pick { kind, items, selected: 0 });
}

/// The palette as a whole: settings toggles, history, file, quit.
fn on_palette(
    doc: &mut Document,
    ui: &mut UiState,
    solve: &SolveState,
    c: &Colorimetry,
    action: Action,
) -> Vec<Effect> {
    match action {
        Action::ToggleBounds => toggle_bounds(doc, ui, c),
        Action::ToggleFitInSubspace => change(doc, ui, c, EditKey::Other, |p, _| {
            p.settings.fit_in_subspace = !p.settings.fit_in_subspace;
            Ok(())
        }),
        Action::Undo | Action::Redo => {
            let undo = action == Action::Undo;
            match (doc.step_history(undo), undo) {
                (false, true) => ui.say("nothing to undo"),
                (false, false) => ui.say("nothing to redo"),
                (true, true) => ui.say("undone"),
                (true, false) => ui.say("redone"),
            }
        }
        Action::Save => return doc.save(solve.current(), false),
        Action::SaveAs => {
            // Relative to the palette's folder: the file's own name.
            let path = doc.path();
            let now = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
            ui.popup = Some(Popup::Prompt(save_as_prompt(now, None, &doc.base_dir())));
        }
        Action::Reload => return doc.reload(),
        _ => {
            if doc.is_dirty() {
                ui.popup = Some(Popup::ConfirmQuit);
            } else {
                ui.quit = true;
            }
        }
    }
    Vec::new()
}

/// Popups that only show, the mismatch overlay and the scene preview.
fn on_view(doc: &Document, ui: &mut UiState, solve: &SolveState, preview: &mut PreviewState, action: Action) {
    match action {
        Action::Help => ui.popup = Some(Popup::Help { scroll: 0 }),
        Action::Legend => ui.popup = Some(Popup::Legend { scroll: 0 }),
        Action::Find { commands } => {
            let finder = if commands {
                crate::tui::finder::Finder::commands(crate::tui::keymap::commands())
            } else {
                crate::tui::finder::Finder::search()
            };
            ui.popup = Some(Popup::Find(finder))
        }
        Action::Diagnostics => {
            if solve.diagnostics().is_empty() {
                ui.say("no diagnostics: every criterion is met");
            } else {
                ui.popup = Some(Popup::Diagnostics { scroll: 0 });
            }
        }
        Action::Feasibility => {
            ui.show_feasibility = !ui.show_feasibility;
            if ui.show_feasibility && crate::tui::app::feasibility_cell(ui, doc).is_none() {
                ui.say("mismatch region: select a cell with a colour criterion");
            }
        }
        _ if !preview.has_scene() => ui.complain(crate::tui::model::NO_SCENE),
        Action::DialKeys => {
            preview.shown = true;
            preview.keys = true;
        }
        _ => preview.shown = !preview.shown,
    }
}

fn move_in_focus(doc: &mut Document, ui: &mut UiState, solve: &SolveState, c: &Colorimetry, d: Direction) {
    match ui.focus {
        Focus::Matrix => {
            let (nl, nr) = (doc.palette.lights.len(), doc.palette.reflectances.len());
            let s = &mut ui.selection;
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
                ui.slider = ui.slider.saturating_sub(1);
            }
            Direction::Down => {
                ui.slider = (ui.slider + 1).min(Slider::ALL.len() - 1);
            }
            Direction::Left => step_slider(doc, ui, solve, c, -1.0, false),
            Direction::Right => step_slider(doc, ui, solve, c, 1.0, false),
        },
        Focus::Settings => match d {
            Direction::Left => ui.setting = ui.setting.saturating_sub(1),
            Direction::Right => ui.setting = (ui.setting + 1).min(SettingField::ALL.len() - 1),
            // The settings row is the last: up goes back to the matrix above it (issue 30, defect 6: the
            // key did nothing and said nothing), down says where the row's keys are.
            Direction::Up => ui.focus = Focus::Matrix,
            Direction::Down => ui.say("settings is the last row: ←/→ choose a field, enter edits it, ↑ or tab leaves"),
        },
    }
}

/// Move the focused slider of the selected cell by one small or big step in direction `sign`.
fn step_slider(doc: &mut Document, ui: &mut UiState, solve: &SolveState, c: &Colorimetry, sign: f64, big: bool) {
    if ui.focus != Focus::Sliders {
        return;
    }
    let Target::Cell { light, reflectance } = ui.target(&doc.palette) else {
        return;
    };
    let slider = Slider::ALL[ui.slider.min(Slider::ALL.len() - 1)];
    let key = EditKey::Slider { light, reflectance, slider: ui.slider };
    let now = current_colour(solve, light, reflectance);
    match slider {
        Slider::Weight => {
            let w = doc.palette.cell(light, reflectance).map_or(1.0, |c| c.weight);
            let step = if big { 1.0 } else { 0.1 };
            let next = ((w + sign * step) * 10.0).round() / 10.0;
            change(doc, ui, c, key, |p, _| edits::set_weight(p, light, reflectance, next.max(0.0), now))
        }
        channel => {
            let k = match channel {
                Slider::Red => 0,
                Slider::Green => 1,
                _ => 2,
            };
            let target = doc.palette.cell(light, reflectance).map_or(now, |c| c.target);
            let display = srgb_encode(target[k]).clamp(0.0, 1.0);
            let step = if big { BIG_STEP } else { SMALL_STEP };
            let next = ((display + sign * step) * 255.0).round().clamp(0.0, 255.0) / 255.0;
            let mut rgb = target;
            rgb[k] = srgb_decode(next);
            change(doc, ui, c, key, |p, _| edits::set_target(p, light, reflectance, rgb))
        }
    }
}

fn activate(doc: &mut Document, ui: &mut UiState, c: &Colorimetry) {
    match ui.focus {
        Focus::Matrix => match ui.target(&doc.palette) {
            Target::Cell { .. } => {
                ui.focus = Focus::Sliders;
            }
            Target::Light(_) | Target::Reflectance(_) => spectrum_op(doc, ui, c, SpectrumOp::ToggleDesign),
            Target::Nothing => {}
        },
        Focus::Sliders => {
            ui.focus = Focus::Matrix;
        }
        Focus::Settings => {
            let field = SettingField::ALL[ui.setting.min(SettingField::ALL.len() - 1)];
            match field {
                SettingField::Bounds => toggle_bounds(doc, ui, c),
                SettingField::FitInSubspace => change(doc, ui, c, EditKey::Other, |p, _| {
                    p.settings.fit_in_subspace = !p.settings.fit_in_subspace;
                    Ok(())
                }),
                other => {
                    let s = &doc.palette.settings;
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
                    ui.open_prompt(title, hint, value, PromptPurpose::Setting(other))
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

fn toggle_bounds(doc: &mut Document, ui: &mut UiState, c: &Colorimetry) {
    if doc.palette.settings.bounded() {
        let s = &doc.palette.settings;
        doc.remembered_bounds = (s.reflectance_bounds, s.light_bounds);
        change(doc, ui, c, EditKey::Other, |p, _| {
            p.settings.reflectance_bounds = Bounds::UNBOUNDED;
            p.settings.light_bounds = Bounds::UNBOUNDED;
            Ok(())
        })
    } else {
        let (r, l) = doc.remembered_bounds;
        change(doc, ui, c, EditKey::Other, |p, _| {
            p.settings.reflectance_bounds = r;
            p.settings.light_bounds = l;
            Ok(())
        })
    }
}

/// A spectrum operation on the selection: direct on a swatch, a choice on a cell (Planck: the cell's light).
fn spectrum_op(doc: &mut Document, ui: &mut UiState, c: &Colorimetry, op: SpectrumOp) {
    match ui.target(&doc.palette) {
        Target::Light(l) => apply_spectrum_op(doc, ui, c, op, Kind::Light, l),
        Target::Reflectance(r) => apply_spectrum_op(doc, ui, c, op, Kind::Reflectance, r),
        Target::Cell { light, .. } if matches!(op, SpectrumOp::Planck | SpectrumOp::NormaliseL2) => {
            apply_spectrum_op(doc, ui, c, op, Kind::Light, light)
        }
        Target::Cell { light, .. } if op == SpectrumOp::NormaliseLuminance => {
            apply_spectrum_op(doc, ui, c, op, Kind::Light, light)
        }
        Target::Cell { light, reflectance } => {
            ui.popup = Some(Popup::ChooseSpectrum { op, light, reflectance });
        }
        Target::Nothing => {
            ui.complain("the palette is empty: add a light (L) or a reflectance (R)");
        }
    }
}
