//! Label fields by shape-based interpolation: for every material near a brick, the signed distance to
//! its boundary within each slice (a 2D Euclidean distance transform per z slice, in the slice's world
//! units), clamped to ±[`LABEL_REACH`], smoothed in-plane by a small Gaussian ([`LABEL_SIGMA`],
//! truncated at [`LABEL_RADIUS`]) and stored per voxel as `u16`.
//!
//! The marcher interpolates these distances trilinearly and only then turns them into an occupancy
//! (a smoothstep of width [`LABEL_RAMP`] across the zero level). Between two slices the boundary is
//! therefore the linear blend of the two slices' contours — the contour of slice k morphs into that
//! of slice k + 1 — so a surface that runs almost parallel to the slices is a smooth ramp, not a
//! staircase of one-slice terraces with treads many voxels wide (which no small 3D blur of the label
//! indicators can remove: a tread wider than the blur stays flat). A sloped plane is reproduced
//! exactly as long as its treads are narrower than twice the clamp. Label volumes are segmented slice
//! by slice along z, often with a wider z spacing (the frog: 1 × 1 × 1.5), which is why z is the
//! interpolated axis.
//!
//! Shading normals are each material's own distance gradient (central differences one voxel either
//! side, stored as `i16` triples and interpolated trilinearly): continuous across cells and slices.

use super::block::{S, S3, SHIFT};
use super::classify::Classifier;
use crate::volume::{Volume, Voxel};

/// Standard deviation (voxels, in-plane) of the Gaussian that smooths each slice's signed distance.
pub const LABEL_SIGMA: f32 = 1.0;
/// Truncation radius of that Gaussian (voxels).
pub const LABEL_RADIUS: usize = 2;
/// Clamp of the in-plane signed distance (in-plane voxels): a contour interpolates smoothly to the next
/// slice's when the two lie within this distance of each other.
pub const LABEL_REACH: f32 = 8.0;
/// Width (in-plane voxels) of the occupancy ramp across a boundary.
pub const LABEL_RAMP: f32 = 2.0;

/// Stored distance units per in-plane voxel: `u16` over [−REACH, REACH].
pub(super) const SDF_UNIT: f32 = 2.0 * LABEL_REACH / 65535.0;

/// Occupancy of a point at signed distance `s` (in-plane voxels, positive outside) from a boundary.
#[inline(always)]
pub(super) fn ramp(s: f32) -> f32 {
    let t = (0.5 - s * (1.0 / LABEL_RAMP)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// How far (index voxels, along any axis) past a labelled voxel a material's occupancy can reach: the
/// ramp's half width, the in-plane blur and one interpolation cell.
pub(super) fn label_reach(volume: &Volume) -> usize {
    let s = volume.spacing;
    let h = s[0].min(s[1]);
    let stretch = if h > 0.0 { (s[0].max(s[1]) / h).ceil() as usize } else { 1 };
    2 + LABEL_RADIUS * stretch.max(1)
}

/// One brick's label fields.
pub(super) struct LabelBlock {
    /// Materials (0-based) with some occupancy in the block.
    pub(super) mats: Vec<u8>,
    /// `mats.len() × S3` signed distances, `u16` in units of [`SDF_UNIT`] from −REACH.
    pub(super) sdf: Vec<u16>,
    /// `mats.len() × S3` distance gradients (per index step) in units of `scale` (empty without
    /// gradients).
    pub(super) grad: Vec<[i16; 3]>,
}

/// Field units per stored gradient unit: a central difference of distances clamped to ±REACH is at
/// most REACH.
pub(super) const GRAD_SCALE: f32 = LABEL_REACH / i16::MAX as f32;

/// Build the label fields of brick `b`, each voxel's material (index + 1, 0 for none) by `classifier`.
pub(super) fn build(volume: &Volume, classifier: &Classifier, b: [usize; 3], gradients: bool) -> LabelBlock {
    build_with(volume, classifier, b, gradients, 0)
}

/// [`build`], transforming the materials with a voxel within `margin` voxels more than it needs (any
/// margin gives the same block: the tests compare them).
#[inline(always)]
fn build_with(volume: &Volume, classifier: &Classifier, b: [usize; 3], gradients: bool, margin: usize) -> LabelBlock {
    const R: usize = LABEL_RADIUS;
    let d = volume.dims;
    let sp = volume.spacing;
    let h = sp[0].min(sp[1]).max(f64::MIN_POSITIVE);
    // Squared in-plane voxel lengths in units of h.
    let wx = ((sp[0] / h) * (sp[0] / h)) as f32;
    let wy = ((sp[1] / h) * (sp[1] / h)) as f32;
    // In-plane margins: the distance clamp, the blur and the central differences.
    let mx = (f64::from(LABEL_REACH) * h / sp[0]).ceil() as usize + R + 1;
    let my = (f64::from(LABEL_REACH) * h / sp[1]).ceil() as usize + R + 1;
    // z: the blur and the central differences.
    let mz = R + 1;
    let (nx, ny, nz) = (S + 2 * mx, S + 2 * my, S + 2 * mz);
    let o = [
        (b[0] << SHIFT) as isize - mx as isize,
        (b[1] << SHIFT) as isize - my as isize,
        (b[2] << SHIFT) as isize - mz as isize,
    ];
    let coord = |a: usize, j: usize| (o[a] + j as isize).clamp(0, d[a] as isize - 1) as usize;
    // The region's voxels by material, in one pass: per material code, slice and row, the bit mask of
    // the row's pixels of that material (`masks[(code · nz + z) · ny + y]`, bit x for pixel x).
    let rows = nz * ny;
    let mut masks = vec![0u32; (classifier.materials + 1) * rows];
    let xs: Vec<usize> = (0..nx).map(|x| coord(0, x)).collect();
    let region_rows = (0..nz).flat_map(|z| (0..ny).map(move |y| (z, y)));
    let starts = region_rows.map(|(z, y)| d[0] * (coord(1, y) + d[1] * coord(2, z)));
    crate::with_voxels!(&volume.voxels, data => classify_rows(data, classifier, starts, &xs, rows, &mut masks, ByteRows::Choose));
    // The blurred distance is read over the block and its one-voxel rim (G³); the unblurred one over
    // that grown by the blur (W per axis), whose window starts at (x0, y0) in the region.
    const G: usize = S + 2;
    const W: usize = G + 2 * LABEL_RADIUS;
    let (x0, y0) = (mx - 1 - R, my - 1 - R);
    // Only materials that can be stored matter (some voxel of the block with a blurred distance below
    // the ramp's outer edge, 1 voxel: `any` below). The blur averages over ±R per axis, so a blurred
    // distance below 1 needs an unblurred one below 1 within ±R, which only a voxel of the material or
    // one next to it in its slice has (any other is a whole voxel from the nearest boundary pixel, at
    // distance ≥ 1.5). So a material with no voxel within ±(R + 1) in-plane and ±R across slices of the
    // block's voxels is never stored: it is not transformed at all. That window is the unblurred one
    // (W columns and rows from (x0, y0)) and the slices 1..nz − 1. (`margin` widens it, for the test
    // that checks the blocks do not change.)
    let (xa, xb) = (x0.saturating_sub(margin), (x0 + W + margin).min(nx));
    let columns = (u32::MAX >> (32 - (xb - xa))) << xa;
    let (ya, yb) = (y0.saturating_sub(margin), (y0 + W + margin).min(ny));
    let (za, zb) = (1usize.saturating_sub(margin), (nz - 1 + margin).min(nz));
    let present: Vec<u8> = (1..=classifier.materials)
        .filter(|&code| {
            let of = &masks[code * rows..][..rows];
            (za..zb).any(|z| of[z * ny + ya..z * ny + yb].iter().any(|&r| r & columns != 0))
        })
        .map(|code| code as u8)
        .collect();

    let kernel = gaussian_kernel();
    let mut edt = Edt::new();
    let mut out = LabelBlock { mats: Vec::new(), sdf: Vec::new(), grad: Vec::new() };
    let mut unblurred = vec![0f32; W * W * nz];
    let mut bxy = vec![0f32; G * G * nz];
    let mut field = vec![0f32; G * G * G];
    let window = Window { x0, y0, n: W };
    for &m in &present {
        for z in 0..nz {
            // The slice's pixels of this material, a bit mask per row.
            let inside = &masks[(usize::from(m) * nz + z) * ny..][..ny];
            let slice = &mut unblurred[W * W * z..W * W * (z + 1)];
            if let Some(c) = edt.signed(inside, nx, wx, wy, window, slice) {
                // All on one side: the blur keeps the constant.
                bxy[G * G * z..G * G * (z + 1)].iter_mut().for_each(|v| *v = c);
                continue;
            }
            // Blur in-plane.
            let mut bx = [[0f32; G]; W];
            for (yy, row) in bx.iter_mut().enumerate() {
                let src = &slice[W * yy..W * (yy + 1)];
                for (xx, v) in row.iter_mut().enumerate() {
                    *v = kernel.iter().zip(&src[xx..]).map(|(k, s)| k * s).sum();
                }
            }
            for yy in 0..G {
                for xx in 0..G {
                    bxy[xx + G * (yy + G * z)] = kernel.iter().enumerate().map(|(t, k)| k * bx[yy + t][xx]).sum();
                }
            }
        }
        // And across the slices.
        for z in 0..G {
            for i in 0..G * G {
                field[i + G * G * z] = kernel.iter().enumerate().map(|(t, k)| k * bxy[i + G * G * (z + t)]).sum();
            }
        }
        // Occupied somewhere in the block: a corner below the ramp's outer edge.
        let at = |x: usize, y: usize, z: usize| field[x + G * (y + G * z)];
        let mut any = false;
        for z in 1..=S {
            for y in 1..=S {
                for x in 1..=S {
                    any |= at(x, y, z) < 0.5 * LABEL_RAMP;
                }
            }
        }
        if !any {
            continue;
        }
        out.mats.push(m - 1);
        // Rounded as `round()` does (half away from zero), without its library call: `q`'s operand is in
        // [0, 65535] (NaN, which no blur of finite distances gives, would be 0 as before); `g` clamps to
        // the integers ±32767 before rounding instead of after, which gives the same integer.
        let q = |s: f32| round_half_up((s.clamp(-LABEL_REACH, LABEL_REACH) + LABEL_REACH) / SDF_UNIT) as u16;
        let max = f32::from(i16::MAX);
        let g = |c: f32| super::fields::round_half_away((c / GRAD_SCALE).clamp(-max, max)) as i16;
        for z in 1..=S {
            for y in 1..=S {
                for x in 1..=S {
                    out.sdf.push(q(at(x, y, z)));
                    if gradients {
                        out.grad.push([
                            g(0.5 * (at(x + 1, y, z) - at(x - 1, y, z))),
                            g(0.5 * (at(x, y + 1, z) - at(x, y - 1, z))),
                            g(0.5 * (at(x, y, z + 1) - at(x, y, z - 1))),
                        ]);
                    }
                }
            }
        }
    }
    debug_assert_eq!(out.sdf.len(), out.mats.len() * S3);
    out
}

/// `c.round()` for `c` in [0, 65535] (NaN: 0; a float just above 65535 gives 65535, as the saturating
/// `as u16` did), without the library call `round` is on x86-64's baseline (`roundf` was 2 % of the frog's
/// render): the fraction `c − trunc(c)` is exact there.
#[inline(always)]
fn round_half_up(c: f32) -> u32 {
    debug_assert!(c.is_nan() || (0.0..=65536.0).contains(&c), "{c}");
    let c = if c >= 0.0 { c.min(65535.0) } else { 0.0 };
    // SAFETY: c is in [0, 65535] (NaN and negatives replaced above), in range for u32.
    let t = unsafe { c.to_int_unchecked::<u32>() };
    t + u32::from(c - t as f32 >= 0.5)
}

fn gaussian_kernel() -> [f32; 2 * LABEL_RADIUS + 1] {
    let mut kernel = [0f32; 2 * LABEL_RADIUS + 1];
    for (k, w) in kernel.iter_mut().enumerate() {
        let x = k as f32 - LABEL_RADIUS as f32;
        *w = (-0.5 * x * x / (LABEL_SIGMA * LABEL_SIGMA)).exp();
    }
    let sum: f32 = kernel.iter().sum();
    kernel.iter_mut().for_each(|w| *w /= sum);
    kernel
}

/// A square window of a slice region: its first column and row, and its edge.
#[derive(Clone, Copy)]
struct Window {
    x0: usize,
    y0: usize,
    n: usize,
}

/// Far: larger than any squared distance within the clamp.
const FAR: f32 = 1e20;

/// The widest slice region a block reads (pixels a row): the block's edge and, each side, the clamp's
/// reach in pixels of the finer in-plane spacing (at most [`LABEL_REACH`]), the blur and one more
/// (`build`'s margins), so that a row of it is one `u32` bit mask.
const MAX_ROW: usize = S + 2 * (LABEL_REACH as usize + LABEL_RADIUS + 1);
const _: () = assert!(MAX_ROW <= 32);

/// Classify a slice region's rows (each row's first voxel at one of `starts`, its pixels at columns
/// `xs` of it) into `masks`: for the region's row `r` and a pixel of material `code` at `x`, bit x of
/// `masks[code · rows + r]` (code 0, no material, is set only where read voxel by voxel: `build` never
/// reads it).
/// One-byte voxels take their code from a table of their 256 values, built once here instead of a bin
/// computed per voxel; where a row's columns are consecutive voxels (every brick but those at the grid's
/// x edges) they are compared 16 at a time with each distinct byte of the row ([`classify_bytes`]), or
/// with the table's runs of one material ([`ByteRuns`]) when the first rows hold more distinct bytes than
/// the table has runs (`choice` forces either, for the tests).
fn classify_rows<T: Voxel>(
    data: &[T],
    classifier: &Classifier,
    starts: impl Iterator<Item = usize>,
    xs: &[usize],
    rows: usize,
    masks: &mut [u32],
    choice: ByteRows,
) {
    assert!(xs.len() <= 32, "a row of {} pixels in one u32 mask", xs.len());
    let code_of = |v: T| classifier.material[classifier.bin(v.to_f32())];
    let bytes: Option<[u8; 256]> = (std::mem::size_of::<T>() == 1)
        .then(|| std::array::from_fn(|b| bytemuck::try_cast::<u8, T>(b as u8).map_or(0, code_of)));
    let consecutive = xs.windows(2).all(|w| w[1] == w[0] + 1);
    let rows_of_bytes = bytes.as_ref().filter(|_| consecutive);
    let runs = rows_of_bytes.and_then(ByteRuns::of).filter(|_| choice != ByteRows::Values);
    // Distinct bytes compared in the first PROBE rows: more than the table's runs a row, and the rest are
    // compared with the runs.
    const PROBE: usize = 16;
    let mut probed = 0;
    for (r, start) in starts.enumerate() {
        if let (Some(table), Some(&first)) = (rows_of_bytes, xs.first())
            && let Some(row) = bytemuck::cast_slice::<T, u8>(data).get(start + first..start + first + 32)
        {
            let mut found = |code: u8, bits| masks[usize::from(code) * rows + r] |= bits;
            match &runs {
                Some(runs) if choice == ByteRows::Runs || (r >= PROBE && probed > runs.runs.len() * PROBE) => {
                    runs.classify(row, xs.len(), found)
                }
                _ => {
                    let values = classify_bytes(row, xs.len(), table, &mut found);
                    if r < PROBE {
                        probed += values;
                    }
                }
            }
            continue;
        }
        let src = &data[start..];
        // The run of one code being read, its bits gathered here and stored when the code changes (label
        // rows are long runs of one material): no store and reload of the same mask at every voxel.
        let (mut run, mut bits) = (0u8, 0u32);
        for (x, &at) in xs.iter().enumerate() {
            let v = src[at];
            let code = match &bytes {
                Some(table) => table[usize::from(bytemuck::cast::<T, u8>(v))],
                None => code_of(v),
            };
            if code != run {
                masks[usize::from(run) * rows + r] |= bits;
                (run, bits) = (code, 0);
            }
            bits |= 1 << x;
        }
        masks[usize::from(run) * rows + r] |= bits;
    }
}

/// A one-byte voxel table's materials as runs of consecutive byte values of one material code:
/// `(first byte, last − first, code)`. Label volumes map a few ranges of label numbers to materials, so a
/// row of bytes is classified by a few range comparisons instead of a table read per byte.
struct ByteRuns {
    runs: Vec<(u8, u8, u8)>,
    /// Per run, its first byte and its span in every byte lane, made once rather than per row.
    #[cfg(target_arch = "x86_64")]
    lanes: Vec<[std::arch::x86_64::__m128i; 2]>,
}

impl ByteRuns {
    /// The runs of `table`'s nonzero codes, or None when there are more than [`ByteRuns::MAX`] (a table
    /// read per byte is then as cheap).
    fn of(table: &[u8; 256]) -> Option<ByteRuns> {
        let mut runs: Vec<(u8, u8, u8)> = Vec::new();
        for (b, &code) in table.iter().enumerate() {
            match runs.last_mut() {
                Some((first, span, c)) if *c == code && usize::from(*first) + usize::from(*span) + 1 == b => *span += 1,
                _ if code != 0 => runs.push((b as u8, 0, code)),
                _ => {}
            }
        }
        if runs.len() > Self::MAX {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        let lanes = runs
            .iter()
            .map(|&(first, span, _)| {
                use std::arch::x86_64::_mm_set1_epi8;
                // SAFETY: SSE2 is part of x86-64's baseline; this only fills registers.
                unsafe { [_mm_set1_epi8(first as i8), _mm_set1_epi8(span as i8)] }
            })
            .collect();
        Some(ByteRuns {
            runs,
            #[cfg(target_arch = "x86_64")]
            lanes,
        })
    }

    const MAX: usize = 24;

    /// For each run, `found(code, bits)` with bit x set for each of the first `n` bytes of `row` in the run
    /// (`row` holds 32 bytes; `n` ≤ 32). Nothing is reported for bytes of no material.
    #[inline]
    fn classify(&self, row: &[u8], n: usize, mut found: impl FnMut(u8, u32)) {
        let row: &[u8; 32] = row.try_into().expect("32 bytes of a row");
        let within = u32::MAX >> (32 - n);
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_cmpeq_epi8, _mm_loadu_si128, _mm_max_epu8, _mm_movemask_epi8, _mm_sub_epi8};
            // SAFETY: SSE2 is part of x86-64's baseline; the loads read the 32 bytes of `row` (two unaligned
            // 16-byte loads), the rest works on registers.
            unsafe {
                let (lo, hi) = (_mm_loadu_si128(row.as_ptr().cast()), _mm_loadu_si128(row.as_ptr().add(16).cast()));
                for (&(_, _, code), &[f, s]) in self.runs.iter().zip(&self.lanes) {
                    // In the run: byte − first ≤ span, unsigned (max(d, span) == span).
                    let inside = |v| {
                        let d = _mm_sub_epi8(v, f);
                        _mm_movemask_epi8(_mm_cmpeq_epi8(_mm_max_epu8(d, s), s)) as u32 & 0xffff
                    };
                    let bits = (inside(lo) | inside(hi) << 16) & within;
                    if bits != 0 {
                        found(code, bits);
                    }
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        for &(first, span, code) in &self.runs {
            let bits =
                row.iter().enumerate().fold(0u32, |m, (x, &b)| m | (u32::from(b.wrapping_sub(first) <= span) << x));
            let bits = bits & within;
            if bits != 0 {
                found(code, bits);
            }
        }
    }
}

/// How [`classify_rows`] compares rows of consecutive one-byte voxels.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum ByteRows {
    /// By their distinct bytes, or by the table's runs when the first rows have more bytes than runs.
    Choose,
    /// By their distinct bytes.
    Values,
    /// By the table's runs (where there are at most [`ByteRuns::MAX`]).
    Runs,
}

/// For each distinct byte among the first `n` of `row` (32 bytes; `n` ≤ 32) whose `table` code is a
/// material, `found(code, bits)` with bit x set for each of those bytes equal to it; returns how many
/// distinct bytes there were. A label row holds few distinct values (long runs of one label), so this
/// takes one comparison of the row per value, 16 bytes at a time, instead of a comparison per range of
/// labels of one material (the frog's table has more ranges than a row has values) or a table read per
/// byte. A noisy volume (a CT read as labels) has many values a row, and its rows are compared with the
/// ranges instead ([`classify_rows`] chooses).
#[inline]
fn classify_bytes(row: &[u8], n: usize, table: &[u8; 256], mut found: impl FnMut(u8, u32)) -> usize {
    let row: &[u8; 32] = row.try_into().expect("32 bytes of a row");
    // The bit mask of the row's bytes equal to `v` (bit x for byte x).
    #[cfg(target_arch = "x86_64")]
    let equal = {
        use std::arch::x86_64::{_mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8, _mm_set1_epi8};
        // SAFETY: SSE2 is part of x86-64's baseline; the loads read the 32 bytes of `row` (two unaligned
        // 16-byte loads), the rest works on registers.
        let (lo, hi) = unsafe { (_mm_loadu_si128(row.as_ptr().cast()), _mm_loadu_si128(row.as_ptr().add(16).cast())) };
        // SAFETY: as above, SSE2 instructions on registers only.
        move |v: u8| unsafe {
            let splat = _mm_set1_epi8(v as i8);
            let eq = |half| _mm_movemask_epi8(_mm_cmpeq_epi8(half, splat)) as u32 & 0xffff;
            eq(lo) | eq(hi) << 16
        }
    };
    #[cfg(not(target_arch = "x86_64"))]
    let equal = |v: u8| row.iter().enumerate().fold(0u32, |m, (x, &b)| m | (u32::from(b == v) << x));
    let mut rest = u32::MAX >> (32 - n);
    let mut values = 0;
    while rest != 0 {
        let v = row[rest.trailing_zeros() as usize];
        let bits = equal(v) & rest;
        rest &= !bits;
        values += 1;
        let code = table[usize::from(v)];
        if code != 0 {
            found(code, bits);
        }
    }
    values
}

/// The smaller of two squared distances (never NaN, never −0): `f32::min` without its NaN handling, which
/// took three more instructions per lane in the transform's innermost loop.
#[inline(always)]
fn least(a: f32, b: f32) -> f32 {
    if b < a { b } else { a }
}

/// Scratch space of the bounded squared Euclidean distance transform: exact distances along each row
/// (the nearest boundary pixel either side, found in the row's bit mask), then along the columns a
/// minimum over the rows within the clamp. Exact up to [`LABEL_REACH`], which is all the clamped
/// distance needs.
struct Edt {
    /// Squared distance along x to the nearest feature of the row, per row and window column.
    rows: Vec<f32>,
    /// Per row, the boundary pixels (bit x for pixel x).
    edge: Vec<u32>,
}

impl Edt {
    fn new() -> Edt {
        Edt { rows: Vec::new(), edge: Vec::new() }
    }

    /// Signed distance (in-plane voxels of length 1 for weight 1; positive outside), over `window`,
    /// of the pixels of a slice of `nx` pixels a row (`inside`: one bit mask a row) to the boundary of
    /// the pixels inside, half a voxel past the boundary pixels' centres, clamped to ±REACH.
    ///
    /// One transform serves both signs: its features are the boundary pixels (those with a neighbour,
    /// diagonals included, on the other side). The pixel on the other side nearest to any pixel is such a boundary pixel
    /// (a step from it towards the pixel would otherwise stay on its side and come closer), so a
    /// pixel `k` voxels deep along an axis is `k − 1` from the nearest boundary pixel of its own side
    /// and `k` from the other's, and `±(distance + ½)` is its distance to the boundary between pixel
    /// centres (exact along the axes, within a fraction of a voxel elsewhere, before the blur).
    /// Returns the value when the whole slice lies on one side (every pixel ±REACH).
    fn signed(&mut self, inside: &[u32], nx: usize, wx: f32, wy: f32, window: Window, out: &mut [f32]) -> Option<f32> {
        assert!((1..=32).contains(&nx), "a slice region of {nx} pixels a row (at most {MAX_ROW} in `build`)");
        let ny = inside.len();
        let full = u32::MAX >> (32 - nx);
        if inside.iter().all(|&r| r == 0) || inside.iter().all(|&r| r == full) {
            let s = if inside[0] == 0 { LABEL_REACH } else { -LABEL_REACH };
            out.iter_mut().for_each(|o| *o = s);
            return Some(s);
        }
        let Window { x0, y0, n } = window;
        // A pixel is on the boundary when its 3×3 neighbourhood (clamped at the region's edge) is not all
        // on its side: separably, the neighbourhood's OR (dilation) and AND (erosion), row then column.
        // Along a row: the pixel before (the first pixel its own) and after (the last its own).
        let along = |r: u32| {
            let before = (r << 1 | r & 1) & full;
            let after = r >> 1 | r & (1 << (nx - 1));
            (before | r | after, before & r & after)
        };
        let edge = &mut self.edge;
        edge.clear();
        for y in 0..ny {
            let (a, c, b) = (along(inside[y.saturating_sub(1)]), along(inside[y]), along(inside[(y + 1).min(ny - 1)]));
            let (or, and) = (a.0 | c.0 | b.0, a.1 & c.1 & b.1);
            let i = inside[y];
            edge.push((i & !and | !i & or) & full);
        }
        // Along x: the nearest feature at or before, and at or after, each window column.
        let rows = &mut self.rows;
        rows.clear();
        rows.resize(ny * n, FAR);
        for (e, r) in edge.iter().zip(rows.chunks_exact_mut(n)) {
            if *e == 0 {
                continue;
            }
            for (xw, v) in r.iter_mut().enumerate() {
                let x = x0 + xw;
                // Features at pixels 0..=x, and at x.. (x < nx ≤ 32).
                let before = *e & (u32::MAX >> (31 - x));
                if before != 0 {
                    let dx = (x - (31 - before.leading_zeros() as usize)) as f32;
                    *v = wx * dx * dx;
                }
                let after = *e >> x;
                if after != 0 {
                    let dx = after.trailing_zeros() as f32;
                    *v = least(*v, wx * dx * dx);
                }
            }
        }
        // Along y: the nearest row within the clamp.
        let half = 0.5 * wx.min(wy).sqrt();
        // Only the rows nearer than the clamp: a row `k` away adds c = wy·k² to each of its candidates
        // (r + c ≥ c, as r ≥ 0). Where √c + half already reaches the clamp (computed with the operations
        // below), a distance through that row is clamped, and leaving the row out can only raise a
        // minimum that is clamped anyway: the same output. At unit spacing, 7 rows either side instead of 9.
        let mut reach = 0;
        while reach < ny {
            let k = (reach + 1) as f32;
            if (wy * k * k).sqrt() + half >= LABEL_REACH {
                break;
            }
            reach += 1;
        }
        let mut best = vec![FAR; n];
        for yw in 0..n {
            let y = y0 + yw;
            best.iter_mut().for_each(|b| *b = FAR);
            for yy in y.saturating_sub(reach)..(y + reach + 1).min(ny) {
                let dy = yy as f32 - y as f32;
                let c = wy * dy * dy;
                for (b, r) in best.iter_mut().zip(&rows[n * yy..n * (yy + 1)]) {
                    *b = least(*b, r + c);
                }
            }
            for (xw, b) in best.iter().enumerate() {
                let d = b.sqrt() + half;
                let is_inside = inside[y] >> (x0 + xw) & 1 == 1;
                out[xw + n * yw] = if is_inside { -d } else { d }.clamp(-LABEL_REACH, LABEL_REACH);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A xorshift64 sequence from `seed`: the tests' data is the same every run.
    fn xorshift(mut seed: u64) -> impl FnMut() -> u64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        }
    }

    #[test]
    fn rounding_a_stored_distance_without_the_library_call_is_round() {
        for i in 0..=262_140 {
            let c = i as f32 * 0.25 + if i % 3 == 0 { 1e-3 } else { 0.0 };
            let c = c.min(65535.0);
            assert_eq!(round_half_up(c), c.round() as u32, "{c}");
        }
        for c in [0.0f32, 0.49999997, 0.5, 1.5, 65534.5, 65535.0, 1.0e-30] {
            assert_eq!(round_half_up(c), c.round() as u32, "{c}");
        }
        assert_eq!(round_half_up(f32::NAN), 0);
    }

    /// The bit masks of a slice given pixel by pixel.
    fn masks(inside: &[bool], nx: usize) -> Vec<u32> {
        inside.chunks_exact(nx).map(|r| r.iter().enumerate().fold(0, |m, (x, &i)| m | (u32::from(i) << x))).collect()
    }

    #[test]
    fn signed_distance_matches_brute_force_on_a_small_grid() {
        let (nx, ny) = (7usize, 5usize);
        let mut inside = vec![false; nx * ny];
        inside[3 + nx * 2] = true;
        inside[4 + nx * 2] = true;
        let mut e = Edt::new();
        let n = ny;
        let mut out = vec![0f32; n * n];
        e.signed(&masks(&inside, nx), nx, 1.0, 1.0, Window { x0: 1, y0: 0, n }, &mut out);
        for y in 0..n {
            for x in 1..1 + n {
                let brute = (0..nx * ny)
                    .filter(|i| inside[*i])
                    .map(|i| {
                        let (px, py) = ((i % nx) as f32, (i / nx) as f32);
                        ((x as f32 - px).powi(2) + (y as f32 - py).powi(2)).sqrt()
                    })
                    .fold(f32::INFINITY, f32::min);
                let got = out[(x - 1) + n * y];
                let want = if inside[x + nx * y] { -0.5 } else { brute - 0.5 };
                // Exact along the axis through the pixels, within half a voxel off it.
                let tol = if y == 2 { 1e-5 } else { 0.5 };
                assert!((got - want).abs() <= tol, "({x}, {y}): {got} vs {want}");
            }
        }
    }

    /// The transform as it was first written, pixel by pixel over `bool`s (two scans a row, the
    /// neighbourhoods as vectors of flags): the reference the bit-mask transform must equal exactly.
    fn reference_signed(
        inside: &[bool],
        nx: usize,
        ny: usize,
        wx: f32,
        wy: f32,
        window: Window,
        out: &mut [f32],
    ) -> Option<f32> {
        let n_in = inside.iter().filter(|i| **i).count();
        if n_in == 0 || n_in == inside.len() {
            let s = if n_in == 0 { LABEL_REACH } else { -LABEL_REACH };
            out.iter_mut().for_each(|o| *o = s);
            return Some(s);
        }
        let Window { x0, y0, n } = window;
        // A pixel is on the boundary when its 3×3 neighbourhood (clamped at the region's edge) is not all
        // on its side: separably, the neighbourhood's OR (dilation) and AND (erosion), row then column.
        let (mut hor_or, mut hor_and) = (Vec::new(), Vec::new());
        for y in 0..ny {
            let r = &inside[nx * y..nx * (y + 1)];
            for x in 0..nx {
                let (a, b, c) = (r[x.saturating_sub(1)], r[x], r[(x + 1).min(nx - 1)]);
                hor_or.push(a | b | c);
                hor_and.push(a & b & c);
            }
        }
        let mut edge = Vec::new();
        for y in 0..ny {
            let (ya, yb) = (nx * y.saturating_sub(1), nx * (y + 1).min(ny - 1));
            let yc = nx * y;
            for x in 0..nx {
                let or = hor_or[ya + x] | hor_or[yc + x] | hor_or[yb + x];
                let and = hor_and[ya + x] & hor_and[yc + x] & hor_and[yb + x];
                edge.push(if inside[yc + x] { !and } else { or });
            }
        }
        // Along x: the nearest feature left and right of each window column.
        let mut rows = vec![FAR; ny * n];
        for y in 0..ny {
            let e = &edge[nx * y..nx * (y + 1)];
            let r = &mut rows[n * y..n * (y + 1)];
            let mut last: Option<usize> = None;
            for (x, f) in e.iter().enumerate().take(x0 + n) {
                if *f {
                    last = Some(x);
                }
                if let (true, Some(l)) = (x >= x0, last) {
                    let dx = (x - l) as f32;
                    r[x - x0] = wx * dx * dx;
                }
            }
            let mut next: Option<usize> = None;
            for x in (x0..nx).rev() {
                if e[x] {
                    next = Some(x);
                }
                if let (true, Some(nn)) = (x < x0 + n, next) {
                    let dx = (nn - x) as f32;
                    r[x - x0] = r[x - x0].min(wx * dx * dx);
                }
            }
        }
        // Along y: the nearest row within the clamp.
        let reach = (LABEL_REACH / wy.sqrt()).ceil() as usize + 1;
        let half = 0.5 * wx.min(wy).sqrt();
        let mut best = vec![FAR; n];
        for yw in 0..n {
            let y = y0 + yw;
            best.iter_mut().for_each(|b| *b = FAR);
            for yy in y.saturating_sub(reach)..(y + reach + 1).min(ny) {
                let dy = yy as f32 - y as f32;
                let c = wy * dy * dy;
                for (b, r) in best.iter_mut().zip(&rows[n * yy..n * (yy + 1)]) {
                    *b = b.min(r + c);
                }
            }
            for (xw, b) in best.iter().enumerate() {
                let d = b.sqrt() + half;
                let i = (x0 + xw) + nx * y;
                out[xw + n * yw] = if inside[i] { -d } else { d }.clamp(-LABEL_REACH, LABEL_REACH);
            }
        }
        None
    }

    #[test]
    fn the_bit_mask_transform_equals_the_pixel_by_pixel_one_exactly() {
        // Regions as `build` makes them (30 × 30 at the frog's spacing, narrower with a coarser x or y
        // spacing), blobs and stripes of every density, in-plane weights of square and oblong pixels.
        let mut next = xorshift(0x2545_f491_4f6c_dd1du64);
        let mut e = Edt::new();
        let mut cases = 0;
        for (nx, ny, wx, wy) in
            [(30, 30, 1.0, 1.0), (30, 22, 1.0, 4.0), (18, 30, 2.25, 1.0), (9, 5, 1.0, 1.0), (32, 32, 1.0, 1.0)]
        {
            let n = (nx.min(ny) - 2).min(14);
            let window = Window { x0: (nx - n) / 2, y0: (ny - n) / 2, n };
            for density in [0u64, 1, 8, 32, 64, 128, 200, 255, 256] {
                for _ in 0..40 {
                    let inside: Vec<bool> = (0..nx * ny).map(|_| next() % 256 < density).collect();
                    let mut want = vec![0f32; n * n];
                    let mut got = vec![1f32; n * n];
                    let a = reference_signed(&inside, nx, ny, wx, wy, window, &mut want);
                    let b = e.signed(&masks(&inside, nx), nx, wx, wy, window, &mut got);
                    assert_eq!(a, b, "{nx}×{ny} density {density}");
                    let same = want.iter().zip(&got).all(|(p, q)| p.to_bits() == q.to_bits());
                    assert!(same, "{nx}×{ny} density {density}: {want:?} against {got:?}");
                    cases += 1;
                }
            }
        }
        assert_eq!(cases, 5 * 9 * 40);
    }

    /// Materials with no voxel near enough to be stored are not transformed ([`build`]'s window): the
    /// blocks are the ones of a window wide enough to take every material of the region, for every brick
    /// of label volumes with blobs, slabs and lone voxels of five materials, on square and on unequal
    /// in-plane spacings (the frog's 1 × 1 × 1.5; 1 × 1.6 × 2, whose x and y clamps differ).
    #[test]
    fn materials_skipped_as_out_of_reach_would_not_have_been_stored() {
        use super::super::MaterialClass;
        let (dx, dy, dz) = (44usize, 37usize, 29usize);
        let mut next = xorshift(0x2545_f491_4f6c_dd1du64);
        let mut data = vec![0u8; dx * dy * dz];
        // Blobs (balls of radius 1–6) of labels 1–5, then lone voxels.
        for _ in 0..40 {
            let c = [next() % dx as u64, next() % dy as u64, next() % dz as u64].map(|v| v as f64);
            let (r, label) = (1.0 + (next() % 6) as f64, 1 + (next() % 5) as u8);
            for (i, v) in data.iter_mut().enumerate() {
                let p = [(i % dx) as f64, ((i / dx) % dy) as f64, (i / (dx * dy)) as f64];
                if (0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f64>() <= r * r {
                    *v = label;
                }
            }
        }
        for _ in 0..60 {
            let i = (next() % data.len() as u64) as usize;
            data[i] = 1 + (next() % 5) as u8;
        }
        let mats: Vec<_> = (1..=5).map(|k| MaterialClass::new([k as f32, k as f32], 0.5)).collect();
        let (mut blocks, mut stored) = (0, 0);
        for spacing in [[1.0, 1.0, 1.5], [1.0, 1.6, 2.0]] {
            let vol =
                Volume::new(std::path::Path::new("blobs"), [dx, dy, dz], spacing, data.clone()).expect("a volume");
            let classifier = Classifier::new(&vol, &mats, 0.5, 1);
            let counts = [dx, dy, dz].map(|n| n.div_ceil(1 << SHIFT));
            for b in (0..counts.iter().product())
                .map(|i| [i % counts[0], (i / counts[0]) % counts[1], i / (counts[0] * counts[1])])
            {
                for gradients in [true, false] {
                    let (tight, wide) =
                        (build(&vol, &classifier, b, gradients), build_with(&vol, &classifier, b, gradients, 32));
                    assert_eq!(tight.mats, wide.mats, "brick {b:?} spacing {spacing:?}");
                    assert!(tight.sdf == wide.sdf && tight.grad == wide.grad, "brick {b:?} spacing {spacing:?}");
                    blocks += 1;
                    stored += tight.mats.len();
                }
            }
        }
        // The volumes exercise it: most blocks hold some material, and some more than one.
        assert!(blocks > 200 && stored > blocks / 2, "{stored} materials stored in {blocks} blocks");
    }

    /// The region's rows classified into masks in one pass ([`classify_rows`]: one-byte voxels by their
    /// table, or by its distinct bytes where a row's columns are consecutive) are each material's pixels as the
    /// classifier gives them voxel by voxel, on every voxel type, with columns clamped at the grid's edge
    /// as `build` clamps them (repeated first columns) and consecutive ones.
    #[test]
    fn rows_classified_into_masks_are_the_classifiers_materials_voxel_by_voxel() {
        use super::super::MaterialClass;
        use crate::volume::Voxels;
        let (dx, dy, dz) = (40usize, 5usize, 3usize);
        let n = dx * dy * dz;
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15u64);
        // Runs of one value (as label volumes have) and single voxels between them.
        let mut raw = Vec::with_capacity(n);
        while raw.len() < n {
            let (v, run) = (next() % 40, 1 + next() % 9);
            raw.extend(std::iter::repeat_n(v, run as usize));
        }
        raw.truncate(n);
        let volumes: Vec<(&str, Voxels)> = vec![
            ("u8", raw.iter().map(|&v| v as u8).collect::<Vec<u8>>().into()),
            ("i8", raw.iter().map(|&v| v as i8 - 20).collect::<Vec<i8>>().into()),
            ("u16", raw.iter().map(|&v| (v * 300) as u16).collect::<Vec<u16>>().into()),
            ("f32", raw.iter().map(|&v| v as f32 * 0.5).collect::<Vec<f32>>().into()),
        ];
        for (name, voxels) in volumes {
            let vol = Volume::new(std::path::Path::new(name), [dx, dy, dz], [1.0; 3], voxels).expect("a volume");
            let [lo, hi] = vol.value_range;
            let w = hi - lo;
            let mats = [
                MaterialClass::new([lo + 0.1 * w, lo + 0.3 * w], 0.5),
                MaterialClass::new([lo + 0.35 * w, lo + 0.38 * w], 0.5),
                MaterialClass::new([lo + 0.6 * w, hi], 0.5),
                MaterialClass::new([lo + 0.4 * w, lo + 0.5 * w], 0.0),
            ];
            let classifier = Classifier::new(&vol, &mats, 0.5, 1);
            // 30 columns from x = −4 (clamped to 0) to 25, as a brick's region at the grid's edge; 30
            // consecutive ones inside (the last rows' 32 bytes run past the voxels: read voxel by voxel).
            let edge: Vec<usize> = (-4isize..26).map(|x| x.clamp(0, dx as isize - 1) as usize).collect();
            let inner: Vec<usize> = (9..39).collect();
            let choices = [ByteRows::Choose, ByteRows::Values, ByteRows::Runs];
            for (xs, choice) in [edge, inner].into_iter().flat_map(|xs| choices.map(|c| (xs.clone(), c))) {
                let starts: Vec<usize> = (0..dz).flat_map(|z| (0..dy).map(move |y| dx * (y + dy * z))).collect();
                let rows = starts.len();
                let mut masks = vec![0u32; (classifier.materials + 1) * rows];
                crate::with_voxels!(&vol.voxels, data => {
                    classify_rows(data, &classifier, starts.iter().copied(), &xs, rows, &mut masks, choice)
                });
                let mut coded = [0usize; 5];
                for (r, &start) in starts.iter().enumerate() {
                    for (x, &at) in xs.iter().enumerate() {
                        let (ix, rest) = ((start + at) % dx, (start + at) / dx);
                        let want = classifier.material[classifier.bin(vol.at(ix, rest % dy, rest / dy))];
                        let want = usize::from(want);
                        coded[want] += 1;
                        // Code 0 (no material) is not read: the rows compared byte value by value leave it unset.
                        for code in 1..=classifier.materials {
                            let bit = masks[code * rows + r] >> x & 1 == 1;
                            assert_eq!(
                                bit,
                                code == want,
                                "{name} {choice:?}: row {r}, column {x}: code {code}, the classifier {want}"
                            );
                        }
                    }
                }
                // Every material but the transparent one, and no material, are met.
                assert!(coded[..4].iter().all(|&c| c > 0) && coded[4] == 0, "{name}: codes met {coded:?}");
            }
        }
    }

    #[test]
    fn ramp_is_monotone_and_half_at_the_boundary() {
        assert_eq!(ramp(-LABEL_RAMP), 1.0);
        assert_eq!(ramp(LABEL_RAMP), 0.0);
        assert!((ramp(0.0) - 0.5).abs() < 1e-6);
        assert!((ramp(0.2) + ramp(-0.2) - 1.0).abs() < 1e-6);
        assert!(ramp(0.1) < ramp(-0.1));
    }
}
