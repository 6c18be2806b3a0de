//! Snapshot tests of the designer's screens, driven through the same event loop as the terminal with an
//! off-screen backend. Snapshots live in the top-level `snapshots/` directory.

use crate::tui_support;

use metamer::tui::colour::ColourMode;
use tui_support::{demo_palette, replay, square_palette, state};

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
    // q closes the help (as in lazygit); q again quits.
    replay(&mut s, "?\nq", 100, 30);
    assert!(!s.ui.quit && s.ui.popup.is_none());
    replay(&mut s, "q", 100, 30);
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
    // The axes are named, with the ranges the canvas spans.
    assert!(text.contains("a* ") && text.contains(" across · b* ") && text.contains(" up"), "{text}");
    snap!("feasibility_100x30", text);
    // It follows the selection; `m` closes it.
    let (text, _) = replay(&mut s, "Right", 100, 30);
    assert!(text.contains("reachable · "));
    let (text, _) = replay(&mut s, "m", 100, 30);
    assert!(!text.contains("reachable · "));
}

/// No line of `text` ends cut (`…` at its end, or running into the right border without a space).
fn nothing_cut(text: &str) {
    for line in text.lines() {
        assert!(!line.trim_end_matches(['│', '┐', '┘', '─', ' ']).ends_with('…'), "cut: {line}\n{text}");
    }
}

#[test]
fn at_80x24_the_title_abbreviates_the_path_first_and_keeps_the_unsaved_marker() {
    let path = std::path::PathBuf::from("volumes/fig6_engine_palette.toml");
    let mut s = metamer::tui::State::new(path, demo_palette(), ColourMode::Indexed256);
    let (text, _) = replay(&mut s, "Down\nu", 80, 24);
    assert!(s.is_dirty());
    let title = text.lines().next().unwrap_or_default();
    assert!(title.contains('●') && title.contains("fig6_") && title.contains("obj"), "{title}");
    snap!("title_unsaved_long_path_80x24", text);
    // Clean again: no marker, and the path gets the room.
    let (text, _) = replay(&mut s, "z", 80, 24);
    assert!(!text.lines().next().unwrap_or_default().contains('●'), "{text}");
}

#[test]
fn a_long_message_wraps_in_the_message_area_and_the_next_key_dismisses_it() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let long = "palettes/demo.toml: line 12: key `colours[3].weight`: this is a long warning that does not fit on \
                the bottom line of an 80-column terminal, so it is wrapped between words above it, all of it \
                readable, up to its very last word: END";
    s.ui.message = Some(metamer::tui::app::Message { text: long.into(), is_error: true });
    let (text, _) = replay(&mut s, "", 80, 24);
    nothing_cut(&text);
    let flat: String = text.split_whitespace().collect::<Vec<_>>().join(" ");
    for word in long.split_whitespace() {
        assert!(flat.contains(word), "'{word}' missing from\n{text}");
    }
    snap!("message_area_80x24", text);
    let (text, _) = replay(&mut s, "Down", 80, 24);
    assert!(!text.contains("END"), "{text}");
}

#[test]
fn the_recovery_copy_is_offered_in_a_popup_and_restored_from_inside() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let path = dir.path().join("p.toml");
    let recovery = metamer::tui::event_loop::recovery_path(&path);
    let mut edited = demo_palette();
    edited.colours[0].weight = 7.0;
    let doc = metamer::palette::PaletteFile::from_palette(&edited);
    std::fs::write(&recovery, doc.text()).expect("write the recovery copy");
    let mut s = metamer::tui::State::new(path, demo_palette(), ColourMode::TrueColor);
    s.ui.popup = Some(metamer::tui::app::Popup::Recovery { path: recovery.clone() });
    let mut saver = metamer::tui::event_loop::FileSaver;
    let worker = metamer::tui::worker::WorkerConfig {
        time_limit: std::time::Duration::from_secs(30),
        basis: metamer::tui::worker::BasisMode::Off,
    };
    let run = |s: &mut metamer::tui::State, script: &str, saver: &mut metamer::tui::event_loop::FileSaver| {
        let steps = metamer::tui::replay::parse_script(script).expect("script");
        let (frames, _) = metamer::tui::replay::run(s, steps, 80, 24, false, saver, worker.clone()).expect("runs");
        frames.last().cloned().unwrap_or_default()
    };
    let text = run(&mut s, "", &mut saver);
    assert!(text.contains("r        restore it here"), "{text}");
    nothing_cut(&text);
    // (The temporary folder's name is not in the snapshot.)
    let shown = text.replace(&*dir.path().display().to_string(), "TMP");
    let unwrapped = shown.lines().map(|l| l.trim_matches(['│', ' '])).collect::<Vec<_>>().join(" ");
    assert!(unwrapped.contains("unsaved work from an interrupted session is in"), "{shown}");
    let text = run(&mut s, "r", &mut saver);
    assert_eq!(s.doc.palette.colours[0].weight, 7.0, "the copy's palette is the one edited");
    assert!(s.is_dirty(), "unsaved until saved");
    assert!(text.contains("restored the unsaved work"), "{text}");
    nothing_cut(&text);
    run(&mut s, "z", &mut saver);
    assert_eq!(s.doc.palette, demo_palette(), "z undoes the restore");
}

#[test]
fn at_80x24_the_help_wraps_its_popup_lines_and_cuts_nothing() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "?\nDown *200", 80, 24);
    nothing_cut(&text);
    assert!(text.contains("diagnostics:"), "scrolled to the end:\n{text}");
    // Every popup key's description is on screen whole (wrapped lines joined).
    let flat: String = text
        .lines()
        .map(|l| l.trim_matches(['│', ' ']))
        .collect::<Vec<_>>()
        .join(" ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    for b in metamer::tui::keymap::HELP {
        assert!(flat.contains(b.help), "'{}' cut in\n{text}", b.help);
    }
    snap!("help_80x24_end", text);
}

#[test]
fn at_80x24_a_refusal_in_a_prompt_wraps_and_is_read_whole() {
    // A folder of a fixed-length name under target/, named relative to the folder the tests run in (the
    // package's), so the screen is the same on every machine once its random part is masked.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target");
    let dir = tempfile::Builder::new().prefix("refusal").tempdir_in(&root).expect("temporary folder");
    let name = dir.path().file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let rel = std::path::Path::new("target").join(&name);
    let path = rel.join("p.toml");
    std::fs::write(&path, metamer::palette::PaletteFile::from_palette(&demo_palette()).text()).expect("write");
    std::fs::create_dir(rel.join("a_folder_not_a_file")).expect("folder");
    let file = metamer::palette::PaletteFile::load(&path).expect("loads");
    let mut s = metamer::tui::State::with_file(file, ColourMode::TrueColor);
    // Typed relative to the palette's folder, as the prompt says.
    let script = "Ctrl-w\nCtrl-u\n\"a_folder_not_a_file\"\nEnter";
    let steps = metamer::tui::replay::parse_script(script).expect("script");
    let worker = metamer::tui::worker::WorkerConfig {
        time_limit: std::time::Duration::from_secs(30),
        basis: metamer::tui::worker::BasisMode::Off,
    };
    let mut saver = metamer::tui::event_loop::FileSaver;
    let (frames, _) = metamer::tui::replay::run(&mut s, steps, 80, 24, false, &mut saver, worker).expect("runs");
    let text = frames.last().cloned().unwrap_or_default();
    nothing_cut(&text);
    let Some(metamer::tui::app::Popup::Prompt(p)) = &s.ui.popup else { panic!("the prompt stays open:\n{text}") };
    let reason = p.error.as_ref().map(|e| e.0.to_string()).expect("a refusal");
    let flat: String = text
        .lines()
        .map(|l| l.trim_matches(['│', ' ']))
        .collect::<Vec<_>>()
        .join(" ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    // Every word of the refusal is on screen (a path longer than the popup is broken across lines).
    for word in reason.split_whitespace().filter(|w| w.chars().count() < 40) {
        assert!(flat.contains(word), "'{word}' of '{reason}' missing from\n{text}");
    }
    snap!("prompt_refusal_80x24", text.replace(&name, &format!("refusal{}", "X".repeat(name.len() - 7))));
}

/// The designer's keys as docs/formats/keys.md lists them: one table per mode, from the one keymap.
fn keys_markdown() -> String {
    let mut out = String::new();
    for (title, table) in metamer::tui::keymap::TABLES {
        out.push_str(&format!("\n### {title}\n\n| keys | what they do |\n|---|---|\n"));
        for b in *table {
            let keys = metamer::tui::keymap::keys_label(b).replace('|', "\\|");
            out.push_str(&format!("| `{keys}` | {} |\n", b.help));
        }
    }
    out
}

#[test]
fn the_keys_page_lists_every_key_of_the_keymap() {
    let page = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/formats/keys.md")).expect("page");
    let begin = "<!-- keys: generated from src/tui/keymap.rs; the test the_keys_page_lists_every_key checks it -->";
    let listed = page.split_once(begin).map(|(_, rest)| rest.split("<!-- /keys -->").next().unwrap_or_default());
    assert_eq!(
        listed.unwrap_or_default(),
        keys_markdown(),
        "docs/formats/keys.md is out of date; it should hold:\n{}",
        keys_markdown()
    );
}
