//! Palette files (DESIGN_SPEC §3): reading TOML into the resolved [`Palette`] model with validation that
//! names the file, the key and the reason, and saving the model back while keeping the user's comments,
//! key order and unknown keys (the file is kept as a `toml_edit` document and only changed values are
//! rewritten). Saving is atomic: a temporary file in the same folder, flushed to disk, then renamed over
//! the target, so a failed save never leaves a half-written or missing palette.

mod read;
mod write;

use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use crate::spectrum::Spectrum;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use toml_edit::DocumentMut;

/// Why a palette file cannot be read, validated or written.
#[derive(Debug, thiserror::Error)]
pub enum PaletteError {
    #[error("{}: cannot read the file: {source}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{}: the file is empty (a palette needs at least a name, lights and reflectances)", path.display())]
    Empty { path: PathBuf },
    #[error("{}: not a text file (invalid UTF-8 at byte {offset})", path.display())]
    Binary { path: PathBuf, offset: usize },
    #[error("{}: TOML syntax error at line {line}, column {column}: {message}", path.display())]
    Syntax { path: PathBuf, line: usize, column: usize, message: String },
    #[error("{}: {key}: {reason}", path.display())]
    Invalid { path: PathBuf, key: String, reason: String },
    #[error("{}: cannot write the file: {source}", path.display())]
    Write { path: PathBuf, source: std::io::Error },
    #[error("this palette has no file yet: save it with save_as")]
    NoPath,
}

impl PaletteError {
    /// The key path the error is about, when it is about one key.
    pub fn key(&self) -> Option<&str> {
        match self {
            PaletteError::Invalid { key, .. } => Some(key),
            _ => None,
        }
    }
}

/// A palette file: the editable TOML document and the resolved model read from it.
#[derive(Clone, Debug)]
pub struct PaletteFile {
    /// Where the file lives (`None` for a palette made in memory and not saved yet).
    pub path: Option<PathBuf>,
    /// The document as the user wrote it; saving edits it in place.
    pub document: DocumentMut,
    /// The resolved model, as the document currently says.
    pub palette: Palette,
    /// Non-fatal remarks from reading (unknown keys, kept as they are).
    pub warnings: Vec<String>,
    /// Raw samples of the CSV sources read, by path as written, so saving needs no file access.
    #[allow(dead_code)] // read by saving
    csv_raw: HashMap<String, Spectrum>,
}

/// Line and column (1-based, columns in characters) of a byte offset.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = text.get(..offset).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

impl PaletteFile {
    /// Read and validate a palette file.
    pub fn load(path: &Path) -> Result<PaletteFile, PaletteError> {
        let bytes = std::fs::read(path).map_err(|source| PaletteError::Read { path: path.to_path_buf(), source })?;
        PaletteFile::parse_bytes(&bytes, path)
    }

    /// Parse the bytes of a palette file; `path` names the file in messages and its folder resolves
    /// `csv = "..."` sources.
    pub fn parse_bytes(bytes: &[u8], path: &Path) -> Result<PaletteFile, PaletteError> {
        let text = std::str::from_utf8(bytes)
            .map_err(|e| PaletteError::Binary { path: path.to_path_buf(), offset: e.valid_up_to() })?;
        if let Some(offset) = text.find('\0') {
            return Err(PaletteError::Binary { path: path.to_path_buf(), offset });
        }
        PaletteFile::parse(text, path)
    }

    /// Parse the text of a palette file; `path` names the file in messages and its folder resolves
    /// `csv = "..."` sources.
    pub fn parse(text: &str, path: &Path) -> Result<PaletteFile, PaletteError> {
        if text.trim().is_empty() {
            return Err(PaletteError::Empty { path: path.to_path_buf() });
        }
        let syntax = |message: &str, span: Option<std::ops::Range<usize>>| {
            let (line, column) = line_column(text, span.map_or(0, |s| s.start));
            PaletteError::Syntax { path: path.to_path_buf(), line, column, message: message.trim().replace('\n', " ") }
        };
        let document: DocumentMut = text.parse().map_err(|e: toml_edit::TomlError| syntax(e.message(), e.span()))?;
        let table: toml::Table = toml::from_str(text).map_err(|e: toml::de::Error| syntax(e.message(), e.span()))?;
        let colorimetry = Colorimetry::default();
        let outcome = read::Reader::new(path, colorimetry.luminance()).read(&table)?;
        Ok(PaletteFile {
            path: Some(path.to_path_buf()),
            document,
            palette: outcome.palette,
            warnings: outcome.warnings,
            csv_raw: outcome.csv_raw,
        })
    }

    /// The file's text as it stands (what `save` writes).
    pub fn text(&self) -> String {
        self.document.to_string()
    }
}
