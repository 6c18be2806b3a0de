//! `metamer bench`: benchmark reports (Markdown + PNG plots). Built so far: `render`.

use anyhow::bail;
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which benchmark to run: render.
    pub which: Option<String>,
    /// Output folder for the reports and plots.
    #[arg(short, long, default_value = "bench")]
    pub output: PathBuf,
    /// Timed repetitions per measurement.
    #[arg(long, default_value_t = 5)]
    pub runs: usize,
    /// Renderer benchmark: volume to use instead of ../shared/volumes/engine.nhdr.
    #[arg(long)]
    pub volume: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.which.as_deref() {
        Some("render") => {
            let options = crate::bench::render::RenderBenchOptions {
                out_dir: args.output.clone(),
                runs: args.runs,
                volume: args.volume.clone(),
                ..Default::default()
            };
            let report = crate::bench::render::run(&options)?;
            println!("{}", report.markdown);
            println!("wrote {}", args.output.join("render.md").display());
            Ok(())
        }
        Some(other) => bail!("`metamer bench {other}` is not built yet (built: render)"),
        None => bail!("name a benchmark: `metamer bench render` (others are not built yet)"),
    }
}
