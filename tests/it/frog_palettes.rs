//! The shipped frog palettes as stored (no solve, no data folder): `volumes/frog_palette.toml` (the
//! gallery's `volumes/frog.toml` sweep, daylight → reveal → fluorescent) and `volumes/fig7_frog_palette.toml`
//! (seed Fig. 7). Colours come from the stored spectra (the full 31-sample model), ΔE00 with the cell's light
//! on a flat white as the reference white, as `metamer solve` reports them.
//!
//! - Every cell of the stored design meets its target (ΔE00 ≤ 1, the solve report's "met"); the cells of a
//!   free group meet one shared colour. A palette whose targets were edited without a re-solve, or whose
//!   design cannot meet them under its bounds (so that the least-squares compromise moves the metamers
//!   apart), fails here.
//! - Under "daylight" the four tissues are metamers: every pair within ΔE00 1.
//! - Under every other light they split: the visible tissues differ pairwise by ΔE00 ≥ 10.

use metamer::colorimetry::Colorimetry;
use metamer::palette::Palette;
use metamer::palette::PaletteFile;
use nalgebra::Vector3;
use std::path::Path;

const TISSUES: [&str; 4] = ["body", "liver", "bone", "nerve"];

fn load(name: &str) -> Palette {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("volumes").join(name);
    match PaletteFile::load(&path) {
        Ok(file) => file.palette,
        Err(e) => panic!("{name}: {e}"),
    }
}

/// The light's index and each tissue's colour under it (linear sRGB of the stored spectra).
fn colours(p: &Palette, light: &str) -> (usize, Vec<(&'static str, Vector3<f64>)>) {
    let col = Colorimetry::default();
    let l = p.lights.iter().position(|e| e.name == light).unwrap_or_else(|| panic!("{}: no light {light}", p.name));
    let c = TISSUES
        .iter()
        .map(|t| {
            let r = p.reflectance_index(t).unwrap_or_else(|| panic!("{}: no reflectance {t}", p.name));
            (*t, col.rgb(&p.lights[l].spectrum, &p.reflectances[r].spectrum))
        })
        .collect();
    (l, c)
}

/// ΔE00 of every tissue pair under `light`, named.
fn pairs(file: &str, p: &Palette, light: &str) -> Vec<(String, f64)> {
    let col = Colorimetry::default();
    let (l, c) = colours(p, light);
    let mut out = Vec::new();
    for (i, (a, ca)) in c.iter().enumerate() {
        for (b, cb) in &c[i + 1..] {
            out.push((format!("{a}–{b}"), col.delta_e00_under(ca, cb, &p.lights[l].spectrum)));
        }
    }
    eprintln!("{file} under {light}: {out:.2?}");
    out
}

fn every_cell_is_met(file: &str) {
    let p = load(file);
    let col = Colorimetry::default();
    let mut unmet = Vec::new();
    let mut groups: Vec<Vec<(String, Vector3<f64>, usize)>> = vec![Vec::new(); p.free.len()];
    for c in p.colours.iter().filter(|c| c.is_active()) {
        let (light, refl) = (&p.lights[c.light], &p.reflectances[c.reflectance]);
        let got = col.rgb(&light.spectrum, &refl.spectrum);
        let cell = format!("{} × {}", light.name, refl.name);
        match c.free {
            Some(g) => groups[g].push((cell, got, c.light)),
            None => {
                let de = col.delta_e00_under(&got, &c.target, &light.spectrum);
                if de > 1.0 {
                    unmet.push(format!("{cell}: ΔE00 {de:.2} from its target"));
                }
            }
        }
    }
    for (g, cells) in groups.iter().enumerate() {
        for (i, (a, ca, la)) in cells.iter().enumerate() {
            for (b, cb, _) in &cells[i + 1..] {
                let de = col.delta_e00_under(ca, cb, &p.lights[*la].spectrum);
                if de > 1.0 {
                    unmet.push(format!("free group {}: {a} and {b} ΔE00 {de:.2} apart", p.free[g].name));
                }
            }
        }
    }
    assert!(
        unmet.is_empty(),
        "{file}: cells not met by the stored spectra (re-solve, or choose feasible targets):\n{}",
        unmet.join("\n")
    );
}

fn metamers_under(file: &str, light: &str) {
    let p = load(file);
    for (pair, de) in pairs(file, &p, light) {
        assert!(de <= 1.0, "{file}: {pair} ΔE00 {de:.2} under {light}, not a metamer");
    }
}

fn split_under(file: &str, light: &str, tissues: &[&str]) {
    let p = load(file);
    for (pair, de) in pairs(file, &p, light) {
        let (a, b) = pair.split_once('–').unwrap_or_default();
        if tissues.contains(&a) && tissues.contains(&b) {
            assert!(de >= 10.0, "{file}: {pair} only ΔE00 {de:.2} apart under {light}");
        }
    }
}

/// Lightness (CIELAB L*, the light on flat white as white) of a tissue under a light.
fn lightness(file: &str, light: &str, tissue: &str) -> f64 {
    let p = load(file);
    let col = Colorimetry::default();
    let (l, c) = colours(&p, light);
    let rgb = c.iter().find(|(t, _)| *t == tissue).map(|(_, c)| *c).unwrap_or_else(Vector3::zeros);
    col.lab_under(&rgb, &p.lights[l].spectrum)[0]
}

#[test]
fn frog_palette_every_cell_is_met() {
    every_cell_is_met("frog_palette.toml");
}

#[test]
fn frog_palette_tissues_are_metamers_under_daylight() {
    metamers_under("frog_palette.toml", "daylight");
}

#[test]
fn frog_palette_reveal_splits_the_tissues_and_blackens_the_body() {
    split_under("frog_palette.toml", "reveal", &["liver", "bone", "nerve"]);
    let l = lightness("frog_palette.toml", "reveal", "body");
    assert!(l < 5.0, "body L* {l:.1} under reveal");
}

#[test]
fn frog_palette_fluorescent_gives_every_tissue_its_own_colour() {
    split_under("frog_palette.toml", "fluorescent", &TISSUES);
}

#[test]
fn fig7_palette_every_cell_is_met() {
    every_cell_is_met("fig7_frog_palette.toml");
}

#[test]
fn fig7_palette_tissues_are_metamers_under_daylight() {
    metamers_under("fig7_frog_palette.toml", "daylight");
}

#[test]
fn fig7_palette_the_other_lights_split_the_tissues() {
    split_under("fig7_frog_palette.toml", "reveal", &["liver", "bone", "nerve"]);
    split_under("fig7_frog_palette.toml", "light3", &TISSUES);
    let l = lightness("fig7_frog_palette.toml", "reveal", "body");
    assert!(l < 5.0, "body L* {l:.1} under reveal");
}
