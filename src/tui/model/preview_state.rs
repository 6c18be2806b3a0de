//! The scene preview (`--scene`): the scene and its raycast, the one live light dial, the keyframes added
//! this session, the relit frame and how it reaches the terminal.

use crate::render::dial::DialState;
use crate::render::scene::Scene;
use crate::tui::graphics::Graphics;
use crate::tui::preview::Preview;
use std::sync::Arc;

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
    /// The pixels under the current spectra and dial (sRGB, 3 bytes per pixel at the raycast's size;
    /// recomputed with the derived colours and on every dial change).
    pub frame: Vec<u8>,
    /// How the preview reaches the terminal: half blocks, or a graphics protocol at real pixels.
    pub graphics: Graphics,
}

impl PreviewState {
    /// The scene of the preview (raycast or on its way).
    pub(crate) fn scene(&self) -> Option<&Scene> {
        self.ready.as_ref().map(|p| p.scene.as_ref()).or(self.waiting.as_deref())
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
        self.pending.map(|(w, h)| format!("raycasting {w}×{h} pixels…"))
    }
}
