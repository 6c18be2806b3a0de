//! How far the spectral factor model and the RGB factor model stray from the full 31-sample reference
//! over a sweep: one raycast projected onto all three models, each frame written to 8-bit sRGB as the
//! PNG frames are, and CIEDE2000 per pixel against the reference frame (CIELAB white = the frame's light
//! on a flat white reflectance, DESIGN_SPEC §1), over the pixels that are not black in the reference.

use super::dial::Dial;
use super::relight::{SrgbLut, relight_linear};
use super::scene::Scene;
use super::sweep::{frame_srgb8, sweep_exposure};
use super::{Acceleration, RenderError, colour_model, relight::Mode, render_views};
use crate::colorimetry::{Colorimetry, srgb_decode};
use nalgebra::Vector3;
use rayon::prelude::*;

/// ΔE00 statistics of one model against the reference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ModelError {
    /// Mean ΔE00 over the pixels compared (0 when there are none).
    pub mean: f64,
    /// 95th percentile ΔE00 (nearest rank).
    pub p95: f64,
    /// Largest ΔE00.
    pub max: f64,
}

/// The factor and RGB models against the full reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccuracyReport {
    /// On the 8-bit frames as written.
    pub factor: ModelError,
    /// The RGB factor model on the 8-bit frames as written.
    pub rgb: ModelError,
    /// On the exposed linear frames before 8-bit quantisation (clamped to the display range).
    pub factor_unquantised: ModelError,
    /// The RGB factor model on the exposed linear frames before quantisation (clamped to the display range).
    pub rgb_unquantised: ModelError,
    /// Non-black reference pixels compared, summed over frames.
    pub pixels: usize,
    /// Frames of the sweep compared (as asked; a request of 0 still compares one frame).
    pub frames: usize,
    /// Basis dimension of the factor model.
    pub dimension: usize,
}

/// Compare the models over an N-frame sweep of `scene` at `size × size`.
pub fn compare_models(
    scene: &Scene,
    colorimetry: &Colorimetry,
    size: usize,
    frames: usize,
) -> Result<AccuracyReport, RenderError> {
    let models = vec![
        colour_model(scene, Mode::Full, colorimetry)?,
        colour_model(scene, Mode::Factor, colorimetry)?,
        colour_model(scene, Mode::Rgb, colorimetry)?,
    ];
    let dimension = models[1].channels();
    let views = render_views(scene, models, size, size, Acceleration::default(), None);
    let reflectances: Vec<_> = scene.materials.iter().map(|m| m.spectrum).collect();
    let exposure = sweep_exposure(colorimetry, &reflectances, &scene.dial, frames, scene.settings.exposure);
    let lut = SrgbLut::new();
    let per_frame: Vec<[Vec<f64>; 4]> = (0..frames.max(1))
        .into_par_iter()
        .map(|k| {
            let light = scene.dial.light_at(Dial::position(k, frames));
            let frame =
                |i: usize| frame_srgb8(&views[i].image, &views[i].model, &scene.dial, k, frames, exposure, &lut);
            let (full, factor, rgb) = (frame(0), frame(1), frame(2));
            let lin = |f: &[u8], p: usize| {
                Vector3::new(
                    srgb_decode(f64::from(f[3 * p]) / 255.0),
                    srgb_decode(f64::from(f[3 * p + 1]) / 255.0),
                    srgb_decode(f64::from(f[3 * p + 2]) / 255.0),
                )
            };
            let linear = |i: usize| {
                let m = views[i].model.frame_matrix(&light, exposure);
                relight_linear(&views[i].image, &m)
            };
            let (full_l, factor_l, rgb_l) = (linear(0), linear(1), linear(2));
            let unq = |f: &[f32], p: usize| {
                Vector3::new(f64::from(f[3 * p]), f64::from(f[3 * p + 1]), f64::from(f[3 * p + 2]))
                    .map(|v| v.clamp(0.0, 1.0))
            };
            let mut de: [Vec<f64>; 4] = Default::default();
            for p in 0..full.len() / 3 {
                if full[3 * p..3 * p + 3].iter().all(|v| *v == 0) {
                    continue;
                }
                let reference = lin(&full, p);
                de[0].push(colorimetry.delta_e00_under(&reference, &lin(&factor, p), &light));
                de[1].push(colorimetry.delta_e00_under(&reference, &lin(&rgb, p), &light));
                let reference = unq(&full_l, p);
                de[2].push(colorimetry.delta_e00_under(&reference, &unq(&factor_l, p), &light));
                de[3].push(colorimetry.delta_e00_under(&reference, &unq(&rgb_l, p), &light));
            }
            de
        })
        .collect();
    let mut all: [Vec<f64>; 4] = Default::default();
    for frame in per_frame {
        for (a, f) in all.iter_mut().zip(frame) {
            a.extend(f);
        }
    }
    Ok(AccuracyReport {
        factor: stats(&mut all[0]),
        rgb: stats(&mut all[1]),
        factor_unquantised: stats(&mut all[2]),
        rgb_unquantised: stats(&mut all[3]),
        pixels: all[0].len(),
        frames,
        dimension,
    })
}

/// ΔE00 statistics of one rendering against a reference rendering of the same scene.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameError {
    /// Mean ΔE00 over the pixels compared; infinite when the images' sizes differ, 0 when no pixel is covered.
    pub mean: f64,
    /// 99th percentile ΔE00 (nearest rank); infinite when the images' sizes differ.
    pub p99: f64,
    /// Largest ΔE00; infinite when the images' sizes differ.
    pub max: f64,
    /// Pixels compared (covered in either frame, summed over frames).
    pub pixels: usize,
}

/// How far `other` strays from `reference` (two raycasts of `scene` in the same colour model, e.g. with a
/// skip or a quality step turned off in one): CIEDE2000 per pixel over an N-frame sweep of the scene's
/// dial, on the 8-bit frames as written (one exposure, the reference's conservative one), over the
/// pixels that are not black in either frame. The images must have the same size (`other` is box-filtered down
/// when it is a whole multiple larger, as a supersampled reference is).
pub fn compare_views(
    scene: &Scene,
    colorimetry: &Colorimetry,
    reference: &super::RenderedView,
    other: &super::RenderedView,
    frames: usize,
) -> FrameError {
    let reflectances: Vec<_> = scene.materials.iter().map(|m| m.spectrum).collect();
    let exposure = sweep_exposure(colorimetry, &reflectances, &scene.dial, frames, scene.settings.exposure);
    let lut = SrgbLut::new();
    let (r, o) = (&reference.image, &other.image);
    let o = if o.width > r.width && r.width > 0 && o.width % r.width == 0 {
        std::borrow::Cow::Owned(super::sweep::downsample(o, o.width / r.width))
    } else {
        std::borrow::Cow::Borrowed(o)
    };
    if (o.width, o.height, o.channels) != (r.width, r.height, r.channels) {
        return FrameError { mean: f64::INFINITY, p99: f64::INFINITY, max: f64::INFINITY, pixels: 0 };
    }
    let mut all: Vec<f64> = (0..frames.max(1))
        .into_par_iter()
        .flat_map_iter(|k| {
            let light = scene.dial.light_at(Dial::position(k, frames));
            let a = frame_srgb8(r, &reference.model, &scene.dial, k, frames, exposure, &lut);
            let b = frame_srgb8(&o, &other.model, &scene.dial, k, frames, exposure, &lut);
            let lin = |f: &[u8], p: usize| {
                Vector3::new(
                    srgb_decode(f64::from(f[3 * p]) / 255.0),
                    srgb_decode(f64::from(f[3 * p + 1]) / 255.0),
                    srgb_decode(f64::from(f[3 * p + 2]) / 255.0),
                )
            };
            (0..a.len() / 3)
                .filter(|p| a[3 * p..3 * p + 3].iter().chain(&b[3 * p..3 * p + 3]).any(|v| *v != 0))
                .map(|p| colorimetry.delta_e00_under(&lin(&a, p), &lin(&b, p), &light))
                .collect::<Vec<f64>>()
        })
        .collect();
    if all.is_empty() {
        return FrameError::default();
    }
    all.sort_by(f64::total_cmp);
    let mean = all.iter().sum::<f64>() / all.len() as f64;
    let p99 = all[((all.len() - 1) as f64 * 0.99).round() as usize];
    FrameError { mean, p99, max: all[all.len() - 1], pixels: all.len() }
}

fn stats(v: &mut [f64]) -> ModelError {
    if v.is_empty() {
        return ModelError::default();
    }
    v.sort_by(f64::total_cmp);
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let p95 = v[((v.len() - 1) as f64 * 0.95).round() as usize];
    ModelError { mean, p95, max: v[v.len() - 1] }
}
