//! Terminal colours: truecolor when the terminal says it has it (`COLORTERM` = `truecolor`/`24bit`),
//! else the entry of the xterm 256-colour palette (6×6×6 cube and grey ramp) nearest in CIELAB.

use crate::colorimetry::{linear_to_srgb8, srgb8_to_lab};
use nalgebra::Vector3;
use ratatui::style::Color;
use std::sync::LazyLock;

/// How colours reach the terminal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColourMode {
    TrueColor,
    Indexed256,
}

impl ColourMode {
    /// Decide from the value of `COLORTERM` (None when unset).
    pub(crate) fn from_colorterm(value: Option<&str>) -> ColourMode {
        match value {
            Some(v) if v.contains("truecolor") || v.contains("24bit") => ColourMode::TrueColor,
            _ => ColourMode::Indexed256,
        }
    }

    /// Decide from the environment.
    pub(crate) fn detect() -> ColourMode {
        ColourMode::from_colorterm(std::env::var("COLORTERM").ok().as_deref())
    }

    /// The terminal colour of a display sRGB 8-bit triple.
    pub(crate) fn color(self, rgb: [u8; 3]) -> Color {
        match self {
            ColourMode::TrueColor => Color::Rgb(rgb[0], rgb[1], rgb[2]),
            ColourMode::Indexed256 => Color::Indexed(nearest_xterm256(rgb)),
        }
    }

    /// The terminal colour of a linear sRGB colour (clamped to the gamut).
    pub(crate) fn linear(self, rgb: &Vector3<f64>) -> Color {
        self.color(linear_to_srgb8(rgb))
    }
}

/// The six levels of each axis of the xterm colour cube.
const CUBE_LEVELS: [u8; 6] = [0, 95, 135, 175, 215, 255];

/// The xterm-256 entry `i` (16..=255) as display sRGB: the 6×6×6 cube, then the grey ramp 8, 18, …, 238.
fn xterm_entry(i: u8) -> [u8; 3] {
    if i >= 232 {
        [8 + 10 * (i - 232); 3]
    } else {
        let k = usize::from(i.max(16) - 16);
        [CUBE_LEVELS[k / 36], CUBE_LEVELS[(k / 6) % 6], CUBE_LEVELS[k % 6]]
    }
}

/// CIELAB of entries 16..=255, derived once from the entries' sRGB values (xterm's defaults).
static XTERM_LAB: LazyLock<Vec<(u8, [f64; 3])>> =
    LazyLock::new(|| (16..=255u8).map(|i| (i, srgb8_to_lab(xterm_entry(i)))).collect());

/// Index (16..=255) of the xterm-256 colour nearest to `rgb` in CIELAB (ΔE*ab, the CIE 1976 colour
/// difference), over the 6×6×6 cube and the 24-step grey ramp. Indices 0..16 are left out because
/// terminals redefine them. Nearest in sRGB distance mapped colours a viewer tells apart (#b45c3d, a brick
/// red, and #a05571, a mauve) to one entry (131); in CIELAB they keep their hues. ΔE*ab rather than
/// CIEDE2000: it is about 1 µs a colour against about 45 µs, and the halfblock preview maps every pixel.
pub fn nearest_xterm256(rgb: [u8; 3]) -> u8 {
    let lab = srgb8_to_lab(rgb);
    let d2 = |e: &[f64; 3]| (0..3).map(|k| (e[k] - lab[k]).powi(2)).sum::<f64>();
    XTERM_LAB.iter().map(|(i, e)| (*i, d2(e))).min_by(|a, b| a.1.total_cmp(&b.1)).map_or(16, |(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::delta_e00;

    #[test]
    fn colorterm_decides_the_mode() {
        assert_eq!(ColourMode::from_colorterm(Some("truecolor")), ColourMode::TrueColor);
        assert_eq!(ColourMode::from_colorterm(Some("24bit")), ColourMode::TrueColor);
        assert_eq!(ColourMode::from_colorterm(Some("")), ColourMode::Indexed256);
        assert_eq!(ColourMode::from_colorterm(None), ColourMode::Indexed256);
    }

    #[test]
    fn cube_corners_and_greys_map_exactly() {
        assert_eq!(nearest_xterm256([0, 0, 0]), 16);
        assert_eq!(nearest_xterm256([255, 255, 255]), 231);
        assert_eq!(nearest_xterm256([255, 0, 0]), 196);
        assert_eq!(nearest_xterm256([0, 255, 0]), 46);
        assert_eq!(nearest_xterm256([0, 0, 255]), 21);
        assert_eq!(nearest_xterm256([128, 128, 128]), 244);
        assert_eq!(nearest_xterm256([95, 135, 175]), 16 + 36 + 12 + 3);
    }

    #[test]
    fn nearest_is_never_farther_in_cielab_than_any_entry() {
        // Over a grid of 18³ sRGB colours: the chosen entry is at least as near (ΔE*ab) as every entry 16..=255.
        for r in (0..=255u16).step_by(15) {
            for g in (0..=255u16).step_by(15) {
                for b in (0..=255u16).step_by(15) {
                    let c = [r as u8, g as u8, b as u8];
                    let lab = srgb8_to_lab(c);
                    let i = nearest_xterm256(c);
                    let d = |j: u8| {
                        let e = srgb8_to_lab(xterm_entry(j));
                        (0..3).map(|k| (e[k] - lab[k]).powi(2)).sum::<f64>().sqrt()
                    };
                    for j in 16..=255u8 {
                        assert!(d(i) <= d(j) + 1e-12, "{c:?}: {i} ({}) vs {j} ({})", d(i), d(j));
                    }
                }
            }
        }
    }

    #[test]
    fn colours_of_distinct_hue_keep_distinct_entries() {
        // Issue 30, defect 11: both went to 131 (#af5f5f) by sRGB distance.
        let (brick, mauve) = (nearest_xterm256([0xb4, 0x5c, 0x3d]), nearest_xterm256([0xa0, 0x55, 0x71]));
        assert_ne!(brick, mauve);
        // Each stays close to its colour, and closer to it than to the other's entry.
        let de = |c: [u8; 3], i: u8| delta_e00(srgb8_to_lab(c), srgb8_to_lab(xterm_entry(i)));
        assert!(de([0xb4, 0x5c, 0x3d], brick) < de([0xb4, 0x5c, 0x3d], mauve));
        assert!(de([0xa0, 0x55, 0x71], mauve) < de([0xa0, 0x55, 0x71], brick));
    }

    #[test]
    fn entries_are_the_xterm_defaults() {
        assert_eq!(xterm_entry(16), [0, 0, 0]);
        assert_eq!(xterm_entry(131), [175, 95, 95]);
        assert_eq!(xterm_entry(231), [255, 255, 255]);
        assert_eq!(xterm_entry(232), [8, 8, 8]);
        assert_eq!(xterm_entry(255), [238, 238, 238]);
    }
}
