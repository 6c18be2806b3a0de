//! Palettes (DESIGN_SPEC §3): lights as columns, reflectances as rows, target colours on cells,
//! free-colour groups and the design settings.
//!
//! [`Palette`] is the resolved in-memory model every other module works on: every spectrum already
//! resolved to samples (lights normalised and scaled), every target in linear sRGB, every reference
//! to a light, reflectance or free group an index. Reading and writing TOML lives in [`file`].

pub(crate) mod dial_edit;
pub(crate) mod edit;
pub(crate) mod file;
pub mod mixing;
/// Seeded generated palettes: the workloads of `metamer bench`, the benchmarks, the examples and the tests.
pub mod random;
pub(crate) mod source;

pub use dial_edit::DialEntry;
pub use edit::EditError;
pub use file::{PaletteError, PaletteFile, PreparedEnd, PreparedSave, StagedEnd, StagedSave};

use crate::spectrum::{Normalize, Spectrum};
use nalgebra::Vector3;

/// Inclusive bounds on a value; `-inf` / `inf` mean unbounded on that side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// The smallest value allowed; `-inf` when there is none.
    pub lower: f64,
    /// The largest value allowed; `inf` when there is none.
    pub upper: f64,
}

impl Bounds {
    /// No bound on either side: what an absent bounds key means.
    pub const UNBOUNDED: Bounds = Bounds { lower: f64::NEG_INFINITY, upper: f64::INFINITY };

    /// Bounds from `lower` to `upper` as given; nothing is checked here (the palette reader refuses inverted bounds).
    pub fn new(lower: f64, upper: f64) -> Bounds {
        Bounds { lower, upper }
    }

    /// True when neither side bounds anything.
    pub fn is_unbounded(&self) -> bool {
        self.lower == f64::NEG_INFINITY && self.upper == f64::INFINITY
    }

    /// Clamp `v` into the bounds.
    pub fn clamp(&self, v: f64) -> f64 {
        v.max(self.lower).min(self.upper)
    }
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds::UNBOUNDED
    }
}

/// Which side of the design matrix a spectrum stands on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    /// A light: a column of the design matrix (`[[lights]]`).
    Light,
    /// A reflectance: a row of the design matrix (`[[reflectances]]`).
    Reflectance,
}

impl Kind {
    /// The kind as a word for messages and the report's `kind` field: `light` or `reflectance`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Kind::Light => "light",
            Kind::Reflectance => "reflectance",
        }
    }
}

/// Where a spectrum's starting samples come from (as written in the file).
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// A built-in CIE illuminant by name.
    Illuminant(String),
    /// A built-in ColorChecker patch by name.
    ColorChecker(String),
    /// A Planck black body at this temperature in kelvin.
    Planck(f64),
    /// A flat spectrum of this value.
    Flat(f64),
    /// Samples given in the file.
    Samples(Vec<f64>),
    /// A CSV file of measured samples, path as written (relative to the palette file).
    Csv(String),
}

/// A light or a reflectance of the palette.
#[derive(Clone, Debug, PartialEq)]
pub struct SpectrumEntry {
    /// The spectrum's name, unique among the palette's lights (or reflectances); cells refer to it by this name.
    pub name: String,
    /// Which list the entry belongs to: [`Palette::lights`] or [`Palette::reflectances`].
    pub kind: Kind,
    /// Where the starting samples come from, kept so that saving writes the same key back.
    pub source: Source,
    /// Lights only; reflectances are never normalised.
    pub normalize: Normalize,
    /// The factor applied after normalisation (`scale`, default 1), for lights and reflectances alike.
    pub scale: f64,
    /// Open to design: the samples are unknowns and [`SpectrumEntry::spectrum`] is only the start.
    pub design: bool,
    /// Per-spectrum bounds overriding the palette's `light_bounds` / `reflectance_bounds`.
    pub bounds: Option<Bounds>,
    /// Optional position on the light dial.
    pub dial: Option<[f64; 2]>,
    /// The resolved samples: source, then (lights) normalisation, then scale.
    pub spectrum: Spectrum,
}

/// How a target was written, so saving can keep the user's notation.
#[derive(Clone, Debug, PartialEq)]
pub enum TargetNotation {
    /// `"#rrggbb"` display sRGB.
    Hex,
    /// `[r, g, b]` linear sRGB.
    Linear,
}

/// A colour criterion on one light × reflectance cell.
#[derive(Clone, Debug, PartialEq)]
pub struct ColourCell {
    /// Index into [`Palette::lights`].
    pub light: usize,
    /// Index into [`Palette::reflectances`].
    pub reflectance: usize,
    /// Desired colour in linear sRGB (ignored when the cell is in a free group).
    pub target: Vector3<f64>,
    /// How the target was written (`"#rrggbb"` or `[r, g, b]`), so saving writes it back the same way.
    pub notation: TargetNotation,
    /// ω ≥ 0; a weight of 0 leaves the cell's rows out.
    pub weight: f64,
    /// Index into [`Palette::free`] when the cell joins a free-colour group.
    pub free: Option<usize>,
    /// `use = false` keeps the cell in the file but out of the design ("use colour" off).
    pub enabled: bool,
}

impl ColourCell {
    /// True when this cell contributes rows to the objective.
    pub fn is_active(&self) -> bool {
        self.enabled && self.weight > 0.0
    }
}

/// A free-colour group (seed Eq. 24): its colour is an unknown shared by its cells, within bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct FreeGroup {
    /// The group's name, unique among the palette's groups; cells join the group by it (`free = "A"`).
    pub name: String,
    /// Per-channel lower bound in linear sRGB (`-inf` where absent).
    pub lower: Vector3<f64>,
    /// Per-channel upper bound in linear sRGB (`inf` where absent).
    pub upper: Vector3<f64>,
}

/// A fixed mixture of the palette's lights: `Σ wᵢ Eᵢ` over `(light index, wᵢ)` pairs, every `wᵢ > 0`.
pub type Mix = Vec<(usize, f64)>;

/// How a mixture was written, so it can be named and checked.
#[derive(Clone, Debug, PartialEq)]
pub enum MixSpec {
    /// `dial = [x, y]` (and `off = [...]`): the light dial's Shepard weights at that point
    /// ([`crate::render::dial`], the renderer's own code), the lights listed in `off` switched off.
    Dial {
        /// The dial point `[x, y]` in dial coordinates, each within ±1e6.
        at: [f64; 2],
        /// Indices into [`Palette::lights`] of the lights switched off, each once; never every light.
        off: Vec<usize>,
    },
    /// `mix = { light = w, … }`: explicit weights, used as given.
    Weights,
}

/// A colour criterion under a mixture of lights (`[[mixtures]]`): reflectance `reflectance` under the
/// light `Σ wᵢ Eᵢ` should give `target` (or its free group's colour).
#[derive(Clone, Debug, PartialEq)]
pub struct MixtureCell {
    /// Index into [`Palette::reflectances`].
    pub reflectance: usize,
    /// The weights, resolved when the file was read.
    pub mix: Mix,
    /// How the mixture was written: a dial position or explicit weights.
    pub spec: MixSpec,
    /// Desired colour in linear sRGB (ignored when the cell is in a free group).
    pub target: Vector3<f64>,
    pub(crate) notation: TargetNotation,
    /// ω ≥ 0; a weight of 0 leaves the cell's rows out.
    pub weight: f64,
    /// Index into [`Palette::free`] when the cell joins a free-colour group.
    pub free: Option<usize>,
    /// `use = false` keeps the cell in the file but out of the design.
    pub enabled: bool,
}

impl MixtureCell {
    /// True when this cell contributes rows to the objective.
    pub fn is_active(&self) -> bool {
        self.enabled && self.weight > 0.0
    }
}

/// The way a constancy path moves over the dial.
#[derive(Clone, Debug, PartialEq)]
pub enum Route {
    /// `through = [...]`: the dial's slider along the polyline through these points at constant speed,
    /// Shepard weights at every position, the lights in `off` switched off (a scene's keyframes).
    Dial {
        /// The dial points `[x, y]` the path passes through in order (a light's name in the file stands
        /// for its vertex), at least 2.
        through: Vec<[f64; 2]>,
        /// Indices into [`Palette::lights`] of the lights switched off all along the path, each once;
        /// never every light.
        off: Vec<usize>,
    },
    /// `lights = [...]`: from light to light, mixing the two neighbours linearly (a scene's `path`).
    Lights(Vec<usize>),
}

/// A constancy along a dial path (`[[paths]]`): reflectance `reflectance` keeps one colour (a target, or
/// a free group's colour) at every position of `route`. The design samples `samples` positions; the
/// solve then checks the colour densely between them against `tolerance` (ΔE00).
#[derive(Clone, Debug, PartialEq)]
pub struct PathConstancy {
    /// Index into [`Palette::reflectances`]: the reflectance whose colour is kept.
    pub reflectance: usize,
    pub(crate) route: Route,
    /// The colour to keep, in linear sRGB (ignored when the path is in a free group).
    pub target: Vector3<f64>,
    pub(crate) notation: TargetNotation,
    /// ω ≥ 0 for the whole path: each of the `samples` positions gets ω/√samples, so a path weighs as much as
    /// one cell; a weight of 0 leaves the path's rows out.
    pub weight: f64,
    /// Index into [`Palette::free`] when the path keeps a free-colour group's colour instead of `target`.
    pub free: Option<usize>,
    /// `use = false` keeps the path in the file but out of the design.
    pub enabled: bool,
    /// Positions the design uses, evenly along the path (both ends included), ≥ 2.
    pub samples: usize,
    /// The largest ΔE00 from the target allowed anywhere along the path.
    pub tolerance: f64,
}

impl PathConstancy {
    /// The way the path moves over the dial.
    pub fn route(&self) -> &Route {
        &self.route
    }

    /// True when this path contributes rows to the objective.
    pub fn is_active(&self) -> bool {
        self.enabled && self.weight > 0.0
    }
}

/// The design settings (DESIGN_SPEC §3 `[settings]`).
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// m, the dimension of the spectral factor model.
    pub basis_dimension: usize,
    /// ω_D.
    pub smoothness: f64,
    /// ω_F.
    pub subspace_error: f64,
    /// Use the subspace colour (`Q_rgb,m Λ Q_m,31`) in the colour rows ("use V7").
    pub fit_in_subspace: bool,
    /// Bounds on every sample of a designed reflectance, unless the reflectance has its own (`reflectance_bounds`).
    pub reflectance_bounds: Bounds,
    /// Bounds on every sample of a designed light, unless the light has its own (`light_bounds`).
    pub light_bounds: Bounds,
}

impl Settings {
    /// True when the reflectance or the light bounds are set.
    pub fn bounded(&self) -> bool {
        !(self.reflectance_bounds.is_unbounded() && self.light_bounds.is_unbounded())
    }
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            basis_dimension: crate::spectrum::DEFAULT_BASIS_DIMENSION,
            smoothness: 0.001,
            subspace_error: 0.0,
            fit_in_subspace: false,
            reflectance_bounds: Bounds::UNBOUNDED,
            light_bounds: Bounds::UNBOUNDED,
        }
    }
}

/// A resolved palette.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Palette {
    /// The palette's `name`, or the file's stem when the file gives none.
    pub name: String,
    /// The design settings (`[settings]`), defaults where the file gives none.
    pub settings: Settings,
    /// The lights (`[[lights]]`) in file order: the columns of the design matrix.
    pub lights: Vec<SpectrumEntry>,
    /// The reflectances (`[[reflectances]]`) in file order: the rows of the design matrix.
    pub reflectances: Vec<SpectrumEntry>,
    /// Colour criteria on light × reflectance cells (`[[colours]]`), in file order, at most one per cell.
    pub colours: Vec<ColourCell>,
    /// Free-colour groups (`[[free]]`) in file order; cells refer to them by index.
    pub free: Vec<FreeGroup>,
    /// Colour criteria under mixtures of lights (`[[mixtures]]`).
    pub mixtures: Vec<MixtureCell>,
    /// Constancy along dial paths (`[[paths]]`).
    pub paths: Vec<PathConstancy>,
}

/// The largest magnitude of any number the design uses (samples, targets, weights, finite bounds, settings).
/// The objective multiplies weights, samples, colour-matching values and targets and squares the result;
/// below this bound every such product stays far inside `f64` (1e15⁴ = 1e60), above it the SVD meets
/// infinities and NaN. Larger values are input errors, named by their key.
pub(crate) const MAX_MAGNITUDE: f64 = 1e15;

/// A number the design cannot use: its key (e.g. `lights[0].samples`, `colours[2].weight`) and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{key}: {reason}")]
pub(crate) struct ScaleError {
    pub(crate) key: String,
    pub(crate) reason: String,
}

fn too_large(key: String, what: &str, v: f64) -> ScaleError {
    ScaleError {
        key,
        reason: if v.is_finite() {
            format!("{what} {v:e} is too large (at most {MAX_MAGNITUDE:e} in magnitude: larger values overflow)")
        } else {
            format!("{what} {v} is not a finite number")
        },
    }
}

fn check_value(key: impl FnOnce() -> String, what: &str, v: f64) -> Result<(), ScaleError> {
    if v.is_finite() && v.abs() <= MAX_MAGNITUDE { Ok(()) } else { Err(too_large(key(), what, v)) }
}

fn check_bounds(key: impl Fn() -> String, lower: f64, upper: f64) -> Result<(), ScaleError> {
    if lower.is_nan() || upper.is_nan() || lower == f64::INFINITY || upper == f64::NEG_INFINITY {
        return Err(ScaleError {
            key: key(),
            reason: format!(
                "bounds [{lower}, {upper}] admit no finite value (the lower bound may be -inf, the upper inf)"
            ),
        });
    }
    for (what, v) in [("lower bound", lower), ("upper bound", upper)] {
        if v.is_finite() {
            check_value(&key, what, v)?;
        }
    }
    Ok(())
}

impl Palette {
    /// Check that every number the design uses is finite and at most [`MAX_MAGNITUDE`] in magnitude (bounds
    /// may be infinite on their open side): the first one that is not, by key.
    pub(crate) fn check_scale(&self) -> Result<(), ScaleError> {
        let s = &self.settings;
        check_value(|| "settings.smoothness".into(), "smoothness", s.smoothness)?;
        check_value(|| "settings.subspace_error".into(), "subspace_error", s.subspace_error)?;
        let rb = s.reflectance_bounds;
        check_bounds(|| "settings.reflectance_bounds".into(), rb.lower, rb.upper)?;
        let lb = s.light_bounds;
        check_bounds(|| "settings.light_bounds".into(), lb.lower, lb.upper)?;
        for (side, entries) in [("lights", &self.lights), ("reflectances", &self.reflectances)] {
            for (i, e) in entries.iter().enumerate() {
                check_value(|| format!("{side}[{i}].scale"), "scale", e.scale)?;
                for v in e.spectrum.as_slice() {
                    check_value(|| format!("{side}[{i}].{}", e.source.key()), "a resolved sample", *v)?;
                }
                if let Some(b) = e.bounds {
                    check_bounds(|| format!("{side}[{i}].bounds"), b.lower, b.upper)?;
                }
            }
        }
        for (k, c) in self.colours.iter().enumerate() {
            for v in c.target.iter() {
                check_value(|| format!("colours[{k}].target"), "target value", *v)?;
            }
            check_value(|| format!("colours[{k}].weight"), "weight", c.weight)?;
        }
        for (k, m) in self.mixtures.iter().enumerate() {
            for v in m.target.iter() {
                check_value(|| format!("mixtures[{k}].target"), "target value", *v)?;
            }
            check_value(|| format!("mixtures[{k}].weight"), "weight", m.weight)?;
            for (_, w) in &m.mix {
                check_value(|| format!("mixtures[{k}].mix"), "mixture weight", *w)?;
            }
        }
        for (k, q) in self.paths.iter().enumerate() {
            for v in q.target.iter() {
                check_value(|| format!("paths[{k}].target"), "target value", *v)?;
            }
            check_value(|| format!("paths[{k}].weight"), "weight", q.weight)?;
        }
        for (g, f) in self.free.iter().enumerate() {
            for c in 0..3 {
                check_bounds(|| format!("free[{g}]"), f.lower[c], f.upper[c])?;
            }
        }
        Ok(())
    }

    /// The criteria along the light dial the palette has, as words (`2 [[mixtures]] and 1 [[paths]]`), or
    /// `None` when it has none.
    pub fn dial_criteria(&self) -> Option<String> {
        let part = |n: usize, what: &str| (n > 0).then(|| format!("{n} [[{what}]]"));
        let parts: Vec<String> =
            [part(self.mixtures.len(), "mixtures"), part(self.paths.len(), "paths")].into_iter().flatten().collect();
        (!parts.is_empty()).then(|| parts.join(" and "))
    }

    /// The entries of one side.
    pub fn entries(&self, kind: Kind) -> &[SpectrumEntry] {
        match kind {
            Kind::Light => &self.lights,
            Kind::Reflectance => &self.reflectances,
        }
    }

    /// The bounds that apply to a spectrum: its own, else the palette's for its kind.
    pub fn bounds_of(&self, entry: &SpectrumEntry) -> Bounds {
        entry.bounds.unwrap_or(match entry.kind {
            Kind::Light => self.settings.light_bounds,
            Kind::Reflectance => self.settings.reflectance_bounds,
        })
    }

    /// Index of a light by name.
    pub(crate) fn light_index(&self, name: &str) -> Option<usize> {
        self.lights.iter().position(|e| e.name == name)
    }

    /// Index of a reflectance by name.
    pub fn reflectance_index(&self, name: &str) -> Option<usize> {
        self.reflectances.iter().position(|e| e.name == name)
    }

    /// The colour cell at (light, reflectance), if any.
    pub fn cell(&self, light: usize, reflectance: usize) -> Option<&ColourCell> {
        self.colours.iter().find(|c| c.light == light && c.reflectance == reflectance)
    }
}
