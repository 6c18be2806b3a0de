//! Palettes (DESIGN_SPEC §3): lights as columns, reflectances as rows, target colours on cells,
//! free-colour groups and the design settings.
//!
//! [`Palette`] is the resolved in-memory model every other module works on: every spectrum already
//! resolved to samples (lights normalised and scaled), every target in linear sRGB, every reference
//! to a light, reflectance or free group an index. Reading and writing TOML lives in [`file`].

pub mod edit;
pub mod file;
pub mod source;

use crate::spectrum::{Normalize, Spectrum};
use nalgebra::Vector3;

/// Inclusive bounds on a value; `-inf` / `inf` mean unbounded on that side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub lower: f64,
    pub upper: f64,
}

impl Bounds {
    pub const UNBOUNDED: Bounds = Bounds { lower: f64::NEG_INFINITY, upper: f64::INFINITY };

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
    Light,
    Reflectance,
}

impl Kind {
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
    pub name: String,
    pub kind: Kind,
    pub source: Source,
    /// Lights only; reflectances are never normalised.
    pub normalize: Normalize,
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
    pub name: String,
    /// Per-channel lower bound in linear sRGB (`-inf` where absent).
    pub lower: Vector3<f64>,
    /// Per-channel upper bound in linear sRGB (`inf` where absent).
    pub upper: Vector3<f64>,
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
    pub reflectance_bounds: Bounds,
    pub light_bounds: Bounds,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            basis_dimension: 7,
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
    pub name: String,
    pub settings: Settings,
    pub lights: Vec<SpectrumEntry>,
    pub reflectances: Vec<SpectrumEntry>,
    pub colours: Vec<ColourCell>,
    pub free: Vec<FreeGroup>,
}

impl Palette {
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
    pub fn light_index(&self, name: &str) -> Option<usize> {
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
