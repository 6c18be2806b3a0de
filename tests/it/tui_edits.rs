//! Spectrum and cell edits through the keys, each undone again: the palette model's edit operations as the
//! designer drives them.

use crate::tui_support;

use metamer::colorimetry::Colorimetry;
use metamer::palette::{Kind, Source};
use metamer::spectrum::{Normalize, Spectrum};
use metamer::tui::colour::ColourMode;
use tui_support::{demo_palette, replay, state};

#[test]
fn planck_normalise_scale_and_undo() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let original = s.doc.palette.clone();
    // The light row is above the first reflectance: Up selects daylight's swatch.
    replay(&mut s, "Up\np\nCtrl-u\n\"3200\"\nEnter", 100, 30);
    assert_eq!(s.doc.palette.lights[0].source, Source::Planck(3200.0));
    let c = Colorimetry::default();
    let y = |e: &Spectrum| (c.q_xyz * e.0)[1];
    assert!((y(&s.doc.palette.lights[0].spectrum) - 1.0).abs() < 1e-9, "still luminance-normalised");
    replay(&mut s, "N", 100, 30);
    assert_eq!(s.doc.palette.lights[0].normalize, Normalize::L2);
    assert!((s.doc.palette.lights[0].spectrum.l2_norm() - 1.0).abs() < 1e-9);
    replay(&mut s, "s\nCtrl-u\n\"2\"\nEnter", 100, 30);
    assert!((s.doc.palette.lights[0].spectrum.l2_norm() - 2.0).abs() < 1e-9);
    // A bad temperature is refused inside the prompt, which stays open.
    let (text, _) = replay(&mut s, "p\nCtrl-u\n\"-5\"\nEnter", 100, 30);
    assert!(text.contains("the temperature must be a positive number of kelvin"), "{text}");
    replay(&mut s, "Esc\nz\nz\nz", 100, 30);
    assert_eq!(s.doc.palette, original);
    assert!(!s.is_dirty());
}

#[test]
fn add_and_remove_spectra() {
    let dir = tempfile::tempdir().expect("temporary folder");
    std::fs::write(dir.path().join("measured.csv"), "nm,value\n380,0.2\n550,0.4\n780,0.6\n").expect("csv");
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    s.doc.file.path = Some(dir.path().join("demo.toml"));
    let original = s.doc.palette.clone();
    // Add illuminant F11 (the list starts at D65: D65 D50 A E F2 F7 F11 …).
    replay(&mut s, "L\nDown *6\nEnter", 100, 30);
    assert_eq!(s.doc.palette.lights.len(), 4);
    assert_eq!(s.doc.palette.lights[3].source, Source::Illuminant("F11".into()));
    // Import a reflectance from CSV (the last entry of the reflectance list: End jumps to it).
    let (text, _) = replay(&mut s, "R\nEnd\nEnter\n\"measured.csv\"\nEnter", 100, 30);
    let added = s.doc.palette.reflectances.last().expect("added");
    assert_eq!(added.name, "measured", "{text}");
    assert!((added.spectrum.0[15] - 0.4).abs() < 1e-12, "550 nm resampled");
    // A missing file is refused with the reason.
    // Home goes back to the first entry, End again to the last.
    let (text, _) = replay(&mut s, "R\nEnd\nHome\nUp\nEnd\nEnter\n\"nope.csv\"\nEnter", 100, 30);
    assert!(text.contains("nope.csv"), "{text}");
    replay(&mut s, "Esc", 100, 30);
    // Remove the selected reflectance (its swatch is selected after adding it) with its cells.
    let n = s.doc.palette.reflectances.len();
    replay(&mut s, "x", 100, 30);
    assert_eq!(s.doc.palette.reflectances.len(), n - 1);
    // Remove light `daylight` from a cell: choose l.
    replay(&mut s, "Right\nUp *9\nDown\nx\nl", 100, 30);
    assert_eq!(s.doc.palette.lights.len(), 3);
    assert!(s.doc.palette.colours.iter().all(|c| c.light < 3));
    for _ in 0..4 {
        replay(&mut s, "z", 100, 30);
    }
    assert_eq!(s.doc.palette, original);
}

#[test]
fn home_and_end_jump_to_the_ends_of_an_add_list() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let n = s.doc.palette.lights.len();
    // The light list starts at D65; End then Home comes back to it.
    replay(&mut s, "L\nDown *3\nEnd\nHome\nEnter", 100, 30);
    assert_eq!(s.doc.palette.lights.len(), n + 1);
    assert_eq!(s.doc.palette.lights[n].source, Source::Illuminant("D65".into()));
    // End reaches the last entry (import a CSV file…), which asks for a path.
    let (text, _) = replay(&mut s, "L\nEnd\nEnter", 100, 30);
    assert!(text.contains("path"), "{text}");
    replay(&mut s, "Esc", 100, 30);
    assert_eq!(s.doc.palette.lights.len(), n + 1);
}

#[test]
fn the_prompt_edits_at_its_cursor() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    replay(&mut s, "u", 100, 30);
    // "25", back one, "." → "2.5"; then Home, Del, "7" and End, Backspace, "9" → "7.9".
    let (text, _) = replay(&mut s, "w\nCtrl-u\n\"25\"\nLeft\n\".\"", 100, 30);
    assert!(text.contains("› 2.5"), "{text}");
    replay(&mut s, "Enter", 100, 30);
    assert_eq!(s.doc.palette.cell(0, 0).expect("cell").weight, 2.5);
    replay(&mut s, "w\nHome\nDel\n\"7\"\nEnd\nBackspace\n\"9\"\nEnter", 100, 30);
    assert_eq!(s.doc.palette.cell(0, 0).expect("cell").weight, 7.9);
    // Ctrl-w deletes the word before the cursor, Right past the end stays at the end.
    replay(&mut s, "w\nCtrl-w\n\"3\"\nRight\nRight\n\"1\"\nEnter", 100, 30);
    assert_eq!(s.doc.palette.cell(0, 0).expect("cell").weight, 31.0);
}

#[test]
fn cell_edits_use_free_groups_and_settings() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    // skin × daylight has no criterion: u creates one from its colour now.
    replay(&mut s, "u", 100, 30);
    let cell = s.doc.palette.cell(0, 0).expect("created").clone();
    assert!(cell.enabled);
    assert!((cell.target - s.solve.derived.cell(0, 0).expect("derived").full).norm() < 1e-12);
    replay(&mut s, "u", 100, 30);
    assert!(!s.doc.palette.cell(0, 0).expect("kept").enabled);
    // Hex target, weight, free group B with bounds.
    replay(&mut s, "#\nCtrl-u\n\"#ff8800\"\nEnter\nw\nCtrl-u\n\"2.5\"\nEnter\nf\n\"B\"\nEnter", 100, 30);
    let cell = s.doc.palette.cell(0, 0).expect("cell").clone();
    assert_eq!(metamer::colorimetry::linear_to_hex(&cell.target), "#ff8800");
    assert_eq!(cell.weight, 2.5);
    let g = cell.free.expect("in a group");
    assert_eq!(s.doc.palette.free[g].name, "B");
    replay(&mut s, "b\nCtrl-u\n\"0.1 0.9\"\nEnter", 100, 30);
    assert_eq!(s.doc.palette.free[g].lower, nalgebra::Vector3::repeat(0.1));
    assert_eq!(s.doc.palette.free[g].upper, nalgebra::Vector3::repeat(0.9));
    // Settings: bounds off and on again, smoothness typed, m refused out of range.
    replay(&mut s, "B", 100, 30);
    assert!(s.doc.palette.settings.reflectance_bounds.is_unbounded());
    replay(&mut s, "B", 100, 30);
    assert_eq!(s.doc.palette.settings.reflectance_bounds.upper, 1.0);
    replay(&mut s, "Tab\nTab\nRight *5\nEnter\nCtrl-u\n\"0.01\"\nEnter", 100, 30);
    assert_eq!(s.doc.palette.settings.smoothness, 0.01);
    let (text, _) = replay(&mut s, "Right *3\nEnter\nCtrl-u\n\"40\"\nEnter", 100, 30);
    assert!(text.contains("the basis dimension is an integer from 1 to 31"), "{text}");
    assert_eq!(s.doc.palette.settings.basis_dimension, 7);
    // Design on/off of a reflectance from its swatch with Enter.
    replay(&mut s, "Esc\nEsc\nLeft\nEnter", 100, 30);
    assert!(s.doc.palette.reflectances[0].design);
    assert_eq!(s.doc.palette.entries(Kind::Reflectance)[0].name, "skin");
}
