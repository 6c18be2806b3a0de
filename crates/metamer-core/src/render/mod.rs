//! Spectral volume rendering with post-illumination (seed §2.2 and §5.1): a volume is raycast once per
//! view under a flat white light, with reflectance spectra assigned by a transfer function of materials;
//! each frame of a light-dial sweep then only relights the stored image with one 3×K matrix per frame.
//!
//! - [`scene`]: scene files (DESIGN_SPEC §4) and the built-in default scene;
//! - [`raycast`]: the raycaster (material weights per pixel → K-channel image);
//! - [`relight`]: the factor / full / RGB colour models and the per-frame matrix;
//! - [`dial`]: the light dial (2D vertices, slider, Shepard weights, keyframes);
//! - [`overlay`]: the dial drawn into the frames;
//! - [`sweep`]: frames to PNG, exposure, contact sheet;
//! - [`accuracy`]: factor and RGB model frames against the full-spectrum reference (ΔE00).

pub(crate) mod accuracy;
pub(crate) mod dial;
pub(crate) mod overlay;
pub(crate) mod raycast;
pub(crate) mod relight;
pub(crate) mod scene;
pub(crate) mod sweep;
pub(crate) mod text;

pub use accuracy::{AccuracyReport, FrameError, ModelError, compare_models, compare_views};
pub use dial::{Dial, DialError, DialLight, DialState, Sweep, Timing};
pub use overlay::{Corner, DialOverlay};
pub use raycast::{
    BrickMap, Camera, ChannelImage, Gradient, Interpolation, LABEL_RADIUS, LABEL_RAMP, LABEL_REACH, LABEL_SIGMA,
    MAX_RAY_STEPS, MIN_FIELD_CACHE, MaterialClass, MaterialWeights, REFINED_STEP, RaycastOptions, RaycastStats,
    Shading, default_field_cache, raycast,
};
pub use relight::{ColourModel, FrameMatrix, Mode, SrgbLut, relight_srgb8};
pub use scene::{
    Scene, builtin_scene, colorchecker_scene, engine_check_scene, generated_check_scene, generated_u16_check_scene,
};
pub use sweep::{
    PngCompression, SweepOptions, contact_sheet_from_frames, downsample, encode_png, frame_name, frame_srgb8,
    render_exposure, sweep_exposure, write_sweep,
};
pub use text::FONT;

use crate::basis::Basis;
use crate::colorimetry::Colorimetry;
use std::path::PathBuf;
use std::time::Instant;

/// Why rendering failed.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// A scene file problem: the file, the key and the reason.
    #[error("{}: {key}: {reason}", path.display())]
    Scene {
        /// The scene file as the caller named it (for a built-in scene, the name it goes by).
        path: PathBuf,
        /// Where in the file: a key path (`dial.keyframes`, `render.step`), `line N` for a TOML error, or
        /// `file` for the file as a whole.
        key: String,
        /// Why, in words (a palette's or the file system's own message where they refused).
        reason: String,
    },
    /// The scene's volume could not be read, parsed or generated.
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
    /// An output (a frame, the contact sheet, the output folder) could not be made or written.
    #[error("{}: {reason}", path.display())]
    Output {
        /// The file or folder that could not be written.
        path: PathBuf,
        /// Why: the file system's or the image encoder's message.
        reason: String,
    },
    /// A frame or the contact sheet refused or not written by the one atomic writer ([`crate::fsio`]), whose
    /// message names the file.
    #[error(transparent)]
    File(#[from] crate::fsio::FsError),
    /// Anything else the renderer refuses (no basis for the factor model, an empty frame range, …): the
    /// whole message.
    #[error("{0}")]
    Invalid(String),
}

/// One raycast view: the K-channel image of the chosen colour model, ready for relighting.
pub struct RenderedView {
    /// The composited image in the model's K channels, one pixel per ray.
    pub image: ChannelImage,
    /// The colour model the image is in; it makes the frame matrices that relight it.
    pub model: ColourModel,
    /// The counters of the raycast, the same for every model projected from it.
    pub stats: RaycastStats,
    /// Wall-clock seconds of the raycast (including projection onto the model's channels).
    pub seconds: f64,
}

/// Switches of the raycaster that do not change the picture (beyond the termination threshold).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Acceleration {
    /// Stop a ray once its transmittance falls below `termination_transmittance`.
    pub early_termination: bool,
    /// Step over bricks whose value range holds no material.
    pub empty_space_skipping: bool,
    /// Transmittance below which early termination stops a ray
    /// ([`raycast::TERMINATION_TRANSMITTANCE`] by default).
    pub termination_transmittance: f64,
}

impl Default for Acceleration {
    fn default() -> Self {
        Acceleration {
            early_termination: true,
            empty_space_skipping: true,
            termination_transmittance: raycast::TERMINATION_TRANSMITTANCE,
        }
    }
}

/// The colour model of a mode for a scene (factor mode trains its basis on the scene).
pub fn colour_model(scene: &Scene, mode: Mode, colorimetry: &Colorimetry) -> Result<ColourModel, RenderError> {
    Ok(match mode {
        Mode::Factor => ColourModel::factor(colorimetry.clone(), scene_basis(scene)?),
        Mode::Full => ColourModel::full(colorimetry.clone()),
        Mode::Rgb => ColourModel::rgb(colorimetry.clone()),
    })
}

/// Raycast options of a scene at `width × height`.
pub fn raycast_options(scene: &Scene, width: usize, height: usize, accel: Acceleration) -> RaycastOptions {
    RaycastOptions {
        width,
        height,
        step: scene.settings.step,
        ambient: scene.settings.ambient,
        shading: scene.settings.shading,
        jitter: scene.settings.jitter,
        refine: scene.settings.refine,
        gradient: scene.settings.gradient,
        interpolation: scene.settings.interpolation,
        early_termination: accel.early_termination,
        empty_space_skipping: accel.empty_space_skipping,
        termination_transmittance: accel.termination_transmittance,
        ..RaycastOptions::default()
    }
}

/// Raycast a scene once and project onto every model given (one image per model, same geometry).
pub fn render_views(
    scene: &Scene,
    models: Vec<ColourModel>,
    width: usize,
    height: usize,
    accel: Acceleration,
    bricks: Option<&BrickMap>,
) -> Vec<RenderedView> {
    let start = Instant::now();
    let classes: Vec<_> = scene.materials.iter().map(|m| m.class.clone()).collect();
    let opts = raycast_options(scene, width, height, accel);
    let (weights, stats) = raycast(&scene.volume, &classes, bricks, &scene.camera, &opts);
    let cast = start.elapsed().as_secs_f64();
    models
        .into_iter()
        .map(|model| {
            let t = Instant::now();
            let colours: Vec<Vec<f32>> = scene.materials.iter().map(|m| model.material_vector(&m.spectrum)).collect();
            let image = weights.project(&colours);
            RenderedView { image, model, stats, seconds: cast + t.elapsed().as_secs_f64() }
        })
        .collect()
}

/// The sharpened basis the factor model renders a scene with: the basis of the palette's spectra of
/// dimension `settings.basis_dimension` decided by the one basis policy ([`crate::basis::basis_for`]),
/// read from / stored in the palette's `.basis.json` sidecar when the scene came from files, so repeated
/// renders skip training.
pub(crate) fn scene_basis(scene: &Scene) -> Result<Basis, RenderError> {
    Ok(scene_basis_report(scene)?.0.clone())
}

/// As [`scene_basis`], with the basis's report (its accuracy on the palette's own pairs and
/// [`crate::basis::Report::poor_model`]).
pub fn scene_basis_report(scene: &Scene) -> Result<crate::basis::policy::Resolved, RenderError> {
    let m = crate::basis::clamp_dimension(scene.palette.settings.basis_dimension);
    let sidecar = scene.palette_path.as_deref().map(crate::basis::store::sidecar_path);
    let err =
        |e: crate::basis::store::StoreError| RenderError::Invalid(format!("palette `{}`: {e}", scene.palette.name));
    let set = crate::basis::TrainingSet::from_palette(&scene.palette)
        .map_err(|e| err(crate::basis::store::StoreError::Train(e)))?;
    crate::basis::basis_for(&set, m, sidecar.as_deref()).map_err(err)
}
