//! `metamer render` (not built yet: it says so and exits non-zero).

use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Input file.
    pub input: Option<PathBuf>,
}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`metamer render` is not built yet")
}
