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
    /// The first key made and its matrix, found without the lock or a hash ([`FactorCache::first`]): the
    /// designs of a batch under the same lights share one key.
    first: OnceLock<(Vec<u64>, Arc<Shared>)>,
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
    /// several threads ask for it at once (the others wait for the first). The key is looked up as a slice
    /// and copied only when it is new (once per distinct matrix, not once per block).
    pub fn get(&self, key: &[u64], assemble: impl FnOnce() -> Arc<DMatrix<f64>>) -> Arc<Shared> {
        let build = |a: Arc<DMatrix<f64>>| Arc::new(Shared { factor: Factor::new(&a), a });
        let slot = match self.map.lock() {
            Ok(mut map) => match map.get(key) {
                Some(slot) => slot.clone(),
                None => map.entry(key.to_vec()).or_default().clone(),
            },
            // A panic elsewhere poisoned the lock: factor without sharing.
            Err(_) => return build(assemble()),
        };
        let shared = slot.get_or_init(|| build(assemble())).clone();
        if self.first.get().is_none() {
            // Another thread may have set it meanwhile: either way it holds a key and that key's matrix.
            let _ = self.first.set((key.to_vec(), shared.clone()));
        }
        shared
    }

    /// The shared A and its factorisation when `key` is the first key made ([`FactorCache::get`] made it):
    /// the same `Shared` as `get` gives, borrowed (no lock, no hash, no count of references changed).
    pub fn first(&self, key: &[u64]) -> Option<&Shared> {
        self.first.get().filter(|(k, _)| k[..] == *key).map(|(_, shared)| &**shared)
    }
}

thread_local! {
    /// A pool thread's buffer for [`Design::matrix_key`]: a block's key is built here and looked up in
    /// place, not in a vector of its own per block.
    static KEY: std::cell::RefCell<Vec<u64>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// How one block was solved. Its new values are written into the solution's own spectra and free colours
/// ([`solve_all`]), not kept here: a block's report holds no memory of its own but a joint block's history.
#[derive(Clone, Debug)]
pub struct BlockReport {
    /// How many of the block's units are spectra (not free colours).
    pub(crate) spectra: usize,
    pub bilinear: bool,
    /// The block's part of the objective at the end.
    pub(crate) objective: f64,
    pub kkt: f64,
    pub(crate) bounds_active: bool,
    /// Joint blocks: objective after each accepted stage (non-increasing).
    pub history: Vec<f64>,
    pub(crate) stopped: Option<crate::optimize::Termination>,
}

/// Solve one block starting from `v` (which holds the fixed spectra too), writing the new values of its
/// units into `out` (one slice per unit of `block.units`, in that order).
pub(crate) fn solve_block(
    design: &Design,
    block: &Block,
    v: &Values,
    cache: &FactorCache,
    limits: &JointLimits,
    out: &mut [&mut [f64]],
) -> BlockReport {
    let mut report = BlockReport {
        spectra: block.units.iter().filter(|u| !matches!(u, Unit::Free(_))).count(),
        bilinear: block.bilinear,
        objective: 0.0,
        kkt: 0.0,
        bounds_active: false,
        history: Vec::new(),
        stopped: None,
    };
    if block.bilinear {
        let mut local = v.clone();
        let joint = joint::solve_block(design, block, &mut local, limits);
        report.history = joint.history;
        report.kkt = joint.kkt;
        report.stopped = joint.stopped;
        report.bounds_active = true;
        report.objective = design.block_objective(block, &local);
        for (u, to) in block.units.iter().zip(out.iter_mut()) {
            put(to, local.get(*u));
        }
        return report;
    }
    // Linear block: no copy of the values; the block objective is ‖Ax − b‖² of its system. A and its
    // factorisation come from the cache (bit-identical for equal keys); b and the bounds are the block's.
    let layout = Layout::new(&block.units);
    let held;
    let shared: &Shared =
        match KEY.with(|key| match key.try_borrow_mut() {
            Ok(mut key) => {
                design.matrix_key_into(&layout, &block.terms, &mut key);
                cache.first(&key).ok_or_else(|| cache.get(&key, || design.linear_system(&layout, &block.terms, v).a))
            }
            Err(_) => Err(cache
                .get(&design.matrix_key(&layout, &block.terms), || design.linear_system(&layout, &block.terms, v).a)),
        }) {
            Ok(first) => first,
            Err(got) => {
                held = got;
                &held
            }
        };
    let sys = design.linear_system_with(&shared.a, &layout, &block.terms, v);
    let solved = if sys.a.nrows() > 0 {
        let solved = lsq::solve(&sys, &shared.factor);
        report.kkt = solved.kkt;
        report.bounds_active = solved.bounds_active;
        if solved.x.iter().all(|x| x.is_finite()) {
            // `objective` is ‖A x − b‖² of the returned x.
            report.objective = solved.objective;
            Some(solved.x)
        } else {
            report.objective = (&*sys.a * layout.gather(v) - &sys.b).norm_squared();
            None
        }
    } else {
        None
    };
    // Units not solved keep their start values.
    for ((u, o), to) in layout.units.iter().zip(out.iter_mut()) {
        match &solved {
            Some(x) => put(to, x.rows(*o, u.len()).as_slice()),
            None => put(to, v.get(*u)),
        }
    }
    report
}

/// Copy a unit's values into its place (of the same length; a scratch slice of another length, which
/// cannot be handed out, takes nothing).
fn put(to: &mut [f64], from: &[f64]) {
    if to.len() == from.len() {
        to.copy_from_slice(from);
    }
}

/// Solve every block (in parallel) and return the new values and the per-block reports.
pub fn solve_all(design: &Design, start: &Values, limits: &JointLimits, parallel: bool) -> (Values, Vec<BlockReport>) {
    let mut v = start.clone();
    let reports = solve_all_into(design, &design.blocks(), start, &mut v, limits, parallel);
    (v, reports)
}

/// [`solve_all`] of the design's `blocks` ([`Design::blocks`]) writing the new values into `v` (a copy of
/// `start`): each block writes its units' values straight into their place in `v` (the blocks' units are
/// disjoint), so a block allocates nothing that outlives it, and the per-block reports are collected into
/// one vector sized up front.
pub(crate) fn solve_all_into(
    design: &Design,
    blocks: &[Block],
    start: &Values,
    v: &mut Values,
    limits: &JointLimits,
    parallel: bool,
) -> Vec<BlockReport> {
    let cache = FactorCache::default();
    // Every unit's values in `v`, by kind and index, handed out once each to the block that holds it, in
    // the blocks' order.
    let (nl, nr) = (v.lights.len(), v.reflectances.len());
    let mut places: Vec<Option<&mut [f64]>> = v
        .lights
        .iter_mut()
        .map(|s| s.0.as_mut_slice())
        .chain(v.reflectances.iter_mut().map(|s| s.0.as_mut_slice()))
        .chain(v.free.iter_mut().map(|f| f.as_mut_slice()))
        .map(Some)
        .collect();
    let index = |u: &Unit| match *u {
        Unit::Light(i) => i,
        Unit::Reflectance(i) => nl + i,
        Unit::Free(g) => nl + nr + g,
    };
    let mut outs: Vec<&mut [f64]> = Vec::with_capacity(blocks.iter().map(|b| b.units.len()).sum());
    for b in blocks {
        // A unit is in one block only (the blocks are the connected components of the units); a unit
        // listed again would get a scratch slice that no one reads.
        outs.extend(b.units.iter().map(|u| places.get_mut(index(u)).and_then(Option::take).unwrap_or_default()));
    }
    let mut per_block: Vec<&mut [&mut [f64]]> = Vec::with_capacity(blocks.len());
    let mut rest = &mut outs[..];
    for b in blocks {
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(b.units.len());
        per_block.push(head);
        rest = tail;
    }
    if parallel {
        blocks
            .par_iter()
            .zip(per_block.into_par_iter())
            .map(|(b, out)| solve_block(design, b, start, &cache, limits, out))
            .collect()
    } else {
        blocks.iter().zip(per_block).map(|(b, out)| solve_block(design, b, start, &cache, limits, out)).collect()
    }
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

    /// A palette built in memory with a number too large and a cell the design refuses: the solve returns
    /// the scale check's error, on the pool (where the check runs beside the terms' building) as without it.
    #[test]
    fn the_scale_checks_error_comes_first_with_and_without_the_pool() {
        let col = Colorimetry::default();
        let mut p = random::batch_palette(30, 10, &col);
        p.colours[5].weight = 1e300;
        p.colours[7].target = nalgebra::Vector3::new(f64::NAN, 0.0, 0.0);
        let options = crate::design::SolveOptions::default();
        for parallel in [true, false] {
            match crate::design::solve_with(&p, None, &col, &options, parallel) {
                Err(crate::design::DesignError::Invalid(e)) => {
                    assert!(e.starts_with("colours[5].weight"), "{e}")
                }
                other => panic!("expected the scale error, got {:?}", other.map(|s| s.objective)),
            }
        }
        // With the number in range, the building's own error is the one returned.
        p.colours[5].weight = 1.0;
        for parallel in [true, false] {
            match crate::design::solve_with(&p, None, &col, &options, parallel) {
                Err(crate::design::DesignError::Invalid(e)) => assert!(e.contains("colours[7]"), "{e}"),
                other => panic!("expected the design's error, got {:?}", other.map(|s| s.objective)),
            }
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
                let shared = cache.get(&key, || own.a.clone());
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
