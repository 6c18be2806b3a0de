//! Several samples of one ray at once (x86-64 with AVX2, detected at run time): the value loop
//! (`march.rs`) takes the next [`LANES`] samples of its ray in one batch — positions, where they fall
//! (cell and fractions), the cell's eight voxels, the trilinear value and its bin — and then consumes
//! them one by one with its scalar logic (brick table, refinement test, compositing, termination). A
//! batch cut short by a skipped brick or by termination wastes its tail.
//!
//! Every lane does the scalar path's operations in its order and precision (f64 positions, no fused
//! multiply-add, the same clamps and truncations), so the frames are bit for bit those of the portable
//! path (`tests.rs` compares them on every voxel type).
//!
//! The time a profile puts on the instruction after a batch's first voxel gather and after [`shade`]'s
//! first gradient read is the reads' own latency, not a wait on memory: a cache simulation of the
//! engine CT at 384² (step 0.5, one thread; 48 KiB first level, 2 MiB second) found about 5 first-level
//! misses per [`shade`] call (then made of gathers) and 0.1 beyond the second level, and hiding them
//! does not pay. [`shade`] reads its gradient corners lane by lane for the lanes it shades (4.66 a call on
//! that scene, of which 4.30 are then composited) rather than by sixteen gathers for all eight lanes:
//! 0.91–0.93 of the raycast's time (docs/render_performance.md). Tried and not
//! kept (the same frames; CPU time of the whole render, one thread, paired): prefetching the next
//! batch's voxel rows when a batch is filled, 0.992 (the profile's weight moves off the gather, the time
//! stays); prefetching the next batch's gradient corners in its block at the end of [`shade`], 1.006
//! (and 1.04 in raycast time with every corner of four samples); filling and classifying the next batch
//! as soon as a batch is taken, so that its gathers are issued before this batch is consumed, 1.06 (6 %
//! more instructions: batches cut short by skipped bricks waste the batch ahead); the cell index's two
//! products side by side instead of chained, 0.982 to 0.994 over four runs (36 of 61 pairs faster in
//! the largest): within the noise; the four pair gathers as eight scalar 32-bit reads each (the same
//! bytes), 0.98–0.99 on the engine CT and 0.97–0.99 on the large u16 volume: within the noise too.
//!
//! Lanes across rays instead of along one (packets of eight neighbouring rays in lockstep, one ray a
//! lane, each lane doing its ray's operations: the same frames) were built and measured, and did not pay:
//! interleaving rays mixes their branch histories and adds the lanes' bookkeeping, while the samples of
//! one ray already overlap in the processor. `docs/render_performance.md` has the figures; the prototype
//! is in the history ("raycast packets prototype").

use super::block::{FIELD_BRICK, S, S3, SHIFT};
use super::classify::{Classifier, LUT_BINS};
use super::fields::CORNERS;
use super::march::Grid;
use super::view::View;
use crate::volume::{ScalarType, Voxel};
use std::arch::x86_64::*;

/// `a + t·(b − a)` in eight lanes, multiplied then added (the scalar lerps' operations). A macro, not
/// a closure: a closure does not take its function's target features, so its intrinsics were calls.
macro_rules! lerp {
    ($a:expr, $b:expr, $t:expr) => {{
        let a = $a;
        _mm256_add_ps(a, _mm256_mul_ps($t, _mm256_sub_ps($b, a)))
    }};
}

/// Samples per batch.
pub(super) const LANES: usize = 8;

/// Up to [`LANES`] consecutive samples of one ray: steps `k0 .. k0 + LANES`.
pub(super) struct Batch {
    /// The step of the first lane (NaN: no batch yet).
    pub(super) k0: f64,
    /// Per lane, the first voxel of the sample's trilinear cell.
    pub(super) b: [u32; LANES],
    /// Per axis and lane, the cell's first voxel.
    pub(super) i: [[u32; LANES]; 3],
    /// Per axis and lane, the sample's fraction in its cell.
    pub(super) f: [[f32; LANES]; 3],
    /// Per lane, the skipping brick of the sample's cell (x-fastest index; 0 without bricks).
    pub(super) brick: [u32; LANES],
    /// Per lane, the classifier's bin of the trilinear value, once `classified` ([`classify`]).
    pub(super) bin: [u32; LANES],
    pub(super) classified: bool,
    /// Per lane, the shading of the smooth gradient ([`shade`]), where bit `lane` of `shaded` is set.
    pub(super) shade: [f32; LANES],
    pub(super) shaded: u32,
}

impl Default for Batch {
    fn default() -> Batch {
        Batch {
            k0: f64::NAN,
            b: [0; LANES],
            i: [[0; LANES]; 3],
            f: [[0.0; LANES]; 3],
            brick: [0; LANES],
            bin: [0; LANES],
            classified: false,
            shade: [0.0; LANES],
            shaded: 0,
        }
    }
}

impl Batch {
    /// The lane of step `k`, or None when the batch does not hold it.
    #[inline(always)]
    pub(super) fn lane(&self, k: f64) -> Option<usize> {
        // Steps are whole numbers, so the difference is exact (NaN when there is no batch: None).
        let j = k - self.k0;
        // SAFETY: j is a whole number in [0, LANES) when the comparison holds.
        (j >= 0.0 && j < LANES as f64).then(|| unsafe { j.to_int_unchecked::<u32>() } as usize)
    }
}

/// Whether the lanes can take samples of a volume of `bytes` bytes of voxels and `dims`: the gathers
/// index the voxels with signed 32-bit offsets (scaled by the voxel's size), and cells are indexed in
/// 32 bits (with room for a cell's strides).
pub(super) fn fits(bytes: usize, dims: [usize; 3]) -> bool {
    let limit = i32::MAX as usize / 8;
    bytes < limit && dims.iter().all(|&d| d < limit)
}

/// Whether this processor has AVX2 (asked once per raycast; the answer is cached by the standard library).
pub(super) fn detected() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// The ray as the lanes read it.
pub(super) struct RayLanes {
    pub(super) origin: [f64; 3],
    pub(super) dir: [f64; 3],
    pub(super) jitter: f64,
}

/// Fill `batch` with the samples at steps `k .. k + LANES` of `ray` (samples past the ray's end are
/// taken too, clamped into the volume like any other: the caller stops at the end): where they fall
/// and, with `bricks` (the skipping bricks' shift and counts), their bricks. Not yet classified.
#[target_feature(enable = "avx2")]
#[inline(never)]
pub(super) fn fill(
    batch: &mut Batch,
    grid: &Grid,
    dims: [usize; 3],
    bricks: Option<(u32, [usize; 3])>,
    ray: &RayLanes,
    k: f64,
) {
    batch.k0 = k;
    batch.shaded = 0;
    batch.classified = false;
    let zero = _mm256_setzero_pd();
    let mut cell = [_mm_setzero_si128(); 6];
    let mut frac = [_mm_setzero_ps(); 6];
    for h in 0..2 {
        let k4 = k + (4 * h) as f64;
        // Whole steps: k + j is exact, as the scalar loop's k += 1.
        let t = _mm256_add_pd(_mm256_set_pd(k4 + 3.0, k4 + 2.0, k4 + 1.0, k4), _mm256_set1_pd(ray.jitter));
        for a in 0..3 {
            // origin + t·dir, multiplied then added (as the scalar path: no fused multiply-add).
            let p = _mm256_add_pd(_mm256_set1_pd(ray.origin[a]), _mm256_mul_pd(t, _mm256_set1_pd(ray.dir[a])));
            // max(p, 0) is `p > 0 ? p : 0` (NaN to 0), min(q, hi) is `q < hi ? q : hi`: the scalar
            // locate's comparisons.
            let q = _mm256_min_pd(_mm256_max_pd(p, zero), _mm256_set1_pd(grid.hi[a]));
            // In [0, dims − 2] and dims < 2³¹ ([`fits`]): the truncation is in range for i32.
            let ti = _mm256_cvttpd_epi32(_mm256_min_pd(q, _mm256_set1_pd(grid.imax[a])));
            frac[2 * a + h] = _mm256_cvtpd_ps(_mm256_sub_pd(q, _mm256_cvtepi32_pd(ti)));
            cell[2 * a + h] = ti;
        }
    }
    let mut i = [_mm256_setzero_si256(); 3];
    let mut f = [_mm256_setzero_ps(); 3];
    for a in 0..3 {
        i[a] = _mm256_set_m128i(cell[2 * a + 1], cell[2 * a]);
        f[a] = _mm256_set_m128(frac[2 * a + 1], frac[2 * a]);
    }
    // The cell's first voxel i0 + d0·(i1 + d1·i2): below the voxel count < 2³¹ ([`fits`]).
    let d0 = _mm256_set1_epi32(dims[0] as i32);
    let d1 = _mm256_set1_epi32(dims[1] as i32);
    let b = _mm256_add_epi32(i[0], _mm256_mullo_epi32(d0, _mm256_add_epi32(i[1], _mm256_mullo_epi32(d1, i[2]))));
    // SAFETY (the stores): each destination holds eight 32-bit lanes, the bytes an unaligned store writes.
    unsafe {
        _mm256_storeu_si256(batch.b.as_mut_ptr().cast(), b);
        for a in 0..3 {
            _mm256_storeu_si256(batch.i[a].as_mut_ptr().cast(), i[a]);
            _mm256_storeu_ps(batch.f[a].as_mut_ptr(), f[a]);
        }
    }
    if let Some((shift, counts)) = bricks {
        // The brick of each cell (its start over the brick edge; a cell starts at most at dims − 2, so
        // below the counts), x fastest: below the voxel count.
        let sh = _mm_cvtsi32_si128(shift as i32);
        let (bx, by, bz) = (_mm256_srl_epi32(i[0], sh), _mm256_srl_epi32(i[1], sh), _mm256_srl_epi32(i[2], sh));
        let (c0, c1) = (_mm256_set1_epi32(counts[0] as i32), _mm256_set1_epi32(counts[1] as i32));
        let bi = _mm256_add_epi32(bx, _mm256_mullo_epi32(c0, _mm256_add_epi32(by, _mm256_mullo_epi32(c1, bz))));
        // SAFETY: `batch.brick` holds eight u32, the bytes an unaligned store writes.
        unsafe { _mm256_storeu_si256(batch.brick.as_mut_ptr().cast(), bi) };
    }
}

/// The trilinear value's bin of every sample of a [`fill`]ed `batch` (`classifier`'s bins), from the
/// voxels `data` of the grid it was filled on ([`fits`] true for it).
#[target_feature(enable = "avx2")]
#[inline(never)]
pub(super) fn classify<T: Voxel>(batch: &mut Batch, grid: &Grid, classifier: &Classifier, data: &[T]) {
    batch.classified = true;
    let mut f = [_mm256_setzero_ps(); 3];
    // SAFETY (the loads): each source holds eight 32-bit lanes, the bytes an unaligned load reads.
    let b = unsafe { _mm256_loadu_si256(batch.b.as_ptr().cast()) };
    for (fa, src) in f.iter_mut().zip(&batch.f) {
        *fa = unsafe { _mm256_loadu_ps(src.as_ptr()) };
    }
    let [sx, sy, sz] = grid.strides;
    let offsets = [0, sx, sy, sy + sx, sz, sz + sx, sz + sy, sz + sy + sx];
    let last = offsets[7];
    // Every lane's cell lies inside the voxels: its last voxel is below their count. The cell start is
    // clamped to dims − 2 (0 along an axis of one voxel) on every axis, so this holds; checked once per
    // batch since the gathers below read without bounds checks.
    let high = batch.b.iter().fold(0, |m, &x| m.max(x)) as usize;
    assert!(high + last < data.len(), "cell {high} past the voxels");
    // An integer voxel is read as the 32-bit word that ends with it (the gathers read 32-bit words), its
    // bytes then shifted down: that word starts 4 − size bytes before the voxel, which must lie inside
    // the voxels, so the lowest cell start must be at least that many voxels in.
    let size = std::mem::size_of::<T>();
    let before = (4 - size).div_ceil(size);
    let low = batch.b.iter().fold(u32::MAX, |m, &x| m.min(x)) as usize;
    let mut v = [_mm256_setzero_ps(); 8];
    // One- and two-byte voxels along x (stride 1): a cell's two voxels along x lie in the 32-bit word that
    // starts at the first of them, so four gathers read the eight corners (half the gathers). The word of
    // the last pair ends `4 − size` bytes past that pair's first voxel, which must lie inside the voxels.
    let pairs = size <= 2 && sx == 1 && (high + sz + sy) * size + 4 <= std::mem::size_of_val(data);
    if pairs {
        let p = data.as_ptr().cast::<u8>();
        for (c, o) in [0, sy, sz, sz + sy].into_iter().enumerate() {
            let idx = _mm256_add_epi32(b, _mm256_set1_epi32(o as i32));
            // SAFETY: every lane's pair starts at voxel b + o ≤ high + sz + sy, and its word's 4 bytes end
            // inside `data` (checked above); the byte offset fits i32 ([`fits`]).
            let w = unsafe {
                if size == 1 {
                    _mm256_i32gather_epi32::<1>(p.cast(), idx)
                } else {
                    _mm256_i32gather_epi32::<2>(p.cast(), idx)
                }
            };
            // The pair's first voxel in the word's low bytes, its second in the next (little-endian),
            // sign- or zero-extended as the voxel type is.
            let (first, second) = match T::TYPE {
                ScalarType::U8 => (
                    _mm256_and_si256(w, _mm256_set1_epi32(0xff)),
                    _mm256_and_si256(_mm256_srli_epi32::<8>(w), _mm256_set1_epi32(0xff)),
                ),
                ScalarType::I8 => (
                    _mm256_srai_epi32::<24>(_mm256_slli_epi32::<24>(w)),
                    _mm256_srai_epi32::<24>(_mm256_slli_epi32::<16>(w)),
                ),
                ScalarType::U16 => (_mm256_and_si256(w, _mm256_set1_epi32(0xffff)), _mm256_srli_epi32::<16>(w)),
                _ => {
                    debug_assert!(T::TYPE == ScalarType::I16);
                    (_mm256_srai_epi32::<16>(_mm256_slli_epi32::<16>(w)), _mm256_srai_epi32::<16>(w))
                }
            };
            v[2 * c] = _mm256_cvtepi32_ps(first);
            v[2 * c + 1] = _mm256_cvtepi32_ps(second);
        }
    } else if low < before {
        // Near the first voxel: the portable reads.
        let mut r = [0f32; LANES];
        for (c, o) in offsets.iter().enumerate() {
            for (l, &bl) in batch.b.iter().enumerate() {
                r[l] = data[bl as usize + o].to_f32();
            }
            // SAFETY: `r` holds eight f32, the bytes an unaligned load reads.
            v[c] = unsafe { _mm256_loadu_ps(r.as_ptr()) };
        }
    } else {
        let p = data.as_ptr().cast::<u8>();
        for (c, o) in offsets.iter().enumerate() {
            let idx = _mm256_add_epi32(b, _mm256_set1_epi32(*o as i32));
            // SAFETY: every lane's voxel index b + o lies in [low, high + last], inside `data` (checked
            // above), and its byte offset fits i32 ([`fits`]). Integer voxels: the word read spans the
            // 4 − size bytes before the voxel and the voxel itself, all inside `data` since b ≥ before;
            // the base pointer is formed with wrapping arithmetic and only dereferenced in bounds.
            v[c] = unsafe {
                match size {
                    1 => {
                        let w = _mm256_i32gather_epi32::<1>(p.wrapping_sub(3).cast(), idx);
                        let w = if T::TYPE == ScalarType::I8 {
                            _mm256_srai_epi32::<24>(w)
                        } else {
                            _mm256_srli_epi32::<24>(w)
                        };
                        _mm256_cvtepi32_ps(w)
                    }
                    2 => {
                        let w = _mm256_i32gather_epi32::<2>(p.wrapping_sub(2).cast(), idx);
                        let w = if T::TYPE == ScalarType::I16 {
                            _mm256_srai_epi32::<16>(w)
                        } else {
                            _mm256_srli_epi32::<16>(w)
                        };
                        _mm256_cvtepi32_ps(w)
                    }
                    _ => {
                        debug_assert!(T::TYPE == ScalarType::F32);
                        _mm256_i32gather_ps::<4>(p.cast(), idx)
                    }
                }
            };
        }
    }
    // Cell::value's lerps, in its order.
    let c00 = lerp!(v[0], v[1], f[0]);
    let c10 = lerp!(v[2], v[3], f[0]);
    let c01 = lerp!(v[4], v[5], f[0]);
    let c11 = lerp!(v[6], v[7], f[0]);
    let c0 = lerp!(c00, c10, f[1]);
    let c1 = lerp!(c01, c11, f[1]);
    let value = lerp!(c0, c1, f[2]);
    // Classifier::bin: ((v − lo)·inv_bin + 0.5), max with 0 (NaN to 0), min with the last bin, truncated.
    let x = _mm256_add_ps(
        _mm256_mul_ps(_mm256_sub_ps(value, _mm256_set1_ps(classifier.lo)), _mm256_set1_ps(classifier.inv_bin)),
        _mm256_set1_ps(0.5),
    );
    let x = _mm256_min_ps(_mm256_max_ps(x, _mm256_setzero_ps()), _mm256_set1_ps((LUT_BINS - 1) as f32));
    // SAFETY: `batch.bin` holds eight u32, the bytes an unaligned store writes.
    unsafe { _mm256_storeu_si256(batch.bin.as_mut_ptr().cast(), _mm256_cvttps_epi32(x)) };
}

/// Shade the lanes from `from` on whose cells lie in the field brick of lane `from`'s (block entries
/// `grad`, lane `from`'s cell at local index `base`), as `RayContext::shade` of `Fields::gradient` does
/// one sample: the gradient's eight corners, seven lerps per component along x, then y, then z, times
/// `scale`, then the headlight or key light term with `ambient`. Sets those lanes' bits of
/// `batch.shaded`.
///
/// The gradient is interpolated lane by lane, only for the lanes shaded (about four a call on the engine
/// CT), its three components side by side in one register: per lane four pairs of 64-bit reads (each a
/// corner's triple and one component more, x-neighbours in one register's halves, the z-neighbours' rows
/// in the other), then the lerps on both halves at once. The eight lanes' gradients are then turned into
/// one register per component for the light term. The same operations on each component as eight lanes
/// of gathered corners did (a lerp is `a + t·(b − a)` either way), so the same shades; sixteen gathers of
/// four 64-bit words each for every call, whatever the lanes shaded, cost more.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn shade(
    batch: &mut Batch,
    from: usize,
    grad: &[[i16; 3]],
    base: usize,
    scale: f32,
    view: &View,
    ambient: f32,
) {
    // A cell starts at most at dims − 2 on each axis, so its field brick is its start over the brick edge
    // (`Fields::brick_of`'s clamp never applies) and its place in the brick the start's low bits.
    let mut local = _mm256_setzero_si256();
    // Lanes in lane `from`'s brick: the same start over the brick edge on every axis.
    let mut same = _mm256_set1_epi32(-1);
    for a in (0..3).rev() {
        // SAFETY: `batch.i[a]` holds eight 32-bit lanes, the bytes an unaligned load reads.
        let i = unsafe { _mm256_loadu_si256(batch.i[a].as_ptr().cast()) };
        let l = _mm256_and_si256(i, _mm256_set1_epi32(FIELD_BRICK as i32 - 1));
        local = _mm256_add_epi32(l, _mm256_mullo_epi32(_mm256_set1_epi32(S as i32), local));
        let brick = _mm256_srli_epi32::<{ SHIFT as i32 }>(i);
        let mine = _mm256_set1_epi32((batch.i[a][from] >> SHIFT) as i32);
        same = _mm256_and_si256(same, _mm256_cmpeq_epi32(brick, mine));
    }
    debug_assert_eq!(base, (0..3).rev().fold(0, |acc, a| acc * S + (batch.i[a][from] as usize % FIELD_BRICK)));
    let lanes = (_mm256_movemask_ps(_mm256_castsi256_ps(same)) as u32) & !((1u32 << from) - 1);
    // Each lane's cell at local index l0 + S·(l1 + S·l2) with every l ≤ S − 2: its last corner at most
    // S3 − 1, whose 64-bit word reaches the first component of the entry after it, the padding entry.
    assert!(grad.len() > S3, "a value block ends with its padding entry");
    let flat = grad.as_flattened().as_ptr();
    // In i16 units: entry `local` times 3.
    let mut first = [0u32; LANES];
    // SAFETY: `first` holds eight u32, the bytes an unaligned store writes.
    unsafe { _mm256_storeu_si256(first.as_mut_ptr().cast(), _mm256_mullo_epi32(local, _mm256_set1_epi32(3))) };
    // Per lane the interpolated gradient (x, y, z and a discarded fourth lane); lanes not shaded stay 0
    // and are blended away below.
    let mut rows = [0f32; 4 * LANES];
    let mut todo = lanes;
    while todo != 0 {
        let l = todo.trailing_zeros() as usize;
        todo &= todo - 1;
        // The 64-bit word at i16 offset `o` of the lane's cell, as four i16 in an xmm's low half.
        // SAFETY: every shaded lane's cell starts at a local index whose corners are at most S3 − 1
        // (above), so the eight bytes at each corner's 2-byte offset end at most at the padding entry's
        // first component, inside `grad` (asserted above). x86-64 reads unaligned words.
        let p = unsafe { flat.add(first[l] as usize) };
        let word = |o: usize| unsafe { p.add(o).cast::<i64>().read_unaligned() };
        // Two corners' words (the second in the high half) widened to eight f32: corner triples and
        // one component of the next entry, whose lane is carried along and discarded.
        macro_rules! pair {
            ($lo:expr, $hi:expr) => {
                _mm256_cvtepi32_ps(_mm256_cvtepi16_epi32(_mm_set_epi64x(word($hi), word($lo))))
            };
        }
        // Corners x + 2y + 4z at offsets CORNERS (times 3 components): the y = 0 rows (z = 0 | z = 1) and
        // the y = 1 rows, their first corner and its x-neighbour.
        let (z, y, x) = (3 * CORNERS[4], 3 * CORNERS[2], 3 * CORNERS[1]);
        let y0a = pair!(0, z);
        let y0b = pair!(x, z + x);
        let y1a = pair!(y, z + y);
        let y1b = pair!(y + x, z + y + x);
        let fx = _mm256_set1_ps(batch.f[0][l]);
        let fy = _mm256_set1_ps(batch.f[1][l]);
        let fz = _mm_set1_ps(batch.f[2][l]);
        // Along x: corners 0|4 to 1|5 and 2|6 to 3|7; along y: [c0 | c1]; along z: c0 to c1.
        let c = lerp!(lerp!(y0a, y0b, fx), lerp!(y1a, y1b, fx), fy);
        let (c0, c1) = (_mm256_castps256_ps128(c), _mm256_extractf128_ps::<1>(c));
        let g = _mm_add_ps(c0, _mm_mul_ps(fz, _mm_sub_ps(c1, c0)));
        // SAFETY: l < LANES, so the four f32 at 4·l lie inside `rows`.
        unsafe { _mm_storeu_ps(rows.as_mut_ptr().add(4 * l), g) };
    }
    // Rows of four (lanes l and l + 4 in one register's halves) transposed to one register per component.
    // (A macro, not a closure: a closure does not take this function's target features.)
    macro_rules! row {
        ($l:expr) => {
            // SAFETY: l + 4 < LANES, so both loads read four f32 inside `rows`.
            unsafe {
                _mm256_set_m128(_mm_loadu_ps(rows.as_ptr().add(4 * $l + 16)), _mm_loadu_ps(rows.as_ptr().add(4 * $l)))
            }
        };
    }
    let (r0, r1, r2, r3) = (row!(0), row!(1), row!(2), row!(3));
    let (u0, u1) = (_mm256_unpacklo_ps(r0, r1), _mm256_unpackhi_ps(r0, r1));
    let (u2, u3) = (_mm256_unpacklo_ps(r2, r3), _mm256_unpackhi_ps(r2, r3));
    let s = _mm256_set1_ps(scale);
    let g = [
        _mm256_mul_ps(_mm256_shuffle_ps::<0b01_00_01_00>(u0, u2), s),
        _mm256_mul_ps(_mm256_shuffle_ps::<0b11_10_11_10>(u0, u2), s),
        _mm256_mul_ps(_mm256_shuffle_ps::<0b01_00_01_00>(u1, u3), s),
    ];
    // RayContext::shade: sums of three products, left to right.
    macro_rules! dot {
        ($w:expr, $x:expr, $y:expr, $z:expr) => {{
            let w = $w;
            let (x, y) = (_mm256_mul_ps($x, _mm256_set1_ps(w[0])), _mm256_mul_ps($y, _mm256_set1_ps(w[1])));
            _mm256_add_ps(_mm256_add_ps(x, y), _mm256_mul_ps($z, _mm256_set1_ps(w[2])))
        }};
    }
    let n2 = dot!(view.inv_spacing2, _mm256_mul_ps(g[0], g[0]), _mm256_mul_ps(g[1], g[1]), _mm256_mul_ps(g[2], g[2]));
    let cos = _mm256_div_ps(dot!(view.light_index, g[0], g[1], g[2]), _mm256_sqrt_ps(n2));
    let facing = _mm256_cmp_ps::<_CMP_GT_OQ>(dot!(view.view_index, g[0], g[1], g[2]), _mm256_setzero_ps());
    let cos = _mm256_blendv_ps(cos, _mm256_xor_ps(cos, _mm256_set1_ps(-0.0)), facing);
    let lit = _mm256_add_ps(
        _mm256_set1_ps(ambient),
        _mm256_mul_ps(_mm256_set1_ps(1.0 - ambient), _mm256_max_ps(cos, _mm256_setzero_ps())),
    );
    // 1 where the gradient vanishes (n2 < 1e-12).
    let flat_lanes = _mm256_cmp_ps::<_CMP_LT_OQ>(n2, _mm256_set1_ps(1e-12));
    let out = _mm256_blendv_ps(lit, _mm256_set1_ps(1.0), flat_lanes);
    // The lanes from `from` on in its brick take the new shades, the others keep theirs: blended and stored
    // whole rather than by a masked store, which the consumer's next read of one lane would wait for (a
    // masked store is not forwarded to a later load).
    let after = _mm256_cmpgt_epi32(_mm256_set_epi32(7, 6, 5, 4, 3, 2, 1, 0), _mm256_set1_epi32(from as i32 - 1));
    let take = _mm256_castsi256_ps(_mm256_and_si256(same, after));
    // SAFETY: `batch.shade` holds eight f32, the bytes an unaligned load and store of one register touch.
    unsafe {
        let mut old = _mm256_loadu_ps(batch.shade.as_ptr());
        // The old shades passed through an empty asm block, which the compiler cannot see into: it would
        // otherwise fold this load, the blend and the store back into a masked store (it did with the
        // lane-by-lane interpolation above).
        std::arch::asm!("/* {0} */", inout(ymm_reg) old, options(pure, nomem, nostack, preserves_flags));
        _mm256_storeu_ps(batch.shade.as_mut_ptr(), _mm256_blendv_ps(old, out, take));
    }
    batch.shaded |= lanes;
}
