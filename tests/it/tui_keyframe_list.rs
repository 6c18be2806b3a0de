//! The dial's keyframes listed (issue 30): `f` with the dial keys lists the keyframes added this session
//! and the scene file's; Enter sets the dial to one; `d` / Delete removes a session keyframe (not
//! undoable, and the message says so) and refuses a keyframe of the scene file. Screens at 80×24.

use crate::tui_support;

use metamer::tui::app::Popup;
use metamer::tui::colour::ColourMode;
use metamer::tui::graphics::Graphics;
use tui_support::{replay, state};

/// The engine scene with its sweep as two keyframes (hide, then glow with split off), at a small
/// generated size, and the designer over it.
fn engine_with_keyframes(dir: &std::path::Path) -> metamer::tui::State {
    let repo = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(repo.join("volumes/engine_palette.toml"), dir.join("engine_palette.toml")).unwrap();
    let body = std::fs::read_to_string(repo.join("volumes/engine_generated.toml")).unwrap();
    let body = body.replace("generated_size = 160", "generated_size = 40").replace(
        "[dial]\npath = [\"hide\", \"split\", \"glow\"]\n",
        "[[dial.keyframes]]\nat = \"hide\"\n[[dial.keyframes]]\nat = \"glow\"\noff = [\"split\"]\n",
    );
    assert!(body.contains("[[dial.keyframes]]"));
    let scene_path = dir.join("scene.toml");
    std::fs::write(&scene_path, body).unwrap();
    let scene = metamer::render::Scene::load(&scene_path).expect("scene");
    let mut s = state(scene.palette.clone(), ColourMode::TrueColor);
    s.preview.graphics = Graphics::halfblocks();
    s.set_preview_scene(scene);
    s
}

#[test]
fn keyframes_are_listed_shown_and_deleted() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = engine_with_keyframes(dir.path());
    // Two keyframes of this session: the slider moved right, then light 1 off.
    let (text, _) = replay(&mut s, "g\nL\na\n1\na", 80, 24);
    assert!(text.contains("keyframes 2 new · f lists them"), "{text}");
    let added = s.preview.keyframes.clone();
    assert_eq!(added.len(), 2);
    let (text, buf) = replay(&mut s, "f", 80, 24);
    snap!("keyframes_list_80x24", text);
    assert!(matches!(s.ui.popup, Some(Popup::Keyframes(_))));
    assert!(text.contains("added this session (2;") && text.contains("in the scene file"), "{text}");
    assert!(text.contains(" 3  (") && text.contains("on hide · all lights on"), "{text}");
    assert!(text.contains("on glow · off: split"), "{text}");
    assert!(text.contains("off: hide"), "the second keyframe has light 1 (hide) off: {text}");
    // The chosen row is highlighted on its cells.
    let (y, line) = text.lines().enumerate().find(|(_, l)| l.contains(" 1  (")).expect("row 1");
    let x = line.find(" 1  (").map(|b| line[..b].chars().count()).unwrap() as u16 + 1;
    assert_eq!(buf[(x, y as u16)].bg, ratatui::style::Color::LightGreen);
    // Enter on the first: the dial takes that keyframe (light 1 on again), the list closes.
    let (text, _) = replay(&mut s, "Enter", 80, 24);
    assert_eq!(s.preview.dial_state(), Some(&added[0]));
    assert!(s.ui.popup.is_none());
    assert!(text.contains("the dial set to keyframe 1"), "{text}");
    // d on the second deletes it; the message says it cannot be undone; z leaves the keyframes alone.
    let (text, _) = replay(&mut s, "f\nDown\nd", 80, 24);
    snap!("keyframes_deleted_80x24", text);
    assert_eq!(s.preview.keyframes, vec![added[0].clone()]);
    assert!(text.contains("keyframe 2 deleted") && text.contains("not undoable"), "{text}");
    assert!(matches!(s.ui.popup, Some(Popup::Keyframes(_))), "the list stays open");
    // Delete on a keyframe of the scene file: refused, nothing removed.
    let (text, _) = replay(&mut s, "End\nDel", 80, 24);
    assert!(text.contains("scene file's keyframe 2"), "{text}");
    assert_eq!(s.preview.keyframes.len(), 1);
    // Esc closes the list, the dial keeps the keys; z does not bring the deleted keyframe back.
    replay(&mut s, "Esc\nEsc\nz", 80, 24);
    assert!(s.ui.popup.is_none() && !s.preview.keys);
    assert_eq!(s.preview.keyframes.len(), 1);
}

/// With no keyframes the list says how to add one; `q` closes it without quitting.
#[test]
fn an_empty_list_says_how_to_add_one() {
    let palette = tui_support::demo_palette();
    let scene = metamer::render::Scene::builtin(palette.clone(), 32).expect("built-in scene");
    let mut s = state(palette, ColourMode::TrueColor);
    s.preview.graphics = Graphics::halfblocks();
    s.set_preview_scene(scene);
    let (text, _) = replay(&mut s, "g\nf", 80, 24);
    assert!(text.contains("none yet: `a` adds the dial as it stands"), "{text}");
    let (text, _) = replay(&mut s, "d", 80, 24);
    assert!(text.contains("no keyframes yet"), "{text}");
    replay(&mut s, "q", 80, 24);
    assert!(s.ui.popup.is_none() && !s.ui.quit);
}
