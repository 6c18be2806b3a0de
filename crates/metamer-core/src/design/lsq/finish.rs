//! The exact active-set finish of [`super`] (bounded-variable least squares in the manner of Stark & Parker
//! 1995): its buffers, reused per thread, and its steps on the normal equations (incremental Cholesky) or on
//! A itself (QR with rows sorted by weight). See the parent module's docs for the method.

use super::kernels::{Cholesky, Qr, Status, axpy, column};
use super::*;

/// Buffers and state of the exact active-set finish (reused across its steps: no allocation per step).
pub(super) struct Work {
    pub(super) n: usize,
    /// Current point, status and free list.
    pub(super) x: Vec<f64>,
    pub(super) status: Vec<Status>,
    pub(super) is_free: Vec<bool>,
    pub(super) free: Vec<usize>,
    /// Working on A (QR, residual multipliers) rather than on `AᵀA`.
    pub(super) use_qr: bool,
    pub(super) chol: Cholesky,
    pub(super) qr: Qr,
    /// `H x_B` (the bound variables' part of Hx), kept up to date on the normal-equations path.
    pub(super) hb: Vec<f64>,
    pub(super) z: Vec<f64>,
    /// Half-gradient `Aᵀ(Ax − b)` (on the normal-equations path only at bound variables) and its rounding
    /// level; residual and `|A||x| + |b|`.
    pub(super) g: DVector<f64>,
    pub(super) noise: DVector<f64>,
    pub(super) r: DVector<f64>,
    pub(super) mag: DVector<f64>,
    pub(super) stuck: Vec<bool>,
    pub(super) newly_bound: Vec<usize>,
    /// The last free solve was by QR at the current point, so its multipliers are current.
    pub(super) qr_current: bool,
    /// Only looking for an active set (an exact QR finish follows): keep the Cholesky path even when its
    /// factor is poorly conditioned.
    pub(super) rough: bool,
    /// `‖H‖max` and `‖Aᵀb‖∞` (NaN until first needed).
    pub(super) h_max: f64,
    pub(super) atb_max: f64,
    /// What the finish built from scratch before its first step, for [`Work::polish`]: the free list, the
    /// rows of its fresh factor (row-major, `n` apart), `H x_B` and the point (its bound values). Valid
    /// only on the normal-equations path with a healthy factor (`start_valid`).
    pub(super) start_free: Vec<usize>,
    pub(super) start_l: Vec<f64>,
    pub(super) start_hb: Vec<f64>,
    pub(super) start_x: Vec<f64>,
    pub(super) start_valid: bool,
    /// The starting guess of the active set ([`Work::guess`] in `lsq/guess.rs`): the Cholesky factor of
    /// `G_BB` (`G = H⁻¹`, B the bound variables in the order bound), the bound list and the multipliers.
    pub(super) dual_chol: Cholesky,
    pub(super) bound: Vec<usize>,
    pub(super) mu: Vec<f64>,
    pub(super) zd: Vec<f64>,
}

/// Where [`Work::factor_free_set`] may take the leading rows of a factor from: row k of a factor built in
/// ascending order depends on H and the first k + 1 free variables alone.
#[derive(Clone, Copy)]
pub(super) enum Rows<'a> {
    /// Nothing: every row is looked up or built.
    None,
    /// The finish's own fresh start factor (`start_l`, for the free list `start_free`), when valid.
    Start,
    /// The factor of all of H (every variable free; `rows` of it are valid), shared by every design.
    Full(&'a [f64], usize),
}

/// The rows of the Cholesky factors of `H_FF` built from scratch (free variables added in ascending order)
/// for one H, by the set of free variables each row depends on: row k of the factor of a free list depends
/// on H and the list's first k + 1 variables alone (in ascending order, so their set names them), so the
/// designs of a batch that share H and the leading variables of a free set — not only the whole set — copy
/// those rows instead of building them again. The first [`Sets::FIRST_ROW`] rows of a factor are always
/// built (a short row costs less than its lookup, and is not worth its memory), so the free sets of at
/// most that many variables (most of those of random targets, which press on most bounds) are not looked
/// up at all. On 1200 reachable designs the factors' rows cost 5.46 M instructions (4523 rows) when only
/// whole sets were shared and 4.97 M (4435 rows, the ones found being the long ones) this way. At most
/// [`Sets::CAPACITY`] entries are kept (8 MB), and the rows are no longer looked up once fewer than a
/// quarter of the first [`Sets::TRIAL`] lookups found one (designs that share few leading variables would
/// pay for the lookups and the memory for nothing). Free sets over more than 128 variables are not shared.
/// Whether a row is copied or built changes no bit of it.
#[derive(Clone, Debug, Default)]
pub(crate) struct FreeSets(std::sync::Arc<std::sync::Mutex<Sets>>);

impl FreeSets {
    /// How many lookups found at least one row.
    #[cfg(test)]
    pub(crate) fn hits(&self) -> usize {
        self.0.lock().map_or(0, |s| s.hits)
    }
}

/// The rows held, and how often a lookup found one.
#[derive(Debug, Default)]
pub(crate) struct Sets {
    /// Where row k of a factor starts in `rows` (its k + 1 entries, left of and on the diagonal), by the
    /// bit mask of the k + 1 free variables it depends on.
    index: std::collections::HashMap<u128, u32, foldhash::fast::RandomState>,
    rows: Vec<f64>,
    lookups: usize,
    hits: usize,
}

impl Sets {
    /// Entries of `rows` at most (8 MB), the same bound as the whole factors once kept.
    const CAPACITY: usize = 1 << 20;
    const TRIAL: usize = 256;
    /// Rows before this one (k below it, k + 1 entries and about k²/2 products each) are built, not shared.
    const FIRST_ROW: usize = 8;

    fn worth_it(&self) -> bool {
        self.lookups < Self::TRIAL || 4 * self.hits >= self.lookups
    }
}

thread_local! {
    /// One [`Work`] per thread, reused by every solve on it: the batch path solves thousands of small systems
    /// and would otherwise allocate a dozen buffers for each.
    static WORK: std::cell::RefCell<Work> = std::cell::RefCell::new(Work::new(0, 0, false));
}

/// Run `f` with this thread's [`Work`] prepared for `sys` (a fresh one if it is already in use).
pub(super) fn with_work<R>(sys: &LinearSystem, use_qr: bool, f: impl FnOnce(&mut Work) -> R) -> R {
    let (m, n) = sys.a.shape();
    WORK.with(|cell| match cell.try_borrow_mut() {
        Ok(mut w) => {
            w.reset(m, n, use_qr);
            f(&mut w)
        }
        Err(_) => f(&mut Work::new(m, n, use_qr)),
    })
}

impl Work {
    pub(super) fn new(m: usize, n: usize, use_qr: bool) -> Work {
        Work {
            n,
            x: vec![0.0; n],
            status: vec![Status::Free; n],
            is_free: vec![true; n],
            free: Vec::with_capacity(n),
            use_qr,
            chol: Cholesky::new(n, !use_qr),
            qr: Qr::default(),
            hb: vec![0.0; n],
            z: Vec::with_capacity(n),
            g: DVector::zeros(n),
            noise: DVector::zeros(n),
            r: DVector::zeros(m),
            mag: DVector::zeros(m),
            stuck: vec![false; n],
            newly_bound: Vec::with_capacity(n),
            qr_current: false,
            rough: false,
            h_max: f64::NAN,
            atb_max: f64::NAN,
            start_free: Vec::with_capacity(n),
            start_l: Vec::new(),
            start_hb: Vec::with_capacity(n),
            start_x: Vec::with_capacity(n),
            start_valid: false,
            dual_chol: Cholesky::new(n, true),
            bound: Vec::with_capacity(n),
            mu: Vec::with_capacity(n),
            zd: vec![0.0; n],
        }
    }

    /// Work on A by QR (`true`) or on `AᵀA` by Cholesky (`false`) in the next [`Work::finish`].
    pub(super) fn set_path(&mut self, qr: bool) {
        self.use_qr = qr;
        self.chol.ok = !qr;
        if !qr {
            self.chol.l.resize(self.n * self.n, 0.0);
        }
    }

    /// Prepare for an m×n system, keeping the buffers' storage.
    pub(super) fn reset(&mut self, m: usize, n: usize, use_qr: bool) {
        self.n = n;
        self.x.resize(n, 0.0);
        self.status.resize(n, Status::Free);
        self.is_free.resize(n, true);
        self.free.clear();
        self.use_qr = use_qr;
        self.chol.n = n;
        self.chol.ok = !use_qr;
        if !use_qr {
            self.chol.l.resize(n * n, 0.0);
        }
        // A new matrix: the QR's row order and |A| are recomputed on first use.
        self.qr.order.clear();
        self.hb.resize(n, 0.0);
        self.z.clear();
        for v in [&mut self.g, &mut self.noise] {
            if v.len() != n {
                *v = DVector::zeros(n);
            }
        }
        for v in [&mut self.r, &mut self.mag] {
            if v.len() != m {
                *v = DVector::zeros(m);
            }
        }
        self.stuck.resize(n, false);
        self.newly_bound.clear();
        self.qr_current = false;
        self.rough = false;
        self.h_max = f64::NAN;
        self.atb_max = f64::NAN;
        self.start_valid = false;
        self.dual_chol.n = n;
        self.dual_chol.l.resize(n * n, 0.0);
        self.zd.resize(n, 0.0);
    }

    /// QR solve of the free set with the other variables at `x`, into `self.z`.
    /// The free list of the variables marked free (ascending) and, on the normal-equations path, the
    /// Cholesky factor of their block of H built from scratch: copied from `sets` when that free set was
    /// factored before (the same bits: the additions depend on H and the set alone), else built by adding
    /// the variables in ascending order (and kept in `sets` when it succeeds).
    ///
    /// With `from` a factor already built ([`Rows::Start`]: the finish's own fresh factor, for the polish;
    /// [`Rows::Full`]: the factor of all of H), the rows it shares are reused: row k of a factor built in
    /// ascending order depends on H and the first k + 1 free variables alone, so the rows of the longest
    /// common prefix of the two free lists are the same bits. When the whole set is such a prefix, the
    /// factor is copied without a lookup.
    pub(super) fn factor_free_set(&mut self, h: &DMatrix<f64>, sets: Option<&FreeSets>, from: Rows) {
        self.free.clear();
        self.free.extend((0..self.n).filter(|&i| self.is_free[i]));
        if !self.chol.ok {
            return;
        }
        let n = self.n;
        let (prefix, source) = match from {
            Rows::Start if self.start_valid => {
                (self.free.iter().zip(&self.start_free).take_while(|(a, b)| a == b).count(), &self.start_l[..])
            }
            Rows::Full(rows, valid) => {
                (self.free.iter().enumerate().take(valid).take_while(|&(k, &i)| k == i).count(), rows)
            }
            _ => (0, &[][..]),
        };
        self.chol.l[..prefix * n].copy_from_slice(&source[..prefix * n]);
        let nf = self.free.len();
        if prefix == nf {
            return;
        }
        // The rows after the copied ones that `sets` holds, looked up by the set of the variables up to
        // each (a row is held only when every row before it is, or is the source's).
        let sets = sets.filter(|_| n <= 128 && nf > Sets::FIRST_ROW);
        let mut mask = match sets {
            Some(_) => self.free[..prefix].iter().fold(0u128, |m, &i| m | 1 << i),
            None => 0,
        };
        // The short rows are built: cheaper than a lookup, and not worth their memory.
        let mut k = prefix;
        if sets.is_some() {
            while k < Sets::FIRST_ROW {
                self.chol.add(h, &self.free[..k], self.free[k]);
                mask |= 1 << self.free[k];
                k += 1;
            }
        }
        let first = k;
        if let Some(sets) = sets
            && let Ok(mut held) = sets.0.lock()
            && held.worth_it()
        {
            held.lookups += 1;
            while k < nf {
                let with = mask | 1 << self.free[k];
                let Some(&at) = held.index.get(&with) else { break };
                let at = at as usize;
                self.chol.l[k * n..k * n + k + 1].copy_from_slice(&held.rows[at..at + k + 1]);
                mask = with;
                k += 1;
            }
            held.hits += usize::from(k > first);
        }
        // The rest built without the lock (which other threads may want meanwhile), and kept in `sets`
        // when the factor succeeds (another thread may have kept the same rows meanwhile: the same bits).
        let built = k;
        for k in built..nf {
            self.chol.add(h, &self.free[..k], self.free[k]);
        }
        if let Some(sets) = sets
            && self.chol.ok
            && let Ok(mut held) = sets.0.lock()
            && held.worth_it()
        {
            let Sets { index, rows, .. } = &mut *held;
            for k in built..nf {
                if rows.len() + k + 1 > Sets::CAPACITY {
                    break;
                }
                mask |= 1 << self.free[k];
                index.entry(mask).or_insert_with(|| {
                    let at = rows.len() as u32;
                    rows.extend_from_slice(&self.chol.l[k * n..k * n + k + 1]);
                    at
                });
            }
        }
    }

    pub(super) fn qr_solve(&mut self, sys: &LinearSystem, x: &[f64]) -> bool {
        self.qr.solve(sys, x, &self.free, &self.is_free, &mut self.z)
    }

    pub(super) fn bind(&mut self, h: &DMatrix<f64>, i: usize, to: Status) {
        self.status[i] = to;
        self.is_free[i] = false;
        if let Some(k) = self.free.iter().position(|&f| f == i) {
            let nf = self.free.len();
            self.free.remove(k);
            self.chol.remove(k, nf);
        }
        if !self.use_qr && self.x[i] != 0.0 {
            axpy(self.x[i], column(h, i), &mut self.hb);
        }
    }

    pub(super) fn release(&mut self, h: &DMatrix<f64>, j: usize) {
        self.status[j] = Status::Free;
        self.is_free[j] = true;
        if !self.use_qr && self.x[j] != 0.0 {
            axpy(-self.x[j], column(h, j), &mut self.hb);
        }
        self.chol.add(h, &self.free, j);
        self.free.push(j);
    }

    /// Least squares over the free set into `self.z`: Cholesky of `H_FF` while it is healthy, else QR (for
    /// the rest of the finish). False when neither gives a finite result.
    pub(super) fn solve_free(&mut self, sys: &LinearSystem, atb: &DVector<f64>) -> bool {
        if !self.use_qr && self.chol.ok && (self.rough || self.chol.well_conditioned(self.free.len())) {
            self.z.clear();
            self.z.extend(self.free.iter().map(|&i| atb[i] - self.hb[i]));
            self.chol.solve_in_place(&mut self.z);
            if self.z.iter().all(|v| v.is_finite()) {
                return true;
            }
        }
        self.use_qr = true;
        self.chol.ok = false;
        let x = std::mem::take(&mut self.x);
        let ok = self.qr.solve(sys, &x, &self.free, &self.is_free, &mut self.z);
        self.x = x;
        ok
    }

    /// The half-gradient `g = Aᵀ(Ax − b)` at `self.x` and, per component, the level below which its sign is
    /// rounding noise. Normal equations: `g = Hx − Aᵀb`, noise `2(n+1)²ε·max(‖Aᵀb‖∞, ‖H‖max‖x‖∞)` (the worst
    /// case of the product's rounding). QR path: from the last QR solve when it is current (see [`Qr::solve`];
    /// noise `4mε·Σ|(Qᵀa_j)_i t_i|`), else from the residual with noise `8ε·(|A|ᵀ(|A||x| + |b|))ᵢ`, about the
    /// typical rounding of each component. Smaller multipliers are not trusted.
    pub(super) fn gradient(&mut self, sys: &LinearSystem, h: &DMatrix<f64>, atb: &DVector<f64>) {
        if self.h_max.is_nan() {
            // H is positive semidefinite: |H_ij| ≤ √(H_ii H_jj), so its largest entry is on the diagonal.
            self.h_max = h.diagonal().iter().fold(0.0, |m, v| m.max(v.abs()));
            self.atb_max = atb.iter().fold(0.0, |m, v| m.max(v.abs()));
        }
        if self.use_qr && self.qr_current {
            for i in 0..self.n {
                (self.g[i], self.noise[i]) =
                    if self.is_free[i] { (0.0, 0.0) } else { (self.qr.mult[i], self.qr.mult_noise[i]) };
            }
        } else if self.use_qr {
            self.qr.prepare(&sys.a);
            let x = nalgebra::DVectorView::from_slice(&self.x, self.n);
            self.r.copy_from(&sys.b);
            self.r.gemv(1.0, &*sys.a, &x, -1.0);
            self.g.gemv_tr(1.0, &*sys.a, &self.r, 0.0);
            let xabs = x.abs();
            self.mag.copy_from(&sys.b.abs());
            self.mag.gemv(1.0, &self.qr.abs_a, &xabs, 1.0);
            self.noise.gemv_tr(8.0 * f64::EPSILON, &self.qr.abs_a, &self.mag, 0.0);
        } else {
            // Only the bound variables' components are needed: g_i = (H x_B)_i + H_iF x_F − (Aᵀb)_i, with
            // `hb = H x_B` kept up to date (H is symmetric: row i is column i).
            for i in 0..self.n {
                self.g[i] = if self.is_free[i] {
                    0.0
                } else {
                    let col = column(h, i);
                    self.free.iter().fold(self.hb[i] - atb[i], |v, &k| v + col[k] * self.x[k])
                };
            }
            let n = self.n as f64;
            let level = 2.0
                * (n + 1.0)
                * (n + 1.0)
                * f64::EPSILON
                * self.atb_max.max(self.h_max * self.x.iter().fold(0.0f64, |m, v| m.max(v.abs())));
            self.noise.fill(level);
        }
    }

    /// Solve the final free set once more from a fresh Cholesky factor of `H_FF` (free variables added in
    /// ascending order, `H x_B` summed in ascending order: what [`Work::finish`] does before its first
    /// step), so that the result depends on the active set alone, not on the binds and releases (Givens
    /// deletions, appended rows) that led to it. Kept only when it is finite and inside the box (else the
    /// finish's own point stays); normal-equations path only. Returns whether it was kept.
    pub(super) fn polish(
        &mut self,
        sys: &LinearSystem,
        h: &DMatrix<f64>,
        atb: &DVector<f64>,
        sets: Option<&FreeSets>,
        from: Rows,
    ) -> bool {
        if self.use_qr {
            return false;
        }
        let (lo, hi) = (sys.lower.as_slice(), sys.upper.as_slice());
        self.chol.ok = true;
        self.chol.l.resize(self.n * self.n, 0.0);
        self.factor_free_set(h, sets, from);
        // `H x_B` as the start summed it when the bound variables and their values are the start's.
        let same_bound = matches!(from, Rows::Start)
            && self.start_valid
            && self.free == self.start_free
            && (0..self.n).all(|j| self.is_free[j] || self.x[j] == self.start_x[j]);
        if same_bound {
            self.hb.copy_from_slice(&self.start_hb);
        } else {
            self.hb.iter_mut().for_each(|v| *v = 0.0);
            for j in 0..self.n {
                if !self.is_free[j] && self.x[j] != 0.0 {
                    axpy(self.x[j], column(h, j), &mut self.hb);
                }
            }
        }
        if self.free.is_empty() {
            return true;
        }
        if !self.chol.ok {
            return false;
        }
        self.z.clear();
        self.z.extend(self.free.iter().map(|&i| atb[i] - self.hb[i]));
        self.chol.solve_in_place(&mut self.z);
        let inside = self.free.iter().zip(&self.z).all(|(&i, &v)| v.is_finite() && v >= lo[i] && v <= hi[i]);
        if inside {
            for (k, &i) in self.free.iter().enumerate() {
                self.x[i] = self.z[k];
            }
        }
        inside
    }

    /// The bound variable (not stuck, with distinct bounds) whose multiplier, from the last
    /// [`Work::gradient`], has the wrong sign by the most beyond its rounding level: the finish releases it;
    /// none means the point is optimal.
    pub(super) fn worst_multiplier(&self, lo: &[f64], hi: &[f64]) -> Option<usize> {
        let mut worst: Option<(usize, f64)> = None;
        let (g, noise) = (self.g.as_slice(), self.noise.as_slice());
        for i in 0..self.n {
            if self.stuck[i] || lo[i] == hi[i] {
                continue;
            }
            let v = match self.status[i] {
                Status::Lower => -g[i],
                Status::Upper => g[i],
                Status::Free => continue,
            };
            if v > noise[i] && worst.is_none_or(|(_, w)| v > w) {
                worst = Some((i, v));
            }
        }
        worst.map(|(i, _)| i)
    }

    /// The exact active-set finish from `x0` projected onto the box (see the module docs). Leaves the result
    /// in `self.x`; returns the number of releases (outer steps).
    pub(super) fn finish(
        &mut self,
        sys: &LinearSystem,
        h: &DMatrix<f64>,
        atb: &DVector<f64>,
        x0: &DVector<f64>,
        sets: Option<&FreeSets>,
    ) -> usize {
        let n = self.n;
        let (lo, hi) = (sys.lower.as_slice(), sys.upper.as_slice());
        self.hb.iter_mut().for_each(|v| *v = 0.0);
        self.stuck.iter_mut().for_each(|v| *v = false);
        for i in 0..n {
            let v = if x0[i].is_finite() { x0[i] } else { 0.0 };
            if v <= lo[i] {
                self.x[i] = lo[i];
                self.status[i] = Status::Lower;
                self.is_free[i] = false;
            } else if v >= hi[i] {
                self.x[i] = hi[i];
                self.status[i] = Status::Upper;
                self.is_free[i] = false;
            } else {
                self.x[i] = v;
                self.status[i] = Status::Free;
                self.is_free[i] = true;
            }
        }
        // The free variables in ascending order, and their factor (from `sets` when that set was seen).
        self.start_valid = false;
        self.factor_free_set(h, sets, Rows::None);
        if !self.use_qr {
            for j in 0..n {
                if !self.is_free[j] && self.x[j] != 0.0 {
                    axpy(self.x[j], column(h, j), &mut self.hb);
                }
            }
        }
        if !self.use_qr && self.chol.ok {
            // Kept for the polish (see `factor_free_set`).
            let nf = self.free.len();
            self.start_free.clear();
            self.start_free.extend_from_slice(&self.free);
            self.start_l.clear();
            self.start_l.extend_from_slice(&self.chol.l[..nf * n]);
            self.start_hb.clear();
            self.start_hb.extend_from_slice(&self.hb);
            self.start_x.clear();
            self.start_x.extend_from_slice(&self.x);
            self.start_valid = true;
        }
        let mut released: Option<(usize, Status)> = None;
        let max_steps = 4 * n + 20;
        let mut steps = 0;
        while steps < max_steps {
            steps += 1;
            // Inner loop: solve on the free set, walking back to the box when the solution leaves it.
            self.qr_current = false;
            for _ in 0..=2 * n {
                if self.free.is_empty() || !self.solve_free(sys, atb) {
                    break;
                }
                // A variable released a moment ago that wants straight back out on the same side: its
                // multiplier was rounding noise. Bind it again and skip it until another release succeeds.
                if let Some((j, from)) = released.take() {
                    let k = self.free.iter().position(|&f| f == j).unwrap_or(0);
                    let back = goes_back(from, self.z[k], lo[j], hi[j]);
                    if back {
                        self.stuck[j] = true;
                        self.bind(h, j, from);
                        continue;
                    }
                    self.stuck.iter_mut().for_each(|s| *s = false);
                }
                let (alpha, hit) =
                    step_to_box(self.free.iter().enumerate().map(|(k, &i)| (i, self.z[k])), &self.x, lo, hi);
                let Some(hit) = hit else {
                    for (k, &i) in self.free.iter().enumerate() {
                        self.x[i] = self.z[k];
                    }
                    self.qr_current = self.use_qr;
                    break;
                };
                self.newly_bound.clear();
                for (k, &i) in self.free.iter().enumerate() {
                    let (v, bound) = step_variable(i == hit, self.x[i], self.z[k], alpha, lo[i], hi[i]);
                    self.x[i] = v;
                    if bound.is_some() {
                        self.newly_bound.push(i);
                    }
                }
                for t in 0..self.newly_bound.len() {
                    let i = self.newly_bound[t];
                    let to = if self.x[i] == lo[i] { Status::Lower } else { Status::Upper };
                    self.bind(h, i, to);
                }
            }
            // Multipliers: the half-gradient at bound variables must point out of the box.
            self.gradient(sys, h, atb);
            let Some(j) = self.worst_multiplier(lo, hi) else { break };
            released = Some((j, self.status[j]));
            self.release(h, j);
        }
        steps
    }
}

/// The ratio test of a step from x towards z (given as `(i, z_i)` for the free variables, ascending): the
/// largest share α ∈ [0, 1] of the step that keeps every free variable in its box, and the first variable
/// to reach its bound at that share (None when the whole step stays inside). A share that is not finite
/// counts as 0. The finish and the guess of the active set take the same step.
#[inline(always)]
pub(super) fn step_to_box(
    free: impl Iterator<Item = (usize, f64)>,
    x: &[f64],
    lo: &[f64],
    hi: &[f64],
) -> (f64, Option<usize>) {
    let mut alpha: f64 = 1.0;
    let mut hit: Option<usize> = None;
    for (i, zi) in free {
        let xi = x[i];
        let a = if zi < lo[i] {
            (lo[i] - xi) / (zi - xi)
        } else if zi > hi[i] {
            (hi[i] - xi) / (zi - xi)
        } else {
            continue;
        };
        let a = if a.is_finite() { a.clamp(0.0, 1.0) } else { 0.0 };
        if hit.is_none() || a < alpha {
            alpha = a;
            hit = Some(i);
        }
    }
    (alpha, hit)
}

/// Whether a variable released from bound `from` a moment ago wants straight back out on the same side
/// (its new value z at or past that bound): its multiplier was rounding noise.
#[inline(always)]
pub(super) fn goes_back(from: Status, z: f64, lo: f64, hi: f64) -> bool {
    match from {
        Status::Lower => z <= lo,
        Status::Upper => z >= hi,
        Status::Free => false,
    }
}

/// A free variable moved the share `alpha` of its step from x towards z ([`step_to_box`]) and kept in
/// its box: its new value, and the bound it is then bound at — the variable that set the share (`hit`),
/// or one that came within 1e-14 (relative) of the bound its step passes — or None while it stays free.
#[inline(always)]
pub(super) fn step_variable(hit: bool, x: f64, z: f64, alpha: f64, lo: f64, hi: f64) -> (f64, Option<Status>) {
    let v = (x + alpha * (z - x)).max(lo).min(hi);
    if z < lo && (hit || v - lo <= 1e-14 * (1.0 + lo.abs())) {
        (lo, Some(Status::Lower))
    } else if z > hi && (hit || hi - v <= 1e-14 * (1.0 + hi.abs())) {
        (hi, Some(Status::Upper))
    } else {
        (v, None)
    }
}
