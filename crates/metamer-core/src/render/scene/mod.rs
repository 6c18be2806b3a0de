//! Scene files (DESIGN_SPEC §4): a palette, a volume, materials (value range → reflectance, opacity),
//! a camera and a light-dial path, plus optional render settings. Paths are relative to the scene file.
//!
//! ```toml
//! palette = "engine_palette.toml"
//! volume = "../../shared/volumes/engine.nhdr"   # .nhdr/.nrrd, .vti, a raw file with [raw], or "generated:engine_like"
//! [[materials]]
//! reflectance = "block"
//! range = [80, 255]
//! opacity = 0.6
//! absorbs = true             # optional; false = emissive only (adds colour, hides nothing behind it)
//! max_gradient = 8.0         # optional; opacity falls linearly to 0 at this gradient magnitude (value/voxel)
//! [camera]
//! azimuth_deg = 30.0
//! elevation_deg = 20.0
//! zoom = 1.0                 # optional; 1 fits what is framed with a 4% margin
//! fit = "materials"          # optional: frame the voxels that belong to a material (default), or "volume"
//! [dial]
//! path = ["daylight", "split"]   # optional: default = the palette's lights that have `dial` positions,
//!                                # in angular order around their centre, else all lights in file order
//! vertices = { split = [1.0, 0.0] }   # optional vertex overrides (else the palette's `dial = [x, y]`)
//! # or, instead of `path`, keyframes (docs/formats/dial.md; Shepard weights, see `super::dial`):
//! # [[dial.keyframes]]
//! # at = "daylight"          # or a point [x, y]
//! # off = ["split"]          # switched off from here on; also on = [...], move = { name = [x, y] },
//! #                          # intensity = { name = 0.5 }
//! [render]                   # optional
//! step = 1.0                 # voxels between samples
//! ambient = 0.3              # shading = ambient + (1 − ambient)·max(n·l, 0)
//! shading = "key"            # key light above left of the eye, "headlight", or "unshaded" (the seed's look)
//! interpolation = "trilinear"    # "labels" for label volumes (smoothed per tissue), or "nearest"
//! exposure = 1.0             # multiplies the automatic sweep exposure
//! generated_size = 160       # size of a generated volume
//! [raw]                      # only for raw volume files
//! dims = [256, 256, 128]
//! type = "u8"
//! endian = "little"
//! spacing = [1, 1, 1]
//! ```

use super::RenderError;
use super::dial::{Dial, DialLight, DialState};
use super::raycast::{Camera, Gradient, Interpolation, MAX_MATERIALS, MaterialClass, Shading};
use crate::palette::{Kind, Palette, SpectrumEntry};
use crate::spectrum::{Normalize, Spectrum};
use crate::volume::{Endian, ScalarType, Volume, generate, raw};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A material of the spectral transfer function, resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The palette reflectance's name.
    pub reflectance: String,
    pub spectrum: Spectrum,
    pub class: MaterialClass,
}

/// Render settings of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSettings {
    pub step: f64,
    pub(crate) ambient: f64,
    pub shading: Shading,
    /// Per-pixel ray-start jitter.
    pub jitter: bool,
    /// Split steps that cross a material boundary into substeps.
    pub refine: bool,
    pub gradient: Gradient,
    pub interpolation: Interpolation,
    /// Multiplies the automatic sweep exposure.
    pub exposure: f64,
}

impl Default for SceneSettings {
    fn default() -> Self {
        SceneSettings {
            step: 1.0,
            ambient: 0.3,
            shading: Shading::Key,
            jitter: true,
            refine: true,
            gradient: Gradient::Smooth,
            interpolation: Interpolation::Trilinear,
            exposure: 1.0,
        }
    }
}

/// A resolved scene.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene file, if any.
    pub path: Option<PathBuf>,
    /// The palette file, if any (its folder holds the trained basis sidecar).
    pub palette_path: Option<PathBuf>,
    /// The volume file read, if any (an input no output may overwrite).
    pub volume_path: Option<PathBuf>,
    /// The palette the materials' reflectances and the dial's lights come from.
    pub palette: Palette,
    /// The voxels the rays march through.
    pub volume: Volume,
    /// The transfer function, at most 64 materials in file order; a material's index here is its channel in
    /// the raycast's `MaterialWeights`.
    pub materials: Vec<Material>,
    /// View direction and framing.
    pub camera: Camera,
    /// The light dial: every light of the palette, its vertices and the sweep the frames follow.
    pub dial: Dial,
    /// Render settings (`[render]`), defaults where the file gives none.
    pub settings: SceneSettings,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    palette: String,
    volume: String,
    materials: Vec<MaterialFile>,
    camera: Option<CameraFile>,
    dial: Option<DialFile>,
    render: Option<RenderFile>,
    raw: Option<RawFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    reflectance: String,
    range: [f64; 2],
    opacity: f64,
    absorbs: Option<bool>,
    max_gradient: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraFile {
    azimuth_deg: Option<f64>,
    elevation_deg: Option<f64>,
    zoom: Option<f64>,
    fit: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DialFile {
    path: Option<Vec<String>>,
    /// Vertex overrides by light name (else the palette's `dial = [x, y]`).
    vertices: Option<std::collections::BTreeMap<String, [f64; 2]>>,
    keyframes: Option<Vec<KeyframeFile>>,
}

/// Where a keyframe puts the slider: a light's vertex (by name) or a point.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum AtFile {
    Light(String),
    Point([f64; 2]),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyframeFile {
    at: AtFile,
    #[serde(default)]
    off: Vec<String>,
    #[serde(default)]
    on: Vec<String>,
    #[serde(rename = "move")]
    moves: Option<std::collections::BTreeMap<String, [f64; 2]>>,
    intensity: Option<std::collections::BTreeMap<String, f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderFile {
    step: Option<f64>,
    ambient: Option<f64>,
    shading: Option<String>,
    interpolation: Option<String>,
    exposure: Option<f64>,
    generated_size: Option<usize>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    dims: [usize; 3],
    #[serde(rename = "type")]
    ty: String,
    endian: Option<String>,
    spacing: Option<[f64; 3]>,
}

/// Loads the palette a scene names (the palette file reader lives in `crate::palette::file`).
fn load_palette(path: &Path) -> Result<Palette, String> {
    crate::palette::file::PaletteFile::load(path).map(|f| f.palette).map_err(|e| e.to_string())
}

impl Scene {
    /// Read a scene file, its palette and its volume.
    pub fn load(path: &Path) -> Result<Scene, RenderError> {
        let bytes =
            crate::fsio::read(path, crate::fsio::Kind::Scene).map_err(|e| scene_err(path, "file", e.to_string()))?;
        let text =
            std::str::from_utf8(&bytes).map_err(|_| scene_err(path, "file", "not a text file (invalid UTF-8)"))?;
        Scene::parse(text, path)
    }

    /// Read a scene file with its volume taken from `volume` instead of the scene's `volume` key (the
    /// command line's `--volume PATH`); `None` resolves the key as [`Scene::load`] does.
    pub fn load_with_volume(path: &Path, volume: Option<&Path>) -> Result<Scene, RenderError> {
        let bytes =
            crate::fsio::read(path, crate::fsio::Kind::Scene).map_err(|e| scene_err(path, "file", e.to_string()))?;
        let text =
            std::str::from_utf8(&bytes).map_err(|_| scene_err(path, "file", "not a text file (invalid UTF-8)"))?;
        Scene::parse_with_volume(text, path, volume)
    }

    /// Parse a scene's text; `path` names it in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> Result<Scene, RenderError> {
        Scene::parse_with_volume(text, path, None)
    }

    /// [`Scene::parse`] with the volume file given (`Some`) instead of found from the `volume` key: see
    /// [`resolve_volume_path`].
    pub fn parse_with_volume(text: &str, path: &Path, volume_override: Option<&Path>) -> Result<Scene, RenderError> {
        if text.trim().is_empty() {
            return Err(scene_err(path, "file", "the file is empty (a scene needs palette, volume and materials)"));
        }
        let file: SceneFile = toml::from_str(text).map_err(|e: toml::de::Error| {
            let line = e.span().map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            scene_err(
                path,
                line.map_or("file".to_string(), |l| format!("line {l}")),
                e.message().trim().replace('\n', " "),
            )
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let palette_path = dir.join(&file.palette);
        let palette = load_palette(&palette_path).map_err(|e| scene_err(path, "palette", e))?;
        let render = file.render.as_ref();
        // Settings first: a bad `render` key is refused before a volume is read or generated.
        let settings = settings_of(path, render)?;
        let generated = file.volume.strip_prefix("generated:").filter(|_| volume_override.is_none());
        let mut volume_path = None;
        let volume = if let Some(kind) = generated {
            match kind {
                "engine_like" => generate::engine_like(render.and_then(|r| r.generated_size).unwrap_or(160)),
                other => {
                    return Err(scene_err(path, "volume", format!("unknown generated volume `{other}` (engine_like)")));
                }
            }
        } else {
            let vpath = resolve_volume_path(path, &file.volume, volume_override)?;
            volume_path = Some(vpath.clone());
            match &file.raw {
                Some(r) => {
                    let ty = ScalarType::parse(&r.ty)
                        .ok_or_else(|| scene_err(path, "raw.type", format!("unknown type `{}`", r.ty)))?;
                    let endian = match r.endian.as_deref() {
                        None | Some("little") => Endian::Little,
                        Some("big") => Endian::Big,
                        Some(o) => {
                            return Err(scene_err(path, "raw.endian", format!("`{o}` is neither little nor big")));
                        }
                    };
                    raw::read(&vpath, r.dims, ty, endian, r.spacing.unwrap_or([1.0; 3]))?
                }
                None => Volume::open(&vpath)?,
            }
        };
        if let Some(thin) = volume.dims.iter().position(|d| *d < 2) {
            // A 2-D image (or one slice of a volume) has no thickness: every ray would take 0 samples and
            // the frames would be black.
            let d = volume.dims;
            return Err(scene_err(
                path,
                if volume_override.is_some() { "--volume" } else { "volume" },
                format!(
                    "{} is {}×{}×{} voxels, a single voxel thick along {}: rendering needs at least 2 voxels along \
                     every axis (a 2-D image is not a volume)",
                    volume_path.as_deref().map_or("the volume".to_string(), crate::fsio::show),
                    d[0],
                    d[1],
                    d[2],
                    ["x", "y", "z"][thin]
                ),
            ));
        }
        let camera = camera_of(path, file.camera.as_ref())?;
        let materials = materials_of(path, &palette, &file.materials)?;
        if settings.interpolation == Interpolation::Labels
            && let Some(i) = materials.iter().position(|m| m.class.max_gradient.is_some())
        {
            return Err(scene_err(
                path,
                format!("materials[{i}].max_gradient"),
                "works on value classes only (render.interpolation \"trilinear\" or \"nearest\"), not \"labels\"",
            ));
        }
        let dial = match &file.dial {
            Some(d) => dial_of_file(path, &palette, d)?,
            None => dial_of(path, &palette, None)?,
        };
        Ok(Scene {
            path: Some(path.to_path_buf()),
            palette_path: Some(palette_path),
            volume_path,
            palette,
            volume,
            materials,
            camera,
            dial,
            settings,
        })
    }

    /// The embedded default: the generated engine-like volume (no data files needed) with its
    /// materials, camera and light dial over `palette`'s reflectances `smoke`, `block`, `inner` (when a
    /// palette lacks one of these names, its reflectances are taken in order).
    pub fn builtin(palette: Palette, size: usize) -> Result<Scene, RenderError> {
        let origin = Path::new("builtin scene");
        let pick = |name: &str, fallback: usize| {
            palette
                .reflectance_index(name)
                .or_else(|| (fallback < palette.reflectances.len()).then_some(fallback))
                .map(|i| palette.reflectances[i].name.clone())
                .ok_or_else(|| scene_err(origin, "palette", "the built-in scene needs three reflectances"))
        };
        let spec = [
            (pick("smoke", 0)?, generate::SMOKE_RANGE, 0.025),
            (pick("block", 1)?, generate::BLOCK_RANGE, 0.12),
            (pick("inner", 2)?, generate::INNER_RANGE, 0.6),
        ];
        let files: Vec<MaterialFile> = spec
            .iter()
            .map(|(name, r, o)| MaterialFile {
                reflectance: name.clone(),
                range: [f64::from(r[0]), f64::from(r[1])],
                opacity: *o,
                absorbs: None,
                max_gradient: None,
            })
            .collect();
        let materials = materials_of(origin, &palette, &files)?;
        let dial = dial_of(origin, &palette, None)?;
        Ok(Scene {
            path: None,
            palette_path: None,
            volume_path: None,
            volume: generate::engine_like(size),
            materials,
            camera: Camera { azimuth_deg: 35.0, elevation_deg: 25.0, ..Camera::default() },
            dial,
            settings: SceneSettings::default(),
            palette,
        })
    }
}

/// The volume file of a scene: `volume_override` (the command line's `--volume`) when given, else the
/// scene's `volume` key relative to the scene file's folder, else the key's file name in the data folder
/// named by `METAMER_DATA` (the file itself or under `volumes/`). A missing file is an error naming the
/// scene's `volume` key (or `--volume`), where it was looked for and how to get the dataset.
pub(crate) fn resolve_volume_path(
    scene: &Path,
    key: &str,
    volume_override: Option<&Path>,
) -> Result<PathBuf, RenderError> {
    use crate::volume::data;
    // Paths are quoted and their control characters escaped (Debug) in the messages.
    let q = |p: &Path| format!("{:?}", p.display().to_string());
    if let Some(p) = volume_override {
        if p.is_file() {
            return Ok(p.to_path_buf());
        }
        return Err(scene_err(
            scene,
            "--volume",
            format!("{} is not a file (it replaces the scene's `volume` = {key:?})", q(p)),
        ));
    }
    let dir = scene.parent().unwrap_or(Path::new("."));
    let beside = dir.join(key);
    if beside.is_file() {
        return Ok(beside);
    }
    let name = Path::new(key).file_name();
    let env = data::data_dir();
    if let (Some(dir), Some(name)) = (&env, name)
        && let Some(found) = data::find_in(dir, name)
    {
        return Ok(found);
    }
    let name_str = name.map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| key.to_string());
    let looked = match &env {
        Some(d) => {
            format!("looked for {} and for {name_str:?} in {}={} and its volumes/", q(&beside), data::DATA_ENV, q(d))
        }
        None => format!("looked for {}; {} is not set", q(&beside), data::DATA_ENV),
    };
    let what = data::dataset_origin(&name_str).map(|o| format!(". {name_str} is {o}")).unwrap_or_default();
    Err(scene_err(
        scene,
        "volume",
        format!(
            "{key:?} not found ({looked}){what}. Pass the file with --volume PATH, or set {}=DIR to a folder \
             that holds {name_str:?} (README, section Data)",
            data::DATA_ENV
        ),
    ))
}

fn scene_err(path: &Path, key: impl Into<String>, reason: impl Into<String>) -> RenderError {
    RenderError::Scene { path: path.to_path_buf(), key: key.into(), reason: reason.into() }
}

fn settings_of(path: &Path, r: Option<&RenderFile>) -> Result<SceneSettings, RenderError> {
    let mut s = SceneSettings::default();
    let Some(r) = r else { return Ok(s) };
    if let Some(step) = r.step {
        if !(step.is_finite() && (0.05..=8.0).contains(&step)) {
            return Err(scene_err(path, "render.step", format!("{step} is outside 0.05..=8 voxels")));
        }
        s.step = step;
    }
    if let Some(a) = r.ambient {
        if !(a.is_finite() && (0.0..=1.0).contains(&a)) {
            return Err(scene_err(path, "render.ambient", format!("{a} is outside 0..=1")));
        }
        s.ambient = a;
    }
    if let Some(e) = r.exposure {
        // Bounded both ways: the factor multiplies the automatic exposure, and 1e308 made it infinite.
        if !(e.is_finite() && (1e-6..=1e6).contains(&e)) {
            return Err(scene_err(path, "render.exposure", format!("{e:e} is outside 1e-6..=1e6")));
        }
        s.exposure = e;
    }
    if let Some(i) = &r.interpolation {
        s.interpolation = match i.as_str() {
            "trilinear" => Interpolation::Trilinear,
            "nearest" => Interpolation::Nearest,
            "labels" => Interpolation::Labels,
            o => {
                return Err(scene_err(
                    path,
                    "render.interpolation",
                    format!("`{}` is not trilinear, nearest or labels", crate::fsio::escape(o)),
                ));
            }
        };
    }
    if let Some(sh) = &r.shading {
        s.shading = match sh.as_str() {
            "key" => Shading::Key,
            "headlight" => Shading::Headlight,
            "unshaded" => Shading::Unshaded,
            o => {
                return Err(scene_err(
                    path,
                    "render.shading",
                    format!("`{}` is not key, headlight or unshaded", crate::fsio::escape(o)),
                ));
            }
        };
    }
    if let Some(g) = r.generated_size
        && !(16..=512).contains(&g)
    {
        return Err(scene_err(path, "render.generated_size", format!("{g} is outside 16..=512")));
    }
    Ok(s)
}

fn camera_of(path: &Path, c: Option<&CameraFile>) -> Result<Camera, RenderError> {
    let mut cam = Camera::default();
    let Some(c) = c else { return Ok(cam) };
    for (key, v) in
        [("camera.azimuth_deg", c.azimuth_deg), ("camera.elevation_deg", c.elevation_deg), ("camera.zoom", c.zoom)]
    {
        if let Some(v) = v
            && !v.is_finite()
        {
            return Err(scene_err(path, key, format!("{v} is not a finite number")));
        }
    }
    if let Some(z) = c.zoom {
        if z <= 0.0 {
            return Err(scene_err(path, "camera.zoom", format!("{z} is not positive")));
        }
        cam.zoom = z;
    }
    if let Some(e) = c.elevation_deg {
        if e.abs() > 90.0 {
            return Err(scene_err(path, "camera.elevation_deg", format!("{e} is outside -90..=90")));
        }
        cam.elevation_deg = e;
    }
    if let Some(a) = c.azimuth_deg {
        cam.azimuth_deg = a;
    }
    if let Some(f) = &c.fit {
        cam.fit_materials = match f.as_str() {
            "materials" => true,
            "volume" => false,
            o => {
                return Err(scene_err(
                    path,
                    "camera.fit",
                    format!("`{}` is neither materials nor volume", crate::fsio::escape(o)),
                ));
            }
        };
    }
    Ok(cam)
}

fn materials_of(path: &Path, palette: &Palette, files: &[MaterialFile]) -> Result<Vec<Material>, RenderError> {
    if files.is_empty() {
        return Err(scene_err(path, "materials", "a scene needs at least one [[materials]] entry"));
    }
    if files.len() > MAX_MATERIALS {
        return Err(scene_err(path, "materials", format!("{} materials; at most {MAX_MATERIALS}", files.len())));
    }
    let names = || palette.reflectances.iter().map(|r| r.name.as_str()).collect::<Vec<_>>().join(", ");
    files
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let key = |k: &str| format!("materials[{i}].{k}");
            let idx = palette.reflectance_index(&m.reflectance).ok_or_else(|| {
                scene_err(
                    path,
                    key("reflectance"),
                    format!("`{}` is not a reflectance of the palette ({})", m.reflectance, names()),
                )
            })?;
            let [lo, hi] = m.range;
            if !(lo.is_finite() && hi.is_finite()) || lo > hi {
                return Err(scene_err(path, key("range"), format!("[{lo}, {hi}] is not an ordered pair of numbers")));
            }
            if !(m.opacity.is_finite() && (0.0..=1.0).contains(&m.opacity)) {
                return Err(scene_err(path, key("opacity"), format!("{} is outside 0..=1", m.opacity)));
            }
            if let Some(g) = m.max_gradient
                && !(g.is_finite() && g > 0.0)
            {
                return Err(scene_err(path, key("max_gradient"), format!("{g} is not a positive number")));
            }
            Ok(Material {
                reflectance: m.reflectance.clone(),
                spectrum: palette.reflectances[idx].spectrum,
                class: MaterialClass {
                    range: [lo as f32, hi as f32],
                    opacity: m.opacity as f32,
                    absorbs: m.absorbs.unwrap_or(true),
                    max_gradient: m.max_gradient.map(|g| g as f32),
                },
            })
        })
        .collect()
}

mod builtin;
mod dial_of;

pub use builtin::*;
use dial_of::*;
