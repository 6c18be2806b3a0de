//! Snapshot tests of the designer's screens, driven through the same event loop as the terminal with an
//! off-screen backend. Snapshots live in the top-level `snapshots/` directory.

use crate::tui_support;

use metamer::tui::colour::ColourMode;
use tui_support::{demo_palette, replay, square_palette, state};

macro_rules! snap {
    ($name:expr, $text:expr) => {
        insta::with_settings!({ snapshot_path => "../../snapshots", prepend_module_to_snapshot => false }, {
            insta::assert_snapshot!($name, $text);
        })
    };
}

#[test]
fn main_screen_100x30() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "", 100, 30);
    println!("{text}");
    snap!("main_100x30", text);
}

#[test]
fn main_screen_80x24_scrolls_an_8x8_palette() {
    let mut s = state(square_palette(8), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "", 80, 24);
    snap!("main_80x24_8x8", text);
    // The selection scrolls the matrix: far corner.
    let (text, _) = replay(&mut s, "Right *7\nDown *7", 80, 24);
    snap!("main_80x24_8x8_far_corner", text);
}

#[test]
fn main_screen_256_colours() {
    let mut s = state(demo_palette(), ColourMode::Indexed256);
    let (text, buf) = replay(&mut s, "", 100, 30);
    assert!(text.contains("256 colours"));
    snap!("main_100x30_256", text);
    // Every colour drawn is an xterm index, never RGB.
    assert!(buf.content.iter().all(|c| !matches!(c.fg, ratatui::style::Color::Rgb(..))
        && !matches!(c.bg, ratatui::style::Color::Rgb(..))));
}

#[test]
fn help_lists_every_key() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "?", 100, 30);
    snap!("help_100x30", text);
    // The main screen's and the light dial's keys (on a screen tall enough not to scroll).
    let (tall, _) = replay(&mut state(demo_palette(), ColourMode::TrueColor), "?", 100, 60);
    for b in metamer::tui::keymap::MAIN.iter().chain(metamer::tui::keymap::DIAL) {
        assert!(tall.contains(b.help), "help lacks '{}'", b.help);
    }
    let (text, _) = replay(&mut s, "Esc", 100, 30);
    assert!(!text.contains("keys (↑↓ scroll)"));
}

#[test]
fn prompts_and_popups() {
    let cases = [
        ("prompt_hex", "Down *2\n#"),
        ("prompt_weight", "Down *2\nw"),
        ("prompt_free_group", "Down *2\nf"),
        ("prompt_free_bounds", "Down *2\nRight\nb"),
        ("prompt_planck", "Right *2\np"),
        ("prompt_scale", "Up\ns"),
        ("prompt_setting", "Tab\nTab\nRight *5\nEnter"),
        ("popup_choose_spectrum", "d"),
        ("popup_add_light", "L"),
        ("popup_add_reflectance", "R\nDown *3"),
        ("prompt_bad_hex", "Down *2\n#\nCtrl-u\n\"#12zz00\"\nEnter"),
    ];
    for (name, script) in cases {
        let mut s = state(demo_palette(), ColourMode::TrueColor);
        let (text, _) = replay(&mut s, script, 100, 30);
        snap!(name, text);
    }
}

#[test]
fn workflow_edit_solve_undo_save() {
    use metamer::colorimetry::srgb_encode;
    use metamer::tui::replay::MemorySaver;
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let mut saver = MemorySaver::default();
    let red = |s: &metamer::tui::State| (srgb_encode(s.doc.palette.colours[2].target[0]) * 255.0).round();
    let before = red(&s);
    // tissue × daylight: raise R by three steps on the sliders.
    let (text, _) = tui_support::replay_saving(&mut s, "Down *2\nEnter\nRight *3", 100, 30, &mut saver);
    snap!("workflow_1_edited", text);
    assert_eq!(red(&s), before + 3.0);
    assert!(s.is_dirty());
    assert!(text.contains("●"));
    // The three slider steps are one undo step.
    let (text, _) = tui_support::replay_saving(&mut s, "Esc\nwait-solve\nz", 100, 30, &mut saver);
    snap!("workflow_2_undone", text);
    assert_eq!(red(&s), before);
    assert!(!s.is_dirty());
    // Redo, then save: the marker goes and the saver got the edited palette.
    let (text, _) = tui_support::replay_saving(&mut s, "Z\nCtrl-s", 100, 30, &mut saver);
    snap!("workflow_3_saved", text);
    assert_eq!(saver.saved.len(), 1);
    assert_eq!((srgb_encode(saver.saved[0].colours[2].target[0]) * 255.0).round(), before + 3.0);
    assert!(!s.is_dirty());
    assert!(!text.contains("●"));
}

#[test]
fn quit_asks_first_when_unsaved() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "Down\nu\nq", 100, 30);
    snap!("popup_confirm_quit", text);
    assert!(!s.ui.quit);
    let (_, _) = replay(&mut s, "n\nq\ny", 100, 30);
    assert!(s.ui.quit);
    // A clean palette quits at once.
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    replay(&mut s, "q", 100, 30);
    assert!(s.ui.quit);
}

#[test]
fn help_and_diagnostics_at_80x24() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "?", 80, 24);
    snap!("help_80x24", text);
    let (text, _) = replay(&mut s, "Down *20", 80, 24);
    snap!("help_80x24_scrolled", text);
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "!", 100, 30);
    assert!(!s.diagnostics().is_empty(), "the demo palette has unmet cells");
    snap!("popup_diagnostics", text);
}

#[test]
fn main_screen_80x24_and_focused_panels() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "", 80, 24);
    snap!("main_80x24", text);
    // Sliders focused on the weight slider, then the settings row focused on smoothness.
    let (text, _) = replay(&mut s, "Down\nEnter\nDown *3", 100, 30);
    snap!("focus_sliders_weight", text);
    let (text, _) = replay(&mut s, "Tab\nRight *5", 100, 30);
    snap!("focus_settings_smoothness", text);
    // A light swatch selected: the panel shows the light's details.
    let (text, _) = replay(&mut s, "Esc\nUp *3\nRight", 100, 30);
    snap!("select_light", text);
}

#[test]
fn many_reflectances_fold_to_one_row_each() {
    let mut p = square_palette(14);
    p.lights.truncate(5);
    p.colours.retain(|c| c.light < 5);
    let mut s = state(p.clone(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "", 100, 30);
    snap!("main_100x30_5x14", text);
    for e in p.lights.iter().chain(&p.reflectances) {
        assert!(text.contains(&e.name), "{} is not on screen", e.name);
    }
}

#[test]
fn main_keys_work_through_help_and_esc_bursts() {
    use metamer::tui::replay::MemorySaver;
    // With the help open, Ctrl-s saves (closing the help) and q quits.
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let mut saver = MemorySaver::default();
    tui_support::replay_saving(&mut s, "Down\nu\n?\nCtrl-s", 100, 30, &mut saver);
    assert_eq!(saver.saved.len(), 1);
    assert!(s.ui.popup.is_none());
    replay(&mut s, "?\nq", 100, 30);
    assert!(s.ui.quit);
    // Esc and a key sent together arrive as Alt+key: taken as Esc, then the key.
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let mut saver = MemorySaver::default();
    tui_support::replay_saving(&mut s, "Down\nu\n?\nAlt-Ctrl-s", 100, 30, &mut saver);
    assert_eq!(saver.saved.len(), 1);
    assert!(s.ui.popup.is_none());
}

#[test]
fn mismatch_region_overlay() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    // petal × tungsten: a designed reflectance under a fixed light.
    let (text, _) = replay(&mut s, "Down\nRight\nm", 100, 30);
    println!("{text}");
    assert!(text.contains("reachable · "), "no region drawn:\n{text}");
    assert!(text.contains("L* ") && text.contains("held within ΔE 0.5"));
    assert!(text.contains('×') && text.contains('○'));
    snap!("feasibility_100x30", text);
    // It follows the selection; `m` closes it.
    let (text, _) = replay(&mut s, "Right", 100, 30);
    assert!(text.contains("reachable · "));
    let (text, _) = replay(&mut s, "m", 100, 30);
    assert!(!text.contains("reachable · "));
}
