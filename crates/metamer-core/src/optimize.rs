//! The one argmin set-up: every iterative minimisation over a vector (L-BFGS-B in the design,
//! `design/lsq.rs` and `design/joint.rs`; argmin's L-BFGS in the basis refinement, `basis/refine.rs`)
//! runs through [`run`]: a starting point, an iteration cap, an optional target cost, an optional
//! deadline (argmin's `Executor::timeout`), no Ctrl-C handler. [`Termination`] says, typed, why it stopped.
//! [`Rng`] seeds the deterministic perturbed starts of the joint design's multi-start.

use argmin::core::{Error, Executor, IterState, Solver, State, TerminationReason, TerminationStatus};
use nalgebra::DVector;
use std::time::Instant;

/// The argmin state of a minimisation over `DVector<f64>` with a gradient (L-BFGS-B and L-BFGS).
pub(crate) type VecState = IterState<DVector<f64>, DVector<f64>, (), (), (), f64>;

/// The `TerminationReason::SolverExit` text of a solver that could not decrease the cost along any
/// direction it tried (L-BFGS-B's line search, even from steepest descent).
pub(crate) const NO_DECREASE: &str = "line search found no decrease";

/// Why an iterative minimisation (or a stage of one) stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Termination {
    /// The solver's own convergence test held.
    Converged,
    /// The iteration cap was reached.
    MaxIters,
    /// The target cost was reached.
    TargetCost,
    /// The deadline passed.
    TimeLimit,
    /// The cancel flag was set.
    Cancelled,
    /// The solver found no decrease along any direction it tried ([`NO_DECREASE`]).
    NoDecrease,
    /// The run has not terminated (an error ended it) or a solver stopped for a reason of its own.
    Other,
}

impl Termination {
    /// The typed reason of an argmin termination status.
    pub(crate) fn of(status: &TerminationStatus) -> Termination {
        match status {
            TerminationStatus::NotTerminated => Termination::Other,
            TerminationStatus::Terminated(reason) => match reason {
                TerminationReason::SolverConverged => Termination::Converged,
                TerminationReason::MaxItersReached => Termination::MaxIters,
                TerminationReason::TargetCostReached => Termination::TargetCost,
                TerminationReason::Timeout => Termination::TimeLimit,
                TerminationReason::Interrupt => Termination::Cancelled,
                TerminationReason::SolverExit(why) if why == NO_DECREASE => Termination::NoDecrease,
                TerminationReason::SolverExit(_) => Termination::Other,
            },
        }
    }

    /// Words for a diagnostic: "time limit", "cancelled", …
    pub fn as_str(self) -> &'static str {
        match self {
            Termination::Converged => "converged",
            Termination::MaxIters => "iteration cap",
            Termination::TargetCost => "target cost reached",
            Termination::TimeLimit => "time limit",
            Termination::Cancelled => "cancelled",
            Termination::NoDecrease => NO_DECREASE,
            Termination::Other => "stopped",
        }
    }
}

impl std::fmt::Display for Termination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The limits of one run.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Limits {
    pub(crate) max_iters: u64,
    /// Stop once this instant has passed (checked after every iteration); `None`: no deadline.
    pub(crate) deadline: Option<Instant>,
    /// Stop once the cost is at most this.
    pub(crate) target_cost: Option<f64>,
}

impl Limits {
    /// At most `max_iters` iterations, no deadline, no target cost.
    pub(crate) fn iterations(max_iters: u64) -> Limits {
        Limits { max_iters, deadline: None, target_cost: None }
    }
}

/// The end of a run: argmin's final state and why it stopped.
pub(crate) struct Run {
    pub(crate) state: VecState,
    pub(crate) termination: Termination,
}

impl Run {
    /// Iterations done.
    pub(crate) fn iterations(&self) -> u64 {
        self.state.get_iter()
    }
}

/// Minimise `problem` with `solver` from `x0` within `limits` through argmin's `Executor`.
pub(crate) fn run<O, S>(problem: O, solver: S, x0: DVector<f64>, limits: &Limits) -> Result<Run, Error>
where
    S: Solver<O, VecState>,
{
    let Limits { max_iters, deadline, target_cost } = *limits;
    let mut executor = Executor::new(problem, solver)
        .configure(|s| {
            let s = s.param(x0).max_iters(max_iters);
            match target_cost {
                Some(t) => s.target_cost(t),
                None => s,
            }
        })
        .ctrlc(false)
        .timer(false);
    if let Some(d) = deadline {
        executor = executor.timeout(d.saturating_duration_since(Instant::now()));
    }
    let result = executor.run()?;
    let termination = Termination::of(result.state.get_termination_status());
    Ok(Run { state: result.state, termination })
}

/// SplitMix64: a small, good-enough deterministic generator.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator whose sequence is fixed by `seed`: the same seed, the same numbers on every machine.
    pub fn new(seed: u64) -> Rng {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    /// The next 64 uniformly distributed bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [a, b).
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uniform()
    }

    /// Uniform index below n (n > 0).
    pub fn index(&mut self, n: usize) -> usize {
        (self.uniform() * n as f64) as usize % n.max(1)
    }
}
