//! Prompts remember and complete (issue 30, defect 12): ↑/↓ recall the earlier answers to the same
//! kind of prompt, Tab completes a path in the CSV and save-as prompts, and both paths are relative to
//! the palette's folder (the hint says which).

use crate::tui_support;

use metamer::tui::colour::ColourMode;
use metamer::tui::msg::{Effect, Msg};
use metamer::tui::update::update;
use tui_support::{demo_palette, replay, state};

/// The prompt's line (`› …`) on the screen.
fn typed(text: &str) -> String {
    let line = text.lines().find(|l| l.contains("› ")).unwrap_or_else(|| panic!("no prompt\n{text}"));
    let after = &line[line.find("› ").unwrap() + "› ".len()..];
    after.split(['▏', '│']).next().unwrap_or_default().trim_end().to_string()
}

#[test]
fn up_and_down_recall_earlier_answers_of_the_same_prompt() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    // Two hex targets typed on two cells.
    replay(&mut s, "Down\n#\nCtrl-u\n\"#ff0000\"\nEnter\nRight\n#\nCtrl-u\n\"#00ff00\"\nEnter", 80, 24);
    // A third cell: its prompt opens with its own target; ↑ shows the newest answer, ↑ again the older.
    let (text, _) = replay(&mut s, "Right\n#", 80, 24);
    let own = typed(&text);
    assert!(own.starts_with('#') && own != "#00ff00", "{text}");
    let (text, _) = replay(&mut s, "Up", 80, 24);
    assert_eq!(typed(&text), "#00ff00");
    let (text, _) = replay(&mut s, "Up", 80, 24);
    assert_eq!(typed(&text), "#ff0000");
    snap!("prompt_history_80x24", text);
    // ↑ at the oldest stays; ↓ goes back to the newer, then to what was typed before.
    let (text, _) = replay(&mut s, "Up\nDown", 80, 24);
    assert_eq!(typed(&text), "#00ff00");
    let (text, _) = replay(&mut s, "Down", 80, 24);
    assert_eq!(typed(&text), own);
    // Another kind of prompt has its own history (none yet).
    let (text, _) = replay(&mut s, "Esc\nw\nUp", 80, 24);
    assert!(text.contains("no earlier answer to this prompt"), "{text}");
}

#[test]
fn tab_completes_a_csv_path_in_the_palettes_folder() {
    // A folder of a fixed-length name under target/, named relative to the folder the tests run in, so
    // the screen is the same on every machine once its random part is masked.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target");
    let tmp = tempfile::Builder::new().prefix("completion").tempdir_in(&root).expect("temporary folder");
    let name = tmp.path().file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let rel = std::path::Path::new("target").join(&name);
    let dir = &rel;
    let csv: String = (0..=30).map(|i| format!("{},{}\n", 400 + 10 * i, 0.25)).collect();
    std::fs::write(dir.join("grey.csv"), &csv).unwrap();
    std::fs::write(dir.join("green.csv"), &csv).unwrap();
    std::fs::create_dir(dir.join("spectra")).unwrap();
    std::fs::write(dir.join("spectra").join("flat.csv"), &csv).unwrap();
    let mut s = metamer::tui::State::new(dir.join("p.toml"), demo_palette(), ColourMode::TrueColor);
    // R, the last entry of the list: import a CSV file.
    let (text, _) = replay(&mut s, "R\nEnd\nEnter", 80, 24);
    assert!(text.contains("relative to the palette's folder"), "{text}");
    let (text, _) = replay(&mut s, "\"gr\"\nTab", 80, 24);
    assert_eq!(typed(&text), "gre");
    assert!(text.contains("2 match: green.csv  grey.csv"), "{text}");
    snap!("prompt_completion_80x24", text.replace(&name, &format!("completion{}", "X".repeat(name.len() - 10))));
    let (text, _) = replay(&mut s, "\"y\"\nTab", 80, 24);
    assert_eq!(typed(&text), "grey.csv");
    // A folder completes with its slash, then the name inside it.
    let (text, _) = replay(&mut s, "Ctrl-u\n\"sp\"\nTab\n\"f\"\nTab", 80, 24);
    assert_eq!(typed(&text), "spectra/flat.csv");
    let (text, _) = replay(&mut s, "Ctrl-u\n\"x\"\nTab", 80, 24);
    assert!(text.contains("nothing here starts with x"), "{text}");
    // Enter imports it, from the palette's folder (the tests run elsewhere).
    let lights = s.doc.palette.reflectances.len();
    replay(&mut s, "Ctrl-u\n\"spectra/flat.csv\"\nEnter", 80, 24);
    assert_eq!(s.doc.palette.reflectances.len(), lights + 1, "{:?}", s.ui.message);
}

#[test]
fn save_as_paths_are_relative_to_the_palettes_folder() {
    let dir = std::path::Path::new("somewhere/else");
    let mut s = metamer::tui::State::new(dir.join("p.toml"), demo_palette(), ColourMode::TrueColor);
    update(&mut s, Msg::Start { width: 80, height: 24, trains_bases: false });
    let mut effects = Vec::new();
    for m in tui_support::keys("Ctrl-w\nCtrl-u\n\"copy.toml\"\nEnter") {
        effects.extend(update(&mut s, m));
    }
    let saved: Vec<_> = effects
        .iter()
        .filter_map(|e| if let Effect::SaveAs { path, .. } = e { Some(path.clone()) } else { None })
        .collect();
    assert_eq!(saved, [dir.join("copy.toml")]);
    // The prompt says so, and opens with the file's own name.
    let mut s = metamer::tui::State::new(dir.join("p.toml"), demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "Ctrl-w", 80, 24);
    assert!(text.contains("relative to the palette's folder somewhere/else/"), "{text}");
    assert_eq!(typed(&text), "p.toml");
}
