//! `metamer bench`: benchmark reports (Markdown + PNG plots). Built so far: `render`, `basis`.

use anyhow::bail;
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which benchmark to run: render, basis.
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
        Some("basis") => {
            std::fs::create_dir_all(&args.output)
                .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", args.output.display()))?;
            let options = crate::bench::basis::BenchOptions { runs: args.runs.max(1), ..Default::default() };
            let markdown = crate::bench::basis::run_and_write(&options, &args.output)?;
            println!("{markdown}");
            println!("wrote {}", args.output.join("basis.md").display());
            Ok(())
        }
        Some(other) => bail!("`metamer bench {other}` is not built yet (built: render, basis)"),
        None => bail!("name a benchmark: `metamer bench render` or `metamer bench basis` (others are not built yet)"),
    }
}
