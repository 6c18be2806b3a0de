//! The palette edits the designer performs, as one seam onto the palette model's edit operations
//! ([`crate::palette::edit`]). Each returns a typed [`EditError`] when the edit cannot be made (the view
//! renders it); the caller then keeps the palette unchanged.
//!
//! Two small operations the model does not offer live here: setting a free group's bounds (validated like
//! `Palette::add_free_group`) and adding a CSV spectrum relative to the palette file's folder.

use crate::colorimetry::Colorimetry;
use crate::palette::{Kind, Palette, Source};
use crate::spectrum::Normalize;
use nalgebra::Vector3;
use std::path::Path;

/// Why an edit or a prompt's answer was refused; the view shows it (message line or prompt).
#[derive(Debug, thiserror::Error)]
pub enum EditError {
    /// The palette model refused the edit.
    #[error(transparent)]
    Palette(#[from] crate::palette::EditError),
    /// A removal refused because mixtures or paths use the entry (the designer can delete those: `M`).
    #[error("{what} is used by {by}: M lists them and x there deletes one")]
    DialInUse { what: String, by: String },
    #[error("'{0}' is not a group name (use letters or digits, no spaces)")]
    GroupName(String),
    #[error("'{0}' cannot be a name (no quotes or control characters)")]
    BadName(String),
    #[error("channel {channel}: lower bound {lower} is not ≤ upper bound {upper}")]
    FreeBounds { channel: usize, lower: f64, upper: f64 },
    #[error("there is no free group number {0}")]
    NoGroup(usize),
    #[error("'{0}' is not a number")]
    NotANumber(String),
    #[error("'{0}' is not #rrggbb")]
    NotHex(String),
    #[error("{0} is not a finite number ≥ 0")]
    NotNonNegative(f64),
    #[error("the lower bound is above the upper")]
    Unordered,
    #[error("the basis dimension is an integer from 1 to 31")]
    BasisDimension,
    #[error("the temperature must be a positive number of kelvin")]
    Temperature,
    #[error("the scale must be a positive finite number")]
    Scale,
    #[error("give 2 numbers (lower upper) or 6 (lower r g b, upper r g b)")]
    BoundsCount,
    #[error("give a path")]
    NoPath,
    /// The CSV reader thread could not be started.
    #[error("cannot start the reader: {0}")]
    Reader(String),
    /// A save-as was refused (the file named, and why).
    #[error(transparent)]
    File(#[from] FileError),
}

/// Why a save, a save-as, a reload or a recovery copy did not happen.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FileError {
    /// Another program changed the file since it was opened or last saved; the designer's version was
    /// saved aside (`aside`: where, or why not).
    #[error(
        "{} changed on disk since it was opened; {}. Ctrl-s again overwrites the file, Ctrl-r reloads it, \
         Ctrl-w saves as another file",
        crate::fsio::show(.path),
        match .aside { Ok(p) => format!("your version is saved as {}", crate::fsio::show(p)), Err(e) => format!("your version could not be saved aside ({e})") }
    )]
    Conflict { path: std::path::PathBuf, aside: Result<std::path::PathBuf, String> },
    /// The palette has no file (tests, in-memory designs).
    #[error("the palette has no file")]
    NoFile,
    /// The target of a save-as is empty.
    #[error("give a path")]
    NoPath,
    /// Save-as onto a file that exists (and is not the palette itself): asked once, the same path again
    /// replaces it.
    #[error("{} exists: press Enter again to replace it, or change the path", .0.display())]
    Exists(std::path::PathBuf),
    /// The file system or the palette writer refused (the message names the file and the reason).
    #[error("{0}")]
    Failed(String),
}

/// An [`EditError`] kept by a prompt until the next key (cloned with the prompt; compared by its text).
#[derive(Clone, Debug)]
pub struct Refusal(pub std::sync::Arc<EditError>);

impl PartialEq for Refusal {
    fn eq(&self, other: &Refusal) -> bool {
        self.0.to_string() == other.0.to_string()
    }
}

impl From<EditError> for Refusal {
    fn from(e: EditError) -> Refusal {
        Refusal(std::sync::Arc::new(e))
    }
}

/// The outcome of an edit.
pub(crate) type EditResult = Result<(), EditError>;

fn text(e: crate::palette::EditError) -> EditError {
    EditError::Palette(e)
}

/// Make sure (light, reflectance) has a colour criterion, created in use with target `initial` when absent.
pub(crate) fn ensure_cell(
    palette: &mut Palette,
    light: usize,
    reflectance: usize,
    initial: Vector3<f64>,
) -> EditResult {
    if palette.cell_index(light, reflectance).is_none() {
        palette.set_target(light, reflectance, initial).map_err(text)?;
    }
    Ok(())
}

/// Set the target of a cell (created if absent).
pub(crate) fn set_target(palette: &mut Palette, light: usize, reflectance: usize, rgb: Vector3<f64>) -> EditResult {
    palette.set_target(light, reflectance, rgb).map_err(text)
}

/// Set the weight of a cell (created with target `initial` if absent).
pub(crate) fn set_weight(
    palette: &mut Palette,
    light: usize,
    reflectance: usize,
    weight: f64,
    initial: Vector3<f64>,
) -> EditResult {
    ensure_cell(palette, light, reflectance, initial)?;
    palette.set_weight(light, reflectance, weight).map_err(text)
}

/// Toggle "use colour"; a cell without a criterion gets one with target `current` (its colour now).
pub(crate) fn toggle_use(palette: &mut Palette, light: usize, reflectance: usize, current: Vector3<f64>) -> EditResult {
    match palette.cell(light, reflectance).map(|c| c.enabled) {
        Some(enabled) => palette.set_enabled(light, reflectance, !enabled).map_err(text),
        None => ensure_cell(palette, light, reflectance, current),
    }
}

/// Put a cell into free-colour group `name` (created with bounds [0, 1] per channel when new), or take it
/// out of its group with `None`.
pub(crate) fn set_free(
    palette: &mut Palette,
    light: usize,
    reflectance: usize,
    name: Option<&str>,
    current: Vector3<f64>,
) -> EditResult {
    match name.map(str::trim) {
        None => {
            if palette.cell_index(light, reflectance).is_some() {
                palette.set_free(light, reflectance, None).map_err(text)?;
            }
            Ok(())
        }
        Some(n) => {
            if n.is_empty() || n.chars().any(|c| c.is_whitespace() || c.is_control() || c == '"') {
                return Err(EditError::GroupName(n.to_string()));
            }
            let group = match palette.free.iter().position(|g| g.name == n) {
                Some(g) => g,
                None => palette.add_free_group(n, Vector3::zeros(), Vector3::repeat(1.0)).map_err(text)?,
            };
            ensure_cell(palette, light, reflectance, current)?;
            palette.set_free(light, reflectance, Some(group)).map_err(text)
        }
    }
}

/// Set the per-channel bounds (linear sRGB) of a free group.
pub(crate) fn set_free_bounds(
    palette: &mut Palette,
    group: usize,
    lower: Vector3<f64>,
    upper: Vector3<f64>,
) -> EditResult {
    if let Some(k) = (0..3).find(|&k| lower[k].is_nan() || upper[k].is_nan() || lower[k] > upper[k]) {
        return Err(EditError::FreeBounds { channel: k + 1, lower: lower[k], upper: upper[k] });
    }
    let g = palette.free.get_mut(group).ok_or(EditError::NoGroup(group))?;
    g.lower = lower;
    g.upper = upper;
    Ok(())
}

/// Open a spectrum to design, or fix it again.
pub(crate) fn toggle_design(palette: &mut Palette, kind: Kind, index: usize) -> EditResult {
    palette.toggle_design(kind, index).map(|_| ()).map_err(text)
}

/// Make a light a Planck black body at `kelvin`.
pub(crate) fn make_planck(palette: &mut Palette, light: usize, kelvin: f64, colorimetry: &Colorimetry) -> EditResult {
    palette.make_planck(Kind::Light, light, kelvin, colorimetry).map_err(text)
}

/// Normalise a light (luminance 1 or unit L2 norm, before its scale).
pub(crate) fn normalise(palette: &mut Palette, light: usize, how: Normalize, colorimetry: &Colorimetry) -> EditResult {
    palette.set_normalize(light, how, colorimetry).map_err(text)
}

/// Set a spectrum's scale (the spectrum is its normalised source times the scale).
pub(crate) fn scale(
    palette: &mut Palette,
    kind: Kind,
    index: usize,
    scale: f64,
    colorimetry: &Colorimetry,
) -> EditResult {
    palette.set_scale(kind, index, scale, colorimetry).map_err(text)
}

/// Add a light or reflectance. A CSV path is read relative to `base_dir` (the palette file's folder).
pub(crate) fn add(
    palette: &mut Palette,
    kind: Kind,
    name: &str,
    source: Source,
    base_dir: &Path,
    colorimetry: &Colorimetry,
) -> EditResult {
    palette.add_spectrum_in(kind, name, source, Some(base_dir), colorimetry).map(|_| ()).map_err(text)
}

/// Remove a light or reflectance with its cells.
pub(crate) fn remove(palette: &mut Palette, kind: Kind, index: usize) -> EditResult {
    palette.remove_spectrum(kind, index).map(|_| ()).map_err(|e| match e {
        crate::palette::EditError::InUse { what, by } => EditError::DialInUse { what, by },
        other => text(other),
    })
}

/// A name not yet used on that side of the palette: `base`, else `base_2`, `base_3`…
pub(crate) fn unique_name(palette: &Palette, kind: Kind, base: &str) -> String {
    let taken = |n: &str| palette.entries(kind).iter().any(|e| e.name == n);
    if !taken(base) {
        return base.to_string();
    }
    (2..).map(|k| format!("{base}_{k}")).find(|n| !taken(n)).unwrap_or_else(|| base.to_string())
}
