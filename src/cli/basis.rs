//! `metamer basis PALETTE [--dimension M] [--json]`: train (or load) the palette's sharpened spectral
//! factor basis and report how faithfully the factor model reproduces the palette's own light × reflectance
//! colours, beside the RGB factor model and the unsharpened PCA projection (DESIGN_SPEC §5).

use crate::basis::{self, Report};
use crate::basis::{Basis, POOR_MODEL_MEAN_DE00, accuracy::ErrorStats};
use crate::basis::{TrainOptions, TrainingSet};
use crate::palette::PaletteFile;
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};

#[derive(Debug, clap::Args)]
#[command(
    about = "Train the sharpened spectral factor basis of a palette and report its accuracy",
    long_about = "Train the palette's spectral factor basis B (31×m): principal components of its colour signals \
                  (every light × reflectance, designed spectra at their current samples), interval sharpening, then \
                  L-BFGS refinement of the sharpening transform and of all of B against the factor-model colour \
                  error in a local CIEDE2000 metric. Prints mean / p95 / max ΔE00 of the factor model c = e ∘ s \
                  against full 31-sample colour for the palette's own pairs, beside the RGB factor model and the \
                  unsharpened PCA basis, the projection of the signals onto the PCA span, and the off-diagonal mass of Λ (seed Eq. 7).",
    after_help = "The trained basis is stored next to the palette as NAME.basis.json, keyed by the exact spectra, m and \
                  the training version: it is reused until one of them changes (--no-cache trains afresh and writes \
                  nothing). With --json the output is {\"dimension\": m, \"basis\": [[31 numbers] × m], ...}, the \
                  columns of the sharpened B, plus the accuracy figures."
)]
pub struct Args {
    /// The palette file.
    #[arg(value_name = "PALETTE")]
    pub palette: PathBuf,
    /// Basis dimension m (default: the palette's `basis_dimension`).
    #[arg(long, short = 'm', value_name = "M")]
    pub(crate) dimension: Option<usize>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub(crate) json: bool,
    /// Neither read nor write the NAME.basis.json sidecar: always train.
    #[arg(long)]
    pub(crate) no_cache: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let file = PaletteFile::load(&args.palette)?;
    for w in &file.warnings {
        eprintln!("warning: {}", crate::fsio::escape_lines(w));
    }
    let m = args.dimension.unwrap_or(file.palette.settings.basis_dimension);
    if let Err(e) = crate::basis::check_dimension(m) {
        bail!("--dimension: the {e}");
    }
    let sidecar = basis::sidecar_path(&args.palette);
    let cache = (!args.no_cache).then_some(sidecar.as_path());
    let set = TrainingSet::from_palette(&file.palette)
        .with_context(|| format!("{}: cannot build its basis", args.palette.display()))?;
    let resolved = if args.no_cache {
        // Train afresh: neither the sidecar nor this process's memory.
        std::sync::Arc::new(
            basis::for_set(&set, m, None, &TrainOptions::default())
                .with_context(|| format!("{}: cannot build its basis", args.palette.display()))?,
        )
    } else {
        crate::basis::basis_for(&set, m, cache)
            .with_context(|| format!("{}: cannot build its basis", args.palette.display()))?
    };
    let (basis, report) = &*resolved;
    if let Some(w) = report.poor_model() {
        eprintln!("warning: {}: {w}", args.palette.display());
    }
    if args.json {
        // Through a `Value`: its objects print their keys sorted, the order the output has always had.
        let doc = serde_json::to_value(BasisJson::new(basis, report, &args.palette, cache))?;
        super::out::println(&serde_json::to_string_pretty(&doc)?)?;
    } else {
        super::out::print(&crate::fsio::escape_lines(&table(report, &args.palette, cache)))?;
    }
    Ok(())
}

/// The `--json` document: DESIGN_SPEC §5's `dimension` and `basis` (columns of B), then the report
/// (keys print sorted; see `run`).
#[derive(serde::Serialize)]
pub(crate) struct BasisJson<'a> {
    dimension: usize,
    /// The columns of the sharpened B, 31 samples each.
    basis: Vec<Vec<f64>>,
    palette: String,
    /// The sidecar read and written, `null` with --no-cache.
    cache: Option<String>,
    pairs: usize,
    signal_rank: usize,
    padded: usize,
    from_cache: bool,
    stored: bool,
    training_seconds: f64,
    key: &'a str,
    accuracy: &'a basis::AccuracyReport,
    stages: &'a [crate::basis::StageResult],
    start: Option<crate::basis::Start>,
    candidates: &'a [crate::basis::CandidateSummary],
    condition: f64,
    poor_model_threshold: f64,
    poor_model: Option<String>,
    notes: &'a [String],
}

impl<'a> BasisJson<'a> {
    pub fn new(basis: &Basis, report: &'a Report, palette: &Path, cache: Option<&Path>) -> BasisJson<'a> {
        BasisJson {
            dimension: basis.dimension(),
            basis: basis.b.column_iter().map(|c| c.iter().copied().collect()).collect(),
            palette: palette.display().to_string(),
            cache: cache.map(|p| p.display().to_string()),
            pairs: report.pairs,
            signal_rank: report.signal_rank,
            padded: report.padded,
            from_cache: report.from_cache,
            stored: report.stored,
            training_seconds: report.training_seconds,
            key: &report.key,
            accuracy: &report.accuracy,
            stages: &report.stages,
            start: report.start,
            candidates: &report.candidates,
            condition: report.condition,
            poor_model_threshold: POOR_MODEL_MEAN_DE00,
            poor_model: report.poor_model(),
            notes: &report.notes,
        }
    }
}

/// The human-readable report.
pub(crate) fn table(report: &Report, palette: &Path, cache: Option<&Path>) -> String {
    let a = &report.accuracy;
    let origin = match (report.from_cache, cache) {
        (true, Some(c)) => format!("loaded from {} (trained in {:.2} s)", c.display(), report.training_seconds),
        (false, Some(c)) if report.stored => {
            format!("trained in {:.2} s, stored in {}", report.training_seconds, c.display())
        }
        (false, Some(c)) => format!("trained in {:.2} s, not stored in {}", report.training_seconds, c.display()),
        _ => format!("trained in {:.2} s, not stored", report.training_seconds),
    };
    let mut out = format!(
        "{}: spectral factor basis, m = {}, {} light × reflectance pairs; {origin}\n\n",
        palette.display(),
        report.dimension,
        report.pairs
    );
    out.push_str(&format!("{:<52}{:>8}{:>8}{:>8}\n", "ΔE00 against full 31-sample colour", "mean", "p95", "max"));
    let mut row = |label: &str, s: &ErrorStats| {
        out.push_str(&format!("{label:<52}{:>8.2}{:>8.2}{:>8.2}\n", s.mean, s.p95, s.max));
    };
    row("spectral factor model c = e ∘ s (accepted B)", &a.factor_model);
    if let Some(t) = &a.factor_model_pca_span {
        row("  same, best B in the PCA span (T refined only)", t);
    }
    row("  same, unsharpened PCA basis", &a.pca_factor_model);
    row("no factor model: signal E ∘ S projected on PCA span", &a.pca_signal_projection);
    row("RGB factor model (seed Eq. 9)", &a.rgb_factor_model);
    row("full Λ (seed Eq. 7) with the accepted B", &a.full_lambda_model);
    out.push_str(&format!(
        "\nΛ off-diagonal mass ‖offdiag Λ(s)‖/‖diag Λ(s)‖, mean over reflectances: {:.3}\n\
         product tensor B⁺(B_j ∘ B_k) off-diagonal / diagonal (Frobenius): {:.3}\n",
        a.lambda_offdiagonal.reflectances, a.lambda_offdiagonal.tensor
    ));
    let start = report.start.map_or("unknown", |s| s.label());
    out.push_str(&format!(
        "accepted: {start}; condition number of B with unit-norm columns {:.3e}\n",
        report.condition
    ));
    for c in &report.candidates {
        out.push_str(&format!(
            "  candidate {:<40} mean {:>8.3} p95 {:>8.3} cond {:.2e}{}\n",
            format!(
                "{}{}",
                c.start.label(),
                match (c.refined, c.screened) {
                    (false, _) => ", unrefined",
                    (true, true) => ", screened",
                    (true, false) => ", refined",
                }
            ),
            c.factor_mean,
            c.factor_p95,
            c.condition,
            if c.accepted { "  ← accepted" } else { "" }
        ));
    }
    if let Some(w) = report.poor_model() {
        out.push_str(&format!("WARNING: {w}\n"));
    }
    for n in &report.notes {
        out.push_str(&format!("note: {n}\n"));
    }
    out
}
