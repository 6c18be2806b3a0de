//! The light-dial preview (`--scene SCENE.toml`): the scene's volume is raycast once into per-pixel
//! material weights (post-illumination, seed §2.2); every frame then only relights that image with the
//! designer's current spectra — the materials' reflectances and the dial's lights as they stand (solved
//! where solved) — at the dial position the user moves with `[` and `]`.

use crate::colorimetry::{Colorimetry, linear_to_srgb8};
use crate::palette::Palette;
use crate::render::raycast::{MaterialWeights, raycast};
use crate::render::scene::Scene;
use crate::render::{Acceleration, RenderError, raycast_options};
use crate::spectrum::Spectrum;
use crate::tui::derived::Derived;
use nalgebra::Vector3;
use std::path::Path;

/// Pixels of the one raycast (the panel samples it to its own size).
pub const PREVIEW_WIDTH: usize = 120;
pub const PREVIEW_HEIGHT: usize = 72;

/// A raycast scene ready for relighting.
#[derive(Clone, Debug)]
pub struct Preview {
    pub weights: MaterialWeights,
    /// Each material's reflectance name, and the scene's own spectrum for it (used when the palette being
    /// designed has no reflectance of that name).
    pub materials: Vec<(String, Spectrum)>,
    /// The dial's lights by name, with the scene's own spectra as fallback.
    pub dial: Vec<(String, Spectrum)>,
    /// Multiplies linear colours so the brightest channel anywhere along the dial is 1.
    pub exposure: f64,
}

/// The spectrum named `name` among `names`/`spectra`, else `fallback`.
fn current(names: &[crate::palette::SpectrumEntry], spectra: &[Spectrum], name: &str, fallback: &Spectrum) -> Spectrum {
    names.iter().position(|e| e.name == name).and_then(|i| spectra.get(i).copied()).unwrap_or(*fallback)
}

impl Preview {
    /// Load a scene and raycast it once.
    pub fn load(path: &Path, colorimetry: &Colorimetry) -> Result<Preview, RenderError> {
        let scene = Scene::load(path)?;
        Ok(Preview::from_scene(&scene, colorimetry))
    }

    /// Raycast a loaded scene once.
    pub fn from_scene(scene: &Scene, colorimetry: &Colorimetry) -> Preview {
        let classes: Vec<_> = scene.materials.iter().map(|m| m.class.clone()).collect();
        let options = raycast_options(scene, PREVIEW_WIDTH, PREVIEW_HEIGHT, Acceleration::default());
        let (weights, _) = raycast(&scene.volume, &classes, None, &scene.camera, &options);
        let materials = scene.materials.iter().map(|m| (m.reflectance.clone(), m.spectrum)).collect();
        let dial = scene.dial.visited().iter().map(|l| (l.name.clone(), l.spectrum)).collect();
        let mut preview = Preview { weights, materials, dial, exposure: 1.0 };
        // One exposure for the whole dial (as the renderer's sweep): the brightest channel over five dial
        // positions with the scene's own spectra maps to 1.
        let brightest = [0.0, 0.25, 0.5, 0.75, 1.0]
            .iter()
            .flat_map(|t| preview.linear(&scene.palette, &Derived::default(), colorimetry, *t))
            .flat_map(|c| [c[0], c[1], c[2]])
            .fold(0.0f64, f64::max);
        preview.exposure = if brightest > 1e-12 { 1.0 / brightest } else { 1.0 };
        preview
    }

    /// The dial's light at position `t` in [0, 1] with the current light spectra (linear mix of neighbours).
    pub fn light_at(&self, palette: &Palette, derived: &Derived, t: f64) -> Spectrum {
        let n = self.dial.len();
        if n == 0 {
            return Spectrum::flat(1.0);
        }
        let spectrum = |k: usize| {
            let (name, fallback) = &self.dial[k];
            current(&palette.lights, &derived.light_spectra, name, fallback)
        };
        if n == 1 {
            return spectrum(0);
        }
        let u = t.clamp(0.0, 1.0) * (n - 1) as f64;
        let i = (u.floor() as usize).min(n - 2);
        let f = u - i as f64;
        Spectrum(spectrum(i).0 * (1.0 - f) + spectrum(i + 1).0 * f)
    }

    /// The two dial lights around `t` and the mix, as a caption.
    pub fn caption(&self, t: f64) -> String {
        let n = self.dial.len();
        match n {
            0 => "flat light".to_string(),
            1 => self.dial[0].0.clone(),
            _ => {
                let u = t.clamp(0.0, 1.0) * (n - 1) as f64;
                let i = (u.floor() as usize).min(n - 2);
                format!("{} → {} {:.0}%", self.dial[i].0, self.dial[i + 1].0, (u - i as f64) * 100.0)
            }
        }
    }

    /// Linear sRGB of every pixel (row-major) under the dial's light at `t` (before exposure).
    fn linear(&self, palette: &Palette, derived: &Derived, colorimetry: &Colorimetry, t: f64) -> Vec<Vector3<f64>> {
        let light = self.light_at(palette, derived, t);
        let colours: Vec<Vector3<f64>> = self
            .materials
            .iter()
            .map(|(name, fallback)| {
                colorimetry.rgb(&light, &current(&palette.reflectances, &derived.reflectance_spectra, name, fallback))
            })
            .collect();
        let k = self.weights.materials;
        self.weights
            .data
            .chunks_exact(k.max(1))
            .map(|w| w.iter().zip(&colours).map(|(wi, c)| c * f64::from(*wi)).sum())
            .collect()
    }

    /// Display sRGB of every pixel under the dial's light at `t`, with the preview's exposure.
    pub fn frame(&self, palette: &Palette, derived: &Derived, colorimetry: &Colorimetry, t: f64) -> Vec<[u8; 3]> {
        self.linear(palette, derived, colorimetry, t).iter().map(|c| linear_to_srgb8(&(c * self.exposure))).collect()
    }
}
