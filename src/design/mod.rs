//! The design engine (seed §3, DESIGN_SPEC §2): stacked weighted least squares over the samples of every
//! designed spectrum and the free colours, an SVD solve, then bounds by L-BFGS-B.
//!
//! Interface pinned for the other modules (TUI, CLI, renderer); the engine fills it in.

use crate::basis::Basis;
use crate::colorimetry::Colorimetry;
use crate::palette::Palette;
use nalgebra::Vector3;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// Options of a solve.
#[derive(Clone, Debug)]
pub struct SolveOptions {
    /// Wall-clock cap for the iterative parts (joint bilinear design, L-BFGS-B).
    pub time_limit: Duration,
    /// Set to true from another thread to abandon the solve (the TUI drops stale work this way).
    pub cancel: Option<Arc<AtomicBool>>,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions { time_limit: Duration::from_secs(10), cancel: None }
    }
}

/// The colours of one cell at the solution.
#[derive(Clone, Debug, PartialEq)]
pub struct CellResult {
    /// Index into `palette.colours`.
    pub cell: usize,
    /// The target (a free cell's target is its group's colour), linear sRGB.
    pub target: Vector3<f64>,
    /// Full 31-sample colour.
    pub rgb_full: Vector3<f64>,
    /// Subspace (spectral factor model) colour, when a basis was given.
    pub rgb_subspace: Option<Vector3<f64>>,
    pub delta_e_full: f64,
    pub delta_e_subspace: Option<f64>,
}

/// Something the user should know about a design: a cell that cannot be met and why, a degenerate input…
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// Index into `palette.colours` when it is about one cell.
    pub cell: Option<usize>,
    pub message: String,
}

/// The result of a solve.
#[derive(Clone, Debug)]
pub struct Solution {
    /// The palette with every designed spectrum replaced by its solution.
    pub palette: Palette,
    /// One colour per free group (same order as `palette.free`).
    pub free: Vec<Vector3<f64>>,
    /// The pinned objective (DESIGN_SPEC §2) at the returned solution.
    pub objective: f64,
    /// Largest violation of the first-order (KKT) conditions, scaled.
    pub kkt_residual: f64,
    pub seconds: f64,
    pub cells: Vec<CellResult>,
    pub diagnostics: Vec<Diagnostic>,
}

/// Why a solve failed outright (as opposed to a design that is merely infeasible, which is reported in
/// [`Solution::diagnostics`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DesignError {
    #[error("the design engine is not built yet")]
    NotBuilt,
    #[error("the solve was cancelled")]
    Cancelled,
    #[error("{0}")]
    Invalid(String),
}

/// Solve a palette's design.
pub fn solve(
    _palette: &Palette,
    _basis: Option<&Basis>,
    _colorimetry: &Colorimetry,
    _options: &SolveOptions,
) -> Result<Solution, DesignError> {
    Err(DesignError::NotBuilt)
}
