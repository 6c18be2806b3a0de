//! The colour pipeline of DESIGN_SPEC §1: `Q_xyz,31`, `Q_rgb,31`, sRGB transfer functions,
//! CIELAB against a light's white and CIEDE2000 (from the `palette` crate).

use crate::spectrum::{SAMPLES, Samples, Spectrum, tables};
use nalgebra::{Matrix3, SMatrix, Vector3};
use palette::color_difference::Ciede2000;

/// 3×31 matrix taking a colour signal to a tristimulus.
pub(crate) type Q31 = SMatrix<f64, 3, SAMPLES>;

/// The observer and display: CIE 1931 2° point-sampled, linear sRGB (IEC 61966-2-1).
#[derive(Clone, Debug, PartialEq)]
pub struct Colorimetry {
    /// `Q_xyz,31 = CMFᵀ / Σ ȳ`: a flat light on a flat reflectance gives Y = 1.
    pub q_xyz: Q31,
    /// `Q_rgb,31 = Q_rgb,xyz · Q_xyz,31`.
    pub q_rgb: Q31,
    /// XYZ → linear sRGB.
    pub xyz_to_rgb: Matrix3<f64>,
    /// Linear sRGB → XYZ (inverse of the above).
    pub rgb_to_xyz: Matrix3<f64>,
}

impl Default for Colorimetry {
    fn default() -> Self {
        Colorimetry::cie1931_srgb()
    }
}

impl Colorimetry {
    /// The pipeline pinned by DESIGN_SPEC §1.
    pub(crate) fn cie1931_srgb() -> Colorimetry {
        let cmf = &tables::CIE1931_2DEG;
        let y_sum: f64 = cmf[1].iter().sum();
        let q_xyz = Q31::from_fn(|r, c| cmf[r][c] / y_sum);
        let m = &tables::XYZ_TO_LINEAR_SRGB;
        let xyz_to_rgb = Matrix3::from_fn(|r, c| m[r][c]);
        // The published matrix is invertible (det ≈ 0.33); fall back to identity never happens in practice.
        let rgb_to_xyz = xyz_to_rgb.try_inverse().unwrap_or_else(Matrix3::identity);
        Colorimetry { q_xyz, q_rgb: xyz_to_rgb * q_xyz, xyz_to_rgb, rgb_to_xyz }
    }

    /// The Y row of `Q_xyz,31` (luminance weights).
    pub fn luminance(&self) -> Samples {
        self.q_xyz.row(1).transpose()
    }

    /// XYZ of a colour signal.
    pub fn xyz_of_signal(&self, signal: &Spectrum) -> Vector3<f64> {
        self.q_xyz * signal.0
    }

    /// Linear sRGB of a colour signal.
    pub(crate) fn rgb_of_signal(&self, signal: &Spectrum) -> Vector3<f64> {
        self.q_rgb * signal.0
    }

    /// Linear sRGB of light `e` on reflectance `s`: `Q_rgb,31 (E ∘ S)`.
    pub fn rgb(&self, e: &Spectrum, s: &Spectrum) -> Vector3<f64> {
        self.q_rgb * e.0.component_mul(&s.0)
    }

    /// XYZ of light `e` on reflectance `s`.
    pub fn xyz(&self, e: &Spectrum, s: &Spectrum) -> Vector3<f64> {
        self.q_xyz * e.0.component_mul(&s.0)
    }

    /// XYZ of a linear sRGB colour.
    pub fn rgb_to_xyz(&self, rgb: &Vector3<f64>) -> Vector3<f64> {
        self.rgb_to_xyz * rgb
    }

    /// The CIELAB reference white under `light`: the light on a flat reflectance of 1 (DESIGN_SPEC §1).
    /// A light without luminance (Y ≤ [`DARK_LIGHT_Y`], e.g. an all-zero light) has no white of its own —
    /// CIELAB against it would map every colour to L = 0 and call any error 0 — so it falls back to the
    /// sRGB display white (linear RGB [1, 1, 1], Y = 1), the scale on which targets are written.
    pub fn reference_white(&self, light: &Spectrum) -> Vector3<f64> {
        let white = self.xyz_of_signal(light);
        if white.iter().all(|v| v.is_finite()) && white[1] > DARK_LIGHT_Y {
            white
        } else {
            self.rgb_to_xyz(&Vector3::new(1.0, 1.0, 1.0))
        }
    }

    /// CIELAB of a linear sRGB colour against the white of `light` ([`Colorimetry::reference_white`]).
    pub fn lab_under(&self, rgb: &Vector3<f64>, light: &Spectrum) -> [f64; 3] {
        xyz_to_lab(&self.rgb_to_xyz(rgb), &self.reference_white(light))
    }

    /// CIEDE2000 between two linear sRGB colours seen under `light` (reference white:
    /// [`Colorimetry::reference_white`]).
    pub fn delta_e00_under(&self, a: &Vector3<f64>, b: &Vector3<f64>, light: &Spectrum) -> f64 {
        self.delta_e00_against(a, b, &self.reference_white(light))
    }

    /// [`Colorimetry::delta_e00_under`] with the light's white given (`reference_white(light)`): a caller
    /// with many colours under few lights finds each white once.
    pub(crate) fn delta_e00_against(&self, a: &Vector3<f64>, b: &Vector3<f64>, white: &Vector3<f64>) -> f64 {
        delta_e00(xyz_to_lab(&self.rgb_to_xyz(a), white), xyz_to_lab(&self.rgb_to_xyz(b), white))
    }
}

/// Lights whose white has a luminance Y at or below this have no usable CIELAB white of their own.
pub(crate) const DARK_LIGHT_Y: f64 = 1e-12;

/// sRGB transfer function: linear → display (IEC 61966-2-1). Negative input maps to negative output
/// (odd extension) so out-of-gamut values stay ordered.
pub fn srgb_encode(linear: f64) -> f64 {
    let a = linear.abs();
    let v = if a <= 0.0031308 { 12.92 * a } else { 1.055 * a.powf(1.0 / 2.4) - 0.055 };
    v.copysign(linear)
}

/// sRGB transfer function: display → linear (IEC 61966-2-1), odd-extended for negative input.
pub fn srgb_decode(encoded: f64) -> f64 {
    let a = encoded.abs();
    let v = if a <= 0.04045 { a / 12.92 } else { ((a + 0.055) / 1.055).powf(2.4) };
    v.copysign(encoded)
}

/// Parse `"#rrggbb"` (display sRGB) into linear sRGB. `None` when malformed.
pub fn hex_to_linear(hex: &str) -> Option<Vector3<f64>> {
    let h = hex.strip_prefix('#')?;
    if h.len() != 6 || !h.chars().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    let byte = |i: usize| u8::from_str_radix(&h[i..i + 2], 16).ok();
    Some(Vector3::new(
        srgb_decode(f64::from(byte(0)?) / 255.0),
        srgb_decode(f64::from(byte(2)?) / 255.0),
        srgb_decode(f64::from(byte(4)?) / 255.0),
    ))
}

/// Display 8-bit sRGB of a linear colour, clamped to the gamut.
pub fn linear_to_srgb8(rgb: &Vector3<f64>) -> [u8; 3] {
    let q = |v: f64| {
        let e = srgb_encode(v);
        if e.is_finite() { (e.clamp(0.0, 1.0) * 255.0).round() as u8 } else { 0 }
    };
    [q(rgb[0]), q(rgb[1]), q(rgb[2])]
}

/// `"#rrggbb"` of a linear colour, clamped to the gamut.
pub fn linear_to_hex(rgb: &Vector3<f64>) -> String {
    let mut hex = String::with_capacity(7);
    push_hex(&mut hex, rgb);
    hex
}

/// [`linear_to_hex`] of `rgb` appended to `w` (writers of long texts, such as the solve's table, append it
/// without a `String` of its own).
pub fn push_hex(w: &mut String, rgb: &Vector3<f64>) {
    const HEX: &[u8; 16] = b"0123456789abcdef";
    w.push('#');
    for b in linear_to_srgb8(rgb) {
        w.push(char::from(HEX[usize::from(b >> 4)]));
        w.push(char::from(HEX[usize::from(b & 15)]));
    }
}

/// CIELAB (CIE 1976) of `xyz` against reference white `white`.
pub fn xyz_to_lab(xyz: &Vector3<f64>, white: &Vector3<f64>) -> [f64; 3] {
    const EPS: f64 = 216.0 / 24389.0;
    const KAPPA: f64 = 24389.0 / 27.0;
    let f = |t: f64| if t > EPS { t.cbrt() } else { (KAPPA * t + 16.0) / 116.0 };
    let ratio = |v: f64, w: f64| if w.abs() > f64::MIN_POSITIVE { v / w } else { 0.0 };
    let fx = f(ratio(xyz[0], white[0]));
    let fy = f(ratio(xyz[1], white[1]));
    let fz = f(ratio(xyz[2], white[2]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// CIELAB (D65 white) of a display sRGB 8-bit triple (the `palette` crate's conversion).
pub fn srgb8_to_lab(rgb: [u8; 3]) -> [f64; 3] {
    use palette::IntoColor;
    let srgb = palette::Srgb::new(rgb[0], rgb[1], rgb[2]).into_format::<f64>();
    let lab: palette::Lab<palette::white_point::D65, f64> = srgb.into_color();
    [lab.l, lab.a, lab.b]
}

/// CIEDE2000 colour difference between two CIELAB colours (implemented by the `palette` crate).
pub fn delta_e00(a: [f64; 3], b: [f64; 3]) -> f64 {
    let la: palette::Lab<palette::white_point::D65, f64> = palette::Lab::new(a[0], a[1], a[2]);
    let lb: palette::Lab<palette::white_point::D65, f64> = palette::Lab::new(b[0], b[1], b[2]);
    la.difference(lb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_light_on_flat_white_has_unit_luminance() {
        let c = Colorimetry::default();
        let xyz = c.xyz(&Spectrum::flat(1.0), &Spectrum::flat(1.0));
        assert!((xyz[1] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn srgb_round_trip() {
        for i in 0..=100 {
            let v = i as f64 / 100.0;
            assert!((srgb_decode(srgb_encode(v)) - v).abs() < 1e-12);
        }
        assert_eq!(linear_to_hex(&hex_to_linear("#6a7b5c").unwrap()), "#6a7b5c");
        assert!(hex_to_linear("#6a7b5").is_none());
        assert!(hex_to_linear("6a7b5c").is_none());
        assert!(hex_to_linear("#6a7b5g").is_none());
    }

    #[test]
    fn a_dark_light_falls_back_to_the_display_white() {
        let c = Colorimetry::default();
        let grey = Vector3::new(0.2159, 0.2159, 0.2159);
        let black = Vector3::zeros();
        // Under an all-zero light a grey target against black is a large error, not zero.
        let de = c.delta_e00_under(&grey, &black, &Spectrum::flat(0.0));
        assert!(de > 30.0, "ΔE00 {de}");
        // A luminous light keeps its own white: E on flat 1 is L* = 100 under E itself.
        let e = Spectrum::flat(1.0);
        let lab = c.lab_under(&c.rgb(&e, &Spectrum::flat(1.0)), &e);
        assert!((lab[0] - 100.0).abs() < 1e-9 && lab[1].abs() < 1e-9 && lab[2].abs() < 1e-9, "{lab:?}");
    }
}
