//! The one way metamer reads and writes files.
//!
//! **Reads** ([`read`], [`read_to_string`]) open without blocking (`O_NONBLOCK`, so a FIFO cannot hang the
//! open), check the *opened* file with `fstat`, refuse anything that is not a regular file (FIFOs, devices
//! such as `/dev/zero`, directories, sockets), refuse a file larger than the cap of its [`Kind`] from its size
//! alone (a 2 GB sparse file is never read) and never read more than the cap (a file that grows while it is
//! read is refused too).
//!
//! **Writes** ([`write_atomic`], or [`stage`] then [`Staged::commit`] for outputs written together) go to a temporary file in the target's folder, are synced, renamed over the
//! target and the folder is synced: a reader (or a crash, or a full disk) sees the old file or the new one,
//! never a mix. Outputs committed together ([`Staged::commit_in`]) are renamed in turn and each distinct
//! folder is then synced once ([`FolderSync`]), after the last rename into it. A file staged without its
//! sync ([`stage_unsynced`], for a thread that commits what others produce) is synced by its commit, before
//! its rename. A target that exists and is not a regular file (FIFO, device: `-o /dev/null`) is refused, and so
//! is one whose mode gives no write permission (read-only) unless the caller passes [`Replace::Force`]; a
//! symbolic link to a regular file is followed, so the target is rewritten and the link kept. New files follow
//! the umask (the temporary file is created `0666 & !umask`); an in-place save keeps the old file's mode and,
//! where permitted, its owner and group.
//!
//! **Interrupts**: every temporary file of a staged output is listed while it exists ([`Staged`] holds its
//! entry), so a command stopped by a signal removes them all in one call ([`remove_staged`], which the CLI's
//! signal thread makes on SIGINT, SIGTERM and SIGHUP before the signal's own action): an interrupted
//! `render` or `solve` leaves its outputs as they were, without the hidden `.NAME.XXXXXX.tmp` files of the
//! frames or outputs it was writing. After that call no output can be staged any more (the command is
//! ending).
//!
//! **Changed since read**: every read records what it read (device, inode, size, modification and change
//! times, and a CRC-32 of the content for files of at most 16 MiB). A write over a file this process read
//! is refused ([`FsError::Changed`]) when the file on disk is no longer what was read (another program
//! wrote it meanwhile: `solve p.toml -o p.toml` while an editor saved `p.toml`), unless the caller passes
//! [`Replace::Changed`] or [`Replace::Force`]; the check is made when the output is staged and again just
//! before the rename. A file whose times changed but whose content is what was read (`touch`) is not a
//! change. After a write, what was written is what counts as read.
//!
//! **Links**: a path the user named (`-o FILE`, the palette the designer opened: [`Name::User`]) is
//! followed when it is a symbolic link, and the link kept. A file whose name the command chose inside a
//! folder the user named (frames and their contact sheet in `render -o DIR`, basis sidecars, the
//! benchmark's files in `bench -o DIR`: [`Name::Chosen`]) that is found to be a symbolic link is refused
//! ([`FsError::ChosenLink`]) unless the caller passes [`Replace::Force`] (the commands' `--force`): the
//! command did not make that link, and following it would write wherever it points.
//!
//! **Same file** ([`Outputs`]): an output must not be any input nor another output. Files are compared by
//! identity (device and inode when they exist, the canonical folder plus name when they do not), so
//! `p.toml`, `./p.toml` and a link to it are one file. [`record_reads`] lists every file a piece of work
//! read through this module (a scene's palette, its CSV sources, a NRRD header's detached data file…), so a
//! command registers all its inputs at once ([`Outputs::inputs_read`]) instead of naming each one.

use std::borrow::Cow;
use std::fs::{File, Metadata};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// What kind of file is read: it names the file in messages and sets its size cap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A palette (TOML).
    Palette,
    /// A CSV spectrum named by `csv = "..."`.
    Csv,
    /// A scene description (TOML).
    Scene,
    /// A volume file (NRRD header, attached NRRD, VTI, raw or detached data).
    Volume,
    /// A designer key script (`--replay`).
    KeyScript,
    /// The trained-basis sidecar (`X.basis.json`), read automatically.
    Sidecar,
    /// A text file the tool updates (the README's generated section).
    Text,
    /// A rendered frame read back (a contact sheet assembled from frames already written).
    Frame,
}

const MIB: u64 = 1 << 20;

impl Kind {
    /// The largest file of this kind that is read, in bytes.
    pub fn cap(self) -> u64 {
        match self {
            // A 200 × 200 palette of designed spectra with comments is about 2 MiB; parsing costs a few
            // times the input (see the robustness section of the README).
            Kind::Palette => 8 * MIB,
            Kind::Csv => 16 * MIB,
            Kind::Scene => 4 * MIB,
            Kind::Volume => 4096 * MIB,
            Kind::KeyScript => 4 * MIB,
            Kind::Sidecar => 64 * MIB,
            Kind::Text => 16 * MIB,
            // A 4096² RGB PNG that does not compress at all is 48 MiB.
            Kind::Frame => 64 * MIB,
        }
    }

    /// The kind as messages name it.
    pub fn label(self) -> &'static str {
        match self {
            Kind::Palette => "palette",
            Kind::Csv => "CSV spectrum",
            Kind::Scene => "scene",
            Kind::Volume => "volume file",
            Kind::KeyScript => "key script",
            Kind::Sidecar => "basis sidecar",
            Kind::Text => "text file",
            Kind::Frame => "frame image",
        }
    }
}

/// Why a file could not be read or written. Every message names the file (control characters escaped) and
/// the reason.
#[derive(Debug, thiserror::Error)]
pub enum FsError {
    /// Looking at, opening or reading the file failed (missing, no permission, …), or a text file is not UTF-8.
    #[error("{}: cannot read the {}: {source}", show(path), kind.label())]
    Read {
        /// The file as the caller named it (a link not resolved).
        path: PathBuf,
        /// What the file was read as; names it in the message.
        kind: Kind,
        /// The operating system's error (`InvalidData` naming the byte offset for text that is not UTF-8).
        source: std::io::Error,
    },
    /// The file to read is a directory, FIFO, device, socket or other non-regular file.
    #[error("{}: the {} is {found}, not a regular file", show(path), kind.label())]
    NotRegularInput {
        /// The file as the caller named it (a link not resolved).
        path: PathBuf,
        /// What the file was read as; names it in the message.
        kind: Kind,
        /// What is there instead, as words (`a FIFO`, `a directory`, …).
        found: &'static str,
    },
    /// The file is larger than the cap of its kind (or of the caller), or grew past it while being read.
    #[error("{}: the {} is {size} bytes, more than the limit of {cap} bytes", show(path), kind.label())]
    TooLarge {
        /// The file as the caller named it (a link not resolved).
        path: PathBuf,
        /// What the file was read as; names it in the message.
        kind: Kind,
        /// The file's size in bytes as `fstat` gave it, or cap + 1 when it grew past the cap while read.
        size: u64,
        /// The most bytes that are read of this file: its kind's [`Kind::cap`] or the caller's cap.
        cap: u64,
    },
    /// The target exists and is not a regular file (a directory, FIFO, device: `-o /dev/null`).
    #[error("{}: refusing to write: it is {found}, not a regular file", show(path))]
    NotRegularOutput {
        /// The output as the caller named it.
        path: PathBuf,
        /// What is there instead, as words (`a FIFO`, `a character device`, …).
        found: &'static str,
    },
    /// An output is the same file (device and inode, or canonical name) as an input or another output
    /// already recorded in [`Outputs`].
    #[error("{}: refusing to write the {role}: it is the same file as the {other_role} {}", show(path), show(other))]
    SameFile {
        /// The output refused, as the caller named it.
        path: PathBuf,
        /// What the output is, as the caller named its role (`palette`, `benchmark report`, …).
        role: String,
        /// The file recorded first, as it was named then (possibly another spelling or a link).
        other: PathBuf,
        /// The role recorded with `other` (`palette`, `CSV spectrum`, `key script`, …).
        other_role: String,
    },
    /// Creating, writing, syncing or renaming the temporary file failed (no such folder, full disk, …).
    #[error("{}: cannot write: {source}", show(path))]
    Write {
        /// The output as the caller named it.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The target's mode gives no write permission and the caller did not pass [`Replace::Force`].
    #[error(
        "{}: refusing to replace a read-only file (no write permission in its mode): make it writable, or ask \
         for it explicitly (solve --force)",
        show(path)
    )]
    ReadOnly {
        /// The output as the caller named it.
        path: PathBuf,
    },
    /// The target changed on disk since this process read it and the caller did not pass
    /// [`Replace::Changed`] or [`Replace::Force`].
    #[error(
        "{}: refusing to replace it: it changed on disk since this command read it (another program wrote it \
         meanwhile); nothing was written: run again on the new file, or ask for it explicitly (--force)",
        show(path)
    )]
    Changed {
        /// The output as the caller named it.
        path: PathBuf,
    },
    /// A name the command chose in the user's folder is a symbolic link and the caller did not pass
    /// [`Replace::Force`].
    #[error(
        "{}: refusing to write through a symbolic link this command did not make (it points to {}): remove \
         the link, or ask for it explicitly (--force)",
        show(path),
        show(target)
    )]
    ChosenLink {
        /// The output at the name the command chose.
        path: PathBuf,
        /// Where the link points, as stored in the link (empty when it could not be read).
        target: PathBuf,
    },
}

/// What the one writer may replace besides an ordinary writable file: a file whose mode gives no write
/// permission (a palette the user made read-only, `chmod a-w`; the mode is what counts, not whether this
/// process could write it: root is refused all the same), a file changed since it was read, a symbolic
/// link at a name the command chose. The variants are ordered: each allows what the one before does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub enum Replace {
    /// Refuse all three ([`FsError::ReadOnly`], [`FsError::Changed`], [`FsError::ChosenLink`]).
    #[default]
    Writable,
    /// Replace a file changed since it was read (the user was shown the outside change and chose to
    /// overwrite it); still refuse a read-only file and a link at a chosen name.
    Changed,
    /// Replace any of them (the command was given an explicit flag, `--force`); a read-only file keeps its
    /// mode, a link at a chosen name is followed.
    Force,
}

/// Who chose the name of an output (see the module docs, **Links**).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Name {
    /// The user named the file (`-o FILE`): a symbolic link there is followed and kept.
    #[default]
    User,
    /// The command chose the name (a frame in the output folder, a sidecar): a symbolic link there is
    /// refused unless [`Replace::Force`].
    Chosen,
}

impl FsError {
    /// The message without the leading file name (for callers that name the file themselves).
    pub(crate) fn reason(&self) -> String {
        let text = self.to_string();
        let prefix = format!("{}: ", show(self.path()));
        text.strip_prefix(&prefix).map(str::to_string).unwrap_or(text)
    }

    /// The file the error is about.
    pub(crate) fn path(&self) -> &Path {
        match self {
            FsError::Read { path, .. }
            | FsError::NotRegularInput { path, .. }
            | FsError::TooLarge { path, .. }
            | FsError::NotRegularOutput { path, .. }
            | FsError::SameFile { path, .. }
            | FsError::Write { path, .. }
            | FsError::ReadOnly { path }
            | FsError::Changed { path }
            | FsError::ChosenLink { path, .. } => path,
        }
    }
}

/// `text` with every control character (and the escape character in particular) shown as `\u{..}`, `\n`,
/// `\t` or `\r`: the one helper for text from users or files that reaches a terminal.
pub fn escape(text: &str) -> Cow<'_, str> {
    escape_keeping(text, false)
}

/// As [`escape`], but keep line feeds and tabs (for multi-line messages and tables).
pub fn escape_lines(text: &str) -> Cow<'_, str> {
    escape_keeping(text, true)
}

fn escape_keeping(text: &str, keep_lines: bool) -> Cow<'_, str> {
    let bad = |c: char| c.is_control() && !(keep_lines && (c == '\n' || c == '\t')) || is_bidi_control(c);
    if !needs_escape(text.as_bytes(), keep_lines) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        if !bad(c) {
            out.push(c);
            continue;
        }
        match c {
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
        }
    }
    Cow::Owned(out)
}

/// Does UTF-8 `text` hold a character [`escape_keeping`] escapes: a control character (U+0000–U+001F,
/// U+007F–U+009F; line feeds and tabs kept when `keep_lines`) or a bidirectional control? The same answer
/// as testing each `char`, a run of 32 bytes at a time: a run of printable ASCII (nearly all of a solve's
/// table of 3600 cells, 447 KB; decoding it a `char` at a time was 20 instructions a byte) is passed over
/// by comparisons the compiler does on the whole run at once, and only a run with another byte below a
/// space, DEL or a non-ASCII byte is looked at byte by byte. In UTF-8 a character's first byte tells it: U+0080–
/// U+009F are `C2 80`–`C2 9F`, U+202A–U+202E `E2 80 AA`–`E2 80 AE`, U+2066–U+2069 `E2 81 A6`–`E2 81 A9`,
/// and a continuation byte (80–BF) is never C2 or E2.
fn needs_escape(text: &[u8], keep_lines: bool) -> bool {
    const RUN: usize = 32;
    // What needs a closer look: a byte below a space (but a kept line feed or tab), DEL, a non-ASCII byte.
    let odd = |c: u8| (c < b' ' && !(keep_lines && (c == b'\n' || c == b'\t'))) || c >= 0x7f;
    let bad_at = |i: usize| -> bool {
        match text[i] {
            b'\n' | b'\t' => !keep_lines,
            c if c < b' ' || c == 0x7f => true,
            0xC2 => matches!(text.get(i + 1), Some(0x80..=0x9F)),
            0xE2 => matches!(
                (text.get(i + 1), text.get(i + 2)),
                (Some(0x80), Some(0xAA..=0xAE)) | (Some(0x81), Some(0xA6..=0xA9))
            ),
            _ => false,
        }
    };
    let mut at = 0;
    for run in text.chunks(RUN) {
        // No early exit inside the run, so that the comparisons are made on the whole run at once.
        if run.iter().fold(false, |any, &c| any | odd(c)) && (at..at + run.len()).any(bad_at) {
            return true;
        }
        at += run.len();
    }
    false
}

/// Bidirectional overrides and isolates, which reorder what a terminal shows.
fn is_bidi_control(c: char) -> bool {
    matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// A path for messages, control characters escaped.
pub fn show(path: &Path) -> String {
    escape(&path.to_string_lossy()).into_owned()
}

/// What a non-regular file is, for messages.
fn describe(meta: &Metadata) -> &'static str {
    let t = meta.file_type();
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        return "a directory";
    }
    if t.is_symlink() {
        return "a symbolic link";
    }
    "not a regular file"
}

/// Open `path` for reading without blocking on a FIFO and without making a terminal the controlling one.
fn open_nonblocking(path: &Path) -> std::io::Result<File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY);
    }
    options.open(path)
}

/// Every read while a [`record_reads`] is running, from any thread (readers work on rayon's threads too).
struct ReadLog {
    recorders: usize,
    reads: Vec<(PathBuf, Kind)>,
}

static READ_LOG: std::sync::Mutex<ReadLog> = std::sync::Mutex::new(ReadLog { recorders: 0, reads: Vec::new() });
/// The number of running recorders, read without the lock (reads pay nothing when none runs).
static RECORDERS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

fn read_log() -> std::sync::MutexGuard<'static, ReadLog> {
    READ_LOG.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn note_read(path: &Path, kind: Kind) {
    if RECORDERS.load(std::sync::atomic::Ordering::Acquire) > 0 {
        let mut log = read_log();
        if log.recorders > 0 {
            log.reads.push((path.to_path_buf(), kind));
        }
    }
}

/// What a read saw of a file: enough to tell, later, whether another program changed it.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Seen {
    /// Every kind the file was read as (a CSV source named `p.basis.json` is read as a sidecar too).
    kinds: Vec<Kind>,
    stamp: Stamp,
    /// CRC-32 of the content (files of at most [`CHECKSUM_CAP`] bytes read whole).
    crc: Option<u32>,
}

/// Device, inode, size and the modification and change times (nanoseconds) of a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Stamp {
    dev: u64,
    ino: u64,
    len: u64,
    mtime: (i64, i64),
    ctime: (i64, i64),
}

impl Stamp {
    fn of(meta: &Metadata) -> Stamp {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            Stamp {
                dev: meta.dev(),
                ino: meta.ino(),
                len: meta.len(),
                mtime: (meta.mtime(), meta.mtime_nsec()),
                ctime: (meta.ctime(), meta.ctime_nsec()),
            }
        }
        #[cfg(not(unix))]
        {
            let nanos = |t: std::io::Result<std::time::SystemTime>| {
                t.ok()
                    .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                    .map_or((0, 0), |d| (d.as_secs() as i64, i64::from(d.subsec_nanos())))
            };
            Stamp { dev: 0, ino: 0, len: meta.len(), mtime: nanos(meta.modified()), ctime: nanos(meta.created()) }
        }
    }
}

/// Files up to this size are checksummed when read (a palette, a CSV, a scene, a sidecar); larger ones
/// (volumes) are compared by their [`Stamp`] alone.
const CHECKSUM_CAP: u64 = 16 * MIB;

/// Every file this process read, by canonical path: what it saw ([`Seen`]).
static SEEN: std::sync::Mutex<std::collections::BTreeMap<PathBuf, Seen>> =
    std::sync::Mutex::new(std::collections::BTreeMap::new());

fn seen_log() -> std::sync::MutexGuard<'static, std::collections::BTreeMap<PathBuf, Seen>> {
    SEEN.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn note_seen(path: &Path, kind: Kind, meta: &Metadata, bytes: Option<&[u8]>) {
    let Ok(canonical) = std::fs::canonicalize(path) else { return };
    let crc = bytes.filter(|b| b.len() as u64 <= CHECKSUM_CAP).map(crc32fast::hash);
    let mut log = seen_log();
    let seen = log.entry(canonical).or_insert_with(|| Seen { kinds: Vec::new(), stamp: Stamp::of(meta), crc });
    if !seen.kinds.contains(&kind) {
        seen.kinds.push(kind);
    }
    seen.stamp = Stamp::of(meta);
    seen.crc = crc;
}

/// Is the file at `target` (a resolved write target) one this process read and no longer what it read?
fn changed_since_read(target: &Path) -> bool {
    let Ok(canonical) = std::fs::canonicalize(target) else { return false };
    let Some(seen) = seen_log().get(&canonical).cloned() else { return false };
    // A file that is gone is not a change (writing puts it back).
    let Ok(now) = std::fs::metadata(&canonical) else { return false };
    if Stamp::of(&now) == seen.stamp {
        return false;
    }
    // The times moved: the same content is still no change (`touch`, an editor saving what it read).
    match seen.crc {
        Some(crc) if now.len() == seen.stamp.len && now.len() <= CHECKSUM_CAP => {
            std::fs::read(&canonical).map_or(true, |bytes| crc32fast::hash(&bytes) != crc)
        }
        _ => true,
    }
}

/// Did this process read the file at `target` (a resolved path)? Only then does a write to it need the
/// written content's checksum ([`note_written`] keeps it for a later [`changed_since_read`]).
fn was_read(target: &Path) -> bool {
    std::fs::canonicalize(target).is_ok_and(|canonical| seen_log().contains_key(&canonical))
}

/// After this process wrote `target`: if it was a file read, what was written is now what was read.
fn note_written(target: &Path, bytes_crc: Option<u32>) {
    let Ok(canonical) = std::fs::canonicalize(target) else { return };
    let mut log = seen_log();
    if let Some(seen) = log.get_mut(&canonical)
        && let Ok(meta) = std::fs::metadata(&canonical)
    {
        seen.stamp = Stamp::of(&meta);
        seen.crc = bytes_crc;
    }
}

/// Every file this process has read whose kind passes `keep`, with its kind, for an [`Outputs`] check by a
/// writer that does not know all its command's inputs (the basis sidecar's, the designer's save-as, which
/// must not land on the `--scene` file or the running key script).
pub fn read_by_this_process(keep: impl Fn(Kind) -> bool) -> Vec<(PathBuf, Kind)> {
    let log = seen_log();
    log.iter().flat_map(|(p, s)| s.kinds.iter().filter(|k| keep(**k)).map(|k| (p.clone(), *k))).collect()
}

/// Ends a recording, also when the work panics.
struct Recording {
    start: usize,
}

impl Recording {
    fn start() -> Recording {
        let mut log = read_log();
        log.recorders += 1;
        RECORDERS.fetch_add(1, std::sync::atomic::Ordering::AcqRel);
        Recording { start: log.reads.len() }
    }
}

impl Drop for Recording {
    fn drop(&mut self) {
        let mut log = read_log();
        log.recorders = log.recorders.saturating_sub(1);
        RECORDERS.fetch_sub(1, std::sync::atomic::Ordering::AcqRel);
        if log.recorders == 0 {
            log.reads = Vec::new();
        }
    }
}

/// Run `work` and return its result with every file it read (or tried to read) through [`read`] or
/// [`read_to_string`], in order, with its kind: the files readers find on their own (a scene's palette and
/// volume, a palette's CSV sources, a NRRD header's `data file`) included. Reads on every thread are
/// recorded, so work that runs while another thread reads too lists that thread's files as well (never
/// fewer than its own).
pub fn record_reads<T>(work: impl FnOnce() -> T) -> (T, Vec<(PathBuf, Kind)>) {
    let recording = Recording::start();
    let out = work();
    let reads = read_log().reads.get(recording.start..).map(<[_]>::to_vec).unwrap_or_default();
    drop(recording);
    (out, reads)
}

/// Read the whole of a regular file of kind `kind`, at most its cap.
pub fn read(path: &Path, kind: Kind) -> Result<Vec<u8>, FsError> {
    read_capped(path, kind, kind.cap())
}

/// As [`read`], with an explicit cap (bytes).
pub fn read_capped(path: &Path, kind: Kind, cap: u64) -> Result<Vec<u8>, FsError> {
    let io = |source| FsError::Read { path: path.to_path_buf(), kind, source };
    note_read(path, kind);
    // Look before opening: a device is never opened (opening some has side effects).
    let before = std::fs::metadata(path).map_err(io)?;
    check_input(path, kind, cap, &before)?;
    let file = open_nonblocking(path).map_err(io)?;
    // The opened file is what counts (the path may have been swapped in between).
    let meta = file.metadata().map_err(io)?;
    check_input(path, kind, cap, &meta)?;
    let mut reader = file.take(cap.saturating_add(1));
    let bytes = read_sized(&mut reader, usize::try_from(meta.len()).unwrap_or(0)).map_err(io)?;
    if bytes.len() as u64 > cap {
        return Err(FsError::TooLarge { path: path.to_path_buf(), kind, size: bytes.len() as u64, cap });
    }
    note_seen(path, kind, &meta, Some(&bytes));
    Ok(bytes)
}

/// Everything `reader` gives, expecting `size` bytes: read in one call of that size, then to the end (one more
/// call that finds nothing, unless the file grew; `reader` bounds what is read). `read_to_end` alone reads a
/// reader whose size it is not told (a `Take`) in calls of 8 KiB doubling: eight calls for a 0.7 MB palette.
fn read_sized(reader: &mut impl Read, size: usize) -> std::io::Result<Vec<u8>> {
    // Zeroed, not written: an allocation this large is fresh memory the allocator knows to be zero.
    let mut bytes = vec![0; size];
    let mut filled = 0;
    while filled < size {
        match reader.read(&mut bytes[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    bytes.truncate(filled);
    reader.read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// Open a regular file of kind `kind` of at most `cap` bytes to read it in pieces, never whole (the
/// volume readers stream a file's data straight into the voxel buffer): the same checks as [`read`],
/// recorded as read. Returns the opened file and its size.
pub(crate) fn open_capped(path: &Path, kind: Kind, cap: u64) -> Result<(File, u64), FsError> {
    let io = |source| FsError::Read { path: path.to_path_buf(), kind, source };
    note_read(path, kind);
    let before = std::fs::metadata(path).map_err(io)?;
    check_input(path, kind, cap, &before)?;
    let file = open_nonblocking(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    check_input(path, kind, cap, &meta)?;
    note_seen(path, kind, &meta, None);
    Ok((file, meta.len()))
}

fn check_input(path: &Path, kind: Kind, cap: u64, meta: &Metadata) -> Result<(), FsError> {
    if !meta.is_file() {
        return Err(FsError::NotRegularInput { path: path.to_path_buf(), kind, found: describe(meta) });
    }
    if meta.len() > cap {
        return Err(FsError::TooLarge { path: path.to_path_buf(), kind, size: meta.len(), cap });
    }
    Ok(())
}

/// Read a regular UTF-8 text file of kind `kind` (at most its cap); invalid UTF-8 is an error naming the
/// byte offset.
pub fn read_to_string(path: &Path, kind: Kind) -> Result<String, FsError> {
    let bytes = read(path, kind)?;
    String::from_utf8(bytes).map_err(|e| FsError::Read {
        path: path.to_path_buf(),
        kind,
        source: std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text (at byte {})", e.utf8_error().valid_up_to()),
        ),
    })
}

#[cfg(unix)]
fn inode(meta: &Metadata) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    Some((meta.dev(), meta.ino()))
}

#[cfg(not(unix))]
fn inode(_meta: &Metadata) -> Option<(u64, u64)> {
    None
}

/// Which file a path names, whether or not it exists yet.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Identity {
    /// An existing file: device and inode (links and different spellings agree).
    Inode(u64, u64),
    /// A file that does not exist yet: its canonical folder and name.
    Path(PathBuf),
}

/// Do `a` and `b` name the same file (same device and inode, or the same canonical path for a file not
/// yet made)? False when either cannot be resolved.
pub fn same_file(a: &Path, b: &Path) -> bool {
    matches!((identity(a), identity(b)), (Some(x), Some(y)) if x == y)
}

/// The [`Identity`] of `path` (None when neither it nor its folder can be resolved).
pub(crate) fn identity(path: &Path) -> Option<Identity> {
    if let Ok(meta) = std::fs::metadata(path)
        && let Some((dev, ino)) = inode(&meta)
    {
        return Some(Identity::Inode(dev, ino));
    }
    if let Ok(c) = std::fs::canonicalize(path) {
        return Some(Identity::Path(c));
    }
    // Folders that do not exist yet (an output folder created later): the nearest existing ancestor,
    // canonical, then the rest of the path spelt out (`..` over a folder still to be created is its parent,
    // as it will be once the folder exists), so `out/../p.toml` is still `p.toml`.
    let relative;
    let path = if path.is_relative() {
        relative = Path::new(".").join(path);
        relative.as_path()
    } else {
        path
    };
    let (base, rest) = path.ancestors().skip(1).find_map(|a| {
        let a = if a.as_os_str().is_empty() { Path::new(".") } else { a };
        let c = std::fs::canonicalize(a).ok()?;
        Some((c, path.strip_prefix(a).ok()?.to_path_buf()))
    })?;
    let mut full = base;
    for part in rest.components() {
        match part {
            std::path::Component::ParentDir => {
                full.pop();
            }
            std::path::Component::Normal(n) => full.push(n),
            _ => {}
        }
    }
    if let Ok(meta) = std::fs::metadata(&full)
        && let Some((dev, ino)) = inode(&meta)
    {
        return Some(Identity::Inode(dev, ino));
    }
    Some(Identity::Path(full))
}

/// The files one command reads and writes, checked so no output is an input or another output.
#[derive(Debug, Default)]
pub struct Outputs {
    known: Vec<(Identity, PathBuf, String)>,
}

impl Outputs {
    /// Nothing recorded yet.
    pub fn new() -> Outputs {
        Outputs::default()
    }

    /// Record an input (`role` names it in messages, e.g. "palette").
    pub fn input(&mut self, role: &str, path: &Path) -> &mut Self {
        if let Some(id) = identity(path) {
            self.known.push((id, path.to_path_buf(), role.to_string()));
        }
        self
    }

    /// Record every file of `reads` (from [`record_reads`]) as an input, each named by its kind.
    pub fn inputs_read(&mut self, reads: &[(PathBuf, Kind)]) -> &mut Self {
        for (path, kind) in reads {
            self.input(kind.label(), path);
        }
        self
    }

    /// Check that output `path` (`role`: "report", "solved palette"…) is none of the inputs and outputs
    /// recorded so far, and record it.
    pub fn output(&mut self, role: &str, path: &Path) -> Result<&mut Self, FsError> {
        self.check(role, path)?;
        if let Some(id) = identity(path) {
            self.known.push((id, path.to_path_buf(), role.to_string()));
        }
        Ok(self)
    }

    /// As [`Outputs::output`], but `path` may be the file `allowed` (an in-place save: `solve p.toml -o
    /// p.toml`); it must still be no other input or output.
    pub fn output_except(&mut self, role: &str, path: &Path, allowed: &Path) -> Result<&mut Self, FsError> {
        let skip = identity(allowed);
        self.check_skipping(role, path, skip.as_ref())?;
        if let Some(id) = identity(path) {
            self.known.push((id, path.to_path_buf(), role.to_string()));
        }
        Ok(self)
    }

    /// Check `path` against everything recorded without recording it (for many files of one role,
    /// e.g. frames).
    pub fn check(&self, role: &str, path: &Path) -> Result<(), FsError> {
        self.check_skipping(role, path, None)
    }

    fn check_skipping(&self, role: &str, path: &Path, skip: Option<&Identity>) -> Result<(), FsError> {
        let Some(id) = identity(path) else { return Ok(()) };
        if skip == Some(&id) {
            return Ok(());
        }
        match self.known.iter().find(|(k, _, _)| *k == id) {
            Some((_, other, other_role)) => Err(FsError::SameFile {
                path: path.to_path_buf(),
                role: role.to_string(),
                other: other.clone(),
                other_role: other_role.clone(),
            }),
            None => Ok(()),
        }
    }
}

/// Where a write to `path` lands: a symbolic link is followed (to its final target), so the link is kept.
fn resolve_target(path: &Path) -> std::io::Result<PathBuf> {
    let mut target = path.to_path_buf();
    // A bounded walk: a loop of links ends in an error rather than spinning.
    for _ in 0..40 {
        match std::fs::symlink_metadata(&target) {
            Ok(m) if m.file_type().is_symlink() => {
                let link = std::fs::read_link(&target)?;
                target = match target.parent() {
                    Some(dir) if link.is_relative() => dir.join(link),
                    _ => link,
                };
            }
            _ => return Ok(target),
        }
    }
    Err(std::io::Error::other("too many levels of symbolic links"))
}

/// Write `bytes` to `path` atomically (see the module docs). Nothing at `path` changes unless the whole
/// new content is on disk.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FsError> {
    stage(path, bytes)?.commit()
}

/// A new content written and synced beside its target (a temporary file in the target's folder) but not
/// yet in place: [`Staged::commit`] renames it over the target and syncs the folder; dropping it instead
/// removes the temporary file and leaves the target as it was. A command with several outputs stages them
/// in parallel (the syncs, mostly waiting for the disk, overlap) and commits them only when every one was
/// written, so a failure writes none of them.
#[derive(Debug)]
pub struct Staged {
    tmp: tempfile::NamedTempFile,
    /// The path the caller named (for messages) and the file it resolves to (a link is followed).
    path: PathBuf,
    target: PathBuf,
    dir: PathBuf,
    replace: Replace,
    /// The content's CRC-32 when it was taken as written (the target was a file this process read, and
    /// the content at most [`CHECKSUM_CAP`] bytes).
    crc: Option<u32>,
    /// Whether the content was checksummed as written; when not, a target read since is checksummed at the
    /// commit from the staged file ([`Staged::commit_in`]).
    checksummed: bool,
    /// Whether the temporary file was synced when it was staged; when not ([`stage_unsynced`]), the commit
    /// syncs it before its rename.
    synced: bool,
    /// The temporary file's entry in the list [`remove_staged`] empties. After `tmp`, so that it is dropped
    /// after the file is removed or renamed (an entry whose file is gone is only a failed removal).
    _live: Listed,
}

impl Staged {
    /// The path the caller named for this output.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Put the staged content in place (a rename over the target), then sync the folder. A target
    /// changed since it was read is refused here too (it may have changed while the output was staged).
    pub fn commit(self) -> Result<(), FsError> {
        let mut folders = FolderSync::default();
        self.commit_in(&mut folders)
        // `folders` dropped here: the folder is synced before this returns.
    }

    /// [`Staged::commit`] whose folder sync is left to `folders`: a command committing several outputs
    /// renames each in turn and syncs each distinct folder once, after the last rename ([`FolderSync`]).
    pub fn commit_in(self, folders: &mut FolderSync) -> Result<(), FsError> {
        // `_live` is dropped when this returns: after the rename, or after the failed commit dropped `tmp`.
        let Staged { tmp, path, target, dir, replace, crc, checksummed, synced, _live } = self;
        if replace < Replace::Changed && changed_since_read(&target) {
            return Err(FsError::Changed { path });
        }
        // The content is on disk before its name is: a file staged without its sync is synced here.
        if !synced {
            tmp.as_file().sync_all().map_err(|source| FsError::Write { path: path.clone(), source })?;
        }
        // A target first read while this output was staged (not seen in any command so far): the content's
        // checksum from the staged file, so that the next check compares contents as for any file read.
        let crc = if checksummed || !was_read(&target) {
            crc
        } else {
            std::fs::read(tmp.path())
                .ok()
                .filter(|bytes| bytes.len() as u64 <= CHECKSUM_CAP)
                .map(|bytes| crc32fast::hash(&bytes))
        };
        // The file being replaced, held open across the rename: freeing its blocks then waits for the last
        // close, which [`FolderSync`] makes on a thread of its own while the folder syncs, instead of inside
        // the rename (about 1 ms for a 1 MB output on ext4, measured with `strace -T`). Best effort: a
        // replaced file that cannot be opened (no read permission) is freed by the rename as before.
        #[cfg(unix)]
        let replaced = open_nonblocking(&target).ok();
        #[cfg(not(unix))]
        let replaced: Option<File> = None;
        tmp.persist(&target).map_err(|e| FsError::Write { path: path.clone(), source: e.error })?;
        note_written(&target, crc);
        folders.add(dir);
        folders.replaced.extend(replaced);
        Ok(())
    }
}

/// The folders of renamed outputs still to be synced (the last step of an atomic write, which makes the
/// rename itself durable). [`FolderSync::sync`] syncs each distinct folder once, so the outputs of one
/// command in one folder (a solve's palette and report) cost one folder sync rather than one each; the
/// sync still follows every rename into that folder. Dropping it syncs too, so a command that fails after
/// a rename (its next output refused) still syncs the folder of what it renamed. Folders are told apart
/// by their path as written: one folder named two ways is synced twice, which is only slower.
///
/// It also holds the files the renames replaced ([`Staged::commit_in`] opens each before its rename), and
/// closes them on a thread of its own while the folders sync: the last close of a replaced file frees its
/// blocks, which then overlaps the sync instead of lengthening each rename. Closing a replaced file
/// changes nothing a reader or a crash can see (its name already belongs to the new content).
#[derive(Debug, Default)]
pub struct FolderSync {
    dirs: Vec<PathBuf>,
    replaced: Vec<File>,
}

impl FolderSync {
    fn add(&mut self, dir: PathBuf) {
        if !self.dirs.contains(&dir) {
            self.dirs.push(dir);
        }
    }

    /// The distinct folders waiting for their sync.
    pub fn pending(&self) -> &[PathBuf] {
        &self.dirs
    }

    /// Sync every folder added (best effort: some file systems refuse to sync a directory).
    pub fn sync(mut self) {
        self.sync_pending();
    }

    /// Close the files the commits so far replaced, now and on this thread (freeing their blocks), instead
    /// of holding them to the folder sync: for a thread that commits many outputs one after another and
    /// syncs their folder once at the end (a sweep's frames), which would otherwise hold every replaced
    /// frame open and start a thread per frame to close them.
    pub fn close_replaced(&mut self) {
        self.replaced.clear();
    }

    fn sync_pending(&mut self) {
        let replaced = std::mem::take(&mut self.replaced);
        std::thread::scope(|scope| {
            // One thread per replaced file: each last close frees its file's blocks and cached pages
            // (0.5 ms for a solve's 1.2 MB palette, 1 ms and more for its 2.9 MB report, `perf trace`), and
            // the two frees overlap each other as well as the folder sync. When no thread can be started
            // the spawn drops the file: it is closed at once.
            for file in replaced {
                let _ = std::thread::Builder::new().spawn_scoped(scope, move || drop(file));
            }
            for dir in self.dirs.drain(..) {
                #[cfg(unix)]
                if let Ok(d) = File::open(&dir) {
                    let _ = d.sync_all();
                }
                #[cfg(not(unix))]
                let _ = dir;
            }
        });
    }
}

impl Drop for FolderSync {
    fn drop(&mut self) {
        self.sync_pending();
    }
}

/// The first half of [`write_atomic`]: everything up to the rename (see [`Staged`]). The same checks and
/// refusals; nothing at `path` changes until [`Staged::commit`].
pub fn stage(path: &Path, bytes: &[u8]) -> Result<Staged, FsError> {
    stage_with(path, bytes, Replace::Writable)
}

/// [`stage`] of a file the user named, replacing what [`Replace`] allows.
pub fn stage_with(path: &Path, bytes: &[u8], replace: Replace) -> Result<Staged, FsError> {
    stage_as(path, bytes, Name::User, replace)
}

/// [`write_atomic`] of a file whose name the command chose ([`Name::Chosen`]: a symbolic link there is
/// refused unless [`Replace::Force`]).
pub fn write_chosen(path: &Path, bytes: &[u8], replace: Replace) -> Result<(), FsError> {
    stage_as(path, bytes, Name::Chosen, replace)?.commit()
}

/// The check [`stage_as`] makes of a name the command chose ([`Name::Chosen`]), for a command that checks
/// its outputs before it starts: a symbolic link there is refused unless [`Replace::Force`].
pub fn check_chosen(path: &Path, replace: Replace) -> Result<(), FsError> {
    if replace < Replace::Force && std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        let target = std::fs::read_link(path).unwrap_or_default();
        return Err(FsError::ChosenLink { path: path.to_path_buf(), target });
    }
    Ok(())
}

/// [`stage`] with who chose the name and what may be replaced.
pub fn stage_as(path: &Path, bytes: &[u8], name: Name, replace: Replace) -> Result<Staged, FsError> {
    stage_writing(path, name, replace, |w| w.write_all(bytes))
}

/// [`stage_as`] without the temporary file's sync, which [`Staged::commit_in`] then makes before the rename:
/// for a caller that hands the staged file to a thread of its own to commit (a sweep's frames), so that the
/// thread producing the content does not wait for the disk. The same checks and refusals; the content is
/// synced before its rename all the same.
pub fn stage_unsynced(path: &Path, bytes: &[u8], name: Name, replace: Replace) -> Result<Staged, FsError> {
    stage_impl(path, name, replace, |w| w.write_all(bytes), false)
}

/// The staged file's content as it is produced: `write` writes it into a [`StagedWriter`] (buffered, its
/// checksum computed as written), so a large output (a solve's report) is never held whole in memory.
/// An error from `write` removes the temporary file and leaves the target as it was.
pub fn stage_writing(
    path: &Path,
    name: Name,
    replace: Replace,
    write: impl FnOnce(&mut StagedWriter<'_>) -> std::io::Result<()>,
) -> Result<Staged, FsError> {
    stage_impl(path, name, replace, write, true)
}

/// [`stage_writing`], the temporary file synced when `sync` (else at the commit, [`stage_unsynced`]). The one
/// place the rules of the module docs are applied.
fn stage_impl(
    path: &Path,
    name: Name,
    replace: Replace,
    write: impl FnOnce(&mut StagedWriter<'_>) -> std::io::Result<()>,
    sync: bool,
) -> Result<Staged, FsError> {
    let err = |source| FsError::Write { path: path.to_path_buf(), source };
    if name == Name::Chosen {
        check_chosen(path, replace)?;
    }
    let target = resolve_target(path).map_err(err)?;
    let existing = match std::fs::metadata(&target) {
        Ok(m) if !m.is_file() => {
            return Err(FsError::NotRegularOutput { path: path.to_path_buf(), found: describe(&m) });
        }
        Ok(m) if m.permissions().readonly() && replace < Replace::Force => {
            return Err(FsError::ReadOnly { path: path.to_path_buf() });
        }
        Ok(_) if replace < Replace::Changed && changed_since_read(&target) => {
            return Err(FsError::Changed { path: path.to_path_buf() });
        }
        Ok(m) => Some(m),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(err(e)),
    };
    let dir = folder_of(&target);
    let stem = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let prefix = format!(".{stem}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // The kernel applies the umask to this mode, as for any new file.
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    // Created and listed under the list's lock, so that no temporary file exists unlisted: refused once the
    // command is being stopped ([`remove_staged`]).
    let (mut tmp, live) = STAGED.create(|| builder.tempfile_in(&dir)).map_err(err)?;
    // The checksum is taken as the content is written only when the target is a file this process read:
    // it is kept for a later check of that file against outside changes ([`note_written`]), and nothing
    // else uses it (a solve's report and solved palette, 4.1 MB for a 1200-design batch, are new files to
    // it: 2.2 M instructions of checksum, half of them on the thread the report is written from).
    let checksummed = was_read(&target);
    let (len, crc) = {
        let mut w = StagedWriter {
            file: tmp.as_file_mut(),
            buf: Vec::with_capacity(STAGED_BUFFER),
            crc: checksummed.then(crc32fast::Hasher::new),
            len: 0,
            started: 0,
        };
        write(&mut w).map_err(err)?;
        w.flush().map_err(err)?;
        (w.len, w.crc.map(crc32fast::Hasher::finalize))
    };
    if let Some(meta) = &existing {
        tmp.as_file().set_permissions(meta.permissions()).map_err(err)?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            // Keep owner and group where permitted (as root, or a group the user is in); else the new file
            // is the user's own, as with any editor's save.
            let file = tmp.as_file();
            if std::os::unix::fs::fchown(file, Some(meta.uid()), Some(meta.gid())).is_err() {
                let _ = std::os::unix::fs::fchown(file, None, Some(meta.gid()));
            }
            // chown may clear set-id bits; put the mode back.
            let _ = file.set_permissions(meta.permissions());
        }
    }
    if sync {
        tmp.as_file().sync_all().map_err(err)?;
    }
    let crc = crc.filter(|_| len <= CHECKSUM_CAP);
    Ok(Staged { tmp, path: path.to_path_buf(), target, dir, replace, crc, checksummed, synced: sync, _live: live })
}

/// The temporary files of outputs staged and not yet committed or dropped, by a serial number: the list
/// [`remove_staged`] empties. Process-wide, as the signals that call for it are.
static STAGED: LiveTemps = LiveTemps::new();

/// Remove the temporary file of every output staged and not yet committed or dropped, and refuse any staged
/// from now on ([`FsError::Write`] with [`std::io::ErrorKind::Interrupted`]): for a command being stopped
/// (the CLI calls it from its signal thread on SIGINT, SIGTERM and SIGHUP, then lets the signal end the
/// process). Targets are not touched: each is the old file, or the new one where its rename came first.
/// Returns how many files were removed.
pub fn remove_staged() -> usize {
    STAGED.remove_all()
}

/// A list of temporary files ([`STAGED`]; the tests make their own).
struct LiveTemps {
    inner: std::sync::Mutex<Temps>,
}

#[derive(Default)]
struct Temps {
    next: u64,
    paths: Vec<(u64, PathBuf)>,
    /// Set by [`LiveTemps::remove_all`]: nothing is listed after it.
    closed: bool,
}

impl LiveTemps {
    const fn new() -> LiveTemps {
        LiveTemps { inner: std::sync::Mutex::new(Temps { next: 0, paths: Vec::new(), closed: false }) }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Temps> {
        self.inner.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// A temporary file made by `make` and listed until the returned entry is dropped, both under the lock
    /// (a signal's [`LiveTemps::remove_all`] cannot come between); refused with
    /// [`std::io::ErrorKind::Interrupted`] once `remove_all` was called.
    fn create(
        &'static self,
        make: impl FnOnce() -> std::io::Result<tempfile::NamedTempFile>,
    ) -> std::io::Result<(tempfile::NamedTempFile, Listed)> {
        let mut t = self.lock();
        if t.closed {
            return Err(std::io::Error::new(std::io::ErrorKind::Interrupted, "the command was interrupted"));
        }
        let tmp = make()?;
        let id = t.next;
        t.next += 1;
        t.paths.push((id, tmp.path().to_path_buf()));
        Ok((tmp, Listed { list: self, id }))
    }

    fn unlist(&self, id: u64) {
        let mut t = self.lock();
        if let Some(k) = t.paths.iter().position(|(i, _)| *i == id) {
            t.paths.swap_remove(k);
        }
    }

    /// Remove every listed file (under the lock, so none is listed meanwhile) and close the list.
    fn remove_all(&self) -> usize {
        let mut t = self.lock();
        t.closed = true;
        t.paths.drain(..).filter(|(_, path)| std::fs::remove_file(path).is_ok()).count()
    }
}

/// A temporary file's entry in [`STAGED`], removed from it when dropped.
#[derive(Debug)]
struct Listed {
    list: &'static LiveTemps,
    id: u64,
}

impl std::fmt::Debug for LiveTemps {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "LiveTemps({} listed)", self.lock().paths.len())
    }
}

impl Drop for Listed {
    fn drop(&mut self) {
        self.list.unlist(self.id);
    }
}

/// The write buffer of a [`StagedWriter`].
const STAGED_BUFFER: usize = 64 * 1024;

/// The content of a staged file as it is written ([`stage_writing`]): buffered, and checksummed on the way
/// when the target is a file this process read (the checksum a later changed-since-read check compares with). The buffer is this writer's own rather
/// than a `BufWriter` so that the checksum is taken over whole buffers as they go to the file: serialisers
/// write a few bytes at a time, and checksumming each of those writes was measured at 4 % of a solve's
/// whole process.
pub struct StagedWriter<'a> {
    file: &'a mut File,
    buf: Vec<u8>,
    crc: Option<crc32fast::Hasher>,
    len: u64,
    /// Bytes from the start whose write-back has been started ([`StagedWriter::start_write_back`]).
    started: u64,
}

impl StagedWriter<'_> {
    /// Checksum the buffered bytes and write them to the file.
    fn drain(&mut self) -> std::io::Result<()> {
        if let Some(crc) = &mut self.crc {
            crc.update(&self.buf);
        }
        self.len += self.buf.len() as u64;
        let written = self.file.write_all(&self.buf);
        self.buf.clear();
        self.start_write_back();
        written
    }

    /// Once [`WRITE_BACK_STEP`] bytes more are written, ask the kernel to start writing them to the disk
    /// (`sync_file_range(SYNC_FILE_RANGE_WRITE)`: it starts the write-back and waits for none of it), so
    /// that the disk works while the rest of the file is produced and the closing `fsync`, which still
    /// makes the file durable and reports any error, has only the tail left. Advisory: its errors are left
    /// to that `fsync`. Measured on a 1200-design `metamer solve -o OUT --report R.json` (a 2.9 MB report):
    /// docs/solve_performance.md, "The outputs' write-back started as they are written".
    fn start_write_back(&mut self) {
        if let Some((from, len)) = write_back_range(self.started, self.len) {
            #[cfg(target_os = "linux")]
            {
                use std::os::fd::AsRawFd;
                // SAFETY: `sync_file_range` reads the file descriptor this writer holds open and two
                // offsets; it changes no memory of this process.
                unsafe {
                    libc::sync_file_range(
                        self.file.as_raw_fd(),
                        from as libc::off64_t,
                        len as libc::off64_t,
                        libc::SYNC_FILE_RANGE_WRITE,
                    );
                }
            }
            self.started = from + len;
        }
    }
}

/// How many more bytes written start their write-back ([`StagedWriter::start_write_back`]). Every 1 MiB
/// paid on this machine's disk; every 256 KiB lost at load 5, where the block layer holds such background
/// writes back behind other processes' I/O (docs/solve_performance.md).
const WRITE_BACK_STEP: u64 = MIB;

/// The range whose write-back to start once `written` bytes are in the file and those before `started`
/// have been started: the whole pages from `started` on, when they are at least [`WRITE_BACK_STEP`].
fn write_back_range(started: u64, written: u64) -> Option<(u64, u64)> {
    const PAGE: u64 = 4096;
    let end = written / PAGE * PAGE;
    (end >= started + WRITE_BACK_STEP).then(|| (started, end - started))
}

impl Write for StagedWriter<'_> {
    /// Inlined: serialisers call this for every few bytes, and the common case is one copy into the buffer
    /// (with the call and `write_all`'s loop around it, a 1200-design solve's report took 103.7 M instructions
    /// to serialise; 47.5 M inlined).
    #[inline]
    fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
        self.write_all(data)?;
        Ok(data.len())
    }

    #[inline]
    fn write_all(&mut self, data: &[u8]) -> std::io::Result<()> {
        if data.len() < WRITE_THROUGH && self.buf.len() + data.len() <= STAGED_BUFFER {
            self.buf.extend_from_slice(data);
            return Ok(());
        }
        self.write_slow(data)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.drain()?;
        self.file.flush()
    }
}

impl StagedWriter<'_> {
    /// `write_all` of a large slice (written through, after the buffered bytes, in one `writev`: not
    /// copied into the buffer, and no separate write of the few bytes before it), or of a small one the
    /// buffer cannot take (drained first).
    #[cold]
    fn write_slow(&mut self, data: &[u8]) -> std::io::Result<()> {
        if data.len() >= WRITE_THROUGH {
            if let Some(crc) = &mut self.crc {
                crc.update(&self.buf);
                crc.update(data);
            }
            self.len += (self.buf.len() + data.len()) as u64;
            let written = write_both(self.file, &self.buf, data);
            self.buf.clear();
            self.start_write_back();
            return written;
        }
        self.drain()?;
        self.buf.extend_from_slice(data);
        Ok(())
    }
}

/// Writes of at least this many bytes go to the file as they are ([`StagedWriter::write_slow`]): the
/// pieces of text a command formats ahead (a report's rows, a solved palette's tables, tens of KB each).
const WRITE_THROUGH: usize = 16 * 1024;

/// `first` then `second` written whole to `file`, in one `writev` when the file takes it all.
fn write_both(file: &mut File, mut first: &[u8], mut second: &[u8]) -> std::io::Result<()> {
    while !first.is_empty() {
        match file.write_vectored(&[std::io::IoSlice::new(first), std::io::IoSlice::new(second)]) {
            Ok(0) => return Err(std::io::ErrorKind::WriteZero.into()),
            Ok(n) if n < first.len() => first = &first[n..],
            Ok(n) => {
                second = &second[n - first.len()..];
                first = &[];
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    file.write_all(second)
}

/// The folder a file lives in: its parent, or `.` for a bare file name (relative paths in a file, its
/// sidecars and its temporary files are taken from here).
pub fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_is_read_whole_whatever_size_it_was_said_to_have() {
        /// Gives at most 7000 bytes a call, and is interrupted once.
        struct Trickle<'a>(&'a [u8], bool);
        impl Read for Trickle<'_> {
            fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                if !self.1 {
                    self.1 = true;
                    return Err(std::io::ErrorKind::Interrupted.into());
                }
                let n = buf.len().min(7000).min(self.0.len());
                buf[..n].copy_from_slice(&self.0[..n]);
                self.0 = &self.0[n..];
                Ok(n)
            }
        }
        let text: Vec<u8> = (0..100_000u32).map(|i| (i % 251) as u8).collect();
        // The size told may be right, or wrong because the file changed since its size was read.
        for size in [0, 1, 4096, 99_999, 100_000, 100_001, 300_000] {
            assert_eq!(read_sized(&mut Trickle(&text, false), size).unwrap(), text, "{size}");
            assert_eq!(read_sized(&mut &text[..], size).unwrap(), text, "{size}");
            // What bounds the reader bounds what is read.
            assert_eq!(read_sized(&mut (&text[..]).take(5000), size).unwrap(), &text[..5000], "{size}");
        }
    }

    #[test]
    fn a_file_over_its_cap_is_refused_and_one_at_it_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.toml");
        std::fs::write(&path, vec![b'x'; 5000]).unwrap();
        assert_eq!(read_capped(&path, Kind::Palette, 5000).unwrap().len(), 5000);
        assert!(matches!(read_capped(&path, Kind::Palette, 4999), Err(FsError::TooLarge { size: 5000, .. })));
    }

    #[test]
    fn escape_shows_control_characters() {
        assert_eq!(escape("a\x1b]0;x\x07b"), "a\\u{1b}]0;x\\u{7}b");
        assert_eq!(escape("plain"), "plain");
        assert_eq!(escape_lines("a\nb\x1b"), "a\nb\\u{1b}");
        assert_eq!(escape("a\nb"), "a\\nb");
    }

    /// The byte scan ([`needs_escape`]) answers as testing every `char` does: every character around the
    /// ones escaped (each control, each bidirectional control and their neighbours in the code space, the
    /// other characters of two and three bytes starting C2 or E2, four-byte ones), alone and at every
    /// position of texts longer than a run, so that a character also straddles the runs' boundaries.
    #[test]
    fn the_byte_scan_finds_what_the_char_test_finds() {
        let by_chars = |text: &str, keep: bool| {
            text.chars().any(|c| c.is_control() && !(keep && (c == '\n' || c == '\t')) || is_bidi_control(c))
        };
        let mut probes: Vec<char> = (0u32..0x2ff).chain(0x2000..0x2100).filter_map(char::from_u32).collect();
        probes.extend(['\u{ffff}', '\u{1f600}', '\u{10ffff}', 'Δ', '—', '…', '×']);
        // A table's characters, with and without its line feeds and tabs.
        let fillers = ["light r0 #7097e6 0.1618 ΔE00 ", "light\tr0 #7097e6 0.1618 ΔE00\n"];
        for &c in &probes {
            for keep in [false, true] {
                let alone = c.to_string();
                assert_eq!(needs_escape(alone.as_bytes(), keep), by_chars(&alone, keep), "{c:?} {keep}");
            }
        }
        for (at, filler) in (0..70).flat_map(|at| fillers.map(|f| (at, f))) {
            for &c in &probes {
                let mut text: String = filler.chars().cycle().take(at).collect();
                text.push(c);
                text.extend(filler.chars().cycle().take(40));
                for keep in [false, true] {
                    assert_eq!(needs_escape(text.as_bytes(), keep), by_chars(&text, keep), "{c:?} at {at} {keep}");
                }
            }
        }
    }

    #[cfg(unix)]
    #[test]
    fn a_read_only_file_is_replaced_only_when_forced() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.toml");
        std::fs::write(&path, "old").unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o444)).unwrap();
        let refused = write_atomic(&path, b"new");
        assert!(matches!(refused, Err(FsError::ReadOnly { .. })), "{refused:?}");
        assert!(refused.unwrap_err().to_string().contains("read-only"));
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary file is left");
        stage_with(&path, b"new", Replace::Force).unwrap().commit().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o444, "the mode is kept");
        // A writable file is replaced as before.
        let other = dir.path().join("q.toml");
        std::fs::write(&other, "old").unwrap();
        write_atomic(&other, b"new").unwrap();
        assert_eq!(std::fs::read(&other).unwrap(), b"new");
    }

    #[test]
    fn a_streamed_output_is_written_whole_and_checksummed_as_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.json");
        std::fs::write(&path, "old").unwrap();
        // Read by this process: the content written over it is checksummed as it goes.
        read(&path, Kind::Text).unwrap();
        // Pieces of odd sizes, more than the buffer in all, so some writes fill it and some go through.
        let mut pieces: Vec<Vec<u8>> =
            (0..400u32).map(|i| (0..(i * 37 % 1500)).map(|j| (i * 7 + j) as u8).collect()).collect();
        pieces.insert(200, (0..3 * STAGED_BUFFER).map(|j| (j % 251) as u8).collect());
        // Pieces at the size from which writes go through ([`WRITE_THROUGH`]), and a run of a few bytes
        // then a large piece (a report's separators and rows), each large one after some buffered bytes.
        let sized = |n: usize, seed: usize| -> Vec<u8> { (0..n).map(|j| ((j * 13 + seed) % 241) as u8).collect() };
        pieces.insert(50, sized(WRITE_THROUGH - 1, 1));
        pieces.insert(100, sized(WRITE_THROUGH, 2));
        for k in 0..6 {
            pieces.insert(300 + 2 * k, sized(6, k));
            pieces.insert(301 + 2 * k, sized(46_000 + 1000 * k, k));
        }
        let whole: Vec<u8> = pieces.concat();
        assert!(whole.len() > 2 * STAGED_BUFFER);
        let staged = stage_writing(&path, Name::User, Replace::Writable, |w| {
            for p in &pieces {
                w.write_all(p)?;
            }
            Ok(())
        })
        .unwrap();
        assert_eq!(staged.crc, Some(crc32fast::hash(&whole)), "the checksum is the written content's");
        assert_eq!(std::fs::read(&path).unwrap(), b"old", "nothing is in place before the commit");
        staged.commit().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), whole);
        // A writer that fails leaves the target as it was and no temporary file.
        let failed = stage_writing(&path, Name::User, Replace::Writable, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("the producer failed"))
        });
        assert!(matches!(failed, Err(FsError::Write { .. })), "{failed:?}");
        assert_eq!(std::fs::read(&path).unwrap(), whole);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary file is left");
    }

    #[test]
    fn write_back_is_started_on_whole_pages_once_a_step_more_is_written() {
        // A writer's progress in uneven steps: each range starts where the one before ended, covers whole
        // pages, is at least a step long, and none is asked for before a step is written.
        let (mut started, mut written, mut ranges) = (0u64, 0u64, Vec::new());
        for (k, add) in [7u64, 4096, 65_536, 700_000, 300_000, 1, 2 * MIB + 5, 40_000, 9, MIB, 3].iter().enumerate() {
            written += add;
            if let Some((from, len)) = write_back_range(started, written) {
                assert_eq!(from, started, "step {k}: ranges follow one another");
                assert!(len >= WRITE_BACK_STEP, "step {k}: {len} bytes");
                assert_eq!((from + len) % 4096, 0, "step {k}: whole pages");
                assert!(from + len <= written, "step {k}: past what is written");
                started = from + len;
                ranges.push((from, len));
            }
        }
        assert_eq!(ranges.first().map(|r| r.0), Some(0));
        assert!(ranges.len() >= 3, "{ranges:?}");
        assert!(written - started < WRITE_BACK_STEP + 4096, "a step or more left unstarted: {started} of {written}");
        assert_eq!(write_back_range(0, WRITE_BACK_STEP - 1), None);
    }

    #[test]
    fn a_staged_file_written_past_several_write_back_steps_is_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.json");
        // Small runs and pieces that go through, as a report's rows, past three steps.
        let pieces: Vec<Vec<u8>> = (0..400)
            .map(|k: usize| {
                let n = if k.is_multiple_of(2) { 5 + k % 11 } else { 9_000 + 97 * k };
                (0..n).map(|j| ((j * 31 + k) % 251) as u8).collect()
            })
            .collect();
        let whole: Vec<u8> = pieces.concat();
        assert!(whole.len() as u64 > 3 * WRITE_BACK_STEP);
        let mut started = 0;
        let staged = stage_writing(&path, Name::User, Replace::Writable, |w| {
            for p in &pieces {
                w.write_all(p)?;
            }
            started = w.started;
            Ok(())
        })
        .unwrap();
        assert!(started >= 2 * WRITE_BACK_STEP, "write-back started on {started} bytes only");
        staged.commit().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), whole);
    }

    #[test]
    fn only_a_file_this_process_read_is_checksummed_and_its_next_check_compares_contents() {
        let dir = tempfile::tempdir().unwrap();
        let seen_crc = |path: &Path| seen_log().get(&std::fs::canonicalize(path).unwrap()).and_then(|s| s.crc);
        let content: Vec<u8> = (0..3 * STAGED_BUFFER + 17).map(|j| (j % 253) as u8).collect();
        let write = |w: &mut StagedWriter<'_>| {
            for piece in content.chunks(1000).chain([&content[..0]]) {
                w.write_all(piece)?;
            }
            w.write_all(&[])
        };
        // A new output, and one over a file never read: no checksum taken, none kept.
        let fresh = dir.path().join("fresh.json");
        let staged = stage_writing(&fresh, Name::User, Replace::Writable, write).unwrap();
        assert!(!staged.checksummed && staged.crc.is_none(), "{staged:?}");
        staged.commit().unwrap();
        assert_eq!(std::fs::read(&fresh).unwrap(), content);
        assert_eq!(seen_crc(&fresh), None, "not a file this process read");
        // A file read before its output is staged: checksummed as written, and the checksum kept.
        let read_first = dir.path().join("read_first.toml");
        std::fs::write(&read_first, "old").unwrap();
        read(&read_first, Kind::Text).unwrap();
        let staged = stage_writing(&read_first, Name::User, Replace::Writable, write).unwrap();
        assert!(staged.checksummed && staged.crc == Some(crc32fast::hash(&content)), "{staged:?}");
        staged.commit().unwrap();
        assert_eq!(seen_crc(&read_first), Some(crc32fast::hash(&content)));
        // A file first read while its output was staged: checksummed from the staged file at the commit.
        let read_later = dir.path().join("read_later.toml");
        std::fs::write(&read_later, "old").unwrap();
        let staged = stage_writing(&read_later, Name::User, Replace::Writable, write).unwrap();
        assert!(!staged.checksummed && staged.crc.is_none(), "{staged:?}");
        read(&read_later, Kind::Text).unwrap();
        staged.commit().unwrap();
        assert_eq!(seen_crc(&read_later), Some(crc32fast::hash(&content)));
        // So a later change of its times alone (the same content) is no change, and a change of content is.
        let later = std::time::SystemTime::now() + std::time::Duration::from_secs(5);
        std::fs::File::options().write(true).open(&read_later).unwrap().set_modified(later).unwrap();
        assert!(!changed_since_read(&read_later), "the same content with new times");
        std::fs::write(&read_later, b"changed").unwrap();
        assert!(changed_since_read(&read_later), "another content");
    }

    #[test]
    fn outputs_committed_together_are_in_place_with_one_sync_per_folder() {
        let dir = tempfile::tempdir().unwrap();
        let other = tempfile::tempdir().unwrap();
        let (a, b, c) = (dir.path().join("a.toml"), dir.path().join("a.json"), other.path().join("c.json"));
        std::fs::write(&a, "old").unwrap();
        let staged: Vec<Staged> =
            [(&a, b"A"), (&b, b"B"), (&c, b"C")].iter().map(|(p, t)| stage(p, *t).unwrap()).collect();
        let mut folders = FolderSync::default();
        for s in staged {
            s.commit_in(&mut folders).unwrap();
        }
        // Every output is renamed into place before any folder is synced; two folders, each listed once.
        assert_eq!(std::fs::read(&a).unwrap(), b"A");
        assert_eq!(std::fs::read(&b).unwrap(), b"B");
        assert_eq!(std::fs::read(&c).unwrap(), b"C");
        assert_eq!(folders.pending(), [dir.path().to_path_buf(), other.path().to_path_buf()]);
        folders.sync();
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2, "no temporary file is left");
        // A failed second commit leaves the first in place (its folder synced when `folders` drops): the
        // second's target became a folder after it was staged, so its rename fails.
        let first = stage(&a, b"A2").unwrap();
        let second = stage(&b, b"B2").unwrap();
        std::fs::remove_file(&b).unwrap();
        std::fs::create_dir(&b).unwrap();
        std::fs::write(b.join("inside"), "x").unwrap();
        let mut folders = FolderSync::default();
        first.commit_in(&mut folders).unwrap();
        let failed = second.commit_in(&mut folders);
        assert!(matches!(failed, Err(FsError::Write { .. })), "{failed:?}");
        assert_eq!(folders.pending(), [dir.path().to_path_buf()]);
        drop(folders);
        assert_eq!(std::fs::read(&a).unwrap(), b"A2");
        assert!(b.is_dir());
    }

    /// The files a commit replaces are held open from before their rename until the folder sync, which
    /// closes them (on a thread of its own): the new content is in place meanwhile, the old one is still
    /// what the held file reads, and a new output (nothing replaced) holds nothing.
    #[cfg(unix)]
    #[test]
    fn replaced_files_are_held_until_the_folder_sync() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.toml"), dir.path().join("b.json"));
        std::fs::write(&a, "old a").unwrap();
        let staged = [stage(&a, b"new a").unwrap(), stage(&b, b"new b").unwrap()];
        let mut folders = FolderSync::default();
        for s in staged {
            s.commit_in(&mut folders).unwrap();
        }
        assert_eq!(std::fs::read(&a).unwrap(), b"new a");
        assert_eq!(std::fs::read(&b).unwrap(), b"new b");
        assert_eq!(folders.replaced.len(), 1, "only a replaced a file");
        let mut old = String::new();
        folders.replaced[0].read_to_string(&mut old).unwrap();
        assert_eq!(old, "old a");
        folders.sync();
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2, "no temporary file is left");
    }

    /// A file staged without its sync: nothing at the target changes until the commit (which syncs it
    /// first), dropping it removes it, and a replaced file closed at once is no longer held.
    #[cfg(unix)]
    #[test]
    fn a_file_staged_unsynced_is_committed_or_dropped_like_any_other() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.png");
        std::fs::write(&a, "old").unwrap();
        let dropped = stage_unsynced(&a, b"never", Name::Chosen, Replace::Writable).unwrap();
        assert!(!dropped.synced);
        drop(dropped);
        assert_eq!(std::fs::read(&a).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "the dropped temporary file is gone");
        let staged = stage_unsynced(&a, b"new", Name::Chosen, Replace::Writable).unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"old", "staged, not in place");
        let mut folders = FolderSync::default();
        staged.commit_in(&mut folders).unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"new");
        assert_eq!(folders.replaced.len(), 1);
        folders.close_replaced();
        assert!(folders.replaced.is_empty());
        assert_eq!(folders.pending(), [dir.path().to_path_buf()], "the folder still waits for its sync");
        folders.sync();
        // A name the command chose that is a symbolic link is refused as when staged with the sync.
        std::os::unix::fs::symlink("a.png", dir.path().join("l.png")).unwrap();
        let refused = stage_unsynced(&dir.path().join("l.png"), b"x", Name::Chosen, Replace::Writable);
        assert!(matches!(refused, Err(FsError::ChosenLink { .. })), "{refused:?}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2, "no temporary file is left");
    }

    /// The list of live temporary files (a list of the test's own: the process's is shared with the other
    /// tests): a file made through it is listed until its entry drops; `remove_all` removes every listed one
    /// and nothing else, and from then on makes nothing. A staged output's entry leaves the process's list
    /// when it is committed or dropped.
    #[test]
    fn temporary_files_are_listed_while_they_live_and_removed_all_at_once() {
        let list: &'static LiveTemps = Box::leak(Box::new(LiveTemps::new()));
        let dir = tempfile::tempdir().unwrap();
        let make = || tempfile::Builder::new().prefix(".t.").suffix(".tmp").tempfile_in(dir.path());
        let (a, a_entry) = list.create(make).unwrap();
        let (b, b_entry) = list.create(make).unwrap();
        let (c, c_entry) = list.create(make).unwrap();
        assert_eq!(list.lock().paths.len(), 3);
        // A file renamed into place and its entry dropped, as a commit does: no longer listed.
        let kept = dir.path().join("kept");
        a.persist(&kept).unwrap();
        drop(a_entry);
        // One file already gone when the list is emptied (dropped before its entry): not counted.
        let c_path = c.path().to_path_buf();
        drop(c);
        assert!(!c_path.exists());
        let b_path = b.path().to_path_buf();
        // `b` is still open (a worker writing it) when a signal empties the list.
        assert_eq!(list.remove_all(), 1);
        assert!(!b_path.exists(), "the listed file is removed");
        assert!(kept.exists(), "a file renamed into place is not");
        drop((b, b_entry, c_entry));
        let refused = list.create(make);
        assert!(matches!(&refused, Err(e) if e.kind() == std::io::ErrorKind::Interrupted), "{refused:?}");
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left, [std::ffi::OsString::from("kept")], "nothing made once the list is closed");
        // The process's list: a staged output is listed until it is committed or dropped.
        let listed = |path: &Path| STAGED.lock().paths.iter().any(|(_, p)| p.starts_with(path));
        let staged = stage(&dir.path().join("out"), b"x").unwrap();
        assert!(listed(dir.path()));
        drop(staged);
        assert!(!listed(dir.path()));
        stage(&dir.path().join("out"), b"y").unwrap().commit().unwrap();
        assert!(!listed(dir.path()));
    }

    #[test]
    fn folder_of_a_bare_name_is_dot() {
        assert_eq!(folder_of(Path::new("a.toml")), PathBuf::from("."));
        assert_eq!(folder_of(Path::new("d/e/a.toml")), PathBuf::from("d/e"));
        assert_eq!(folder_of(Path::new("/a.toml")), PathBuf::from("/"));
    }
}
