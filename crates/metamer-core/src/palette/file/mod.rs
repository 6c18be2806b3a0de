//! Palette files (DESIGN_SPEC §3): reading TOML into the resolved [`Palette`] model with validation that
//! names the file, the key and the reason, and saving the model back while keeping the user's comments,
//! key order and unknown keys. Saving is atomic ([`crate::fsio::write_atomic`]: a temporary file in the same
//! folder, flushed to disk, then renamed over the target), so a failed save never leaves a half-written or
//! missing palette.
//!
//! One parser, one writer. Reading ([`read`]) walks the tree of `toml`'s borrowing parser (spans kept for
//! messages, no document built; a long text is parsed in pieces on several threads, [`pieces`]; the faster
//! paths keep the `[[name]]` tables in flat lists, [`doc`]).
//! Writing ([`write`]) updates a `toml_edit` document of the text so only
//! what changed is rewritten; the document is parsed when a save needs it. A save that only changes
//! spectra (what a solve does) updates a document of each changed table instead of one of the whole
//! file ([`tables`]); it is the same writer, applied to less text.

mod budget;
mod doc;
mod events;
mod float_text;
mod lines;
mod numbers;
mod pieces;
mod read;
mod read_mix;
pub(crate) use read_mix::MAX_PATH_SAMPLES;
mod tables;
mod write;
mod write_dial;

use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use crate::spectrum::Spectrum;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use toml_edit::DocumentMut;

/// Why a palette file cannot be read, validated or written.
#[derive(Debug, thiserror::Error)]
pub enum PaletteError {
    /// The file could not be read (missing, a folder, unreadable, too large, …).
    #[error("{cause}")]
    Read {
        /// The palette file as the caller named it.
        path: PathBuf,
        /// What the file system said, with the path and the kind of file in its message.
        cause: Box<crate::fsio::FsError>,
    },
    /// The text is blank, or holds only comments and no key.
    #[error("{}: the file is empty (a palette needs at least a name, lights and reflectances)", path.display())]
    Empty {
        /// The palette file as the caller named it.
        path: PathBuf,
    },
    /// The bytes are not UTF-8 text, or hold a NUL byte.
    #[error("{}: not a text file (invalid UTF-8 at byte {offset})", path.display())]
    Binary {
        /// The palette file as the caller named it.
        path: PathBuf,
        /// Byte offset (from 0) of the first invalid UTF-8 sequence or, in valid UTF-8, of the first NUL.
        offset: usize,
    },
    /// The text is not valid TOML, or holds a number TOML cannot represent.
    #[error("{}: TOML syntax error at line {line}, column {column}: {message}", path.display())]
    Syntax {
        /// The palette file as the caller named it (empty for a palette that has no file yet).
        path: PathBuf,
        /// Line of the error, from 1.
        line: usize,
        /// Column of the error, from 1, counted in characters.
        column: usize,
        /// The parser's message, trimmed and joined onto one line.
        message: String,
    },
    /// The TOML is well formed but a key's value breaks the palette's rules (DESIGN_SPEC §3).
    #[error("{}{}: {key}: {reason}", path.display(), at_line(line))]
    Invalid {
        /// The palette file as the caller named it.
        path: PathBuf,
        /// The key path, e.g. `colours[3].light`.
        key: String,
        /// Why the value is refused, in words that say what would be accepted.
        reason: String,
        /// The line of the key (or of its table when the key is missing), when known.
        line: Option<usize>,
    },
    /// The new text could not be staged beside the target or put in place; the file on disk is unchanged.
    #[error("{cause}")]
    Write {
        /// The file being saved to, as the caller named it.
        path: PathBuf,
        /// What the file system said, with the path in its message.
        cause: Box<crate::fsio::FsError>,
    },
    /// The text holds so many tables, arrays and values for its size that parsing it would take more
    /// memory than allowed; refused before any parse.
    #[error(
        "{}: the palette holds {tables} tables, {arrays} arrays and {values} values for its size: parsing it \
         would take about {estimate_mb} MiB, more than the limit of {limit_mb} MiB",
        path.display()
    )]
    TooComplex {
        /// The palette file as the caller named it.
        path: PathBuf,
        /// Tables counted in the text (`{` and headers), outside strings and comments.
        tables: u64,
        /// Arrays counted in the text, outside strings and comments.
        arrays: u64,
        /// Values counted in the text (`=` and `,`), outside strings and comments.
        values: u64,
        /// The estimated memory of the parse, MiB (2²⁰ bytes), rounded down.
        estimate_mb: u64,
        /// The most the parse of a text of this length may take, MiB, rounded down.
        limit_mb: u64,
    },
    /// `save` was asked of a palette made in memory, which has no file yet.
    #[error("this palette has no file yet: save it with save_as")]
    NoPath,
}

fn at_line(line: &Option<usize>) -> String {
    line.map(|l| format!(":{l}")).unwrap_or_default()
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

/// A palette file: its text, the resolved model read from it, and (built when a save needs it) the editable
/// TOML document.
#[derive(Clone, Debug)]
pub struct PaletteFile {
    /// Where the file lives (`None` for a palette made in memory and not saved yet).
    pub path: Option<PathBuf>,
    /// The document as the user wrote it (parsed from `original` on first use); saving edits a copy.
    document: OnceLock<DocumentMut>,
    /// Where each spectrum's table sits in `original` (for saves that rewrite only some tables).
    tables: Option<tables::Tables>,
    /// The resolved model, as the document currently says.
    pub palette: Palette,
    /// Non-fatal remarks from reading (unknown keys, kept as they are).
    pub warnings: Vec<String>,
    /// Raw samples of the CSV sources read, by path as written, so saving needs no file access.
    csv_raw: HashMap<String, Spectrum>,
    /// The file used CRLF line endings (the document keeps LF; saving writes CRLF back).
    crlf: bool,
    /// Some lines of the file end in CRLF and some in LF.
    mixed_newlines: bool,
    /// The file ended without a newline (saving keeps it that way).
    no_final_newline: bool,
    /// The file began with a UTF-8 byte order mark (the document drops it; saving writes it back).
    bom: bool,
    /// The text as read (or last written): an unchanged document saves as exactly these bytes.
    original: String,
}

/// A text read: the model and where its spectra's tables sit.
type Read = (read::ReadOutcome, Option<tables::Tables>);

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
        let bytes = crate::fsio::read(path, crate::fsio::Kind::Palette)
            .map_err(|cause| PaletteError::Read { path: path.to_path_buf(), cause: Box::new(cause) })?;
        // The bytes read become the file's text as they are (checked as `parse_bytes` checks them, not copied).
        let text = String::from_utf8(bytes)
            .map_err(|e| PaletteError::Binary { path: path.to_path_buf(), offset: e.utf8_error().valid_up_to() })?;
        if let Some(offset) = memchr::memchr(0, text.as_bytes()) {
            return Err(PaletteError::Binary { path: path.to_path_buf(), offset });
        }
        let (read, _) = PaletteFile::read_text(&text, path, true)?;
        Ok(PaletteFile::from_read(text, path, read))
    }

    /// Parse the bytes of a palette file; `path` names the file in messages and its folder resolves
    /// `csv = "..."` sources.
    pub fn parse_bytes(bytes: &[u8], path: &Path) -> Result<PaletteFile, PaletteError> {
        let text = std::str::from_utf8(bytes)
            .map_err(|e| PaletteError::Binary { path: path.to_path_buf(), offset: e.valid_up_to() })?;
        if let Some(offset) = memchr::memchr(0, text.as_bytes()) {
            return Err(PaletteError::Binary { path: path.to_path_buf(), offset });
        }
        PaletteFile::parse(text, path)
    }

    /// Parse the text of a palette file; `path` names the file in messages and its folder resolves
    /// `csv = "..."` sources.
    pub fn parse(text: &str, path: &Path) -> Result<PaletteFile, PaletteError> {
        PaletteFile::parse_with(text, path, true).map(|(file, _)| file)
    }

    /// [`PaletteFile::parse`], trying the parse from events with the number arrays read by hand first when
    /// `fast` (and saying how many arrays were read by hand when the palette came from that path).
    fn parse_with(text: &str, path: &Path, fast: bool) -> Result<(PaletteFile, Option<usize>), PaletteError> {
        let (read, used) = PaletteFile::read_text(text, path, fast)?;
        Ok((PaletteFile::from_read(text.to_string(), path, read), used))
    }

    /// What [`PaletteFile::parse_with`] reads from `text`: the model and the tables' layout, and how many
    /// arrays were read by hand when they were.
    fn read_text(text: &str, path: &Path, fast: bool) -> Result<(Read, Option<usize>), PaletteError> {
        if text.trim().is_empty() {
            return Err(PaletteError::Empty { path: path.to_path_buf() });
        }
        // A palette written in the plainest lines, read in one pass ([`lines`]); the text read as below when
        // it holds any other line, is over the parse budget, or the palette is refused.
        if fast
            && let Some(lines) = lines::parse(text)
            && let Ok((outcome, tables)) = PaletteFile::read_parsed(text, lines.tree, path, Some(&lines.read))
            && lines.read.all_taken()
        {
            return Ok(((outcome, tables), Some(lines.read.len())));
        }
        // Parse memory is bounded by the input size (see [`budget`]): refused before any parse.
        let scan = budget::scan(text);
        let counts = scan.counts;
        if counts.cost() > budget::budget(text.len()) {
            return Err(PaletteError::TooComplex {
                path: path.to_path_buf(),
                tables: counts.tables,
                arrays: counts.arrays,
                values: counts.values,
                estimate_mb: counts.cost() >> 20,
                limit_mb: budget::budget(text.len()) >> 20,
            });
        }
        // The usual shapes parsed from the parser's events with the number arrays read by hand
        // ([`events`]); the text parsed as it is when that path does not apply or the palette is refused.
        if fast
            && let Some((tree, read)) = events::parse(text, &scan.headers)
            && let Ok((outcome, tables)) = PaletteFile::read_parsed(text, tree, path, Some(&read))
            && read.all_taken()
        {
            return Ok(((outcome, tables), Some(read.len())));
        }
        let (outcome, tables) = PaletteFile::read_tree(text, &scan.headers, path)?;
        Ok(((outcome, tables), None))
    }

    /// Parse `text` (cut at some of its `headers` when long) and read the tree into the model.
    fn read_tree(
        text: &str,
        headers: &[usize],
        path: &Path,
    ) -> Result<(read::ReadOutcome, Option<tables::Tables>), PaletteError> {
        let syntax = |message: &str, span: Option<std::ops::Range<usize>>| {
            let (line, column) = line_column(text, span.map_or(0, |s| s.start));
            PaletteError::Syntax { path: path.to_path_buf(), line, column, message: message.trim().replace('\n', " ") }
        };
        // The parser keeps numbers as text; one TOML cannot represent is a syntax error, as in `toml_edit`.
        let spanned = pieces::parse(text, headers).map_err(|e| match e {
            pieces::Failure::Syntax(e) => syntax(e.message(), e.span()),
            pieces::Failure::Number(span, message) => syntax(message, Some(span)),
        })?;
        PaletteFile::read_parsed(text, doc::Doc::tree(spanned), path, None)
    }

    /// Read the parsed tree of `text` into the model, with the sample arrays already read (`numbers`) taken
    /// at their spans.
    fn read_parsed(
        text: &str,
        doc: doc::Doc<'_>,
        path: &Path,
        numbers: Option<&numbers::Read>,
    ) -> Result<(read::ReadOutcome, Option<tables::Tables>), PaletteError> {
        let root = &doc;
        let colorimetry = Colorimetry::default();
        // The tables' layout is found beside the reading (and dropped if the palette is refused).
        let (outcome, tables) = rayon::join(
            || {
                read::Reader::new(path, colorimetry.luminance(), numbers).read(root).map_err(|e| match e {
                    PaletteError::Invalid { path, key, reason, line: None } => {
                        let line = root.span_of_key(&key).map(|s| line_column(text, s.start).0);
                        PaletteError::Invalid { path, key, reason, line }
                    }
                    other => other,
                })
            },
            || tables::Tables::of(root, text),
        );
        pieces::drop_doc(doc);
        Ok((outcome?, tables))
    }

    /// The file of the text `original` read as `read`.
    fn from_read(original: String, path: &Path, read: Read) -> Self {
        let (outcome, tables) = read;
        let text = original.as_str();
        // Line endings: CRLF when most newlines have a carriage return before them.
        // Line feeds counted in runs of 255 bytes with a byte-wide count (which the compiler vectorises), and
        // only when there is a CRLF: most files hold no carriage return at all (then LF, not mixed).
        let bytes = text.as_bytes();
        let crlf = if memchr::memchr(b'\r', bytes).is_some() { text.matches("\r\n").count() } else { 0 };
        let newlines: usize = if crlf == 0 {
            0
        } else {
            bytes.chunks(255).map(|run| usize::from(run.iter().fold(0u8, |n, &c| n + u8::from(c == b'\n')))).sum()
        };
        PaletteFile {
            path: Some(path.to_path_buf()),
            document: OnceLock::new(),
            tables,
            palette: outcome.palette,
            warnings: outcome.warnings,
            csv_raw: outcome.csv_raw,
            crlf: crlf * 2 > newlines,
            mixed_newlines: crlf != 0 && crlf != newlines,
            no_final_newline: !text.ends_with('\n'),
            bom: text.starts_with('\u{feff}'),
            original,
        }
    }

    /// A new file for a palette made in memory (no path yet: save it with [`PaletteFile::save_as`]).
    pub fn from_palette(palette: &Palette) -> PaletteFile {
        let mut document = DocumentMut::new();
        let ctx = write::SaveContext {
            old_base: None,
            new_base: Path::new("."),
            csv_raw: &HashMap::new(),
            luminance: Colorimetry::default().luminance(),
        };
        // A fresh document has no structure that could refuse the model.
        let _ = write::update_document(&mut document, &Palette::default(), palette, &ctx);
        PaletteFile {
            path: None,
            document: OnceLock::from(document),
            tables: None,
            palette: palette.clone(),
            warnings: Vec::new(),
            csv_raw: HashMap::new(),
            crlf: false,
            mixed_newlines: false,
            no_final_newline: false,
            bom: false,
            original: String::new(),
        }
    }

    /// The file's text as it stands.
    pub fn text(&self) -> String {
        if !self.original.is_empty() {
            return self.original.clone();
        }
        self.document().map(|d| self.text_of(d)).unwrap_or_default()
    }

    /// The editable document, parsed from the text on first use.
    fn document(&self) -> Result<&DocumentMut, PaletteError> {
        if let Some(d) = self.document.get() {
            return Ok(d);
        }
        let path = self.path.clone().unwrap_or_default();
        let document = self.original.parse::<DocumentMut>().map_err(|e| {
            let (line, column) = line_column(&self.original, e.span().map_or(0, |s| s.start));
            PaletteError::Syntax { path, line, column, message: e.message().trim().replace('\n', " ") }
        })?;
        Ok(self.document.get_or_init(|| document))
    }

    /// A document's text with this file's byte order mark, line endings and final newline (the text as read
    /// when the document is unchanged).
    fn text_of(&self, document: &DocumentMut) -> String {
        let mut text = document.to_string();
        if !self.original.is_empty() && self.document().is_ok_and(|d| text == d.to_string()) {
            return self.original.clone();
        }
        if self.bom && !text.starts_with('\u{feff}') {
            text.insert(0, '\u{feff}');
        }
        if self.no_final_newline && text.ends_with('\n') {
            text.pop();
        }
        if self.crlf { text.replace("\r\n", "\n").replace('\n', "\r\n") } else { text }
    }

    /// The text that saving `palette` to `path` would write, checked by reading it back: the updated
    /// document and the file it reads as. Nothing is written.
    pub fn render(&self, palette: &Palette, path: &Path) -> Result<(DocumentMut, PaletteFile), PaletteError> {
        let mut document = self.document()?.clone();
        self.with_save_context(path, |ctx| write::update_document(&mut document, &self.palette, palette, ctx))
            .map_err(|e| PaletteError::Invalid {
                path: path.to_path_buf(),
                key: "(document)".to_string(),
                reason: e.0,
                line: None,
            })?;
        let reread = PaletteFile::parse(&self.text_of(&document), path)?;
        Ok((document, reread))
    }

    /// True when the file on disk is no longer the text this file was read from or last saved as: another
    /// program changed it. A file that is gone is not a change (saving writes it again).
    pub fn changed_on_disk(&self) -> bool {
        let Some(path) = &self.path else { return false };
        match crate::fsio::read(path, crate::fsio::Kind::Palette) {
            Ok(bytes) => bytes != self.original.as_bytes(),
            Err(crate::fsio::FsError::Read { source, .. }) if source.kind() == std::io::ErrorKind::NotFound => false,
            Err(_) => true,
        }
    }

    /// Record the files this palette was read from (itself, as `role`, and the CSV files its sources name)
    /// as inputs of `outputs`, so no output of the command can be one of them.
    pub fn record_inputs(&self, role: &str, outputs: &mut crate::fsio::Outputs) {
        if let Some(path) = &self.path {
            outputs.input(role, path);
            let base = crate::fsio::folder_of(path);
            for csv in self.csv_raw.keys() {
                outputs.input("CSV spectrum", &base.join(csv));
            }
        }
    }

    /// Save `palette` over this file (atomically). On any error the file on disk is left as it was.
    pub fn save(&mut self, palette: &Palette) -> Result<(), PaletteError> {
        let path = self.path.clone().ok_or(PaletteError::NoPath)?;
        self.save_as(palette, &path)
    }

    /// Save `palette` to `path` (atomically) and make that this file's path. The text is checked by reading
    /// it back before anything is written (a save by tables, in debug builds); on any error
    /// the file on disk is left as it was.
    pub fn save_as(&mut self, palette: &Palette, path: &Path) -> Result<(), PaletteError> {
        let staged = self.stage_save_as(palette, path, crate::fsio::Replace::Writable)?;
        self.commit(staged)
    }

    /// The first half of [`PaletteFile::save_as`]: the new text rendered, checked, written and synced beside
    /// `path` ([`crate::fsio::stage`]) but not yet in place, and this file unchanged. [`PaletteFile::commit`]
    /// puts it in place; dropping it leaves the file on disk as it was (a command whose other output failed).
    /// A read-only file at `path` is replaced only with [`crate::fsio::Replace::Force`].
    pub fn stage_save_as(
        &self,
        palette: &Palette,
        path: &Path,
        replace: crate::fsio::Replace,
    ) -> Result<StagedSave, PaletteError> {
        self.prepare_save_as(palette, path)?.stage(replace)
    }

    /// The first part of [`PaletteFile::stage_save_as`]: the new text rendered and checked, nothing written
    /// ([`PreparedSave::stage`] writes it). A command formats it while other work runs and stages it after.
    pub fn prepare_save_as(&self, palette: &Palette, path: &Path) -> Result<PreparedSave, PaletteError> {
        self.prepare(palette, path, true)
    }

    /// [`PaletteFile::prepare_save_as`] for a command that ends once the save is in place
    /// ([`PreparedEnd::stage_to_end`]): the same text, without what the file would become. A save by
    /// tables then builds no entry for the rewritten tables (for a solve's 1200 designs, the copies of
    /// their samples and entries were about 200 pages of fresh memory, and each spectrum was resolved twice).
    pub fn prepare_save_to_end(&self, palette: &Palette, path: &Path) -> Result<PreparedEnd, PaletteError> {
        self.prepare(palette, path, false).map(PreparedEnd)
    }

    /// The new text, and with `keep_entries` what a save by tables makes of the rewritten tables.
    fn prepare(&self, palette: &Palette, path: &Path, keep_entries: bool) -> Result<PreparedSave, PaletteError> {
        let update = match self.save_by_tables(palette, path, keep_entries) {
            Some(saved) => Prepared::Tables(Box::new(saved)),
            None => {
                let (document, reread) = self.render(palette, path)?;
                let text = self.text_of(&document);
                Prepared::Document(Box::new((document, reread)), text)
            }
        };
        Ok(PreparedSave { path: path.to_path_buf(), update })
    }

    /// Put a staged save in place and make this file what was written (its path, text and palette).
    pub fn commit(&mut self, save: StagedSave) -> Result<(), PaletteError> {
        let mut folders = crate::fsio::FolderSync::default();
        self.commit_in(save, &mut folders)
        // `folders` dropped here: the folder is synced before this returns.
    }

    /// [`PaletteFile::commit`] whose folder sync is left to `folders` ([`crate::fsio::FolderSync`]), for a
    /// command that commits other outputs after this one.
    pub fn commit_in(&mut self, save: StagedSave, folders: &mut crate::fsio::FolderSync) -> Result<(), PaletteError> {
        let StagedSave { staged, path, update } = save;
        StagedEnd { staged, path: path.clone() }.commit_only_in(folders)?;
        match update {
            Update::Tables(saved) => {
                let saved = *saved;
                self.palette = saved.palette(&self.palette);
                self.original = saved.text();
                self.tables = Some(saved.tables);
                self.document = OnceLock::new();
            }
            Update::Document(both) => {
                let (document, reread) = *both;
                self.document = OnceLock::from(document);
                self.palette = reread.palette;
                self.csv_raw = reread.csv_raw;
                self.warnings = reread.warnings;
                self.tables = reread.tables;
                self.original = reread.original;
            }
        }
        self.path = Some(path);
        Ok(())
    }

    /// Run `f` with what a save to `path` needs: CSV sources are rebased from this file's folder to `path`'s.
    fn with_save_context<T>(&self, path: &Path, f: impl FnOnce(&write::SaveContext) -> T) -> T {
        let new_base = crate::fsio::folder_of(path);
        let old_base = self.path.as_deref().map(crate::fsio::folder_of);
        f(&write::SaveContext {
            old_base: old_base.as_deref(),
            new_base: &new_base,
            csv_raw: &self.csv_raw,
            luminance: Colorimetry::default().luminance(),
        })
    }

    /// The save of `palette` to `path` that rewrites only the changed spectrum tables, when the change
    /// allows it (see [`tables`]); with `keep_entries`, what the rewritten tables read as too.
    fn save_by_tables(&self, palette: &Palette, path: &Path, keep_entries: bool) -> Option<tables::Saved> {
        let tables = self.tables.as_ref()?;
        if self.original.is_empty() {
            return None;
        }
        let layout = tables::Layout {
            text: &self.original,
            tables,
            crlf: self.crlf,
            mixed_newlines: self.mixed_newlines,
            no_final_newline: self.no_final_newline,
        };
        let save = |keep| self.with_save_context(path, |ctx| tables::save(&layout, &self.palette, palette, ctx, keep));
        let saved = save(keep_entries)?;
        // Debug builds (the tests) also read the whole text back; a save without its entries is checked
        // against the same save with them (the same text, and their palette).
        #[cfg(debug_assertions)]
        {
            let reread = PaletteFile::parse(&saved.text(), path);
            let intended = if keep_entries {
                Some(saved.palette(&self.palette))
            } else {
                save(true).filter(|with| with.pieces == saved.pieces).map(|with| with.palette(&self.palette))
            };
            debug_assert!(
                reread.as_ref().is_ok_and(|r| {
                    intended.is_some_and(|p| r.palette == p) && r.tables.as_ref() == Some(&saved.tables)
                }),
                "a save by tables does not read back as intended"
            );
        }
        Some(saved)
    }
}

/// A palette save written and synced beside its file but not yet in place ([`PaletteFile::stage_save_as`]).
pub struct StagedSave {
    staged: crate::fsio::Staged,
    path: PathBuf,
    update: Update,
}

impl StagedSave {
    /// Put the save in place as [`PaletteFile::commit_in`] does (the same checks, the rename, the folder's
    /// sync left to `folders`) without making the file it was staged from what was written: for a command
    /// that ends after its save and needs that file no more (the new text is not joined and the new
    /// palette not built).
    pub fn commit_only_in(self, folders: &mut crate::fsio::FolderSync) -> Result<(), PaletteError> {
        let StagedSave { staged, path, update: _ } = self;
        StagedEnd { staged, path }.commit_only_in(folders)
    }
}

/// A palette save rendered but not yet written ([`PaletteFile::prepare_save_as`]).
pub struct PreparedSave {
    path: PathBuf,
    update: Prepared,
}

/// The text of a prepared save and what the file becomes once it is committed.
enum Prepared {
    Tables(Box<tables::Saved>),
    Document(Box<(DocumentMut, PaletteFile)>, String),
}

impl PreparedSave {
    /// The second part of [`PaletteFile::stage_save_as`]: the text written and synced beside its file
    /// ([`crate::fsio::stage_writing`]), not yet in place.
    pub fn stage(self, replace: crate::fsio::Replace) -> Result<StagedSave, PaletteError> {
        let PreparedSave { path, update } = self;
        let write_error = |cause| PaletteError::Write { path: path.clone(), cause: Box::new(cause) };
        let (staged, update) = match update {
            Prepared::Tables(saved) => {
                // Its pieces written one after another: the same bytes as the whole text.
                let staged = crate::fsio::stage_writing(&path, crate::fsio::Name::User, replace, |w| {
                    saved.pieces.iter().try_for_each(|piece| std::io::Write::write_all(w, piece.as_bytes()))
                });
                (staged.map_err(write_error)?, Update::Tables(saved))
            }
            Prepared::Document(both, text) => {
                let staged = crate::fsio::stage_with(&path, text.as_bytes(), replace).map_err(write_error)?;
                (staged, Update::Document(both))
            }
        };
        Ok(StagedSave { staged, path, update })
    }
}

/// A palette save rendered for a command that ends once it is in place
/// ([`PaletteFile::prepare_save_to_end`]): it can only be staged to its end.
pub struct PreparedEnd(PreparedSave);

impl PreparedEnd {
    /// [`PreparedSave::stage`] for a command that ends once the save is in place ([`StagedEnd`]): the
    /// text's pieces are freed as soon as they are written (before the sync, so that the memory serves
    /// what the command formats next rather than fresh pages), and what the file would become is not kept.
    pub fn stage_to_end(self, replace: crate::fsio::Replace) -> Result<StagedEnd, PaletteError> {
        let PreparedSave { path, update } = self.0;
        let write_error = |cause| PaletteError::Write { path: path.clone(), cause: Box::new(cause) };
        let staged = match update {
            Prepared::Tables(mut saved) => {
                let pieces = std::mem::take(&mut saved.pieces);
                drop(saved);
                // Its pieces written one after another: the same bytes as the whole text.
                crate::fsio::stage_writing(&path, crate::fsio::Name::User, replace, move |w| {
                    let written = pieces.iter().try_for_each(|piece| std::io::Write::write_all(w, piece.as_bytes()));
                    drop(pieces);
                    written
                })
            }
            Prepared::Document(both, text) => {
                drop(both);
                crate::fsio::stage_with(&path, text.as_bytes(), replace)
            }
        };
        Ok(StagedEnd { staged: staged.map_err(write_error)?, path })
    }
}

/// A palette save written and synced beside its file, for a command that ends once it is in place
/// ([`PreparedEnd::stage_to_end`]): it holds neither the text nor what the file would become.
pub struct StagedEnd {
    staged: crate::fsio::Staged,
    path: PathBuf,
}

impl StagedEnd {
    /// Put the save in place: the checks and the rename of [`crate::fsio::Staged::commit_in`], the folder's
    /// sync left to `folders`. The one place a staged palette save is put in place ([`StagedSave`]'s
    /// commits and [`PaletteFile::commit_in`] come here).
    pub fn commit_only_in(self, folders: &mut crate::fsio::FolderSync) -> Result<(), PaletteError> {
        let StagedEnd { staged, path } = self;
        staged.commit_in(folders).map_err(|cause| PaletteError::Write { path, cause: Box::new(cause) })
    }
}

/// What the file becomes once a staged save is committed.
enum Update {
    Tables(Box<tables::Saved>),
    Document(Box<(DocumentMut, PaletteFile)>),
}
