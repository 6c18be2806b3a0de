//! Write the benchmark palettes as TOML files:
//! `cargo run --release --example batch_palette -- batch N OUT.toml [SEED]` (N independent bounded
//! single-reflectance designs under 3 lights, targets perturbed), `... reachable N OUT.toml [SEED]` (the same,
//! every target reachable) or `... capacity N OUT.toml [SEED]` (the n×n joint protocol).

use metamer::colorimetry::Colorimetry;
use metamer::palette::random;

use metamer::palette::PaletteFile;
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: batch_palette (batch|reachable|capacity) N OUT.toml [SEED]";
    let (kind, n, out) = match (args.get(1), args.get(2), args.get(3)) {
        (Some(k), Some(n), Some(o)) => (k.as_str(), n.parse::<usize>()?, o),
        _ => anyhow::bail!(usage),
    };
    let seed: u64 = args.get(4).map(|s| s.parse()).transpose()?.unwrap_or(1);
    let col = Colorimetry::default();
    let palette = match kind {
        "batch" => random::batch_palette(n, seed, &col),
        "reachable" => random::reachable_batch_palette(n, seed, &col),
        "capacity" => random::capacity_palette(n, seed, &col),
        _ => anyhow::bail!(usage),
    };
    let mut file = PaletteFile::from_palette(&palette);
    file.save_as(&palette, Path::new(out))?;
    println!(
        "wrote {out}: {} lights, {} reflectances, {} cells",
        palette.lights.len(),
        palette.reflectances.len(),
        palette.colours.len()
    );
    Ok(())
}
