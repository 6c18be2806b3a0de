//! The light-dial preview: a scene raycast once and relit with the designer's current spectra.

use crate::tui_support;

use metamer::colorimetry::Colorimetry;
use metamer::render::Scene;
use metamer::tui::colour::ColourMode;
use metamer::tui::preview::Preview;
use tui_support::{demo_palette, replay, state};

fn demo_with_preview() -> metamer::tui::State {
    let palette = demo_palette();
    let scene = Scene::builtin(palette.clone(), 32).expect("the built-in scene takes the demo's reflectances");
    let mut s = state(palette, ColourMode::TrueColor);
    s.set_preview(Preview::from_scene(&scene, &Colorimetry::default()));
    s
}

#[test]
fn the_preview_relights_along_the_dial() {
    let mut s = demo_with_preview();
    let (text, buf) = replay(&mut s, "", 100, 30);
    assert!(text.contains("light dial: daylight 100%"), "{text}");
    let (w, h) = s.preview.ready.as_ref().expect("a preview").size();
    assert_eq!(s.preview.frame.len(), w * h * 3);
    assert!(s.preview.frame.iter().any(|v| *v != 0), "something is drawn");
    let at_start = s.preview.frame.clone();
    let half_blocks = buf.content.iter().filter(|c| c.symbol() == "▀").count();
    assert!(half_blocks > 500, "the panel is filled with half blocks ({half_blocks})");
    // Half way along a three-light dial is the middle light.
    let (text, _) = replay(&mut s, "] *10", 100, 30);
    assert!(text.contains("light dial: tungsten 100%"), "{text}");
    assert_ne!(s.preview.frame, at_start, "a different light gives a different picture");
    // Back to the start gives the same picture again; `v` shows the spectra instead.
    let (text, _) = replay(&mut s, "[ *10\nv", 100, 30);
    assert_eq!(s.preview.frame, at_start);
    assert!(text.contains(" spectra "), "{text}");
}

#[test]
fn the_preview_follows_edited_spectra() {
    let mut s = demo_with_preview();
    replay(&mut s, "", 100, 30);
    let before = s.preview.frame.clone();
    // Make daylight a 2000 K black body: the relit picture changes without a new raycast.
    replay(&mut s, "Up\np\nCtrl-u\n\"2000\"\nEnter", 100, 30);
    assert_ne!(s.preview.frame, before);
    replay(&mut s, "z", 100, 30);
    assert_eq!(s.preview.frame, before);
}

#[test]
fn preview_screen_snapshot() {
    let mut s = demo_with_preview();
    let (text, _) = replay(&mut s, "]\n]", 100, 30);
    insta::with_settings!({ snapshot_path => "../../snapshots", prepend_module_to_snapshot => false }, {
        insta::assert_snapshot!("preview_100x30", text);
    });
}

#[test]
fn the_preview_says_when_it_shows_the_scene_s_palette_and_not_the_designed_one() {
    // The designed palette's own spectra light the preview: nothing to say.
    let mut s = demo_with_preview();
    let (text, _) = replay(&mut s, "", 80, 24);
    assert!(!text.contains("the preview"), "{text}");
    // A scene whose materials and lights none of the designed palette's names: said plainly, wrapped.
    let scene = metamer::render::builtin_scene(32).expect("built-in scene");
    let mut other = demo_palette();
    for (k, e) in other.lights.iter_mut().enumerate() {
        e.name = format!("lamp{k}");
    }
    for (k, e) in other.reflectances.iter_mut().enumerate() {
        e.name = format!("paint{k}");
    }
    let mut s = state(other, ColourMode::TrueColor);
    s.set_preview(Preview::from_scene(&scene, &Colorimetry::default()));
    let (text, _) = replay(&mut s, "", 80, 24);
    let flat = text.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(flat.contains("the preview shows the scene's own spectra"), "{text}");
    assert!(flat.contains("edits do not reach it"), "{text}");
    insta::with_settings!({ snapshot_path => "../../snapshots", prepend_module_to_snapshot => false }, {
        insta::assert_snapshot!("preview_scene_palette_80x24", text);
    });
}

#[test]
fn with_the_dial_keys_the_bottom_line_shows_the_dial_s_keys() {
    let mut s = demo_with_preview();
    let (text, _) = replay(&mut s, "g", 80, 24);
    let bottom = text.lines().last().unwrap_or_default().to_string();
    assert!(bottom.contains("Esc leave") && bottom.contains("slider/vertex"), "{bottom}");
    assert!(!bottom.contains("d design"), "{bottom}");
    insta::with_settings!({ snapshot_path => "../../snapshots", prepend_module_to_snapshot => false }, {
        insta::assert_snapshot!("dial_keys_footer_80x24", text);
    });
    let (text, _) = replay(&mut s, "Esc", 80, 24);
    assert!(text.lines().last().unwrap_or_default().contains("d design"), "{text}");
}
