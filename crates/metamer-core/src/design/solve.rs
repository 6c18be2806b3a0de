//! The solve driver: split the design into independent blocks, solve them in parallel (rayon) — linear
//! blocks by the exact bounded least squares of [`super::lsq`], bilinear blocks by [`super::joint`] — and
//! share factorisations between blocks with identical matrices.

use super::joint::{self, JointLimits};
use super::lsq::{self, Factor};
use super::system::{Block, Design, Layout, Unit, Values};
use nalgebra::DMatrix;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// Matrices and their factorisations shared between blocks whose matrices are equal, keyed by
/// [`Design::matrix_key`] (what A is assembled from) rather than by A itself: looking a block up costs a few
/// dozen integers, not a hash of its whole matrix. A cache serves systems assembled from one [`Values`] only
/// (the key names the fixed spectra by index). The first block of a key assembles A and factors it; the
/// others assemble only their right-hand side and bounds (a batch of designs under the same lights shares
/// one A: assembling it again per design was 17 % of the batch solve's instructions).
#[derive(Default)]
pub(crate) struct FactorCache {
    map: Mutex<HashMap<Vec<u64>, Slot>>,
}

/// One matrix and its factorisation, filled by the first block that needs it.
type Slot = Arc<OnceLock<Arc<Shared>>>;

/// A matrix A shared by the blocks of one key, and its factorisation.
pub(crate) struct Shared {
    pub(crate) a: Arc<DMatrix<f64>>,
    pub(crate) factor: Factor,
}

impl FactorCache {
    /// The shared A and its factorisation for `key`, `assemble`d and factored once per key, also when
    /// several threads ask for it at once (the others wait for the first).
    pub fn get(&self, key: Vec<u64>, assemble: impl FnOnce() -> Arc<DMatrix<f64>>) -> Arc<Shared> {
        let build = |a: Arc<DMatrix<f64>>| Arc::new(Shared { factor: Factor::new(&a), a });
        let slot = match self.map.lock() {
            Ok(mut map) => map.entry(key).or_default().clone(),
            // A panic elsewhere poisoned the lock: factor without sharing.
            Err(_) => return build(assemble()),
        };
        slot.get_or_init(|| build(assemble())).clone()
    }
}

/// How one block was solved.
#[derive(Clone, Debug)]
pub struct BlockReport {
    pub(crate) units: Vec<Unit>,
    pub bilinear: bool,
    /// The block's part of the objective at the end.
    pub(crate) objective: f64,
    pub kkt: f64,
    pub(crate) bounds_active: bool,
    /// Joint blocks: objective after each accepted stage (non-increasing).
    pub history: Vec<f64>,
    pub(crate) stopped: Option<crate::optimize::Termination>,
    /// New values of the block's units.
    pub(crate) values: Vec<(Unit, Vec<f64>)>,
}

/// Solve one block starting from `v` (which holds the fixed spectra too).
pub(crate) fn solve_block(
    design: &Design,
    block: &Block,
    v: &Values,
    cache: &FactorCache,
    limits: &JointLimits,
) -> BlockReport {
    let mut report = BlockReport {
        units: block.units.clone(),
        bilinear: block.bilinear,
        objective: 0.0,
        kkt: 0.0,
        bounds_active: false,
        history: Vec::new(),
        stopped: None,
        values: Vec::new(),
    };
    if block.bilinear {
        let mut local = v.clone();
        let out = joint::solve_block(design, block, &mut local, limits);
        report.history = out.history;
        report.kkt = out.kkt;
        report.stopped = out.stopped;
        report.bounds_active = true;
        report.objective = design.block_objective(block, &local);
        report.values = block.units.iter().map(|u| (*u, local.get(*u).to_vec())).collect();
        return report;
    }
    // Linear block: no copy of the values; the block objective is ‖Ax − b‖² of its system. A and its
    // factorisation come from the cache (bit-identical for equal keys); b and the bounds are the block's.
    let layout = Layout::new(&block.units);
    let shared =
        cache.get(design.matrix_key(&layout, &block.terms), || design.linear_system(&layout, &block.terms, v).a);
    let sys = design.linear_system_with(&shared.a, &layout, &block.terms, v);
    let mut x = layout.gather(v);
    if sys.a.nrows() > 0 {
        let out = lsq::solve(&sys, &shared.factor);
        report.kkt = out.kkt;
        report.bounds_active = out.bounds_active;
        if out.x.iter().all(|x| x.is_finite()) {
            // `objective` is ‖A x − b‖² of the returned x.
            report.objective = out.objective;
            x = out.x;
        } else {
            report.objective = (&*sys.a * &x - &sys.b).norm_squared();
        }
    }
    report.values = layout.units.iter().map(|(u, o)| (*u, x.rows(*o, u.len()).iter().copied().collect())).collect();
    report
}

/// Solve every block (in parallel) and return the new values and the per-block reports.
pub fn solve_all(design: &Design, start: &Values, limits: &JointLimits, parallel: bool) -> (Values, Vec<BlockReport>) {
    let blocks = design.blocks();
    let cache = FactorCache::default();
    let reports: Vec<BlockReport> = if parallel {
        blocks.par_iter().map(|b| solve_block(design, b, start, &cache, limits)).collect()
    } else {
        blocks.iter().map(|b| solve_block(design, b, start, &cache, limits)).collect()
    };
    let mut v = start.clone();
    for r in &reports {
        for (u, x) in &r.values {
            v.set(*u, x);
        }
    }
    (v, reports)
}

/// Solve all unknowns as one dense system (no block splitting, no factor sharing): the baseline the
/// benchmarks compare blocks against. Only for designs without bilinear cells; returns None otherwise.
pub fn solve_dense(design: &Design, start: &Values) -> Option<(Values, f64)> {
    let units = design.units();
    let all: Vec<usize> = (0..design.terms.len()).collect();
    if design.terms.iter().any(|t| design.is_bilinear(t)) {
        return None;
    }
    let layout = Layout::new(&units);
    let sys = design.linear_system(&layout, &all, start);
    let out = lsq::solve_system(&sys);
    let mut v = start.clone();
    layout.scatter(&out.x, &mut v);
    Some((v, out.kkt))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::Colorimetry;
    use crate::palette::{Bounds, Palette, random};
    use nalgebra::DVector;
    use std::time::{Duration, Instant};

    /// A batch palette whose designs do not all share one matrix or one box: one cell weighs more (its
    /// design's A differs) and two reflectances have bounds of their own.
    fn mixed_batch(col: &Colorimetry) -> Palette {
        let mut p = random::reachable_batch_palette(60, 3, col);
        p.colours[4].weight = 2.0;
        p.reflectances[7].bounds = Some(Bounds { lower: 0.1, upper: 0.9 });
        p.reflectances[8].bounds = Some(Bounds { lower: 0.0, upper: 0.5 });
        p
    }

    /// The objective's parts computed on the pool (a batch has more terms than the threshold) are summed
    /// in the serial order, and a whole solve gives the same results with and without the pool.
    #[test]
    fn the_pool_changes_no_bit_of_the_objective_or_the_solution() {
        let col = Colorimetry::default();
        for p in [random::batch_palette(300, 5, &col), random::reachable_batch_palette(300, 6, &col)] {
            let design = Design::new(&p, None, &col).expect("valid");
            assert!(design.terms.len() >= 512, "the terms must reach the pool");
            let v = design.start_values();
            assert_eq!(design.objective_with(&v, true).to_bits(), design.objective_with(&v, false).to_bits());
            let options = crate::design::SolveOptions::default();
            let a = crate::design::solve_with(&p, None, &col, &options, true).expect("solved");
            let b = crate::design::solve_with(&p, None, &col, &options, false).expect("solved");
            assert_eq!(a.objective.to_bits(), b.objective.to_bits());
            assert_eq!(a.cells, b.cells);
            assert_eq!(a.diagnostics, b.diagnostics);
            let spectra = |s: &crate::design::Solution| {
                s.palette.reflectances.iter().flat_map(|e| e.spectrum.0.iter().map(|x| x.to_bits())).collect::<Vec<_>>()
            };
            assert_eq!(spectra(&a), spectra(&b));
        }
    }

    /// `then` gets the solved palette while the rest of the solution is computed, and the solution is
    /// solve_with's to the bit, with and without the pool; a `then` that panics ends the call with its panic
    /// (no wait for ever).
    #[test]
    fn solve_with_then_gives_the_solved_palette_and_the_same_solution() {
        let col = Colorimetry::default();
        let options = crate::design::SolveOptions::default();
        for p in [random::batch_palette(300, 7, &col), mixed_batch(&col)] {
            for parallel in [true, false] {
                let plain = crate::design::solve_with(&p, None, &col, &options, parallel).expect("solved");
                let (s, seen) =
                    crate::design::solve_with_then(&p, None, &col, &options, parallel, |solved| solved.clone())
                        .expect("solved");
                assert_eq!(seen, s.palette);
                assert_eq!(s.palette, plain.palette);
                assert_eq!(s.objective.to_bits(), plain.objective.to_bits());
                assert_eq!(s.kkt_residual.to_bits(), plain.kkt_residual.to_bits());
                assert_eq!(s.free, plain.free);
                assert_eq!(s.cells, plain.cells);
                assert_eq!(s.diagnostics, plain.diagnostics);
                assert!(s.seconds > 0.0 && s.seconds.is_finite());
            }
        }
        let p = random::reachable_batch_palette(300, 8, &col);
        for parallel in [true, false] {
            let panicked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                crate::design::solve_with_then(&p, None, &col, &options, parallel, |_| -> () {
                    panic!("formatting failed")
                })
            }));
            assert!(panicked.is_err());
        }
    }

    fn bits(v: &DVector<f64>) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn a_shared_matrix_is_the_bits_of_each_designs_own_assembly() {
        let col = Colorimetry::default();
        for p in [mixed_batch(&col), random::batch_palette(60, 4, &col)] {
            let design = Design::new(&p, None, &col).expect("valid");
            let v = design.start_values();
            let cache = FactorCache::default();
            let mut keys = std::collections::HashSet::new();
            for block in design.blocks() {
                let layout = Layout::new(&block.units);
                let own = design.linear_system(&layout, &block.terms, &v);
                let key = design.matrix_key(&layout, &block.terms);
                keys.insert(key.clone());
                let shared = cache.get(key, || own.a.clone());
                let sys = design.linear_system_with(&shared.a, &layout, &block.terms, &v);
                assert_eq!(sys.a.shape(), own.a.shape());
                assert!(sys.a.iter().zip(own.a.iter()).all(|(x, y)| x.to_bits() == y.to_bits()));
                assert_eq!(bits(&sys.b), bits(&own.b));
                assert_eq!(bits(&sys.lower), bits(&own.lower));
                assert_eq!(bits(&sys.upper), bits(&own.upper));
            }
            // The heavier cell's design has a matrix of its own; the others share one.
            assert_eq!(keys.len(), if p.colours[4].weight == 2.0 { 2 } else { 1 });
        }
    }

    #[test]
    fn the_batch_solve_is_each_design_solved_on_its_own_to_the_bit() {
        let col = Colorimetry::default();
        let p = mixed_batch(&col);
        let design = Design::new(&p, None, &col).expect("valid");
        let start = design.start_values();
        let limits = JointLimits::new(Instant::now() + Duration::from_secs(600), None);
        for parallel in [false, true] {
            let (values, reports) = solve_all(&design, &start, &limits, parallel);
            let mut bounded = 0;
            for (block, report) in design.blocks().iter().zip(&reports) {
                let layout = Layout::new(&block.units);
                let sys = design.linear_system(&layout, &block.terms, &start);
                let own = lsq::solve(&sys, &Factor::new(&sys.a));
                assert_eq!(bits(&layout.gather(&values)), bits(&own.x));
                assert_eq!(report.kkt.to_bits(), own.kkt.to_bits());
                bounded += own.bounds_active as usize;
            }
            assert!(bounded > 0 && bounded < reports.len(), "{bounded} of {} designs bounded", reports.len());
            // The designs with bounds of their own keep to them.
            for (i, lo, hi) in [(7, 0.1, 0.9), (8, 0.0, 0.5)] {
                assert!(values.reflectances[i].as_slice().iter().all(|&x| (lo..=hi).contains(&x)));
            }
        }
    }
}
