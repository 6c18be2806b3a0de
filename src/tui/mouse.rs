//! The mouse: a click selects a matrix cell or swatch, a click or drag on a slider's bar sets the
//! selected cell's R, G, B or weight (on the one-line sliders of a narrow screen, a click on one focuses
//! it for the arrow keys), a click or drag on the light dial moves its slider. The terminal's
//! mouse events come as [`crate::tui::msg::Msg::Mouse`]; [`locate`] reads what is under the pointer with
//! the view's own layout functions (`ui/hit.rs`), before the update step takes the state apart, and
//! [`on_mouse`] acts on it with the sub-models it needs. Pure, like every handler: a drag is remembered
//! in [`crate::tui::model::UiState`] (what the button went down on), never in the terminal.
//!
//! A press on a slider starts one undo step; the drag that follows merges into it (`z` undoes the whole
//! drag). While a popup is open, or the preview covers the whole terminal, the mouse does nothing.

use crate::colorimetry::{Colorimetry, srgb_decode, srgb_encode};
use crate::tui::app::{EditKey, Focus, Slider, State, Target};
use crate::tui::model::{Document, PreviewState, SolveState, UiState};
use crate::tui::ui::hit::{self, Hit};
use ratatui::crossterm::event::{MouseButton, MouseEvent, MouseEventKind};

/// What a held button went down on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Drag {
    /// Slider `k` of the selected cell (R, G, B, weight).
    Slider(usize),
    /// The light dial's slider.
    Dial,
}

/// What is under the pointer, read from the state as last drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Located {
    /// What a press lands on.
    hit: Option<Hit>,
    /// Along the sliders' bars (a drag that left the bar's row).
    fraction: Option<f64>,
    /// On the dial's canvas (a drag that left it: its nearest edge).
    dial: Option<[f64; 2]>,
}

/// Read what `event` points at, with the layout the view drew `state` with.
pub fn locate(state: &State, event: &MouseEvent) -> Located {
    let (x, y) = (event.column, event.row);
    match event.kind {
        MouseEventKind::Down(MouseButton::Left) => Located { hit: hit::hit(state, x, y), ..Located::default() },
        MouseEventKind::Drag(MouseButton::Left) => match state.ui.drag {
            Some(Drag::Slider(_)) => Located { fraction: hit::slider_fraction(state, x), ..Located::default() },
            Some(Drag::Dial) => Located { dial: hit::dial_point(state, x, y), ..Located::default() },
            None => Located::default(),
        },
        _ => Located::default(),
    }
}

/// A mouse event at what [`locate`] found there.
pub(crate) fn on_mouse(
    doc: &mut Document,
    ui: &mut UiState,
    solve: &SolveState,
    preview: &mut PreviewState,
    c: &Colorimetry,
    event: MouseEvent,
    at: Located,
) {
    // A popup, or the preview over the whole terminal, hides the panels the pointer would hit.
    if ui.popup.is_some() || preview.full {
        ui.drag = None;
        return;
    }
    match event.kind {
        MouseEventKind::Down(MouseButton::Left) => {
            ui.message = None;
            ui.drag = None;
            // A press is a new undo step (a drag then merges into it).
            doc.history.last_edit = None;
            match at.hit {
                Some(Hit::Matrix(selection)) => {
                    ui.selection = selection;
                    ui.focus = Focus::Matrix;
                }
                Some(Hit::Slider { slider, fraction }) if set_slider(doc, ui, solve, c, slider, fraction) => {
                    ui.drag = Some(Drag::Slider(slider));
                }
                Some(Hit::Dial(point)) if move_dial(preview, ui, point) => ui.drag = Some(Drag::Dial),
                Some(Hit::SliderName(k)) => {
                    ui.focus = Focus::Sliders;
                    ui.slider = k.min(Slider::ALL.len() - 1);
                    ui.say("←/→ change the slider, PgUp/PgDn in large steps (a wider screen has bars to drag)");
                }
                Some(Hit::Slider { .. } | Hit::Dial(_)) | None => {}
            }
        }
        MouseEventKind::Drag(MouseButton::Left) => match (ui.drag, at) {
            (Some(Drag::Slider(k)), Located { fraction: Some(f), .. }) => {
                set_slider(doc, ui, solve, c, k, f);
            }
            (Some(Drag::Dial), Located { dial: Some(point), .. }) => {
                move_dial(preview, ui, point);
            }
            _ => {}
        },
        MouseEventKind::Up(_) => ui.drag = None,
        _ => {}
    }
}

/// Set slider `k` of the selected cell to `fraction` of its bar (R, G, B: display sRGB 0–1 in steps of
/// 1/255; weight: 0 to 10, or to the weight when it is larger, in steps of 0.1), focusing the sliders.
/// False when no cell is selected.
fn set_slider(
    doc: &mut Document,
    ui: &mut UiState,
    solve: &SolveState,
    c: &Colorimetry,
    k: usize,
    fraction: f64,
) -> bool {
    let Target::Cell { light, reflectance } = ui.target(&doc.palette) else {
        return false;
    };
    ui.focus = Focus::Sliders;
    ui.slider = k.min(Slider::ALL.len() - 1);
    let key = EditKey::Slider { light, reflectance, slider: ui.slider };
    let now = solve.derived.cell(light, reflectance).map(|v| v.full).unwrap_or_default();
    let result = match Slider::ALL[ui.slider] {
        Slider::Weight => {
            let w = doc.palette.cell(light, reflectance).map_or(1.0, |cell| cell.weight);
            let next = (fraction * w.max(10.0) * 10.0).round() / 10.0;
            doc.edit(key, c, |p, _| crate::tui::edits::set_weight(p, light, reflectance, next, now))
        }
        channel => {
            let i = Slider::ALL.iter().position(|s| *s == channel).unwrap_or(0);
            let mut rgb = doc.palette.cell(light, reflectance).map_or(now, |cell| cell.target);
            // Only a channel the pointer changes moves (the others keep their exact value).
            if (srgb_encode(rgb[i]).clamp(0.0, 1.0) * 255.0).round() != (fraction * 255.0).round() {
                rgb[i] = srgb_decode((fraction * 255.0).round() / 255.0);
            }
            doc.edit(key, c, |p, _| crate::tui::edits::set_target(p, light, reflectance, rgb))
        }
    };
    if let Err(reason) = result {
        ui.complain(reason.to_string());
    }
    true
}

/// Put the light dial's slider at `point` (and select it, for the dial keys). False without a dial.
fn move_dial(preview: &mut PreviewState, ui: &mut UiState, point: [f64; 2]) -> bool {
    let Some(live) = preview.dial.as_mut() else { return false };
    match live.state.set_slider(point) {
        Ok(()) => {
            preview.selected = None;
            preview.stale = true;
            true
        }
        Err(e) => {
            ui.complain(e.to_string());
            false
        }
    }
}
