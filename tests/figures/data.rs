//! Where the public volume datasets are: the data folder is `$METAMER_DATA` when set (the folder holding
//! `volumes/`, or `volumes/` itself), else `../shared` beside the crate. A set `METAMER_DATA` is the only
//! place looked at, so pointing it at an empty folder shows what a machine without the data reports.

use std::path::{Path, PathBuf};

/// The data folder holding `volumes/`, when there is one.
pub(crate) fn shared_dir() -> Option<PathBuf> {
    let d = std::env::var_os("METAMER_DATA")
        .filter(|v| !v.is_empty())
        .map_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared"), PathBuf::from);
    if d.join("volumes").is_dir() {
        Some(d)
    } else if d.join("engine.nhdr").is_file() {
        // METAMER_DATA may name the volumes folder itself.
        d.parent().map(Path::to_path_buf).filter(|p| p.join("volumes").is_dir())
    } else {
        None
    }
}

/// Why the data tests cannot run here, naming where the data was looked for.
pub(crate) fn missing() -> String {
    let looked = match std::env::var_os("METAMER_DATA").filter(|v| !v.is_empty()) {
        Some(v) => format!("METAMER_DATA={} holds no volumes/", Path::new(&v).display()),
        None => format!(
            "METAMER_DATA is not set and {} holds no volumes/",
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared").display()
        ),
    };
    format!("needs the public volumes: {looked} (README, section Data)")
}

/// The data folder's `volumes/`. Only the data tests call it, and the harness runs them only when the
/// folder is there, or under `CI=true`, where its absence is this panic: a failure naming the reason.
pub(crate) fn volumes() -> PathBuf {
    match shared_dir() {
        Some(d) => d.join("volumes"),
        None => panic!("{}", missing()),
    }
}
