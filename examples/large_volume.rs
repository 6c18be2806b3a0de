//! Write the renderer benchmark's large generated u16 volume (`metamer bench render`'s workload) as a
//! raw NRRD file and a scene over it, so two builds can render the very same workload from the CLI:
//!
//! `cargo run --release --example large_volume -- OUT_DIR [X Y Z]` (default 512 512 384), then
//! `metamer render OUT_DIR/large.toml --frames 1 --size 512`.

use anyhow::Context;
use std::io::Write;
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().context("usage: large_volume OUT_DIR [X Y Z]")?);
    let rest: Vec<usize> = args.map(|a| a.parse()).collect::<Result<_, _>>().context("X Y Z are voxel counts")?;
    let dims = match rest[..] {
        [x, y, z] => [x, y, z],
        [] => [512, 512, 384],
        _ => anyhow::bail!("give all three of X Y Z, or none"),
    };
    let volume = metamer::volume::engine_like_u16(dims);
    let dims = volume.dims;
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let raw = out.join("large.raw");
    let mut w = std::io::BufWriter::new(std::fs::File::create(&raw).with_context(|| format!("{}", raw.display()))?);
    for i in 0..volume.voxels.len() {
        // u16 voxels stored as u16: the value is a whole number in 0..=65535.
        let v = volume.voxels.get(i) as u16;
        w.write_all(&v.to_le_bytes())?;
    }
    w.flush()?;
    let header = format!(
        "NRRD0004\ntype: unsigned short\ndimension: 3\nsizes: {} {} {}\nspacings: 1 1 1\nendian: little\nencoding: raw\ndata file: ./large.raw\n",
        dims[0], dims[1], dims[2]
    );
    std::fs::write(out.join("large.nhdr"), header)?;
    let k = metamer::volume::U16_SCALE;
    let palette = std::path::absolute("volumes/engine_palette.toml")?;
    let scene = format!(
        "palette = {:?}\nvolume = \"large.nhdr\"\n\n[[materials]]\nreflectance = \"smoke\"\nrange = [{}, {}]\nopacity = 0.05\n\n[[materials]]\nreflectance = \"block\"\nrange = [{}, {}]\nopacity = 0.15\n\n[[materials]]\nreflectance = \"inner\"\nrange = [{}, {}]\nopacity = 0.6\n\n[dial]\npath = [\"hide\", \"split\", \"glow\"]\n",
        palette.display().to_string(),
        18.0 * k,
        75.0 * k,
        105.0 * k,
        175.0 * k,
        200.0 * k,
        255.0 * k
    );
    std::fs::write(out.join("large.toml"), scene)?;
    println!("wrote {} ({}×{}×{} u16) and large.toml", raw.display(), dims[0], dims[1], dims[2]);
    Ok(())
}
