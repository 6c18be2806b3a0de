//! Terminal colours: truecolor when the terminal says it has it (`COLORTERM` = `truecolor`/`24bit`),
//! else the nearest entry of the xterm 256-colour palette (6×6×6 cube and grey ramp).

use crate::colorimetry::linear_to_srgb8;
use nalgebra::Vector3;
use ratatui::style::Color;

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

/// Index (16..=255) of the xterm-256 colour nearest to `rgb` (squared distance in display sRGB),
/// searching the 6×6×6 cube and the 24-step grey ramp. Indices 0..16 are left out because terminals
/// redefine them.
pub fn nearest_xterm256(rgb: [u8; 3]) -> u8 {
    let dist = |c: [u8; 3]| -> u32 { (0..3).map(|i| (i32::from(c[i]) - i32::from(rgb[i])).pow(2) as u32).sum() };
    let nearest_level = |v: u8| -> usize {
        CUBE_LEVELS.iter().enumerate().min_by_key(|(_, l)| (i32::from(**l) - i32::from(v)).abs()).map_or(0, |(i, _)| i)
    };
    let (ri, gi, bi) = (nearest_level(rgb[0]), nearest_level(rgb[1]), nearest_level(rgb[2]));
    let cube = [CUBE_LEVELS[ri], CUBE_LEVELS[gi], CUBE_LEVELS[bi]];
    let cube_index = 16 + 36 * ri + 6 * gi + bi;
    let mean = (u32::from(rgb[0]) + u32::from(rgb[1]) + u32::from(rgb[2])) / 3;
    // Grey ramp 232..=255 has levels 8, 18, …, 238.
    let grey_step = (mean.saturating_sub(3) / 10).min(23);
    let grey_level = (8 + 10 * grey_step) as u8;
    let grey = [grey_level; 3];
    if dist(grey) < dist(cube) { (232 + grey_step) as u8 } else { cube_index as u8 }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn nearest_is_never_farther_than_any_cube_entry() {
        // Exhaustive over a coarse grid: the chosen entry is at least as near as every cube entry.
        for r in (0..=255u16).step_by(17) {
            for g in (0..=255u16).step_by(51) {
                for b in (0..=255u16).step_by(85) {
                    let c = [r as u8, g as u8, b as u8];
                    let i = nearest_xterm256(c);
                    let entry = xterm_entry(i);
                    let d = |e: [u8; 3]| (0..3).map(|k| (i32::from(e[k]) - i32::from(c[k])).pow(2)).sum::<i32>();
                    for j in 16..=255u8 {
                        assert!(d(entry) <= d(xterm_entry(j)), "{c:?}: {i} vs {j}");
                    }
                }
            }
        }
    }

    fn xterm_entry(i: u8) -> [u8; 3] {
        if i >= 232 {
            let l = 8 + 10 * (i - 232);
            [l; 3]
        } else {
            let k = usize::from(i - 16);
            [CUBE_LEVELS[k / 36], CUBE_LEVELS[(k / 6) % 6], CUBE_LEVELS[k % 6]]
        }
    }
}
