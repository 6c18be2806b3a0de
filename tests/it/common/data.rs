//! The public volume datasets for the tests that need them, and honest skips when they are absent.
//!
//! The data folder is `$METAMER_DATA` when set, else `../shared` beside the crate. A test that needs it and
//! finds nothing calls [`skip`]: it writes a visible `SKIPPED` line straight to the terminal (past the
//! test harness's output capture) and counts the skip; the count is printed once more when the test
//! binary exits. With `CI=true` (CI has the data beside its checkout) a skip is a failure instead.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::Once;

/// The data folder holding `volumes/`: `$METAMER_DATA` (the folder itself or its parent), else
/// `$CARGO_MANIFEST_DIR/../shared`.
pub fn shared_dir() -> Option<PathBuf> {
    let from_env = std::env::var_os("METAMER_DATA").filter(|v| !v.is_empty()).map(PathBuf::from);
    let beside = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared");
    from_env.into_iter().chain([beside]).find_map(|d| {
        if d.join("volumes").is_dir() {
            Some(d)
        } else if d.join("engine.nhdr").is_file() {
            // METAMER_DATA may name the volumes folder itself.
            d.parent().map(Path::to_path_buf).filter(|p| p.join("volumes").is_dir())
        } else {
            None
        }
    })
}

/// The data folder's `volumes/`, or a skip (see [`skip`]) naming `test`.
pub fn volumes_or_skip(test: &str) -> Option<PathBuf> {
    match shared_dir() {
        Some(d) => Some(d.join("volumes")),
        None => {
            skip(test, "the data folder with volumes/ was not found ($METAMER_DATA unset or without it, no ../shared)");
            None
        }
    }
}

static SKIPPED: Mutex<Vec<String>> = Mutex::new(Vec::new());
static AT_EXIT: Once = Once::new();

unsafe extern "C" {
    /// The C library's `atexit`: runs the handler when the process exits (after the harness's summary).
    fn atexit(handler: extern "C" fn()) -> std::ffi::c_int;
}

extern "C" fn print_skip_count() {
    // Must not panic (it runs inside the C library's exit).
    let names = match SKIPPED.lock() {
        Ok(v) => v.clone(),
        Err(poisoned) => poisoned.into_inner().clone(),
    };
    if !names.is_empty() {
        let _ = writeln!(
            std::io::stderr(),
            "data tests: {} skipped ({}) — they need the public volumes: set METAMER_DATA=DIR or put the data \
             folder at ../shared (README, section Data)",
            names.len(),
            names.join(", ")
        );
    }
}

/// Skip `test` for `reason`: a visible line now, a count at exit; under `CI=true` a panic (CI has the data).
pub fn skip(test: &str, reason: &str) {
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{test}: {reason}; under CI=true data tests must not skip (CI has ../shared beside the checkout)");
    }
    // Written to the process's stderr directly, so the harness's capture of passing tests does not hide it.
    let _ = writeln!(std::io::stderr().lock(), "SKIPPED {test}: {reason}");
    match SKIPPED.lock() {
        Ok(mut v) => v.push(test.to_string()),
        Err(poisoned) => poisoned.into_inner().push(test.to_string()),
    }
    AT_EXIT.call_once(|| {
        // SAFETY: `atexit` only stores the function pointer; the handler is a plain `extern "C" fn` that
        // takes no arguments, never unwinds and touches only statics that live until exit.
        unsafe {
            atexit(print_skip_count);
        }
    });
}
