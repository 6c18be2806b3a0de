//! Where the public volume datasets are looked for: a data folder named by the `METAMER_DATA`
//! environment variable (the file itself, or under its `volumes/` folder), and what each known dataset is
//! and where it comes from, for the message when one is missing. Nothing here knows a machine path.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// The environment variable naming the data folder.
pub(crate) const DATA_ENV: &str = "METAMER_DATA";

/// The data folder from `METAMER_DATA`, when set and not empty.
pub(crate) fn data_dir() -> Option<PathBuf> {
    std::env::var_os(DATA_ENV).filter(|v| !v.is_empty()).map(PathBuf::from)
}

/// `DIR/NAME` or `DIR/volumes/NAME`, whichever is a file first.
pub fn find_in(dir: &Path, name: &OsStr) -> Option<PathBuf> {
    [dir.join(name), dir.join("volumes").join(name)].into_iter().find(|p| p.is_file())
}

/// The file `name` in the `METAMER_DATA` folder, if the variable is set and the file is there.
pub fn find_in_data_dir(name: &OsStr) -> Option<PathBuf> {
    find_in(&data_dir()?, name)
}

/// What a known public dataset is and where it comes from (by file name), for error messages and the
/// README's data table.
pub fn dataset_origin(name: &str) -> Option<&'static str> {
    Some(match name {
        "engine.nhdr" | "engine.raw.gz" | "engine.raw" => {
            "the engine CT (256×256×128, 8-bit, by General Electric) of the volvis.org collection of public \
             volume datasets, as NRRD engine.nhdr + engine.raw.gz (no licence stated; not part of the repository). \
             Get it from the Open SciVis Datasets collection: \
             http://klacansky.com/open-scivis-datasets/engine/engine_256x256x128_uint8.raw (raw bytes, x fastest; \
             README.md's data table gives the NRRD header and the checksum)"
        }
        "frog_tissues.vti" => {
            "the Whole Frog Project tissue labels (500×470×136, labels 0–29, Lawrence Berkeley Laboratory) as \
             shipped inside the pyvista Python package (pyvista ≥ 0.44: \
             `pyvista.examples.load_frog_tissues().save(\"frog_tissues.vti\")`; not part of the repository)"
        }
        _ => return None,
    })
}
