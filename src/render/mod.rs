//! Spectral volume rendering with post-illumination (seed §2.2 and §5.1): a volume is raycast once per
//! view under a flat white light, with reflectance spectra assigned by a transfer function of materials;
//! each frame of a light-dial sweep then only relights the stored image with one 3×K matrix per frame.
//!
//! - [`scene`]: scene files (DESIGN_SPEC §4) and the built-in default scene;
//! - [`raycast`]: the raycaster (material weights per pixel → K-channel image);
//! - [`relight`]: the factor / full / RGB colour models and the per-frame matrix;
//! - [`dial`]: the light dial path;
//! - [`sweep`]: frames to PNG, exposure, contact sheet;
//! - [`accuracy`]: factor and RGB model frames against the full-spectrum reference (ΔE00).

pub mod accuracy;
pub mod dial;
pub mod raycast;
pub mod relight;
pub mod scene;
pub mod sweep;

use crate::basis::Basis;
use crate::colorimetry::Colorimetry;
use crate::spectrum::{SAMPLES, Spectrum};
use nalgebra::DMatrix;
use raycast::{BrickMap, ChannelImage, RaycastOptions, RaycastStats, raycast};
use relight::{ColourModel, Mode};
use scene::Scene;
use std::path::PathBuf;
use std::time::Instant;

/// Why rendering failed.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// A scene file problem: the file, the key and the reason.
    #[error("{}: {key}: {reason}", path.display())]
    Scene { path: PathBuf, key: String, reason: String },
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
    #[error("{}: {reason}", path.display())]
    Output { path: PathBuf, reason: String },
    #[error("{0}")]
    Invalid(String),
}

/// One raycast view: the K-channel image of the chosen colour model, ready for relighting.
pub struct RenderedView {
    pub image: ChannelImage,
    pub model: ColourModel,
    pub stats: RaycastStats,
    /// Wall-clock seconds of the raycast (including projection onto the model's channels).
    pub seconds: f64,
}

/// Switches of the raycaster that do not change the picture (beyond the termination threshold).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Acceleration {
    pub early_termination: bool,
    pub empty_space_skipping: bool,
}

impl Default for Acceleration {
    fn default() -> Self {
        Acceleration { early_termination: true, empty_space_skipping: true }
    }
}

/// The colour model of a mode for a scene (factor mode trains its basis on the scene).
pub fn colour_model(scene: &Scene, mode: Mode, colorimetry: &Colorimetry) -> Result<ColourModel, RenderError> {
    Ok(match mode {
        Mode::Factor => ColourModel::factor(colorimetry.clone(), scene_basis(scene, colorimetry)?),
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
        interpolation: scene.settings.interpolation,
        early_termination: accel.early_termination,
        empty_space_skipping: accel.empty_space_skipping,
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

/// The sharpened basis the factor model renders a scene with: trained on the scene's colour signals
/// (every dial light on every material reflectance, plus the lights and reflectances themselves).
///
/// Stand-in until the trained basis lands: the first m principal components of those signals,
/// sharpened by concentrating each basis vector on one of m equal wavelength bands (the eigenvector of
/// the band-energy quotient within the PCA span), scaled so a flat spectrum has all-unity coefficients.
pub fn scene_basis(scene: &Scene, colorimetry: &Colorimetry) -> Result<Basis, RenderError> {
    let lights: Vec<Spectrum> = scene.dial.stops.iter().map(|s| s.spectrum).collect();
    let refl: Vec<Spectrum> = scene.materials.iter().map(|m| m.spectrum).collect();
    let m = scene.palette.settings.basis_dimension.clamp(1, SAMPLES);
    sharpened_basis(&lights, &refl, m, colorimetry)
}

/// See [`scene_basis`].
pub fn sharpened_basis(
    lights: &[Spectrum],
    reflectances: &[Spectrum],
    m: usize,
    colorimetry: &Colorimetry,
) -> Result<Basis, RenderError> {
    let mut signals: Vec<Spectrum> = Vec::new();
    for e in lights {
        let peak = e.0.max().max(f64::MIN_POSITIVE);
        for s in reflectances {
            signals.push(e.product(s).scaled(1.0 / peak));
        }
        signals.push(e.scaled(1.0 / peak));
    }
    signals.extend(reflectances.iter().copied());
    signals.push(Spectrum::flat(1.0));
    let a = DMatrix::from_fn(SAMPLES, signals.len(), |r, c| signals[c].0[r]);
    let svd = a.svd(true, false);
    let u = svd.u.ok_or_else(|| RenderError::Invalid("SVD of the colour signals failed".into()))?;
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|x, y| svd.singular_values[*y].total_cmp(&svd.singular_values[*x]));
    let k = m.min(order.len());
    let p = DMatrix::from_fn(SAMPLES, k, |r, c| u[(r, order[c])]);
    // Sharpen: column j concentrates on band j.
    let mut b = DMatrix::zeros(SAMPLES, k);
    for j in 0..k {
        let (lo, hi) = (j * SAMPLES / k, (j + 1) * SAMPLES / k);
        let w = DMatrix::from_fn(SAMPLES, SAMPLES, |r, c| if r == c && r >= lo && r < hi { 1.0 } else { 0.0 });
        let q = p.transpose() * w * &p;
        let eig = nalgebra::SymmetricEigen::new(q);
        let best = (0..k).max_by(|x, y| eig.eigenvalues[*x].total_cmp(&eig.eigenvalues[*y])).unwrap_or(0);
        let mut col = &p * eig.eigenvectors.column(best);
        if col.rows(lo, hi - lo).sum() < 0.0 {
            col = -col;
        }
        b.set_column(j, &col);
    }
    let basis = Basis::from_matrix(b.clone(), colorimetry).map_err(|e| RenderError::Invalid(format!("basis: {e}")))?;
    // Flat white gets all-unity coefficients.
    let ones = basis.coefficients(&Spectrum::flat(1.0));
    if ones.iter().all(|v| v.abs() > 1e-6) {
        for (j, mut col) in b.column_iter_mut().enumerate() {
            col *= ones[j];
        }
    }
    Basis::from_matrix(b, colorimetry).map_err(|e| RenderError::Invalid(format!("basis: {e}")))
}
