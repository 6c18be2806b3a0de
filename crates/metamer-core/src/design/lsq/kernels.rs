//! The kernels of the exact active-set finish in `lsq.rs`: the small dense helpers, the variable status,
//! the Cholesky factor of `H_FF` kept in step with the free list, and the Householder QR of the free
//! columns for ill-conditioned systems.

use super::*;

/// Whether the kernels marked `wide!` below take their AVX2 build: the processor has AVX2 (asked per call;
/// the standard library caches the answer) and, in tests, the portable build is not asked for on this
/// thread ([`portable`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn wide() -> bool {
    #[cfg(test)]
    if PORTABLE.with(std::cell::Cell::get) {
        return false;
    }
    std::arch::is_x86_feature_detected!("avx2")
}

#[cfg(test)]
thread_local! {
    static PORTABLE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Run `f` with the kernels' portable build on this thread (tests compare it with the AVX2 build).
#[cfg(test)]
pub(crate) fn portable<R>(f: impl FnOnce() -> R) -> R {
    PORTABLE.with(|p| p.set(true));
    let r = f();
    PORTABLE.with(|p| p.set(false));
    r
}

/// A kernel built twice from one body: for the baseline processor (SSE2: two `f64` a vector) and for AVX2
/// (four), the AVX2 build taken where the processor has it. The loops are the same source, so each entry
/// gets the same operations in the same order (no fused multiply-add: FMA is not enabled, and Rust never
/// contracts a product and a sum into one), only more entries an instruction: the same bits, fewer
/// instructions (`A x` and `A⁺b` on the batch: 5.7 M → 2.7 M). Everything the body calls must be inlined
/// into it (`#[inline(always)]`) to be built for AVX2 too.
macro_rules! wide {
    ($(#[$attr:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$attr])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn body($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2")]
            fn avx2($($arg: $ty),*) $(-> $ret)? {
                body($($arg),*)
            }
            #[cfg(target_arch = "x86_64")]
            if wide() {
                // SAFETY: the processor has AVX2 (`wide` asked it).
                return unsafe { avx2($($arg),*) };
            }
            body($($arg),*)
        }
    };
}

/// `aᵀb` with four partial sums (vectorises; the rounding is the same order as a plain sum).
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 4];
    let mut ca = a.chunks_exact(4);
    let mut cb = b.chunks_exact(4);
    for (x, y) in (&mut ca).zip(&mut cb) {
        acc[0] += x[0] * y[0];
        acc[1] += x[1] * y[1];
        acc[2] += x[2] * y[2];
        acc[3] += x[3] * y[3];
    }
    let tail: f64 = ca.remainder().iter().zip(cb.remainder()).map(|(x, y)| x * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

wide! {
/// `z = base + Σ_k μ_k G[:, bound[k]]` (G column-major with `n` rows), the products added in the order of
/// `bound`: [`axpy`] a column, in one loop built for AVX2 too.
pub(super) fn add_columns(g: &[f64], n: usize, base: &[f64], bound: &[usize], mu: &[f64], z: &mut [f64]) {
    z.copy_from_slice(base);
    for (&m, &i) in mu.iter().zip(bound) {
        for (t, v) in z.iter_mut().zip(&g[i * n..(i + 1) * n]) {
            *t += m * v;
        }
    }
}
}

/// `y += α·x`.
pub(super) fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (t, v) in y.iter_mut().zip(x) {
        *t += alpha * v;
    }
}

/// `A x` into `y`, with the bits of nalgebra's `&a * &x` (its `gemm` of a matrix by one column is a
/// `gemv`: per row, the first column's product, then each further column's product added in ascending
/// order). Four columns a pass over `y` (the same additions in the same order per row), rather than
/// nalgebra's one: about half the instructions on the batch's 40 × 31 and 31 × 40 products.
pub(crate) fn gemv(a: &DMatrix<f64>, x: &[f64], y: &mut [f64]) {
    let (m, n) = a.shape();
    assert!(x.len() == n && y.len() == m, "gemv: dimensions mismatch");
    let y = &mut y[..m];
    if n == 0 {
        y.fill(0.0);
        return;
    }
    gemv_columns(a.as_slice(), m, &x[..n], y);
}

wide! {
/// y = A x over the columns of A (column-major `s`, `m` rows) that x has entries for, in nalgebra's passes
/// over y: the first column, then four at a time, then the rest one by one. x is not empty.
fn gemv_columns(s: &[f64], m: usize, x: &[f64], y: &mut [f64]) {
    let n = x.len();
    // y of m entries, like the columns: the row loops below then index without checks and vectorise.
    let y = &mut y[..m];
    let c0 = &s[..m];
    for (t, &v) in y.iter_mut().zip(c0) {
        *t = v * x[0];
    }
    let mut j = 1;
    while j + 4 <= n {
        let (c1, c2) = (&s[j * m..(j + 1) * m], &s[(j + 1) * m..(j + 2) * m]);
        let (c3, c4) = (&s[(j + 2) * m..(j + 3) * m], &s[(j + 3) * m..(j + 4) * m]);
        let (x1, x2, x3, x4) = (x[j], x[j + 1], x[j + 2], x[j + 3]);
        for i in 0..m {
            let mut v = y[i];
            v += c1[i] * x1;
            v += c2[i] * x2;
            v += c3[i] * x3;
            v += c4[i] * x4;
            y[i] = v;
        }
        j += 4;
    }
    while j < n {
        let (c, xj) = (&s[j * m..(j + 1) * m], x[j]);
        for (t, &v) in y.iter_mut().zip(c) {
            *t += v * xj;
        }
        j += 1;
    }
}
}

/// [`gemv`] when x ends in exact zeros (a design's right-hand side is zero on its smoothness rows), with the
/// same bits: the columns after x's last nonzero entry are left out. Each would add a product `±0` to every
/// entry, which changes an entry only when it is `−0` and the product `+0`; an entry that is zero after the
/// kept columns is therefore recomputed by the whole product. A must be finite (`0·∞` is not zero).
pub(crate) fn gemv_trailing_zeros(a: &DMatrix<f64>, x: &[f64], y: &mut [f64]) {
    let (m, n) = a.shape();
    assert!(x.len() == n && y.len() == m, "gemv: dimensions mismatch");
    let t = x.iter().rposition(|&v| v != 0.0).map_or(0, |i| i + 1);
    if t == 0 || t == n {
        return gemv(a, x, y);
    }
    let y = &mut y[..m];
    // `gemv` of the first t columns (the same passes over y).
    gemv_columns(&a.as_slice()[..t * m], m, &x[..t], y);
    if y.contains(&0.0) {
        gemv(a, x, y);
    }
}

/// [`gemv_tr`] when v ends in exact zeros, with the same bits: [`dot_nalgebra`]'s whole chunks of eight
/// after v's last nonzero entry are left out (their products `±0` added to a partial sum that starts at
/// `+0` change nothing: such a sum is never `−0`), when they are followed only by zeros too. A must be
/// finite.
pub(crate) fn gemv_tr_trailing_zeros(a: &DMatrix<f64>, v: &[f64], out: &mut [f64]) {
    let (m, n) = a.shape();
    assert!(v.len() == m && out.len() == n, "gemv_tr: dimensions mismatch");
    let t = v.iter().rposition(|&x| x != 0.0).map_or(0, |i| i + 1);
    let whole = m - m % 8;
    let kept = t.div_ceil(8) * 8;
    if kept >= whole {
        return gemv_tr(a, v, out);
    }
    let s = a.as_slice();
    for (j, o) in out.iter_mut().enumerate() {
        *o = dot_nalgebra(&s[j * m..j * m + kept], &v[..kept]);
    }
}

/// `aᵀb` with the bits of nalgebra's `dot` on dynamic vectors: eight partial sums over whole chunks of
/// eight, added pairwise into the result, then the remaining products one by one.
pub(crate) fn dot_nalgebra(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "dot: dimensions mismatch");
    let mut acc = [0.0f64; 8];
    let mut ca = a.chunks_exact(8);
    let mut cb = b.chunks_exact(8);
    for (x, y) in (&mut ca).zip(&mut cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    dot_nalgebra_end(&acc, ca.remainder(), cb.remainder())
}

/// The end of nalgebra's `dot`: the eight partial sums added pairwise into the result, then the products of
/// the remainders one by one.
#[inline(always)]
fn dot_nalgebra_end(acc: &[f64; 8], a: &[f64], b: &[f64]) -> f64 {
    let mut res = 0.0;
    res += acc[0] + acc[4];
    res += acc[1] + acc[5];
    res += acc[2] + acc[6];
    res += acc[3] + acc[7];
    for (x, y) in a.iter().zip(b) {
        res += x * y;
    }
    res
}

/// `Aᵀv` into `out`, with the bits of nalgebra's `a.tr_mul(&v)` (one [`dot_nalgebra`] per column).
pub(crate) fn gemv_tr(a: &DMatrix<f64>, v: &[f64], out: &mut [f64]) {
    let (m, n) = a.shape();
    assert!(v.len() == m && out.len() == n, "gemv_tr: dimensions mismatch");
    let s = a.as_slice();
    for (j, o) in out.iter_mut().enumerate() {
        *o = dot_nalgebra(&s[j * m..(j + 1) * m], v);
    }
}

/// Which of [`dot_nalgebra`]'s chunks of eight rows hold a nonzero entry of each column of A, for
/// [`gemv_tr_zero_chunks`]: a design's A has dense colour rows over sparse smoothness rows (three entries
/// a row), so that most of a column's chunks are zero. Made once per A and shared like the rest of
/// [`Factor`].
#[derive(Clone, Debug)]
pub(crate) struct ZeroChunks {
    /// Per column, bit c set when chunk c (rows `8c..8c + 8`) holds a nonzero entry.
    chunks: Vec<u64>,
}

impl ZeroChunks {
    /// None when A is not finite (a product `0·∞` is not zero), empty, or has more than 64 chunks of eight
    /// rows.
    pub(crate) fn of(a: &DMatrix<f64>) -> Option<ZeroChunks> {
        let (m, n) = a.shape();
        if m == 0 || n == 0 || m / 8 > 64 || a.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let chunks = (0..n)
            .map(|j| {
                (0..m / 8).filter(|&c| (8 * c..8 * c + 8).any(|i| a[(i, j)] != 0.0)).fold(0u64, |mask, c| mask | 1 << c)
            })
            .collect();
        Some(ZeroChunks { chunks })
    }
}

/// [`gemv_tr`] with the chunks of eight rows where A's column (or v) is zero left out, with the same bits:
/// each of [`dot_nalgebra`]'s eight partial sums starts at `+0` and is never `−0` (a sum is `−0` only when
/// both terms are), so a chunk's products `±0` change none of them. v must be finite (else the whole
/// product is [`gemv_tr`]'s).
pub(crate) fn gemv_tr_zero_chunks(a: &DMatrix<f64>, zero_chunks: &ZeroChunks, v: &[f64], out: &mut [f64]) {
    let (m, n) = a.shape();
    assert!(v.len() == m && out.len() == n && zero_chunks.chunks.len() == n, "gemv_tr: dimensions mismatch");
    if !v.iter().all(|x| x.is_finite()) {
        return gemv_tr(a, v, out);
    }
    zero_chunk_columns(a.as_slice(), m, &zero_chunks.chunks, v, out);
}

/// The loops of [`gemv_tr_zero_chunks`] (`chunks`: [`ZeroChunks::chunks`], v finite); with AVX2, the
/// eight partial sums as two vectors of four (each lane's products and sums those of the scalar loop).
fn zero_chunk_columns(s: &[f64], m: usize, chunks: &[u64], v: &[f64], out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if wide() {
        // SAFETY: the processor has AVX2 (`wide` asked it).
        return unsafe { zero_chunk_columns_avx2(s, m, chunks, v, out) };
    }
    let whole = m - m % 8;
    let nonzero = nonzero_chunks(&v[..whole]);
    for ((o, &chunks), col) in out.iter_mut().zip(chunks).zip(s.chunks_exact(m)) {
        let mut acc = [0.0f64; 8];
        let mut left = chunks & nonzero;
        while left != 0 {
            let c = left.trailing_zeros() as usize;
            left &= left - 1;
            let (x, y) = (&col[8 * c..8 * c + 8], &v[8 * c..8 * c + 8]);
            for k in 0..8 {
                acc[k] += x[k] * y[k];
            }
        }
        *o = dot_nalgebra_end(&acc, &col[whole..], &v[whole..]);
    }
}

/// Bit c set when v's chunk c (entries `8c..8c + 8`) holds a nonzero entry.
#[inline(always)]
fn nonzero_chunks(v: &[f64]) -> u64 {
    v.chunks_exact(8).enumerate().filter(|(_, c)| c.iter().any(|&x| x != 0.0)).fold(0u64, |mask, (c, _)| mask | 1 << c)
}

/// [`zero_chunk_columns`] with AVX2: partial sums 0–3 in one vector and 4–7 in another, each lane
/// `acc += x·y` (a product, then a sum: no fused multiply-add), so the same bits as the scalar loop.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn zero_chunk_columns_avx2(s: &[f64], m: usize, chunks: &[u64], v: &[f64], out: &mut [f64]) {
    use std::arch::x86_64::{_mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_setzero_pd, _mm256_storeu_pd};
    let whole = m - m % 8;
    let nonzero = nonzero_chunks(&v[..whole]);
    for ((o, &chunks), col) in out.iter_mut().zip(chunks).zip(s.chunks_exact(m)) {
        let (mut lo, mut hi) = (_mm256_setzero_pd(), _mm256_setzero_pd());
        let mut left = chunks & nonzero;
        while left != 0 {
            let c = left.trailing_zeros() as usize;
            left &= left - 1;
            let (x, y): (&[f64; 8], &[f64; 8]) =
                match (col[8 * c..8 * c + 8].try_into(), v[8 * c..8 * c + 8].try_into()) {
                    (Ok(x), Ok(y)) => (x, y),
                    _ => unreachable!("chunks of eight"),
                };
            // SAFETY: x and y hold eight f64 each; the loads read four from each half.
            unsafe {
                lo = _mm256_add_pd(lo, _mm256_mul_pd(_mm256_loadu_pd(x.as_ptr()), _mm256_loadu_pd(y.as_ptr())));
                hi = _mm256_add_pd(
                    hi,
                    _mm256_mul_pd(_mm256_loadu_pd(x.as_ptr().add(4)), _mm256_loadu_pd(y.as_ptr().add(4))),
                );
            }
        }
        let mut acc = [0.0f64; 8];
        // SAFETY: acc holds eight f64; each store writes four.
        unsafe {
            _mm256_storeu_pd(acc.as_mut_ptr(), lo);
            _mm256_storeu_pd(acc.as_mut_ptr().add(4), hi);
        }
        *o = dot_nalgebra_end(&acc, &col[whole..], &v[whole..]);
    }
}

/// Column j of a column-major matrix as a slice.
pub(super) fn column(m: &DMatrix<f64>, j: usize) -> &[f64] {
    let r = m.nrows();
    &m.as_slice()[j * r..(j + 1) * r]
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Status {
    Free,
    Lower,
    Upper,
}

/// The Cholesky factor `L Lᵀ = H_FF` of the free variables' block of `H = AᵀA`, kept in step with the free
/// list: a released variable appends a row (one forward substitution), a bound one is deleted with Givens
/// rotations — O(n²) per change instead of a new O(n³) factorisation. `ok` turns false for good when a new
/// pivot is not clearly positive; [`Cholesky::well_conditioned`] flags `cond(H_FF) ≳ 1e12`. Either sends
/// the finish to QR.
pub(super) struct Cholesky {
    pub(super) n: usize,
    /// Row-major n×n storage of L (only the leading |free|×|free| part is used).
    pub(super) l: Vec<f64>,
    pub(super) ok: bool,
}

impl Cholesky {
    pub(super) fn new(n: usize, ok: bool) -> Cholesky {
        Cholesky { n, l: if ok { vec![0.0; n * n] } else { Vec::new() }, ok }
    }

    /// Append variable j after the free variables `free` (which do not include j).
    pub(super) fn add(&mut self, h: &DMatrix<f64>, free: &[usize], j: usize) {
        if !self.ok {
            return;
        }
        let (n, k) = (self.n, free.len());
        // Row k of L (its entries 0..=k) after the rows before it, and column j of H (`h[(free[i], j)]`).
        let (done, row) = self.l.split_at_mut(k * n);
        let row = &mut row[..=k];
        let hj = column(h, j);
        let mut yy = 0.0;
        for (i, &f) in free.iter().enumerate() {
            let li = &done[i * n..i * n + i + 1];
            let v = hj[f] - dot(&li[..i], &row[..i]);
            let y = v / li[i];
            row[i] = y;
            yy += y * y;
        }
        let d2 = hj[j] - yy;
        if d2.is_finite() && d2 > 1e-13 * hj[j].abs() && d2 > 0.0 {
            row[k] = d2.sqrt();
        } else {
            self.ok = false;
        }
    }

    /// Delete position k of a free list that had `nf` entries.
    pub(super) fn remove(&mut self, k: usize, nf: usize) {
        if !self.ok {
            return;
        }
        let n = self.n;
        for i in k..nf - 1 {
            self.l.copy_within((i + 1) * n..(i + 1) * n + i + 2, i * n);
        }
        for i in k..nf - 1 {
            let (a, b) = (self.l[i * n + i], self.l[i * n + i + 1]);
            let r = (a * a + b * b).sqrt();
            if r == 0.0 || !r.is_finite() {
                self.ok = false;
                return;
            }
            let (c, s) = (a / r, b / r);
            for row in self.l[i * n..(nf - 1) * n].chunks_exact_mut(n) {
                let (x, y) = (row[i], row[i + 1]);
                row[i] = c * x + s * y;
                row[i + 1] = -s * x + c * y;
            }
            self.l[i * n + i + 1] = 0.0;
        }
        self.l[(nf - 1) * n..nf * n].fill(0.0);
    }

    pub(super) fn well_conditioned(&self, nf: usize) -> bool {
        let n = self.n;
        let (mut dmin, mut dmax) = (f64::INFINITY, 0.0f64);
        for i in 0..nf {
            let d = self.l[i * n + i].abs();
            dmin = dmin.min(d);
            dmax = dmax.max(d);
        }
        dmin > 1e-6 * dmax
    }

    /// Solve `H_FF z = rhs` in place (rhs in the order of the free list).
    pub(super) fn solve_in_place(&self, z: &mut [f64]) {
        let (n, nf) = (self.n, z.len());
        let l = &self.l;
        for k in 0..nf {
            let row = &l[k * n..k * n + k];
            let v = z[k] - row.iter().zip(z.iter()).map(|(a, b)| a * b).sum::<f64>();
            z[k] = v / l[k * n + k];
        }
        for k in (0..nf).rev() {
            let mut v = z[k];
            for p in k + 1..nf {
                v -= l[p * n + k] * z[p];
            }
            z[k] = v / l[k * n + k];
        }
    }
}

/// Householder QR of the free columns of A for ill-conditioned systems (Powell & Reid 1969; Cox & Higham
/// 1998): rows sorted by decreasing size, so that heavy rows are eliminated first and the rounding that
/// reaches the light rows stays relative to them; column pivoting by remaining norm. A column whose
/// remaining norm falls to `4·max(m, n_F)·ε` of its own norm is numerically dependent on the pivoted ones
/// and keeps its current value (the subproblem's objective is the same: the free least squares is solved
/// over the independent columns). One step of iterative refinement on the residual follows.
#[derive(Default)]
pub(super) struct Qr {
    /// Row order (Powell–Reid sorting by the largest entry of each row).
    pub(super) order: Vec<usize>,
    /// `|A|`, for the rounding level of the multipliers.
    pub(super) abs_a: DMatrix<f64>,
    /// Column-major m × (n_F + 1) work matrix: the free columns then the right-hand side.
    pub(super) w: Vec<f64>,
    /// Right-hand side before the reflections (for the refinement).
    pub(super) rhs0: Vec<f64>,
    /// Householder β per column, R's diagonal, column permutation (positions in the free list).
    pub(super) beta: Vec<f64>,
    pub(super) rdiag: Vec<f64>,
    pub(super) perm: Vec<usize>,
    pub(super) norm0: Vec<f64>,
    pub(super) s: Vec<f64>,
    pub(super) y: Vec<f64>,
    /// Bound variables (columns after the right-hand side), the transformed residual below the pivoted rows,
    /// and the multipliers (with their rounding level) of the last solve, indexed by variable.
    pub(super) bound: Vec<usize>,
    pub(super) t: Vec<f64>,
    pub(super) mult: Vec<f64>,
    pub(super) mult_noise: Vec<f64>,
}

impl Qr {
    pub(super) fn prepare(&mut self, a: &DMatrix<f64>) {
        if !self.order.is_empty() && self.order.len() == a.nrows() && self.abs_a.shape() == a.shape() {
            return;
        }
        let m = a.nrows();
        let row_size: Vec<f64> = (0..m).map(|i| a.row(i).amax()).collect();
        self.order = (0..m).collect();
        self.order.sort_by(|&i, &j| row_size[j].total_cmp(&row_size[i]));
        self.abs_a = a.abs();
    }

    pub(super) fn swap_columns(&mut self, m: usize, c: usize, d: usize) {
        if c == d {
            return;
        }
        for i in 0..m {
            self.w.swap(c * m + i, d * m + i);
        }
        self.perm.swap(c, d);
        self.norm0.swap(c, d);
    }

    /// Apply reflectors `0..rank` to the vector `v` (length m, sorted rows).
    pub(super) fn reflect(w: &[f64], beta: &[f64], m: usize, rank: usize, v: &mut [f64]) {
        for k in 0..rank {
            let col = &w[k * m..(k + 1) * m];
            let dot: f64 = (k..m).map(|i| col[i] * v[i]).sum();
            let t = beta[k] * dot;
            if t != 0.0 {
                for i in k..m {
                    v[i] -= t * col[i];
                }
            }
        }
    }

    /// Back substitution with R's leading `rank`×`rank` block: `y = R⁻¹ c` (c = first rank entries).
    pub(super) fn back_substitute(&mut self, m: usize, rank: usize, c: &[f64]) {
        self.y.clear();
        self.y.resize(rank, 0.0);
        for k in (0..rank).rev() {
            let mut v = c[k];
            for j in k + 1..rank {
                v -= self.w[j * m + k] * self.y[j];
            }
            self.y[k] = v / self.rdiag[k];
        }
    }

    /// Least squares over `free` with the other variables held at x; writes z in the order of `free`.
    /// Returns false when the result is not finite.
    pub(super) fn solve(
        &mut self,
        sys: &LinearSystem,
        x: &[f64],
        free: &[usize],
        is_free: &[bool],
        z: &mut Vec<f64>,
    ) -> bool {
        let a = &sys.a;
        let (m, n, nf) = (a.nrows(), a.ncols(), free.len());
        self.prepare(a);
        let nb = n - nf;
        self.w.clear();
        self.w.resize(m * (nf + 1 + nb), 0.0);
        self.norm0.clear();
        for (k, &j) in free.iter().enumerate() {
            let col = a.column(j);
            let dst = &mut self.w[k * m..(k + 1) * m];
            for (d, &r) in dst.iter_mut().zip(&self.order) {
                *d = col[r];
            }
            self.norm0.push(dst.iter().map(|v| v * v).sum::<f64>().sqrt());
        }
        {
            let rhs = &mut self.w[nf * m..];
            for (d, &r) in rhs.iter_mut().zip(&self.order) {
                *d = sys.b[r];
            }
            for j in 0..n {
                if !is_free[j] && x[j] != 0.0 {
                    let col = a.column(j);
                    for (d, &r) in rhs.iter_mut().zip(&self.order) {
                        *d -= col[r] * x[j];
                    }
                }
            }
            self.rhs0.clear();
            self.rhs0.extend_from_slice(rhs);
        }
        // The bound columns after the right-hand side: the reflections carry them along for the multipliers.
        self.bound.clear();
        self.bound.extend((0..n).filter(|&j| !is_free[j]));
        for (q, &j) in self.bound.iter().enumerate() {
            let col = a.column(j);
            let dst = &mut self.w[(nf + 1 + q) * m..(nf + 2 + q) * m];
            for (d, &r) in dst.iter_mut().zip(&self.order) {
                *d = col[r];
            }
        }
        self.perm.clear();
        self.perm.extend(0..nf);
        self.beta.clear();
        self.rdiag.clear();
        let dep = 4.0 * (m.max(nf) as f64) * f64::EPSILON;
        let mut active = nf;
        let mut k = 0;
        while k < active && k < m {
            // Pivot: the largest remaining column; columns at rounding level of their own norm go last.
            let (mut p, mut pn) = (usize::MAX, -1.0);
            let mut c = k;
            while c < active {
                let rem = self.w[c * m + k..(c + 1) * m].iter().map(|v| v * v).sum::<f64>().sqrt();
                if rem.is_nan() || rem <= dep * self.norm0[c] || rem == 0.0 {
                    active -= 1;
                    self.swap_columns(m, c, active);
                    continue;
                }
                if rem > pn {
                    (p, pn) = (c, rem);
                }
                c += 1;
            }
            if p == usize::MAX {
                break;
            }
            self.swap_columns(m, k, p);
            let head = self.w[k * m + k];
            let alpha = if head >= 0.0 { -pn } else { pn };
            let v0 = head - alpha;
            self.w[k * m + k] = v0;
            // vᵀv = ‖x‖² − head² + v0² = 2‖x‖² − 2·head·alpha... computed directly for accuracy.
            let vtv: f64 = v0 * v0 + self.w[k * m + k + 1..(k + 1) * m].iter().map(|v| v * v).sum::<f64>();
            let beta = if vtv > 0.0 { 2.0 / vtv } else { 0.0 };
            self.beta.push(beta);
            self.rdiag.push(alpha);
            let (left, right) = self.w.split_at_mut((k + 1) * m);
            let vcol = &left[k * m..];
            for col in right.chunks_mut(m) {
                let dot: f64 = (k..m).map(|i| vcol[i] * col[i]).sum();
                let t = beta * dot;
                if t != 0.0 {
                    for i in k..m {
                        col[i] -= t * vcol[i];
                    }
                }
            }
            k += 1;
        }
        let rank = k;
        // Multipliers of the bound variables at the subproblem's optimum: with Qᵀ(A x − b) = (0, −t) below the
        // pivoted rows, g_j = a_jᵀ(A x − b) = −Σ_{i ≥ rank} (Qᵀa_j)_i t_i. Rows sorted by weight keep both
        // factors at the light rows' own rounding level, which the residual's heavy rows would swamp.
        self.t.clear();
        self.t.extend_from_slice(&self.w[nf * m + rank..(nf + 1) * m]);
        for d in rank..nf {
            let xd = x[free[self.perm[d]]];
            if xd != 0.0 {
                for (t, wv) in self.t.iter_mut().zip(&self.w[d * m + rank..(d + 1) * m]) {
                    *t -= wv * xd;
                }
            }
        }
        self.mult.resize(n, 0.0);
        self.mult_noise.resize(n, 0.0);
        for (q, &j) in self.bound.iter().enumerate() {
            let col = &self.w[(nf + 1 + q) * m + rank..(nf + 2 + q) * m];
            self.mult[j] = -dot(col, &self.t);
            let size: f64 = col.iter().zip(&self.t).map(|(a, b)| (a * b).abs()).sum();
            self.mult_noise[j] = 4.0 * (m as f64) * f64::EPSILON * size;
        }
        // c₁ − R₁₂ x_dependent, then back substitution.
        let mut c1: Vec<f64> = self.w[nf * m..nf * m + rank].to_vec();
        for d in rank..nf {
            let xd = x[free[self.perm[d]]];
            if xd != 0.0 {
                for (kk, ck) in c1.iter_mut().enumerate() {
                    *ck -= self.w[d * m + kk] * xd;
                }
            }
        }
        self.back_substitute(m, rank, &c1);
        z.clear();
        z.resize(nf, 0.0);
        for d in 0..nf {
            let pos = self.perm[d];
            z[pos] = if d < rank { self.y[d] } else { x[free[pos]] };
        }
        // One step of iterative refinement: s = rhs − A_F z, correction from the same factorisation.
        self.s.clear();
        self.s.extend_from_slice(&self.rhs0);
        for (k, &j) in free.iter().enumerate() {
            let col = a.column(j);
            let zk = z[k];
            if zk != 0.0 {
                for (s, &r) in self.s.iter_mut().zip(&self.order) {
                    *s -= col[r] * zk;
                }
            }
        }
        let mut s = std::mem::take(&mut self.s);
        Self::reflect(&self.w, &self.beta, m, rank, &mut s);
        c1.clear();
        c1.extend_from_slice(&s[..rank]);
        self.s = s;
        self.back_substitute(m, rank, &c1);
        for d in 0..rank {
            z[self.perm[d]] += self.y[d];
        }
        z.iter().all(|v| v.is_finite())
    }
}
