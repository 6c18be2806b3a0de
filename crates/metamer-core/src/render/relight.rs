//! Post-illumination (seed §2.2.2): the raycast image holds, per pixel, the composited reflectance in
//! one of three colour representations; a frame under light E is one 3×K matrix applied to every pixel.
//!
//! | mode | per-pixel channels (K) | frame matrix |
//! |---|---|---|
//! | `factor` | `s = B⁺S`, m coefficients | `Q_rgb,m · diag(e)`, `e = B⁺E` |
//! | `full` | the 31 samples of S | `Q_rgb,31 · diag(E)` (the reference) |
//! | `rgb` | `σ = Q_rgb,31 S` (reflectance under a flat white light) | `diag(ε / w)`, `ε = Q_rgb,31 E`, `w = Q_rgb,31 1` |
//!
//! Every matrix has one exposure folded in; the result is sRGB-encoded through a lookup table.

use crate::basis::Basis;
use crate::colorimetry::{Colorimetry, srgb_encode};
use crate::render::raycast::ChannelImage;
use crate::spectrum::{SAMPLES, Spectrum};

/// Which colour model carries the image from raycast to frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Mode {
    /// The m-dimensional spectral factor model (post-illumination by componentwise products).
    #[default]
    Factor,
    /// Full 31-sample spectra: the reference.
    Full,
    /// The RGB factor model (seed Eq. 13).
    Rgb,
}

impl Mode {
    /// The mode's name on the command line (`--mode`) and in reports: `factor`, `full` or `rgb`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Mode::Factor => "factor",
            Mode::Full => "full",
            Mode::Rgb => "rgb",
        }
    }

    /// The mode called `s` (see `Mode::as_str`); `None` for any other word.
    pub fn parse(s: &str) -> Option<Mode> {
        match s {
            "factor" => Some(Mode::Factor),
            "full" => Some(Mode::Full),
            "rgb" => Some(Mode::Rgb),
            _ => None,
        }
    }
}

/// A colour model ready to produce material vectors and frame matrices.
#[derive(Clone, Debug)]
pub struct ColourModel {
    /// Which of the three representations the image channels hold.
    pub mode: Mode,
    pub(crate) colorimetry: Colorimetry,
    /// The sharpened basis (factor mode only).
    pub basis: Option<Basis>,
}

/// The 3×K matrix of one frame, row-major, exposure included.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameMatrix {
    /// The number of image channels K it multiplies (m in factor mode, 31 in full, 3 in RGB).
    pub channels: usize,
    pub(crate) m: Vec<f32>,
}

impl ColourModel {
    /// The spectral factor model over `basis`.
    pub fn factor(colorimetry: Colorimetry, basis: Basis) -> ColourModel {
        ColourModel { mode: Mode::Factor, colorimetry, basis: Some(basis) }
    }

    /// The full-spectrum reference.
    pub fn full(colorimetry: Colorimetry) -> ColourModel {
        ColourModel { mode: Mode::Full, colorimetry, basis: None }
    }

    /// The RGB factor model.
    pub fn rgb(colorimetry: Colorimetry) -> ColourModel {
        ColourModel { mode: Mode::Rgb, colorimetry, basis: None }
    }

    /// Number of channels per pixel (K).
    pub fn channels(&self) -> usize {
        match (self.mode, &self.basis) {
            (Mode::Factor, Some(b)) => b.dimension(),
            (Mode::Factor, None) => 0,
            (Mode::Full, _) => SAMPLES,
            (Mode::Rgb, _) => 3,
        }
    }

    /// The channels a reflectance contributes to the raycast image.
    pub fn material_vector(&self, s: &Spectrum) -> Vec<f32> {
        match (self.mode, &self.basis) {
            (Mode::Factor, Some(b)) => b.coefficients(s).iter().map(|v| *v as f32).collect(),
            (Mode::Factor, None) => Vec::new(),
            (Mode::Full, _) => s.as_slice().iter().map(|v| *v as f32).collect(),
            (Mode::Rgb, _) => {
                let c = self.colorimetry.q_rgb * s.0;
                vec![c[0] as f32, c[1] as f32, c[2] as f32]
            }
        }
    }

    /// The frame matrix for light `e`, scaled by `exposure`.
    pub fn frame_matrix(&self, e: &Spectrum, exposure: f64) -> FrameMatrix {
        let q = &self.colorimetry.q_rgb;
        let rows: Vec<Vec<f64>> = match (self.mode, &self.basis) {
            (Mode::Factor, Some(b)) => {
                let ec = b.coefficients(e);
                (0..3).map(|r| (0..b.dimension()).map(|c| b.q_rgb_m[(r, c)] * ec[c]).collect()).collect()
            }
            (Mode::Factor, None) => vec![Vec::new(); 3],
            (Mode::Full, _) => (0..3).map(|r| (0..SAMPLES).map(|c| q[(r, c)] * e.0[c]).collect()).collect(),
            (Mode::Rgb, _) => {
                let eps = q * e.0;
                let w = q * Spectrum::flat(1.0).0;
                (0..3).map(|r| (0..3).map(|c| if r == c { eps[r] / w[r] } else { 0.0 }).collect()).collect()
            }
        };
        let m = rows.iter().flat_map(|r| r.iter().map(|v| (v * exposure) as f32)).collect();
        FrameMatrix { channels: self.channels(), m }
    }
}

/// Linear → 8-bit sRGB through a table of 2¹⁶ entries over [0, 1] (values outside are clamped). The
/// table's quantisation (1/65535 in linear) is below half an 8-bit code everywhere.
pub struct SrgbLut {
    /// Exactly [`SrgbLut::N`] entries: an index masked to `N − 1` needs no bounds check.
    table: Box<[u8; SrgbLut::N]>,
}

impl Default for SrgbLut {
    fn default() -> Self {
        SrgbLut::new()
    }
}

impl SrgbLut {
    const N: usize = 1 << 16;

    /// The plain sRGB table (display gamma 1).
    pub fn new() -> SrgbLut {
        SrgbLut::with_gamma(1.0)
    }

    /// A table with a display gamma: linear `x` is encoded as sRGB of `x^(1/gamma)` (gamma > 1 lifts
    /// dark values; 1, or anything not positive and finite, is plain sRGB).
    pub(crate) fn with_gamma(gamma: f64) -> SrgbLut {
        let g = if gamma.is_finite() && gamma > 0.0 { gamma } else { 1.0 };
        let mut table = Box::new([0u8; Self::N]);
        for (i, t) in table.iter_mut().enumerate() {
            let x = (i as f64 / (Self::N - 1) as f64).powf(1.0 / g);
            *t = (srgb_encode(x) * 255.0).round().clamp(0.0, 255.0) as u8;
        }
        SrgbLut { table }
    }

    /// Encode a linear RGB pixel. One brighter than white in some channel is first scaled down as a
    /// whole (hue and saturation kept, [`fit_to_white`]) instead of clipped channel by channel, which
    /// would turn an orange highlight yellow.
    #[inline(always)]
    pub(crate) fn encode_rgb(&self, rgb: [f32; 3]) -> [u8; 3] {
        fit_to_white(rgb).map(|c| self.encode(c))
    }

    #[inline(always)]
    pub(crate) fn encode(&self, v: f32) -> u8 {
        self.table[Self::index(v)]
    }

    /// The table entry of linear `v`: `((v.clamp(0, 1) · (N − 1) + 0.5) as usize).min(N − 1)` for every v,
    /// NaN included (0). Written as compare-and-select (what `maxps`/`minps` do, NaN going to 0 in the
    /// first), then the plain conversion instruction on [0.5, 65535.5] (the saturating `as usize` costs a
    /// dozen instructions, three times per pixel and frame) and a mask that keeps the index in the table
    /// without a bounds check.
    #[inline(always)]
    fn index(v: f32) -> usize {
        let x = if v > 0.0 { v } else { 0.0 };
        let x = if x < 1.0 { x } else { 1.0 };
        let x = x * (Self::N - 1) as f32 + 0.5;
        // SAFETY: x is finite and in [0.5, 65535.5], in range for u32.
        (unsafe { x.to_int_unchecked::<u32>() }) as usize & (Self::N - 1)
    }
}

/// A linear RGB pixel scaled so that its largest channel is at most 1 (unchanged when it already is).
#[inline(always)]
pub(crate) fn fit_to_white(rgb: [f32; 3]) -> [f32; 3] {
    let m = rgb[0].max(rgb[1]).max(rgb[2]);
    // Rare in an exposed frame, so the branch is well predicted and the common pixel pays two maxima.
    if m > 1.0 {
        let k = 1.0 / m;
        [rgb[0] * k, rgb[1] * k, rgb[2] * k]
    } else {
        rgb
    }
}

/// Apply a frame matrix to every pixel: linear RGB, 3 values per pixel.
pub(crate) fn relight_linear(image: &ChannelImage, frame: &FrameMatrix) -> Vec<f32> {
    let mut out = vec![0f32; image.width * image.height * 3];
    relight_with(image, frame, |i, rgb| out[3 * i..3 * i + 3].copy_from_slice(&rgb));
    out
}

/// Per pixel the brightest channel of its linear RGB (as [`relight_linear`] gives it), NaN and infinite
/// pixels left out, into `out` (cleared first). Without the intermediate RGB image: the exposure looks at
/// up to 17 frames, and each one's fresh 3-float-per-pixel buffer was faulted in page by page.
pub(crate) fn relight_peaks(image: &ChannelImage, frame: &FrameMatrix, out: &mut Vec<f32>) {
    out.clear();
    relight_with(image, frame, |_, c| {
        let v = c[0].max(c[1]).max(c[2]);
        if v.is_finite() {
            out.push(v);
        }
    });
}

/// Apply a frame matrix to every pixel and sRGB-encode into `out` (3 bytes per pixel).
pub fn relight_srgb8(image: &ChannelImage, frame: &FrameMatrix, lut: &SrgbLut, out: &mut [u8]) {
    assert_eq!(image.channels, frame.channels, "image and frame matrix disagree on the channel count");
    match image.channels {
        3 => encode_kernel::<3>(image, frame, lut, out, lanes8()),
        5 => encode_kernel::<5>(image, frame, lut, out, lanes8()),
        6 => encode_kernel::<6>(image, frame, lut, out, lanes8()),
        7 => encode_kernel::<7>(image, frame, lut, out, lanes8()),
        8 => encode_kernel::<8>(image, frame, lut, out, lanes8()),
        SAMPLES => encode_kernel::<SAMPLES>(image, frame, lut, out, lanes8()),
        _ => relight_with(image, frame, |i, rgb| out[3 * i..3 * i + 3].copy_from_slice(&lut.encode_rgb(rgb))),
    }
}

/// Whether [`encode_kernel`] may relight eight pixels at once in AVX2 lanes (runtime detection: the
/// portable build runs anywhere).
fn lanes8() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The relight + encode loop for K channels, free of per-pixel bounds checks. With `lanes8` (AVX2
/// present) whole runs are relit eight pixels at once ([`avx2::encode_run`]), to the same bytes.
fn encode_kernel<const K: usize>(
    image: &ChannelImage,
    frame: &FrameMatrix,
    lut: &SrgbLut,
    out: &mut [u8],
    lanes8: bool,
) {
    // The frame matrix by columns, its three rows in four lanes (the fourth 0): a pixel's colour is K
    // multiply-adds of a column by one channel on four lanes at once (the compiler's vector
    // instructions), each lane added up in the order of its row's dot product, so the colour is the
    // same to the bit.
    let mut col = [[0f32; 4]; K];
    for (c, lanes) in col.iter_mut().enumerate() {
        for (r, lane) in lanes[..3].iter_mut().enumerate() {
            *lane = frame.m[r * K + c];
        }
    }
    let relit = |px: &[f32]| {
        let px: &[f32; K] = px.try_into().unwrap_or(&[0.0; K]);
        let mut acc = [0f32; 4];
        for (c, lanes) in col.iter().enumerate() {
            for (a, m) in acc.iter_mut().zip(lanes) {
                *a += m * px[c];
            }
        }
        acc
    };
    // Runs of pixels are encoded channel by channel while their brightest channel is tracked; the rare
    // run holding a pixel brighter than white is encoded again with its hue kept (`encode_rgb`). The
    // common pixel so pays three maxima, not a per-pixel test and reciprocal.
    const RUN: usize = 64;
    #[cfg(target_arch = "x86_64")]
    let rows: [[f32; K]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| frame.m[r * K + c]));
    for (i, (run, o_run)) in image.data.chunks(K * RUN).zip(out.chunks_mut(3 * RUN)).enumerate() {
        // Per lane the brightest value of the run (a NaN never replaces it, as with `f32::max`).
        let mut hi = [0f32; 4];
        // The eight-pixel loads read up to `avx2::SLACK` floats past a run's last pixel: the run is
        // taken in lanes only when they are inside the image.
        #[cfg(target_arch = "x86_64")]
        let in_lanes = lanes8
            && run.len() == K * RUN
            && o_run.len() == 3 * RUN
            && (i + 1) * K * RUN + avx2::slack(K) <= image.data.len();
        // Elsewhere the portable loop only (`lanes8` is false there, `i` unused).
        #[cfg(not(target_arch = "x86_64"))]
        let in_lanes = {
            let _ = (lanes8, i);
            false
        };
        if in_lanes {
            #[cfg(target_arch = "x86_64")]
            {
                // SAFETY: AVX2 is present (`lanes8`), the run is whole and its loads stay in the image.
                hi[0] = unsafe { avx2::encode_run::<K>(&rows, &image.data[i * K * RUN..], lut, o_run) };
            }
        } else {
            for (px, o) in run.chunks_exact(K).zip(o_run.chunks_exact_mut(3)) {
                let rgb = relit(px);
                for (h, v) in hi.iter_mut().zip(rgb) {
                    *h = if v > *h { v } else { *h };
                }
                o[0] = lut.encode(rgb[0]);
                o[1] = lut.encode(rgb[1]);
                o[2] = lut.encode(rgb[2]);
            }
        }
        if hi[0].max(hi[1]).max(hi[2]) > 1.0 {
            for (px, o) in run.chunks_exact(K).zip(o_run.chunks_exact_mut(3)) {
                let c = relit(px);
                o.copy_from_slice(&lut.encode_rgb([c[0], c[1], c[2]]));
            }
        }
    }
}

/// Eight pixels at a time in AVX2 lanes, lane j holding pixel j: each lane does its pixel's K
/// multiply-adds in the portable kernel's order (a product then a sum, no fused multiply-add), so every
/// colour is the same to the bit; the pixels' channels come from eight unaligned loads and an 8×8
/// transpose per block of eight channels, instead of one pixel's channels on four lanes.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::SrgbLut;
    use std::arch::x86_64::*;

    /// How many floats past the last pixel of a group the loads of K channels read (the last pixel's
    /// last block of eight channels).
    pub(super) const fn slack(k: usize) -> usize {
        k.div_ceil(8) * 8 - k
    }

    /// Relight and encode the 64 pixels at the start of `data` (64·K floats, then at least `slack(K)`
    /// more) into `out` (192 bytes); returns the brightest linear value of the run (NaN left out, 0 at
    /// least), which the caller compares with 1 as it does the portable kernel's.
    ///
    /// # Safety
    /// AVX2 must be present; `data.len() >= 64·K + slack(K)` and `out.len() >= 192`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn encode_run<const K: usize>(
        rows: &[[f32; K]; 3],
        data: &[f32],
        lut: &SrgbLut,
        out: &mut [u8],
    ) -> f32 {
        debug_assert!(data.len() >= 64 * K + slack(K) && out.len() >= 192);
        let zero = _mm256_setzero_ps();
        let mut hi = [zero; 3];
        let p = data.as_ptr();
        for g in 0..8 {
            // Eight pixels whose channels are all +0.0 (the background a ray never met) are black: each
            // colour is a sum of products with +0.0, ±0.0, whose table entry is the first (`index8`), and
            // which leaves the brightest values as they were. Their 8·K floats are tested with K/8 loads
            // instead of relit: a third of the engine CT's pixels at 384².
            // SAFETY: the group's 8·K floats end at 8(g + 1)·K ≤ 64·K ≤ data.len().
            if unsafe { zero_floats(p.add(g * 8 * K), 8 * K) } {
                out[g * 24..g * 24 + 24].fill(lut.table[0]);
                continue;
            }
            // SAFETY: group g's loads end at 8g·K + 7K + 8·⌈K/8⌉ ≤ 64·K + slack(K) ≤ data.len().
            let acc = unsafe { relit8::<K>(rows, p.add(g * 8 * K)) };
            let mut idx = [[0i32; 8]; 3];
            for ((h, a), ix) in hi.iter_mut().zip(acc).zip(idx.iter_mut()) {
                // `max(v, h)` keeps h when v is NaN or not larger: the portable `if v > h { v } else { h }`.
                *h = _mm256_max_ps(a, *h);
                let i = index8(a);
                // SAFETY: `ix` is eight i32.
                unsafe { _mm256_storeu_si256(ix.as_mut_ptr().cast(), i) };
            }
            let o = &mut out[g * 24..g * 24 + 24];
            for j in 0..8 {
                for r in 0..3 {
                    o[3 * j + r] = lut.table[idx[r][j] as usize & (SrgbLut::N - 1)];
                }
            }
        }
        let mut lanes = [[0f32; 8]; 3];
        for (l, h) in lanes.iter_mut().zip(hi) {
            // SAFETY: `l` is eight f32.
            unsafe { _mm256_storeu_ps(l.as_mut_ptr(), h) };
        }
        lanes.iter().flatten().fold(0f32, |m, v| if *v > m { *v } else { m })
    }

    /// Whether the `n` floats at `p` (a multiple of 8) are all +0.0, bit for bit (−0.0 and NaN are not).
    ///
    /// # Safety
    /// AVX2 must be present; `p` must be readable for `n` floats.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn zero_floats(p: *const f32, n: usize) -> bool {
        debug_assert!(n.is_multiple_of(8));
        let mut any = _mm256_setzero_si256();
        for i in (0..n).step_by(8) {
            // SAFETY: floats i..i + 8 are below n.
            any = _mm256_or_si256(any, unsafe { _mm256_loadu_si256(p.add(i).cast()) });
        }
        _mm256_testz_si256(any, any) == 1
    }

    /// The linear colours of the eight pixels at `p` (K channels each), row by row: lane j is pixel j's
    /// `Σ_c m[r][c] · px[c]` summed from c = 0 with a product and a sum rounded apart, as the portable
    /// kernel does.
    ///
    /// # Safety
    /// AVX2 must be present; `p` must be readable for `7·K + 8·⌈K/8⌉` floats.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn relit8<const K: usize>(rows: &[[f32; K]; 3], p: *const f32) -> [__m256; 3] {
        let mut acc = [_mm256_setzero_ps(); 3];
        for b in 0..K.div_ceil(8) {
            // SAFETY: pixel j's block b ends at j·K + 8b + 8 ≤ 7·K + 8·⌈K/8⌉.
            let r: [__m256; 8] = std::array::from_fn(|j| unsafe { _mm256_loadu_ps(p.add(j * K + 8 * b)) });
            let t0 = _mm256_unpacklo_ps(r[0], r[1]);
            let t1 = _mm256_unpackhi_ps(r[0], r[1]);
            let t2 = _mm256_unpacklo_ps(r[2], r[3]);
            let t3 = _mm256_unpackhi_ps(r[2], r[3]);
            let t4 = _mm256_unpacklo_ps(r[4], r[5]);
            let t5 = _mm256_unpackhi_ps(r[4], r[5]);
            let t6 = _mm256_unpacklo_ps(r[6], r[7]);
            let t7 = _mm256_unpackhi_ps(r[6], r[7]);
            let s0 = _mm256_shuffle_ps::<0x44>(t0, t2);
            let s1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
            let s2 = _mm256_shuffle_ps::<0x44>(t1, t3);
            let s3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
            let s4 = _mm256_shuffle_ps::<0x44>(t4, t6);
            let s5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
            let s6 = _mm256_shuffle_ps::<0x44>(t5, t7);
            let s7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
            // Channel 8b + j of the eight pixels.
            let ch = [
                _mm256_permute2f128_ps::<0x20>(s0, s4),
                _mm256_permute2f128_ps::<0x20>(s1, s5),
                _mm256_permute2f128_ps::<0x20>(s2, s6),
                _mm256_permute2f128_ps::<0x20>(s3, s7),
                _mm256_permute2f128_ps::<0x31>(s0, s4),
                _mm256_permute2f128_ps::<0x31>(s1, s5),
                _mm256_permute2f128_ps::<0x31>(s2, s6),
                _mm256_permute2f128_ps::<0x31>(s3, s7),
            ];
            for (j, v) in ch.iter().enumerate().take(K.saturating_sub(8 * b).min(8)) {
                let c = 8 * b + j;
                for (a, row) in acc.iter_mut().zip(rows) {
                    *a = _mm256_add_ps(*a, _mm256_mul_ps(_mm256_set1_ps(row[c]), *v));
                }
            }
        }
        acc
    }

    /// [`SrgbLut::index`] in lanes: max and min with the operand order that sends NaN to 0 (`maxps`
    /// returns its second operand when either is NaN), a product and a sum rounded apart, truncation and
    /// the mask.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) fn index8(v: __m256) -> __m256i {
        let x = _mm256_min_ps(_mm256_max_ps(v, _mm256_setzero_ps()), _mm256_set1_ps(1.0));
        let x = _mm256_add_ps(_mm256_mul_ps(x, _mm256_set1_ps((SrgbLut::N - 1) as f32)), _mm256_set1_ps(0.5));
        _mm256_and_si256(_mm256_cvttps_epi32(x), _mm256_set1_epi32((SrgbLut::N - 1) as i32))
    }
}

fn relight_with(image: &ChannelImage, frame: &FrameMatrix, sink: impl FnMut(usize, [f32; 3])) {
    assert_eq!(image.channels, frame.channels, "image and frame matrix disagree on the channel count");
    match image.channels {
        3 => kernel::<3>(image, frame, sink),
        5 => kernel::<5>(image, frame, sink),
        6 => kernel::<6>(image, frame, sink),
        7 => kernel::<7>(image, frame, sink),
        8 => kernel::<8>(image, frame, sink),
        SAMPLES => kernel::<SAMPLES>(image, frame, sink),
        _ => kernel_dyn(image, frame, sink),
    }
}

#[inline(always)]
fn kernel<const K: usize>(image: &ChannelImage, frame: &FrameMatrix, mut sink: impl FnMut(usize, [f32; 3])) {
    let mut m = [[0f32; K]; 3];
    for (r, row) in m.iter_mut().enumerate() {
        row.copy_from_slice(&frame.m[r * K..(r + 1) * K]);
    }
    for (i, px) in image.data.chunks_exact(K).enumerate() {
        let mut rgb = [0f32; 3];
        for (r, row) in m.iter().enumerate() {
            let mut acc = 0f32;
            for c in 0..K {
                acc += row[c] * px[c];
            }
            rgb[r] = acc;
        }
        sink(i, rgb);
    }
}

fn kernel_dyn(image: &ChannelImage, frame: &FrameMatrix, mut sink: impl FnMut(usize, [f32; 3])) {
    let k = image.channels.max(1);
    for (i, px) in image.data.chunks_exact(k).enumerate() {
        let mut rgb = [0f32; 3];
        for (r, v) in rgb.iter_mut().enumerate() {
            *v = frame.m[r * k..(r + 1) * k].iter().zip(px).map(|(a, b)| a * b).sum();
        }
        sink(i, rgb);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::raycast::MaterialWeights;
    use nalgebra::DMatrix;

    #[test]
    fn the_lut_index_is_the_clamped_saturating_one() {
        let lut = SrgbLut::with_gamma(2.2);
        let n = SrgbLut::N;
        let reference = |v: f32| lut.table[((v.clamp(0.0, 1.0) * (n - 1) as f32 + 0.5) as usize).min(n - 1)];
        let mut values = vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -0.0, -1e-30, 1.0, 1.0 + f32::EPSILON, 7.5];
        values.extend((0..=4 * n as u32).map(|i| i as f32 / (4 * (n - 1)) as f32));
        values.extend((0..1000).map(|i| -1.0 + i as f32 * 0.003));
        for v in values {
            assert_eq!(lut.encode(v), reference(v), "{v}");
        }
    }

    #[test]
    fn full_and_rgb_models_match_their_definitions() {
        let col = Colorimetry::cie1931_srgb();
        let s = Spectrum::colorchecker("moderate_red").unwrap();
        let e = Spectrum::illuminant("A").unwrap();
        let want = col.rgb(&e, &s);
        for model in [ColourModel::full(col.clone())] {
            let img = ChannelImage { width: 1, height: 1, channels: model.channels(), data: model.material_vector(&s) };
            let got = relight_linear(&img, &model.frame_matrix(&e, 2.0));
            for c in 0..3 {
                assert!((f64::from(got[c]) - 2.0 * want[c]).abs() < 1e-5, "{got:?} vs {want:?}");
            }
        }
        // RGB factor model: σ ε / w per channel.
        let rgb = ColourModel::rgb(col.clone());
        let img = ChannelImage { width: 1, height: 1, channels: 3, data: rgb.material_vector(&s) };
        let got = relight_linear(&img, &rgb.frame_matrix(&e, 1.0));
        let (sig, eps, w) = (col.q_rgb * s.0, col.q_rgb * e.0, col.q_rgb * Spectrum::flat(1.0).0);
        for c in 0..3 {
            assert!((f64::from(got[c]) - sig[c] * eps[c] / w[c]).abs() < 1e-5);
        }
    }

    #[test]
    fn factor_model_is_exact_for_a_box_basis_on_band_constant_spectra() {
        // A basis of disjoint bands multiplies exactly (B_j ∘ B_k = δ_jk B_j); spectra constant on each
        // band lie in its span, so the factor model must reproduce the full colour (tolerance: f32).
        let col = Colorimetry::cie1931_srgb();
        let bands = [0usize, 5, 10, 15, 20, 25, 31];
        let b = DMatrix::from_fn(SAMPLES, 6, |r, c| if r >= bands[c] && r < bands[c + 1] { 1.0 } else { 0.0 });
        let basis = Basis::from_matrix(b, &col).unwrap();
        let band = |vals: [f64; 6]| {
            Spectrum::from_slice(
                &(0..SAMPLES).map(|i| vals[(0..6).rfind(|c| i >= bands[*c]).unwrap()]).collect::<Vec<_>>(),
            )
            .unwrap()
        };
        let s = band([0.1, 0.4, 0.8, 0.3, 0.6, 0.9]);
        let e = band([0.5, 1.0, 1.5, 1.2, 0.8, 0.7]);
        let model = ColourModel::factor(col.clone(), basis);
        let w = MaterialWeights { width: 1, height: 1, materials: 1, data: vec![0.7] };
        let img = w.project(&[model.material_vector(&s)]);
        let got = relight_linear(&img, &model.frame_matrix(&e, 1.0));
        let want = col.rgb(&e, &s) * 0.7;
        for c in 0..3 {
            assert!((f64::from(got[c]) - want[c]).abs() < 1e-5, "{got:?} vs {want:?}");
        }
    }

    #[test]
    fn encoded_relight_equals_encoding_the_linear_relight() {
        let lut = SrgbLut::new();
        for k in [3usize, 4, 7, 31] {
            let data: Vec<f32> = (0..k * 50).map(|i| ((i * 7919) % 1000) as f32 / 1000.0).collect();
            let image = ChannelImage { width: 10, height: 5, channels: k, data };
            let frame = FrameMatrix {
                channels: k,
                m: (0..3 * k).map(|i| ((i * 31) % 17) as f32 / (17.0 * k as f32)).collect(),
            };
            let linear = relight_linear(&image, &frame);
            let mut out = vec![0u8; 150];
            relight_srgb8(&image, &frame, &lut, &mut out);
            let want: Vec<u8> = linear.chunks(3).flat_map(|p| lut.encode_rgb([p[0], p[1], p[2]])).collect();
            assert_eq!(out, want, "K = {k}");
        }
    }

    /// The eight-lane kernel against the portable one, byte for byte, on every K it is built for, on
    /// images of odd sizes (partial runs, runs whose loads would leave the image) with values below 0,
    /// above 1 (runs encoded again with the hue kept), NaN and infinities, and groups of eight black
    /// pixels (all +0.0, which the lanes do not relight) beside groups holding a −0.0.
    #[test]
    fn the_eight_lane_kernel_gives_the_portable_bytes() {
        if !lanes8() {
            eprintln!("no AVX2 here: only the portable kernel runs");
            return;
        }
        // The sRGB table with every entry moved by 7, so that black is not byte 0 and a black group
        // written with any byte but the table's first fails.
        let mut lut = SrgbLut::new();
        lut.table.iter_mut().for_each(|t| *t = t.wrapping_add(7));
        // One K's kernel, with or without the lanes.
        type Kernel<'a> = dyn Fn(&ChannelImage, &FrameMatrix, &mut [u8], bool) + 'a;
        let check = |k: usize, n: usize, seed: u64, run: &Kernel| {
            let mut x = seed;
            let mut next = move || {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (x >> 40) as f32 / (1u64 << 24) as f32
            };
            // Most runs of 64 pixels stay below white (so the lanes' bytes are what is compared); one
            // pixel in every other run is NaN, infinite or too bright, which sends its run to the
            // hue-keeping encoding; channels below 0 anywhere.
            let data: Vec<f32> = (0..k * n)
                .map(|i| {
                    let (p, c) = (i / k, i % k);
                    match ((p / 64) % 8, p % 64 == 17 && c == 0) {
                        (1, true) => f32::NAN,
                        (3, true) => f32::INFINITY,
                        (5, true) => 9.0,
                        _ if (p / 8) % 5 == 2 => 0.0,
                        _ if (p / 8) % 13 == 6 => {
                            if p % 8 == 3 && c == k - 1 {
                                -0.0
                            } else {
                                0.0
                            }
                        }
                        _ if i % 97 == 41 => -0.5,
                        _ => next(),
                    }
                })
                .collect();
            let image = ChannelImage { width: n, height: 1, channels: k, data };
            let frame = FrameMatrix { channels: k, m: (0..3 * k).map(|_| (next() - 0.2) / k as f32).collect() };
            let (mut a, mut b) = (vec![0u8; 3 * n], vec![1u8; 3 * n]);
            run(&image, &frame, &mut a, false);
            run(&image, &frame, &mut b, true);
            assert_eq!(a, b, "K = {k}, {n} pixels");
        };
        for n in [1usize, 63, 64, 65, 128, 130, 1000, 4096 + 7] {
            for seed in 0..3 {
                check(3, n, seed, &|i, f, o, l| encode_kernel::<3>(i, f, &lut, o, l));
                check(5, n, seed, &|i, f, o, l| encode_kernel::<5>(i, f, &lut, o, l));
                check(6, n, seed, &|i, f, o, l| encode_kernel::<6>(i, f, &lut, o, l));
                check(7, n, seed, &|i, f, o, l| encode_kernel::<7>(i, f, &lut, o, l));
                check(8, n, seed, &|i, f, o, l| encode_kernel::<8>(i, f, &lut, o, l));
                check(SAMPLES, n, seed, &|i, f, o, l| encode_kernel::<SAMPLES>(i, f, &lut, o, l));
            }
        }
    }

    /// The lanes' linear colours are the portable kernel's to the bit (the bytes alone would hide a
    /// fused multiply-add: the table's steps are coarser than one rounding), on every K, and the lanes'
    /// table index is `SrgbLut::index` on every kind of value.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_eight_lanes_relight_and_index_to_the_portable_bits() {
        use std::arch::x86_64::*;
        if !lanes8() {
            eprintln!("no AVX2 here: only the portable kernel runs");
            return;
        }
        fn check<const K: usize>() {
            let n = 24;
            let data: Vec<f32> = (0..K * n + 8).map(|i| ((i * 7919 + 13) % 1009) as f32 / 997.0 - 0.1).collect();
            let m: Vec<f32> = (0..3 * K).map(|i| ((i * 31 + 7) % 17) as f32 / (13.0 * K as f32) - 0.01).collect();
            let rows: [[f32; K]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| m[r * K + c]));
            let image = ChannelImage { width: n, height: 1, channels: K, data: data[..K * n].to_vec() };
            let want = relight_linear(&image, &FrameMatrix { channels: K, m });
            for g in 0..n / 8 {
                // SAFETY: AVX2 is present; 8 spare floats follow the last pixel.
                let acc = unsafe { avx2::relit8::<K>(&rows, data.as_ptr().add(g * 8 * K)) };
                for (r, a) in acc.iter().enumerate() {
                    let mut lanes = [0f32; 8];
                    // SAFETY: eight f32.
                    unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), *a) };
                    for (j, v) in lanes.iter().enumerate() {
                        assert_eq!(v.to_bits(), want[3 * (8 * g + j) + r].to_bits(), "K = {K}, pixel {}", 8 * g + j);
                    }
                }
            }
        }
        check::<3>();
        check::<5>();
        check::<6>();
        check::<7>();
        check::<8>();
        check::<SAMPLES>();
        let mut values = vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -0.0, 0.0, 1.0, -1.0, 7.0, f32::MIN_POSITIVE];
        values.extend((0..200_000).map(|i| i as f32 / 180_000.0 - 0.05));
        for chunk in values.chunks_exact(8) {
            let mut got = [0i32; 8];
            // SAFETY: AVX2 is present; eight f32 in, eight i32 out.
            unsafe {
                let v = _mm256_loadu_ps(chunk.as_ptr());
                _mm256_storeu_si256(got.as_mut_ptr().cast(), avx2::index8(v));
            }
            for (g, v) in got.iter().zip(chunk) {
                assert_eq!(*g as usize, SrgbLut::index(*v), "{v}");
            }
        }
    }

    #[test]
    fn a_pixel_brighter_than_white_keeps_its_hue() {
        let lut = SrgbLut::new();
        // Clipped per channel this would be (255, 255, encode(0.2)): yellow instead of orange.
        assert_eq!(lut.encode_rgb([1.6, 0.8, 0.2]), [255, lut.encode(0.5), lut.encode(0.125)]);
        assert_eq!(lut.encode_rgb([0.9, 0.5, 0.1]), [lut.encode(0.9), lut.encode(0.5), lut.encode(0.1)]);
        // In the whole frame path too (K = 3, identity matrix, brightened).
        let image = ChannelImage { width: 1, height: 1, channels: 3, data: vec![1.6, 0.8, 0.2] };
        let frame = FrameMatrix { channels: 3, m: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0] };
        let mut out = [0u8; 3];
        relight_srgb8(&image, &frame, &lut, &mut out);
        assert_eq!(out, lut.encode_rgb([1.6, 0.8, 0.2]));
    }

    #[test]
    fn srgb_lut_matches_the_transfer_function() {
        let lut = SrgbLut::new();
        for i in 0..=1000 {
            let v = i as f64 / 1000.0;
            let exact = (srgb_encode(v) * 255.0).round() as i32;
            assert!((i32::from(lut.encode(v as f32)) - exact).abs() <= 1, "{v}");
        }
        assert_eq!(lut.encode(-1.0), 0);
        assert_eq!(lut.encode(f32::NAN), 0);
        assert_eq!(lut.encode(7.0), 255);
    }
}
