//! `metamer solve IN.toml [-o OUT.toml] [--report R.json]` (DESIGN_SPEC §5): solve a palette's design,
//! print a per-cell table (target, achieved full and subspace colour, ΔE00) with a line for every cell
//! that cannot be met and why, write the solved palette (atomically; never after a failed solve) and a
//! JSON report.

use crate::basis::Basis;
use crate::basis::store::{self, palette_uses_basis};
use crate::colorimetry::{Colorimetry, linear_to_hex};
use crate::design::{self, Solution, SolveOptions};
use crate::palette::file::PaletteFile;
use crate::palette::{Palette, SpectrumEntry};
use anyhow::Context;
use nalgebra::Vector3;
use serde_json::{Value, json};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Palettes with at most this many spectra get subspace colours in the report by default (training a basis
/// for thousands of spectra would dominate a batch solve).
pub const AUTO_SUBSPACE_SPECTRA: usize = 100;

#[derive(Debug, clap::Args)]
#[command(
    about = "Solve a palette's design headless: write the solved palette and a JSON report",
    long_about = "Solve the design of a palette (DESIGN_SPEC §2): every designed light and reflectance and every \
                  free colour is chosen to minimise the weighted colour errors plus smoothness under the bounds. \
                  Prints one row per colour cell (target, achieved colour in full 31-sample and in the spectral \
                  factor model, CIEDE2000) and says for every cell that cannot be met why. The solved palette is \
                  written to OUT only when the solve succeeds, atomically (OUT may be IN).",
    after_help = "Subspace colours need the palette's trained basis (cached in IN's .basis.json sidecar). It is \
                  always used when the palette sets fit_in_subspace or subspace_error; otherwise it is trained for \
                  palettes of up to 100 spectra, or when --subspace is given, and skipped with --no-subspace."
)]
pub struct Args {
    /// The palette to solve.
    #[arg(value_name = "IN.toml")]
    pub input: PathBuf,
    /// Where to write the solved palette (may be IN). Without it nothing is written but the report.
    #[arg(short = 'o', long = "output", value_name = "OUT.toml")]
    pub output: Option<PathBuf>,
    /// Write a JSON report here.
    #[arg(long, value_name = "REPORT.json")]
    pub report: Option<PathBuf>,
    /// Always report subspace colours (trains the basis if needed).
    #[arg(long, conflicts_with = "no_subspace")]
    pub subspace: bool,
    /// Never train a basis just for reporting subspace colours.
    #[arg(long)]
    pub no_subspace: bool,
    /// Wall-clock cap in seconds for the iterative parts (joint design).
    #[arg(long, default_value_t = 60.0, value_name = "SECONDS")]
    pub time_limit: f64,
    /// Print only the summary and the unmet cells, not the per-cell table.
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let started = Instant::now();
    let file = PaletteFile::load(&args.input)?;
    let palette = &file.palette;
    let colorimetry = Colorimetry::default();
    let sidecar = store::sidecar_path(&args.input);
    let m = palette.settings.basis_dimension;
    let uses = palette_uses_basis(palette);
    let basis: Option<Basis> = if uses {
        let (b, _) = store::for_palette(palette, m, Some(&sidecar))
            .with_context(|| format!("{}: settings need the trained basis", args.input.display()))?;
        Some(b)
    } else {
        None
    };
    if !(args.time_limit.is_finite() && args.time_limit > 0.0) {
        anyhow::bail!("--time-limit must be a positive number of seconds, got {}", args.time_limit);
    }
    let options = SolveOptions { time_limit: Duration::from_secs_f64(args.time_limit), cancel: None };
    let mut solution = design::solve(palette, basis.as_ref(), &colorimetry, &options)
        .with_context(|| format!("{}: the design cannot be solved", args.input.display()))?;
    // Subspace colours for the report: the solve's basis, else one trained on the solved spectra.
    let spectra = palette.lights.len() + palette.reflectances.len();
    let want_subspace = !args.no_subspace && (args.subspace || spectra <= AUTO_SUBSPACE_SPECTRA);
    let mut notes = Vec::new();
    if basis.is_none() && want_subspace {
        match store::for_palette(&solution.palette, m, Some(&sidecar)) {
            Ok((b, _)) => {
                solution.cells = design::report::cell_results(palette, Some(&b), &colorimetry, &values_of(&solution));
            }
            Err(e) => notes.push(format!("no subspace colours: {e}")),
        }
    }
    if let Some(out) = &args.output {
        let mut target = file.clone();
        target
            .save_as(&solution.palette, out)
            .with_context(|| format!("{}: cannot write the solved palette", out.display()))?;
    }
    let seconds = started.elapsed().as_secs_f64();
    print_table(palette, &solution, &notes, args.quiet, args.output.as_deref(), seconds)?;
    if let Some(path) = &args.report {
        let report = report_json(palette, &solution, seconds);
        let write = || -> anyhow::Result<()> {
            let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
            serde_json::to_writer_pretty(&mut w, &report)?;
            writeln!(w)?;
            w.flush()?;
            Ok(())
        };
        write().with_context(|| format!("{}: cannot write the report", path.display()))?;
    }
    Ok(())
}

/// The solution's values as the report module wants them.
fn values_of(s: &Solution) -> design::system::Values {
    design::system::Values {
        lights: s.palette.lights.iter().map(|e| e.spectrum).collect(),
        reflectances: s.palette.reflectances.iter().map(|e| e.spectrum).collect(),
        free: s.free.clone(),
    }
}

fn rgb(c: &Vector3<f64>) -> String {
    format!("{:.4} {:.4} {:.4}", c[0], c[1], c[2])
}

fn print_table(
    palette: &Palette,
    s: &Solution,
    notes: &[String],
    quiet: bool,
    output: Option<&Path>,
    seconds: f64,
) -> anyhow::Result<()> {
    let stdout = std::io::stdout();
    let mut w = std::io::BufWriter::new(stdout.lock());
    if !quiet {
        writeln!(
            w,
            "{:<14} {:<14} {:<8} {:<22} {:<22} {:>7} {:<22} {:>7}",
            "light", "reflectance", "target", "target (linear)", "full", "ΔE00", "subspace", "ΔE00"
        )?;
        for c in &s.cells {
            let cell = &palette.colours[c.cell];
            let (sub, de_sub) = match (c.rgb_subspace, c.delta_e_subspace) {
                (Some(r), Some(d)) => (rgb(&r), format!("{d:7.2}")),
                _ => ("-".into(), "      -".into()),
            };
            writeln!(
                w,
                "{:<14} {:<14} {:<8} {:<22} {:<22} {:>7.2} {:<22} {}{}",
                palette.lights[cell.light].name,
                palette.reflectances[cell.reflectance].name,
                linear_to_hex(&c.target),
                rgb(&c.target),
                rgb(&c.rgb_full),
                c.delta_e_full,
                sub,
                de_sub,
                if cell.is_active() { "" } else { "  (not used)" }
            )?;
        }
    }
    let unmet: Vec<&design::Diagnostic> = s.diagnostics.iter().filter(|d| d.cell.is_some()).collect();
    for d in &s.diagnostics {
        let tag = if d.cell.is_some() && d.message.contains("not met") { "UNMET" } else { "note" };
        writeln!(w, "{tag}: {}", d.message)?;
    }
    for n in notes {
        writeln!(w, "note: {n}")?;
    }
    writeln!(
        w,
        "objective {:.6e}, KKT residual {:.1e}, {} cells ({} with remarks), {:.3} s{}",
        s.objective,
        s.kkt_residual,
        s.cells.len(),
        unmet.len(),
        seconds,
        match output {
            Some(p) => format!(", solved palette written to {}", p.display()),
            None => ", solved palette not written (no -o)".into(),
        }
    )?;
    w.flush()?;
    Ok(())
}

fn spectrum_json(e: &SpectrumEntry) -> Value {
    json!({
        "name": e.name,
        "kind": e.kind.as_str(),
        "design": e.design,
        "samples": e.spectrum.to_vec(),
    })
}

fn vec3(c: &Vector3<f64>) -> Value {
    json!([c[0], c[1], c[2]])
}

/// The JSON report (DESIGN_SPEC §5) plus `kkt_residual`, `diagnostics` and per-cell `weight`/`enabled`.
pub fn report_json(palette: &Palette, s: &Solution, seconds: f64) -> Value {
    let spectra: Vec<Value> = s.palette.lights.iter().chain(&s.palette.reflectances).map(spectrum_json).collect();
    let free: Vec<Value> =
        palette.free.iter().zip(&s.free).map(|(g, c)| json!({"name": g.name, "rgb": vec3(c)})).collect();
    let cells: Vec<Value> = s
        .cells
        .iter()
        .map(|c| {
            let cell = &palette.colours[c.cell];
            json!({
                "light": palette.lights[cell.light].name,
                "reflectance": palette.reflectances[cell.reflectance].name,
                "target": vec3(&c.target),
                "rgb_full": vec3(&c.rgb_full),
                "rgb_subspace": c.rgb_subspace.as_ref().map(vec3),
                "delta_e_full": c.delta_e_full,
                "delta_e_subspace": c.delta_e_subspace,
                "free": cell.free.map(|g| palette.free[g].name.clone()),
                "weight": cell.weight,
                "enabled": cell.enabled,
            })
        })
        .collect();
    let diagnostics: Vec<Value> = s
        .diagnostics
        .iter()
        .map(|d| {
            let cell = d.cell.map(|k| {
                let c = &palette.colours[k];
                json!({"light": palette.lights[c.light].name, "reflectance": palette.reflectances[c.reflectance].name})
            });
            json!({"cell": cell, "message": d.message})
        })
        .collect();
    json!({
        "palette": palette.name,
        "objective": s.objective,
        "seconds": seconds,
        "solve_seconds": s.seconds,
        "kkt_residual": s.kkt_residual,
        "spectra": spectra,
        "free": free,
        "cells": cells,
        "diagnostics": diagnostics,
    })
}
