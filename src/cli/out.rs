//! The one way commands print to standard output. Every command's stdout goes through [`print`] or
//! [`write`], which turn a failed write into an [`OutputError`] instead of a panic (`println!` panics with
//! "failed printing to stdout"): a closed pipe (`metamer check p.toml | head -1`) is
//! [`OutputError::Closed`], which [`super::main`] ends quietly with exit status 0 (the reader has what it
//! wanted, as `head` does); any other failure (`> /dev/full`: no space left) is one line on stderr and
//! exit status 1.

use std::io::{self, Write};

/// Why standard output could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The reading end of the pipe was closed (EPIPE).
    #[error("standard output was closed")]
    Closed,
    #[error("cannot write to standard output: {0}")]
    Write(io::Error),
}

impl From<io::Error> for OutputError {
    fn from(e: io::Error) -> Self {
        if e.kind() == io::ErrorKind::BrokenPipe { OutputError::Closed } else { OutputError::Write(e) }
    }
}

/// Run `f` with a buffered writer on stdout (locked for the whole call) and flush it.
pub fn write(f: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<(), OutputError> {
    let stdout = io::stdout();
    let mut w = io::BufWriter::with_capacity(1 << 16, stdout.lock());
    f(&mut w)?;
    w.flush()?;
    Ok(())
}

/// Print `text` as it is (no newline added).
pub fn print(text: &str) -> Result<(), OutputError> {
    write(|w| w.write_all(text.as_bytes()))
}

/// Print `text` and a newline.
pub fn println(text: &str) -> Result<(), OutputError> {
    write(|w| {
        w.write_all(text.as_bytes())?;
        w.write_all(b"\n")
    })
}

/// True when `e` (or an error it wraps) is a closed standard output: the command ends quietly.
pub fn is_closed(e: &anyhow::Error) -> bool {
    e.chain().any(|c| matches!(c.downcast_ref::<OutputError>(), Some(OutputError::Closed)))
}
