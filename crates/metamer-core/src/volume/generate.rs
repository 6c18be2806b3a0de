//! A deterministic generated volume that stands in for the GE engine CT scan, so the renderer's
//! embedded default needs no data files: an engine block (values ≈ 120–150) with two bores holding
//! pistons and a crankshaft (the "inner parts", ≈ 215–250), surrounded by noisy low-density "smoke"
//! (reconstruction noise, ≈ 20–70) in otherwise empty air (0), stored as 8-bit voxels like the scan.

use super::Volume;
use std::path::Path;

/// Value ranges of the generated engine's parts (inclusive), for scenes over it.
pub(crate) const SMOKE_RANGE: [f32; 2] = [18.0, 75.0];
pub(crate) const BLOCK_RANGE: [f32; 2] = [105.0, 175.0];
pub(crate) const INNER_RANGE: [f32; 2] = [200.0, 255.0];

/// An engine-like block of `size × size × size/2` voxels (size clamped to 16..=512), 8-bit values.
/// The same size always gives the same volume.
pub(crate) fn engine_like(size: usize) -> Volume {
    let n = size.clamp(16, 512);
    let dims = [n, n, (n / 2).max(8)];
    let data: Vec<u8> = engine_values(dims, |v| v.round().clamp(0.0, 255.0) as u8);
    // The generator only produces finite values in 0..=255 with matching sizes: this cannot fail.
    Volume::new(Path::new("generated:engine_like"), dims, [1.0; 3], data)
        .unwrap_or_else(|e| unreachable!("generated volume is consistent: {e}"))
}

/// Value scale of [`engine_like_u16`]: 8-bit value v becomes v × 257 (255 → 65535).
pub const U16_SCALE: f32 = 257.0;

/// The same engine-like block on any grid (each axis clamped to 16..=4096), as 16-bit values (the 8-bit
/// values × [`U16_SCALE`], before rounding, so the parts keep fine gradations): a large CT-like volume in
/// a modern scanner's type for the renderer's benchmark. The same dims always give the same volume.
pub fn engine_like_u16(dims: [usize; 3]) -> Volume {
    let dims = dims.map(|n| n.clamp(16, 4096));
    let data: Vec<u16> = engine_values(dims, |v| (v * f64::from(U16_SCALE)).round().clamp(0.0, 65535.0) as u16);
    Volume::new(Path::new("generated:engine_like_u16"), dims, [1.0; 3], data)
        .unwrap_or_else(|e| unreachable!("generated volume is consistent: {e}"))
}

/// The engine's values (0–255, unrounded) over `dims`, each turned into a voxel by `cast`; slices in
/// parallel, in order.
fn engine_values<T: Send>(dims: [usize; 3], cast: impl Fn(f64) -> T + Sync) -> Vec<T> {
    use rayon::prelude::*;
    let scale = [1.0 / (dims[0] - 1) as f64, 1.0 / (dims[1] - 1) as f64, 1.0 / (dims[2] - 1) as f64];
    // One voxel in normalised units along x, used to turn distances into coverage.
    let voxel = scale[0];
    let cover = |d: f64| (0.5 - d / voxel).clamp(0.0, 1.0);
    (0..dims[2])
        .into_par_iter()
        .flat_map_iter(|z| {
            let cast = &cast;
            (0..dims[1]).flat_map(move |y| {
                (0..dims[0]).map(move |x| {
                    let (u, v, w) = (x as f64 * scale[0], y as f64 * scale[1], z as f64 * scale[2]);
                    // Smoke: two octaves of value noise, kept only where it is dense enough.
                    let s = 0.65 * value_noise(u * 6.0, v * 6.0, w * 3.0, 1)
                        + 0.35 * value_noise(u * 14.0, v * 14.0, w * 7.0, 2);
                    // Block: a rounded box.
                    let block = rounded_box(u - 0.5, v - 0.5, (w - 0.5) * 0.5, [0.3, 0.24, 0.18], 0.04);
                    // Smoke hangs in a shell around the block, like reconstruction noise.
                    let s = s - 2.0 * (block - 0.08).max(0.0);
                    let smoke = if s > 0.55 { 20.0 + 100.0 * (s - 0.55) } else { 0.0 };
                    let mut val = smoke.min(70.0);
                    let grain = 12.0 * (hash3(x as i64, y as i64, z as i64, 7) - 0.5);
                    val = lerp(val, 135.0 + grain, cover(block));
                    // Two bores along z through the top of the block.
                    let bore = cylinder_z(u, v, [0.38, 0.5], 0.085)
                        .max(0.3 - w)
                        .min(cylinder_z(u, v, [0.62, 0.5], 0.085).max(0.3 - w));
                    val = lerp(val, 0.0, cover(bore));
                    // Pistons inside the bores, and a crankshaft along x below them.
                    let piston = cylinder_z(u, v, [0.38, 0.5], 0.055)
                        .max((w - 0.85).max(0.35 - w))
                        .min(cylinder_z(u, v, [0.62, 0.5], 0.055).max((w - 0.75).max(0.35 - w)));
                    let shaft = (((v - 0.5).powi(2) + ((w - 0.5) * 0.5 + 0.1).powi(2)).sqrt() - 0.035)
                        .max((u - 0.5).abs() - 0.42);
                    cast(lerp(val, 235.0 + 0.5 * grain, cover(piston.min(shaft))))
                })
            })
        })
        .collect()
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Signed distance to a box of half sizes `h` with rounded edges of radius `r`.
fn rounded_box(x: f64, y: f64, z: f64, h: [f64; 3], r: f64) -> f64 {
    let q = [x.abs() - h[0] + r, y.abs() - h[1] + r, z.abs() - h[2] + r];
    let outside = (q[0].max(0.0).powi(2) + q[1].max(0.0).powi(2) + q[2].max(0.0).powi(2)).sqrt();
    outside + q[0].max(q[1]).max(q[2]).min(0.0) - r
}

/// Signed distance to an infinite cylinder along z.
fn cylinder_z(u: f64, v: f64, c: [f64; 2], r: f64) -> f64 {
    ((u - c[0]).powi(2) + (v - c[1]).powi(2)).sqrt() - r
}

/// A hash of integer lattice coordinates into [0, 1) (SplitMix64 finaliser).
fn hash3(x: i64, y: i64, z: i64, seed: u64) -> f64 {
    let mut h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ (z as u64).wrapping_mul(0x1656_67B1_9E37_79F9)
        ^ seed.wrapping_mul(0xD6E8_FEB8_6659_FD93);
    h ^= h >> 30;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 27;
    h = h.wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^= h >> 31;
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Smooth value noise in [0, 1): lattice hashes blended with smoothstep weights.
fn value_noise(x: f64, y: f64, z: f64, seed: u64) -> f64 {
    let (ix, iy, iz) = (x.floor(), y.floor(), z.floor());
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let (fx, fy, fz) = (s(x - ix), s(y - iy), s(z - iz));
    let (ix, iy, iz) = (ix as i64, iy as i64, iz as i64);
    let mut acc = 0.0;
    for dz in 0..2 {
        for dy in 0..2 {
            for dx in 0..2 {
                let w = (if dx == 1 { fx } else { 1.0 - fx })
                    * (if dy == 1 { fy } else { 1.0 - fy })
                    * (if dz == 1 { fz } else { 1.0 - fz });
                acc += w * hash3(ix + dx, iy + dy, iz + dz, seed);
            }
        }
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::Voxels;

    #[test]
    fn engine_like_is_deterministic_and_has_all_parts() {
        let a = engine_like(48);
        let b = engine_like(48);
        assert_eq!(a, b);
        assert_eq!(a.dims, [48, 48, 24]);
        let Voxels::U8(data) = &a.voxels else { panic!("the generated engine is 8-bit") };
        let count = |r: [f32; 2]| data.iter().filter(|v| f32::from(**v) >= r[0] && f32::from(**v) <= r[1]).count();
        let total = a.len();
        // Each part covers a visible share of the volume (tolerances: loose bounds on the geometry).
        for (name, r, lo, hi) in
            [("smoke", SMOKE_RANGE, 0.01, 0.4), ("block", BLOCK_RANGE, 0.05, 0.5), ("inner", INNER_RANGE, 0.003, 0.1)]
        {
            let share = count(r) as f64 / total as f64;
            assert!(share > lo && share < hi, "{name} covers {share}");
        }
        assert_eq!(a.value_range[0], 0.0);
    }

    #[test]
    fn the_u16_engine_is_the_8_bit_one_scaled() {
        let a = engine_like(32);
        let b = engine_like_u16([32, 32, 16]);
        let (Voxels::U8(x), Voxels::U16(y)) = (&a.voxels, &b.voxels) else { panic!("u8 and u16") };
        assert_eq!(b.dims, a.dims);
        // The same value before rounding: within half an 8-bit step (and a rounding of each).
        for (p, q) in x.iter().zip(y.iter()) {
            assert!((f32::from(*q) / U16_SCALE - f32::from(*p)).abs() <= 0.51, "{p} vs {q}");
        }
        assert!(b.value_range[1] > 200.0 * U16_SCALE, "{:?}", b.value_range);
    }
}
