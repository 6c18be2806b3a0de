//! Live exploration: the preview draws the frames `metamer render` writes (same raycast, colour model,
//! exposure and relight), and the graphics-protocol path encodes the relit image into the terminal stream.

use crate::tui_support;

use metamer::colorimetry::Colorimetry;
use metamer::render::scene::builtin_scene;
use metamer::tui::colour::ColourMode;
use metamer::tui::derived::Derived;
use metamer::tui::graphics::{Graphics, PreviewMode};
use metamer::tui::preview::{Preview, cast, lut, preview_model};
use std::process::Command;
use std::sync::Arc;
use tui_support::{replay, state};

/// Frame `k` of a `frames`-frame `metamer render` of the built-in scene at `size`², decoded.
fn rendered(dir: &std::path::Path, size: usize, frames: usize, k: usize) -> Vec<u8> {
    let out = Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["render", "--builtin", "--builtin-volume-size", "48", "--no-dial", "--size", &size.to_string()])
        .args(["--frames", &frames.to_string(), "--frame-range", &format!("{k}..{}", k + 1), "-o"])
        .arg(dir)
        .output()
        .expect("the binary runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let img = image::open(dir.join(format!("frame_{k:04}.png"))).expect("a PNG").to_rgb8();
    assert_eq!((img.width() as usize, img.height() as usize), (size, size));
    img.into_raw()
}

#[test]
fn the_preview_shows_the_frames_render_writes() {
    let scene = builtin_scene(48).expect("built-in scene");
    let col = Colorimetry::default();
    let size = 40;
    let mut preview =
        Preview::new(Arc::new(scene.clone()), preview_model(&scene, &col), cast(&scene, size, size), &col);
    let dir = tempfile::tempdir().unwrap();
    let frames = metamer::tui::preview::EXPOSURE_FRAMES;
    let mut differ = 0;
    for k in [0, frames / 3, frames - 1] {
        let want = rendered(dir.path(), size, frames, k);
        let got = preview.frame(&scene.palette, &Derived::default(), &scene.dial.frame_state(k, frames), lut());
        assert_eq!(got.len(), want.len());
        let worst = got.iter().zip(&want).map(|(a, b)| a.abs_diff(*b)).max().unwrap_or(0);
        assert!(worst <= 1, "frame {k}: the preview differs from `metamer render` by {worst}/255");
        assert!(want.iter().any(|v| *v > 16), "frame {k} is not black");
        let first = preview.frame(&scene.palette, &Derived::default(), &scene.dial.state_at(0.0), lut());
        differ += usize::from(k > 0 && got != first);
    }
    assert_eq!(differ, 2, "frames along the dial differ from the first");
}

fn live_state(graphics: Graphics) -> metamer::tui::State {
    let scene = builtin_scene(32).expect("built-in scene");
    let mut s = state(scene.palette.clone(), ColourMode::TrueColor);
    s.graphics = graphics;
    s.set_preview_scene(scene);
    s
}

#[test]
fn the_raycast_follows_the_panel_size() {
    let mut s = live_state(Graphics::halfblocks());
    assert!(s.preview.is_none(), "nothing is raycast before the panel is known");
    replay(&mut s, "", 100, 30);
    let small = s.preview.as_ref().expect("raycast").size();
    assert_eq!(small.0, small.1, "square, as `metamer render`");
    assert_eq!(s.preview_frame.len(), small.0 * small.1 * 3);
    replay(&mut s, "", 120, 44);
    let large = s.preview.as_ref().expect("raycast").size();
    assert!(large.0 > small.0, "a taller panel raycasts more pixels: {small:?} → {large:?}");
    // Moving the dial relights without a new raycast.
    let before = s.preview_frame.clone();
    replay(&mut s, "] *5", 120, 44);
    assert_eq!(s.preview.as_ref().map(Preview::size), Some(large));
    assert_ne!(s.preview_frame, before);
}

#[test]
fn graphics_protocols_encode_the_relit_frame() {
    for (mode, marker) in [(PreviewMode::Kitty, "_G"), (PreviewMode::Sixel, "q"), (PreviewMode::Iterm2, "]1337;File=")]
    {
        let mut s = live_state(Graphics::forced(mode, (8, 16)));
        let (_, buf) = replay(&mut s, "", 100, 30);
        let (w, h) = s.preview.as_ref().expect("raycast").size();
        // 17 panel rows of 16 pixels, less the width of 8-pixel columns: the square is 17·16 = 272 high.
        assert_eq!((w, h), (272, 272), "{mode:?}: the raycast is at the panel's real pixels");
        let escapes: Vec<&str> = buf.content.iter().map(|c| c.symbol()).filter(|t| t.contains('\x1b')).collect();
        assert!(escapes.iter().any(|t| t.contains(marker)), "{mode:?}: no {marker:?} sequence in {escapes:.80?}");
        assert_eq!(half_blocks_in_preview(&s, &buf), 0, "{mode:?}: no half blocks");
        // A dial move re-encodes: the stream changes.
        let first: String = escapes.concat();
        let (_, buf) = replay(&mut s, "] *10", 100, 30);
        let second: String = buf.content.iter().map(|c| c.symbol()).filter(|t| t.contains('\x1b')).collect();
        assert_ne!(first, second, "{mode:?}: the relit frame is sent again");
    }
    let mut s = live_state(Graphics::halfblocks());
    let (text, buf) = replay(&mut s, "", 100, 30);
    assert!(text.contains("half blocks"), "{text}");
    assert!(half_blocks_in_preview(&s, &buf) > 500);
}

/// Half-block cells inside the preview's image area.
fn half_blocks_in_preview(s: &metamer::tui::State, buf: &ratatui::buffer::Buffer) -> usize {
    let image = metamer::tui::ui::preview_areas(s, buf.area).expect("the preview is shown").image;
    image.positions().filter(|p| buf.cell(*p).is_some_and(|c| c.symbol() == "▀")).count()
}

/// The demo palette over the built-in scene (no files), dial keys and all.
fn demo_live() -> metamer::tui::State {
    let palette = tui_support::demo_palette();
    let scene = metamer::render::scene::Scene::builtin(palette.clone(), 32).expect("built-in scene");
    let mut s = state(palette, ColourMode::TrueColor);
    s.graphics = Graphics::halfblocks();
    s.set_preview_scene(scene);
    s
}

macro_rules! snap {
    ($name:expr, $text:expr) => {
        insta::with_settings!({ snapshot_path => "../../snapshots", prepend_module_to_snapshot => false }, {
            insta::assert_snapshot!($name, $text);
        })
    };
}

#[test]
fn dial_widget_states() {
    let mut s = demo_live();
    let (text, _) = replay(&mut s, "g", 100, 30);
    assert!(s.dial_keys && text.contains("Esc leave"), "{text}");
    snap!("dial_keys_100x30", text);
    // The slider moves in small and large steps, and the picture follows.
    let start = s.dial_state.clone().expect("a dial");
    let frame = s.preview_frame.clone();
    replay(&mut s, "Right", 100, 30);
    let small = s.dial_state.as_ref().expect("a dial").slider[0] - start.slider[0];
    replay(&mut s, "L", 100, 30);
    let large = s.dial_state.as_ref().expect("a dial").slider[0] - start.slider[0] - small;
    assert!(small > 0.0 && (large / small - 10.0).abs() < 1e-9, "steps {small} and {large}");
    assert_ne!(s.preview_frame, frame, "the preview relights");
    // Light 2 off: hollow, weight 0.
    let (text, _) = replay(&mut s, "2", 100, 30);
    let d = s.dial_state.as_ref().expect("a dial");
    assert!(!d.lights[1].on && d.weights()[1] == 0.0);
    assert!(text.contains("○2") || text.contains("2○"), "{text}");
    snap!("dial_light_off_100x30", text);
    // Select vertex 1, move it, make it brighter.
    let before = s.dial_state.as_ref().expect("a dial").lights[0].position;
    let (text, _) = replay(&mut s, "Tab\nK\n+ *2", 100, 30);
    let d = s.dial_state.as_ref().expect("a dial");
    assert!(d.lights[0].position[1] > before[1] && d.lights[0].position[0] == before[0]);
    assert!((d.lights[0].intensity - 1.2).abs() < 1e-9 && text.contains("1.20"), "{text}");
    snap!("dial_vertex_selected_100x30", text);
    let (text, _) = replay(&mut s, "", 80, 24);
    snap!("dial_vertex_selected_80x24", text);
    // Esc leaves the dial keys; the arrows move the matrix selection again.
    replay(&mut s, "Esc", 100, 30);
    assert!(!s.dial_keys);
}

#[test]
fn saved_keyframes_render_as_previewed() {
    let dir = tempfile::tempdir().unwrap();
    let repo = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(repo.join("volumes/engine_palette.toml"), dir.path().join("engine_palette.toml")).unwrap();
    let body = std::fs::read_to_string(repo.join("volumes/engine_generated.toml")).unwrap();
    let scene_path = dir.path().join("scene.toml");
    std::fs::write(&scene_path, body.replace("generated_size = 160", "generated_size = 40")).unwrap();
    let scene = metamer::render::scene::Scene::load(&scene_path).expect("scene");
    let mut s = state(scene.palette.clone(), ColourMode::TrueColor);
    s.set_preview_scene(scene);
    // Between the lights, light 1 off, keyframe; then further, keyframe; save into the scene.
    replay(&mut s, "g\nL\nJ\n1\na\nH *2\na", 100, 30);
    let keyframes = s.keyframes.clone();
    assert_eq!(keyframes.len(), 2);
    assert!(!keyframes[0].lights[0].on && keyframes[0].slider != keyframes[1].slider);
    let (text, _) = replay(&mut s, "Ctrl-s", 100, 30);
    assert!(text.contains("saved 2 keyframes"), "{text}");
    assert!(s.keyframes.is_empty(), "saved keyframes are no longer pending: {:?}", s.message);
    let saved = metamer::render::scene::Scene::load(&scene_path).expect("the saved scene loads");
    let col = Colorimetry::default();
    let side = 48;
    let mut preview =
        Preview::new(Arc::new(saved.clone()), preview_model(&saved, &col), cast(&saved, side, side), &col);
    let out = dir.path().join("frames");
    let frames = metamer::tui::preview::EXPOSURE_FRAMES;
    let run = Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["render", "--no-dial", "--frames", &frames.to_string(), "--size", &side.to_string(), "-o"])
        .arg(&out)
        .arg(&scene_path)
        .output()
        .expect("the binary runs");
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    for (key, k) in keyframes.iter().zip([0, frames - 1]) {
        let loaded = saved.dial.frame_state(k, frames);
        for (a, b) in loaded.weights().iter().zip(key.weights()) {
            assert!((a - b).abs() < 1e-5, "keyframe {k}: weights {:?} vs {:?}", loaded.weights(), key.weights());
        }
        let want = image::open(out.join(format!("frame_{k:04}.png"))).expect("a frame").to_rgb8().into_raw();
        let got = preview.frame(&saved.palette, &Derived::default(), key, lut());
        // The designer's preview itself, after the save, has render's exposure for the saved sweep of its own
        // raycast (the exposure comes from the picture, so it is compared at the live preview's size).
        let live = s.preview.as_ref().expect("a preview");
        let fresh = Preview::new(Arc::new(saved.clone()), preview_model(&saved, &col), live.weights.clone(), &col);
        assert!((live.exposure - fresh.exposure).abs() < 1e-12 * fresh.exposure);
        let worst = got.iter().zip(&want).map(|(a, b)| a.abs_diff(*b)).max().unwrap_or(255);
        assert!(worst <= 1, "keyframe {k}: the render differs from the preview by {worst}/255");
    }
}
