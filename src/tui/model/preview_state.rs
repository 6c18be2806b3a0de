//! The scene preview (`--scene`): the scene and its raycast, the one live light dial, the keyframes added
//! this session, the relit frame and how it reaches the terminal.

use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use crate::render::DialState;
use crate::render::Scene;
use crate::tui::action::Action;
use crate::tui::app::Message;
use crate::tui::graphics::Graphics;
use crate::tui::model::SolveState;
use crate::tui::msg::{Effect, SavedScene};
use crate::tui::preview::{Loaded, Preview};
use std::sync::Arc;

/// A small step of the slider or a vertex, as a fraction of the dial's extent; a large step is ten.
pub(crate) const SMALL_STEP: f64 = 0.02;
pub(crate) const LARGE_STEP: f64 = 0.2;
/// Intensity change per `+`/`-`, and its range.
pub(crate) const INTENSITY_STEP: f64 = 0.1;
pub(crate) const MAX_INTENSITY: f64 = 10.0;

/// What the preview says when there is no scene.
pub(crate) const NO_SCENE: &str = "no scene preview: start with --scene SCENE.toml";

/// The live light dial: the lights, vertices, on/off, intensities and slider the preview is lit by, and
/// where along the scene's sweep `[` and `]` step from. The one place the dial's position is kept: the
/// sweep keys set the state from `along`, the dial keys change the state itself.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveDial {
    pub state: DialState,
    /// The last position along the scene's sweep, in [0, 1] (steps of 1/20).
    pub(crate) along: f64,
}

impl LiveDial {
    /// The scene's dial at `along` on its sweep.
    pub(crate) fn at(scene: &Scene, along: f64) -> LiveDial {
        LiveDial { state: scene.dial.state_at(along), along }
    }

    /// One step of 1/20 along the scene's sweep, forward or back (the dial takes the sweep's state there).
    pub(crate) fn step_along(&mut self, scene: &Scene, forward: bool) {
        let step = if forward { 0.05 } else { -0.05 };
        *self = LiveDial::at(scene, ((self.along + step) * 20.0).round().clamp(0.0, 20.0) / 20.0);
    }
}

/// The scene preview, when there is a scene.
#[derive(Debug, Default)]
pub struct PreviewState {
    /// The raycast scene, ready to relight.
    pub ready: Option<Preview>,
    /// A scene waiting for its first raycast (off the UI thread); the progress line says so.
    pub(crate) waiting: Option<Arc<Scene>>,
    /// The preview size being raycast, if any.
    pub(crate) pending: Option<(usize, usize)>,
    /// The preview is shown (else the spectra plot).
    pub(crate) shown: bool,
    /// The dial the preview is lit by.
    pub dial: Option<LiveDial>,
    /// The dial panel has the keys ([`crate::tui::keymap::DIAL`]).
    pub keys: bool,
    /// What the dial keys move: the slider (`None`) or light i's vertex.
    pub(crate) selected: Option<usize>,
    /// Keyframes added this session (written into the scene by the dial's save).
    pub keyframes: Vec<DialState>,
    /// The keyframes are being written into the scene file (the outcome comes back as a message).
    pub(crate) saving: bool,
    /// The pixels under the current spectra and dial (sRGB, 3 bytes per pixel at the raycast's size;
    /// recomputed with the derived colours and on every dial change).
    pub frame: Vec<u8>,
    /// How the preview reaches the terminal: half blocks, or a graphics protocol at real pixels.
    pub graphics: Graphics,
    /// The terminal is being asked for its graphics ([`crate::tui::msg::Msg::Graphics`] answers): the
    /// first raycast waits for the panel's pixel size.
    pub probing: bool,
    /// The relit image is shown over the whole terminal (`P`; Esc returns), raycast at its size.
    pub full: bool,
    /// `frame` no longer shows the current spectra, dial or scene: the update step relights once the
    /// message is handled ([`PreviewState::relight`]), however many changes the message made.
    pub(crate) stale: bool,
}

impl PreviewState {
    /// The scene of the preview (raycast or on its way).
    pub(crate) fn scene(&self) -> Option<Arc<Scene>> {
        self.ready.as_ref().map(|p| p.scene.clone()).or_else(|| self.waiting.clone())
    }

    /// True when a scene preview is attached or on its way.
    pub(crate) fn has_scene(&self) -> bool {
        self.ready.is_some() || self.waiting.is_some()
    }

    /// The dial's state, when there is a scene.
    pub fn dial_state(&self) -> Option<&DialState> {
        self.dial.as_ref().map(|d| &d.state)
    }

    /// What the progress line says while a raycast runs.
    pub(crate) fn loading(&self) -> Option<String> {
        if self.probing {
            return Some("asking the terminal for its graphics…".to_string());
        }
        self.pending.map(|(w, h)| format!("raycasting {w}×{h} pixels…"))
    }

    /// Attach a raycast scene and show it (the caller relights).
    pub(crate) fn attach(&mut self, preview: Preview) {
        if self.dial.is_none() {
            self.dial = Some(LiveDial::at(&preview.scene, 0.0));
        }
        self.ready = Some(preview);
        self.waiting = None;
        self.shown = true;
        self.stale = true;
    }

    /// Attach a scene whose raycast runs off the UI thread (the update step asks for it at the panel's
    /// size), keeping the position along the sweep.
    pub(crate) fn attach_scene(&mut self, scene: Scene) {
        let along = self.dial.as_ref().map_or(0.0, |d| d.along);
        self.dial = Some(LiveDial::at(&scene, along));
        self.waiting = Some(Arc::new(scene));
        self.shown = true;
    }

    /// Relight the scene with `palette`'s current spectra (the solve's, where solved) at the dial's
    /// position, and encode the frame for the terminal. The basis of the spectra shown, once trained, is
    /// the one `metamer render` would use for them.
    pub(crate) fn relight(&mut self, palette: &Palette, solve: &SolveState) {
        self.stale = false;
        let lut = crate::tui::preview::lut();
        if let (Some(ready), Some(shown)) = (&mut self.ready, solve.basis_of_shown()) {
            ready.follow_basis(palette, &shown.key, shown.basis());
        }
        self.frame = match (&mut self.ready, &self.dial) {
            (Some(ready), Some(d)) => ready.frame(palette, &solve.derived, &d.state, lut),
            _ => Vec::new(),
        };
        let size = self.ready.as_ref().map_or((0, 0), |r| r.size());
        self.graphics.encode(&self.frame, size);
    }

    /// Handle one message of the preview: a dial key (after `g`, and `[`/`]`), the scene saved with the
    /// keyframes, a finished raycast, the terminal's graphics. What changes the picture marks the frame
    /// [`PreviewState::stale`].
    pub(crate) fn update(&mut self, msg: PreviewMsg, colorimetry: &Colorimetry) -> PreviewUpdate {
        match msg {
            PreviewMsg::Graphics { graphics, warning } => {
                self.graphics = graphics;
                self.probing = false;
                // The frame encoded for the new protocol (the raycast follows at the panel's new pixel size).
                self.stale = true;
                PreviewUpdate { effects: Vec::new(), message: warning.map(Message::error) }
            }
            PreviewMsg::Dial(action) => {
                let (update, relight) = self.on_dial(action);
                self.stale |= relight;
                update
            }
            PreviewMsg::SceneSaved(result) => {
                self.saving = false;
                let message = match result {
                    Ok(SavedScene { text, count, reloaded }) => {
                        // The written keyframes are in the file (a second save would repeat them); those
                        // added while it was written stay to be saved.
                        self.keyframes.drain(..count.min(self.keyframes.len()));
                        match reloaded {
                            Ok(scene) => {
                                // The saved sweep sets render's exposure: take it, so the preview stays
                                // what `metamer render` writes.
                                if let Some(p) = self.ready.as_mut() {
                                    p.rescene(Arc::new(scene), colorimetry);
                                }
                                Message::info(text)
                            }
                            Err(e) => Message::error(format!("{text}, but it does not load again: {e}")),
                        }
                    }
                    Err(e) => Message::error(format!("scene not saved: {e}")),
                };
                self.stale = true;
                PreviewUpdate { effects: Vec::new(), message: Some(message) }
            }
            PreviewMsg::Raycast(loaded) => {
                let size = (loaded.weights.width, loaded.weights.height);
                if self.pending == Some(size) {
                    self.pending = None;
                }
                match &mut self.ready {
                    Some(p) if Arc::ptr_eq(&p.scene, &loaded.scene) => p.set_weights(loaded.weights),
                    _ => {
                        let preview = Preview::new(loaded.scene, loaded.model, loaded.weights, colorimetry);
                        if self.dial.is_none() {
                            self.dial = Some(LiveDial::at(&preview.scene, 0.0));
                        }
                        self.ready = Some(preview);
                        self.waiting = None;
                    }
                }
                self.stale = true;
                PreviewUpdate { effects: Vec::new(), message: None }
            }
        }
    }

    /// The light dial's keys (after `g`): the slider and the vertices move in small and large steps,
    /// number keys switch lights, `+`/`-` change the selected light's intensity, `a` adds the dial as a
    /// keyframe and Ctrl-s asks the loop to write the keyframes into the scene file, which
    /// `metamer render` then sweeps (the `[[dial.keyframes]]` format of `docs/formats/dial.md`); `[`/`]`
    /// step along the scene's sweep. Every change relights the preview (the second value: relight).
    fn on_dial(&mut self, action: Action) -> (PreviewUpdate, bool) {
        let mut update = PreviewUpdate { effects: Vec::new(), message: None };
        let Some(scene) = self.scene() else {
            update.message = Some(Message::error(NO_SCENE));
            return (update, false);
        };
        let Some(live) = self.dial.as_mut() else {
            return (update, false);
        };
        if action == Action::PreviewFull {
            self.full = !self.full;
            self.shown = true;
            return (update, false);
        }
        if let Action::Dial { forward } = action {
            self.shown = true;
            live.step_along(&scene, forward);
            return (update, true);
        }
        let [[x0, y0], [x1, y1]] = scene.dial.base.bounds();
        let extent = (x1 - x0).max(y1 - y0).max(1e-3);
        let dial = &mut live.state;
        let n = dial.lights.len();
        let result: Result<(), String> = match action {
            Action::DialLeave => {
                self.keys = false;
                return (update, false);
            }
            Action::DialSlide { dx, dy, big } => {
                let step = extent * if big { LARGE_STEP } else { SMALL_STEP };
                let (dx, dy) = (f64::from(dx) * step, f64::from(dy) * step);
                match self.selected {
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
                        let name = &dial.lights[i].name;
                        update.message =
                            Some(Message::info(format!("light {k} {name} {}", if on { "on" } else { "off" })));
                        Ok(())
                    }
                    Err(_) => Err(format!("there is no light {k} (the dial has {n})")),
                }
            }
            Action::DialSelect { forward } => {
                // Cycle: slider, vertex 1, …, vertex n.
                let at = self.selected.map_or(0, |i| i + 1);
                let next = if forward { (at + 1) % (n + 1) } else { (at + n) % (n + 1) };
                self.selected = next.checked_sub(1);
                Ok(())
            }
            Action::DialIntensity { up } => match self.selected {
                None => Err("select a light with Tab first (the slider has no intensity)".to_string()),
                Some(i) => {
                    let v = dial.lights.get(i).map_or(1.0, |l| l.intensity);
                    let step = if up { INTENSITY_STEP } else { -INTENSITY_STEP };
                    let next = ((v + step) * 10.0).round() / 10.0;
                    let set = dial.set_intensity(i, next.clamp(0.0, MAX_INTENSITY)).map_err(|e| e.to_string());
                    if set.is_ok() {
                        // The intensity slider is the preview's: it relights the frame, the palette stays.
                        let l = &dial.lights[i];
                        update.message = Some(Message::info(format!(
                            "{} ×{:.1}: view only, the palette is unchanged",
                            l.name, l.intensity
                        )));
                    }
                    set
                }
            },
            Action::DialKeyframe => {
                if dial.lights.iter().all(|l| !l.on) {
                    Err("every light is off: switch one on before adding a keyframe".to_string())
                } else {
                    let mut k = dial.clone();
                    k.fixed_weights = None;
                    self.keyframes.push(k);
                    let count = self.keyframes.len();
                    let text = format!("keyframe {count} added (Ctrl-s writes the keyframes into the scene)");
                    update.message = Some(Message::info(text));
                    Ok(())
                }
            }
            Action::DialSaveScene => match &scene.path {
                None => {
                    Err("the built-in scene has no file: open a scene file with --scene to save keyframes".to_string())
                }
                Some(_) if self.keyframes.is_empty() => Err("no keyframes yet: `a` adds one".to_string()),
                Some(_) if self.saving => Err("the scene is being saved".to_string()),
                Some(path) => {
                    self.saving = true;
                    update
                        .effects
                        .push(Effect::SaveKeyframes { path: path.clone(), keyframes: self.keyframes.clone() });
                    Ok(())
                }
            },
            _ => Ok(()),
        };
        if let Err(e) = result {
            update.message = Some(Message::error(e));
        }
        (update, true)
    }
}

/// True for the actions [`PreviewState::update`] handles (the dial's keys and the sweep keys).
pub(crate) fn is_dial_action(action: Action) -> bool {
    matches!(
        action,
        Action::Dial { .. }
            | Action::DialSlide { .. }
            | Action::DialToggle(_)
            | Action::DialSelect { .. }
            | Action::DialIntensity { .. }
            | Action::DialKeyframe
            | Action::DialSaveScene
            | Action::DialLeave
            | Action::PreviewFull
    )
}

/// A message for the preview. (One per raycast or save, moved once: the variants' sizes do not matter.)
#[allow(clippy::large_enum_variant)]
pub(crate) enum PreviewMsg {
    /// The terminal answered the graphics probe (or its deadline passed): how the preview is drawn, and a
    /// warning when it had to guess.
    Graphics { graphics: Graphics, warning: Option<String> },
    /// A dial key or a sweep key.
    Dial(Action),
    /// The keyframes were written into the scene file (and the scene read back), or why not.
    SceneSaved(Result<SavedScene, String>),
    /// A raycast finished.
    Raycast(Loaded),
}

/// What a preview message asks for: effects for the loop, a line for the message area.
#[must_use]
pub(crate) struct PreviewUpdate {
    pub(crate) effects: Vec<Effect>,
    pub(crate) message: Option<Message>,
}
