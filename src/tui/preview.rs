//! The light-dial preview (`--scene SCENE.toml`), drawn with the renderer's own code: the scene's volume
//! is raycast once into per-pixel material weights at the panel's pixel size (off the UI thread, see
//! [`PreviewLoader`]); the weights are projected onto the scene's colour model (the factor model of
//! `metamer render`) with the designer's current reflectances; every dial change then only builds one
//! frame matrix and relights ([`crate::render::relight_srgb8`], post-illumination, seed §2.2),
//! with the exposure `metamer render` uses. So the preview at a dial position shows the colours
//! `metamer render` writes for it.
//!
//! The exposure is render's for a palette holding the designer's current spectra: it is taken again when
//! a solve (saved or not) or an edit changes a spectrum, so an unsaved design previews as `metamer render`
//! draws it once saved. The raycast is redone only for a new scene or a new panel size.

use crate::basis::Basis;
use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use crate::render::Scene;
use crate::render::render_exposure;
use crate::render::{Acceleration, colour_model, raycast_options};
use crate::render::{ChannelImage, MaterialWeights, raycast};
use crate::render::{ColourModel, Mode, SrgbLut, relight_srgb8};
use crate::render::{Dial, DialState, Sweep};
use crate::spectrum::Spectrum;
use crate::tui::derived::Derived;
use std::sync::Arc;
use std::sync::mpsc::{self, Sender};
use std::time::Instant;

/// Pixels of the raycast before the panel's size is known (and of [`Preview::from_scene`]).
pub(crate) const PREVIEW_WIDTH: usize = 120;
pub(crate) const PREVIEW_HEIGHT: usize = 72;
/// Largest raycast edge for the preview (graphics protocols on very large panels).
pub const MAX_PREVIEW_EDGE: usize = 1024;
/// The exposure is the one `metamer render` uses for a sweep of this many frames (its default).
pub const EXPOSURE_FRAMES: usize = 48;

/// A raycast scene ready for relighting.
#[derive(Clone, Debug)]
pub struct Preview {
    pub scene: Arc<Scene>,
    /// The colour model of `metamer render` for this scene (factor model over the scene's basis).
    pub model: ColourModel,
    pub weights: MaterialWeights,
    /// `weights` projected onto the model with the current reflectances.
    pub(crate) image: ChannelImage,
    /// The reflectance spectra `image` was projected with (to re-project only when they change).
    projected: Vec<Spectrum>,
    /// Each material's reflectance name, and the scene's own spectrum for it (used when the palette being
    /// designed has no reflectance of that name).
    pub(crate) materials: Vec<(String, Spectrum)>,

    /// The exposure of `metamer render` for this scene (sweep of [`EXPOSURE_FRAMES`] frames) with the
    /// spectra it was last computed for.
    pub exposure: f64,
    /// The reflectances and light spectra `exposure` was computed with (`None`: not yet).
    exposed: Option<(Vec<Spectrum>, Vec<Spectrum>)>,
    colorimetry: Colorimetry,
    /// The key of the designer's basis `model` was built with (`None`: the scene palette's own basis).
    model_key: Option<crate::tui::model::BasisKey>,
}

/// The spectrum named `name` among `names`/`spectra`, else `fallback`.
fn current(names: &[crate::palette::SpectrumEntry], spectra: &[Spectrum], name: &str, fallback: &Spectrum) -> Spectrum {
    names.iter().position(|e| e.name == name).and_then(|i| spectra.get(i).copied()).unwrap_or(*fallback)
}

/// The sRGB encoding table of the relight (built once).
pub fn lut() -> &'static SrgbLut {
    static LUT: std::sync::OnceLock<SrgbLut> = std::sync::OnceLock::new();
    LUT.get_or_init(SrgbLut::new)
}

/// The colour model the preview draws with: `metamer render`'s default (factor), falling back to the
/// full 31-sample model when no basis can be had.
pub fn preview_model(scene: &Scene, colorimetry: &Colorimetry) -> ColourModel {
    colour_model(scene, Mode::Factor, colorimetry).unwrap_or_else(|_| ColourModel::full(colorimetry.clone()))
}

/// Raycast `scene` at `width × height` into material weights (the one expensive step).
pub fn cast(scene: &Scene, width: usize, height: usize) -> MaterialWeights {
    let classes: Vec<_> = scene.materials.iter().map(|m| m.class.clone()).collect();
    let options = raycast_options(scene, width.max(1), height.max(1), Acceleration::default());
    raycast(&scene.volume, &classes, None, &scene.camera, &options).0
}

impl Preview {
    /// Raycast a loaded scene once at [`PREVIEW_WIDTH`] × [`PREVIEW_HEIGHT`] (on this thread).
    pub fn from_scene(scene: &Scene, colorimetry: &Colorimetry) -> Preview {
        let model = preview_model(scene, colorimetry);
        let weights = cast(scene, PREVIEW_WIDTH, PREVIEW_HEIGHT);
        Preview::new(Arc::new(scene.clone()), model, weights, colorimetry)
    }

    /// A preview of `scene` from a finished raycast.
    pub fn new(scene: Arc<Scene>, model: ColourModel, weights: MaterialWeights, colorimetry: &Colorimetry) -> Preview {
        let materials: Vec<(String, Spectrum)> =
            scene.materials.iter().map(|m| (m.reflectance.clone(), m.spectrum)).collect();
        let reflectances: Vec<Spectrum> = materials.iter().map(|m| m.1).collect();
        let image = ChannelImage { width: 0, height: 0, channels: model.channels(), data: Vec::new() };
        let mut preview = Preview {
            scene,
            model,
            weights,
            image,
            projected: Vec::new(),
            materials,
            exposure: 1.0,
            exposed: None,
            colorimetry: colorimetry.clone(),
            model_key: None,
        };
        preview.project(&reflectances);
        let dial = preview.scene.dial.clone();
        preview.expose(&reflectances, &dial);
        preview
    }

    /// The scene as saved (same volume, materials and camera: the raycast stays); the next frame takes
    /// the exposure `metamer render` now uses for its sweep.
    pub(crate) fn rescene(&mut self, scene: Arc<Scene>, colorimetry: &Colorimetry) {
        self.scene = scene;
        self.colorimetry = colorimetry.clone();
        self.exposed = None;
        let reflectances = self.projected.clone();
        let dial = self.scene.dial.clone();
        self.expose(&reflectances, &dial);
    }

    /// Take the exposure `metamer render` uses for a sweep of [`EXPOSURE_FRAMES`] frames of `dial` over
    /// this raycast, projected with `reflectances` (as render projects a palette holding these spectra);
    /// skipped when neither changed. `reflectances` must be the ones `image` is projected with.
    fn expose(&mut self, reflectances: &[Spectrum], dial: &Dial) {
        let key = (reflectances.to_vec(), dial.base.lights.iter().map(|l| l.spectrum).collect::<Vec<_>>());
        if self.exposed.as_ref() == Some(&key) {
            return;
        }
        self.exposure = render_exposure(
            &self.image,
            &self.model,
            dial,
            &self.colorimetry,
            reflectances,
            EXPOSURE_FRAMES,
            self.scene.settings.exposure,
            false,
        );
        self.exposed = Some(key);
    }

    /// The scene's dial (its sweep too) with the designer's current light spectra.
    fn current_sweep(&self, palette: &Palette, derived: &Derived) -> Dial {
        let mut dial = self.scene.dial.clone();
        let fix = |s: &mut DialState| {
            for l in &mut s.lights {
                l.spectrum = current(&palette.lights, &derived.light_spectra, &l.name, &l.spectrum);
            }
        };
        fix(&mut dial.base);
        if let Sweep::Keyframes(k) = &mut dial.sweep {
            k.iter_mut().for_each(fix);
        }
        dial
    }

    /// Draw with the designer's basis `key` (trained on the spectra the designer shows) when it is not
    /// the one in use: `metamer render` of a palette holding those spectra trains exactly that basis.
    /// Only for the factor model, and only when the designer's palette has the scene palette's lights and
    /// reflectances (by name, in order), so the training set is the one render would build. Returns true
    /// when the model changed (the picture is then re-projected and re-exposed by the next frame).
    pub(crate) fn follow_basis(&mut self, palette: &Palette, key: &crate::tui::model::BasisKey, basis: &Basis) -> bool {
        let names = |e: &[crate::palette::SpectrumEntry]| e.iter().map(|e| e.name.clone()).collect::<Vec<_>>();
        let same_set = names(&palette.lights) == names(&self.scene.palette.lights)
            && names(&palette.reflectances) == names(&self.scene.palette.reflectances);
        if self.model.mode != Mode::Factor || !same_set || self.model_key.as_ref() == Some(key) {
            return false;
        }
        self.model = ColourModel::factor(self.colorimetry.clone(), basis.clone());
        self.model_key = Some(key.clone());
        // Re-project and re-expose with the new model.
        self.projected.clear();
        self.image.data.clear();
        self.exposed = None;
        true
    }

    /// Pixel size of the raycast.
    pub fn size(&self) -> (usize, usize) {
        (self.weights.width, self.weights.height)
    }

    /// Replace the raycast (after a resize); the exposure is taken again from the new picture.
    pub fn set_weights(&mut self, weights: MaterialWeights) {
        self.weights = weights;
        let spectra = std::mem::take(&mut self.projected);
        self.project(&spectra);
        self.exposed = None;
        let dial = self.scene.dial.clone();
        self.expose(&spectra, &dial);
    }

    /// Project the weights with these material reflectances (skipped when they are unchanged).
    fn project(&mut self, spectra: &[Spectrum]) {
        let same_size = self.image.width == self.weights.width && self.image.height == self.weights.height;
        if same_size && self.projected == spectra && !self.image.data.is_empty() {
            return;
        }
        let colours: Vec<Vec<f32>> = spectra.iter().map(|s| self.model.material_vector(s)).collect();
        self.image = self.weights.project(&colours);
        self.projected = spectra.to_vec();
    }

    /// The designer's current reflectance of every material.
    fn current_reflectances(&self, palette: &Palette, derived: &Derived) -> Vec<Spectrum> {
        self.materials
            .iter()
            .map(|(name, fallback)| current(&palette.reflectances, &derived.reflectance_spectra, name, fallback))
            .collect()
    }

    /// `dial` with the designer's current light spectra (lights the palette lacks keep theirs).
    pub(crate) fn current_dial(&self, palette: &Palette, derived: &Derived, dial: &DialState) -> DialState {
        let mut d = dial.clone();
        for l in &mut d.lights {
            l.spectrum = current(&palette.lights, &derived.light_spectra, &l.name, &l.spectrum);
        }
        d
    }

    /// The light of `dial` with the designer's current light spectra.
    pub(crate) fn light_at(&self, palette: &Palette, derived: &Derived, dial: &DialState) -> Spectrum {
        self.current_dial(palette, derived, dial).light()
    }

    /// Relight under light `e`: sRGB, 3 bytes per pixel (row-major), with the render's exposure — the
    /// renderer's frame matrix and relight kernel.
    pub(crate) fn relight(&self, e: &Spectrum, lut: &SrgbLut) -> Vec<u8> {
        let matrix = self.model.frame_matrix(e, self.exposure);
        let mut out = vec![0u8; self.image.width * self.image.height * 3];
        if self.image.channels == matrix.channels {
            relight_srgb8(&self.image, &matrix, lut, &mut out);
        }
        out
    }

    /// Display sRGB of every pixel under the light of `dial` with the designer's current spectra
    /// (re-projecting first when a reflectance changed, and taking the exposure `metamer render` gives a
    /// palette holding the current spectra when a spectrum changed).
    pub fn frame(&mut self, palette: &Palette, derived: &Derived, dial: &DialState, lut: &SrgbLut) -> Vec<u8> {
        let spectra = self.current_reflectances(palette, derived);
        self.project(&spectra);
        let sweep = self.current_sweep(palette, derived);
        self.expose(&spectra, &sweep);
        let e = self.light_at(palette, derived, dial);
        self.relight(&e, lut)
    }
}

/// What the loader thread is asked to do.
struct LoadRequest {
    scene: Arc<Scene>,
    /// `None` the first time: the colour model (basis) is built on the thread too.
    model: Option<ColourModel>,
    width: usize,
    height: usize,
    colorimetry: Colorimetry,
}

/// A finished raycast.
pub struct Loaded {
    pub scene: Arc<Scene>,
    pub(crate) model: ColourModel,
    pub(crate) weights: MaterialWeights,
    pub seconds: f64,
}

/// Raycasts the preview off the UI thread: one request at a time, always the newest. Each finished
/// raycast is handed to the deliverer given to [`PreviewLoader::start`] (the designer's loop sends it on
/// its one channel).
pub(crate) struct PreviewLoader {
    requests: Sender<LoadRequest>,
}

impl PreviewLoader {
    /// Start the raycast thread; `deliver` returns false when nobody listens any more (the thread ends).
    pub fn start(deliver: impl Fn(Loaded) -> bool + Send + 'static) -> std::io::Result<PreviewLoader> {
        let (requests, rx) = mpsc::channel::<LoadRequest>();
        std::thread::Builder::new().name("metamer-preview".into()).spawn(move || {
            while let Ok(mut request) = rx.recv() {
                // Only the newest request counts.
                while let Ok(newer) = rx.try_recv() {
                    request = newer;
                }
                let start = Instant::now();
                let model = request.model.unwrap_or_else(|| preview_model(&request.scene, &request.colorimetry));
                let weights = cast(&request.scene, request.width, request.height);
                let loaded = Loaded { scene: request.scene, model, weights, seconds: start.elapsed().as_secs_f64() };
                if !deliver(loaded) {
                    return;
                }
            }
        })?;
        Ok(PreviewLoader { requests })
    }

    /// Ask for a raycast of `scene` at `size` (`model` when already built). False when the thread is gone.
    pub fn submit(
        &mut self,
        scene: Arc<Scene>,
        model: Option<ColourModel>,
        size: (usize, usize),
        colorimetry: &Colorimetry,
    ) -> bool {
        let request = LoadRequest { scene, model, width: size.0, height: size.1, colorimetry: colorimetry.clone() };
        self.requests.send(request).is_ok()
    }
}
