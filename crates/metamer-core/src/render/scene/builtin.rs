//! The scenes and palettes built in: the embedded generated engine, and the check scenes the tests and
//! benchmarks use.

use super::*;

/// A palette made in code from built-in spectra (no file): fixed lights (luminance-normalised
/// illuminants) and fixed ColorChecker reflectances. Used by the accuracy check and tests.
pub fn colorchecker_palette(name: &str, lights: &[&str], reflectances: &[(&str, &str)]) -> Option<Palette> {
    let col = crate::colorimetry::Colorimetry::default();
    let lum = col.luminance();
    let lights = lights
        .iter()
        .map(|l| {
            let s = Spectrum::illuminant(l)?.normalized(Normalize::Luminance, &lum).ok()?;
            Some(entry(l, Kind::Light, crate::palette::Source::Illuminant(l.to_string()), s))
        })
        .collect::<Option<Vec<_>>>()?;
    let reflectances = reflectances
        .iter()
        .map(|(n, cc)| {
            Some(entry(
                n,
                Kind::Reflectance,
                crate::palette::Source::ColorChecker(cc.to_string()),
                Spectrum::colorchecker(cc)?,
            ))
        })
        .collect::<Option<Vec<_>>>()?;
    Some(Palette { name: name.into(), lights, reflectances, ..Palette::default() })
}

pub(super) fn entry(name: &str, kind: Kind, source: crate::palette::Source, spectrum: Spectrum) -> SpectrumEntry {
    let normalize = if kind == Kind::Light { Normalize::Luminance } else { Normalize::None };
    SpectrumEntry::resolved(name, kind, source, normalize, spectrum)
}

/// The designed engine palette (`volumes/engine_palette.toml`), embedded for the default scene.
pub(crate) const BUILTIN_PALETTE_TOML: &str = include_str!("../../../../../volumes/engine_palette.toml");

/// The built-in palette of the embedded default scene: the designed engine palette (smoke, block, inner;
/// lights hide, split, glow).
pub(crate) fn builtin_palette() -> Result<Palette, RenderError> {
    let origin = Path::new("volumes/engine_palette.toml (embedded)");
    crate::palette::file::PaletteFile::parse(BUILTIN_PALETTE_TOML, origin)
        .map(|f| f.palette)
        .map_err(|e| scene_err(origin, "palette", e.to_string()))
}

/// The embedded default scene: the generated engine-like volume of `size` voxels across with the
/// built-in palette (the same scene as `volumes/engine_generated.toml`).
pub fn builtin_scene(size: usize) -> Result<Scene, RenderError> {
    Scene::builtin(builtin_palette()?, size)
}

/// A scene of fixed ColorChecker materials over value ranges of `volume`: the palette named `name` with the
/// CIE illuminants `lights` (luminance-normalised, the dial's path in that order) and one material per
/// `(material name, ColorChecker patch, value range, opacity)`; `None` when a light or patch is not a
/// built-in table.
pub fn colorchecker_scene(
    name: &str,
    volume: Volume,
    lights: &[&str],
    materials: &[(&str, &str, [f32; 2], f32)],
) -> Option<Scene> {
    let names: Vec<(&str, &str)> = materials.iter().map(|&(m, patch, _, _)| (m, patch)).collect();
    let palette = colorchecker_palette(name, lights, &names)?;
    let materials = palette
        .reflectances
        .iter()
        .zip(materials)
        .map(|(r, &(_, _, range, opacity))| Material {
            reflectance: r.name.clone(),
            spectrum: r.spectrum,
            class: MaterialClass::new(range, opacity),
        })
        .collect();
    let dial = dial_of(Path::new(name), &palette, None).ok()?;
    Some(Scene {
        path: None,
        palette_path: None,
        volume_path: None,
        palette,
        volume,
        materials,
        camera: Camera::default(),
        dial,
        settings: SceneSettings::default(),
    })
}

/// The accuracy-check scene of issue 5: four fixed ColorChecker materials (dark skin, foliage, orange,
/// purplish blue) over value ranges of `volume`, dial D65 → A → F11. `ranges` and `opacities` give the
/// transfer function (value ranges in the volume's units).
pub(crate) fn colorchecker_check_scene(volume: Volume, ranges: [[f32; 2]; 4], opacities: [f32; 4]) -> Scene {
    let patches = ["dark_skin", "foliage", "orange", "purplish_blue"];
    let materials: Vec<(&str, &str, [f32; 2], f32)> = ["m1", "m2", "m3", "m4"]
        .into_iter()
        .zip(patches)
        .zip(ranges.into_iter().zip(opacities))
        .map(|((m, p), (r, o))| (m, p, r, o))
        .collect();
    colorchecker_scene("check", volume, &["D65", "A", "F11"], &materials)
        .expect("the CIE illuminants and ColorChecker patches named here are built in")
}

/// [`colorchecker_check_scene`] over the GE engine CT (`engine.nhdr`, 8-bit).
pub fn engine_check_scene(volume: Volume) -> Scene {
    colorchecker_check_scene(
        volume,
        [[30.0, 80.0], [81.0, 160.0], [161.0, 200.0], [201.0, 255.0]],
        [0.02, 0.08, 0.3, 0.8],
    )
}

/// [`generated_check_scene`]'s materials over the 16-bit engine-like volume of `dims`
/// ([`generate::engine_like_u16`], ranges scaled as its values are).
pub fn generated_u16_check_scene(dims: [usize; 3]) -> Scene {
    let (s, b, i) = (generate::SMOKE_RANGE, generate::BLOCK_RANGE, generate::INNER_RANGE);
    let k = generate::U16_SCALE;
    let ranges = [s, b, [i[0], 230.0], [230.5, i[1]]].map(|r| r.map(|v| v * k));
    colorchecker_check_scene(generate::engine_like_u16(dims), ranges, [0.05, 0.15, 0.6, 0.6])
}

/// [`colorchecker_check_scene`] over the generated engine-like volume.
pub fn generated_check_scene(size: usize) -> Scene {
    let (s, b, i) = (generate::SMOKE_RANGE, generate::BLOCK_RANGE, generate::INNER_RANGE);
    colorchecker_check_scene(generate::engine_like(size), [s, b, [i[0], 230.0], [230.5, i[1]]], [0.05, 0.15, 0.6, 0.6])
}
