//! Live exploration: the preview draws the frames `metamer render` writes (same raycast, colour model,
//! exposure and relight), and the graphics-protocol path encodes the relit image into the terminal stream.

use crate::tui_support;

use metamer::colorimetry::Colorimetry;
use metamer::render::builtin_scene;
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
    s.preview.graphics = graphics;
    s.set_preview_scene(scene);
    s
}

#[test]
fn the_raycast_follows_the_panel_size() {
    let mut s = live_state(Graphics::halfblocks());
    assert!(s.preview.ready.is_none(), "nothing is raycast before the panel is known");
    replay(&mut s, "", 100, 30);
    let small = s.preview.ready.as_ref().expect("raycast").size();
    assert_eq!(small.0, small.1, "square, as `metamer render`");
    assert_eq!(s.preview.frame.len(), small.0 * small.1 * 3);
    replay(&mut s, "", 120, 44);
    let large = s.preview.ready.as_ref().expect("raycast").size();
    assert!(large.0 > small.0, "a taller panel raycasts more pixels: {small:?} → {large:?}");
    // Moving the dial relights without a new raycast.
    let before = s.preview.frame.clone();
    replay(&mut s, "] *5", 120, 44);
    assert_eq!(s.preview.ready.as_ref().map(Preview::size), Some(large));
    assert_ne!(s.preview.frame, before);
}

#[test]
fn graphics_protocols_encode_the_relit_frame() {
    for (mode, marker) in [(PreviewMode::Kitty, "_G"), (PreviewMode::Sixel, "q"), (PreviewMode::Iterm2, "]1337;File=")]
    {
        let mut s = live_state(Graphics::forced(mode, (8, 16)));
        let (_, buf) = replay(&mut s, "", 100, 30);
        let (w, h) = s.preview.ready.as_ref().expect("raycast").size();
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
    let scene = metamer::render::Scene::builtin(palette.clone(), 32).expect("built-in scene");
    let mut s = state(palette, ColourMode::TrueColor);
    s.preview.graphics = Graphics::halfblocks();
    s.set_preview_scene(scene);
    s
}

#[test]
fn dial_widget_states() {
    let mut s = demo_live();
    let (text, _) = replay(&mut s, "g", 100, 30);
    assert!(s.preview.keys && text.contains("Esc leave"), "{text}");
    snap!("dial_keys_100x30", text);
    // The slider moves in small and large steps, and the picture follows.
    let start = s.preview.dial_state().cloned().expect("a dial");
    let frame = s.preview.frame.clone();
    replay(&mut s, "Right", 100, 30);
    let small = s.preview.dial_state().expect("a dial").slider[0] - start.slider[0];
    replay(&mut s, "L", 100, 30);
    let large = s.preview.dial_state().expect("a dial").slider[0] - start.slider[0] - small;
    assert!(small > 0.0 && (large / small - 10.0).abs() < 1e-9, "steps {small} and {large}");
    assert_ne!(s.preview.frame, frame, "the preview relights");
    // Light 2 off: hollow, weight 0.
    let (text, _) = replay(&mut s, "2", 100, 30);
    let d = s.preview.dial_state().expect("a dial");
    assert!(!d.lights[1].on && d.weights()[1] == 0.0);
    assert!(text.contains("○2") || text.contains("2○"), "{text}");
    snap!("dial_light_off_100x30", text);
    // Select vertex 1, move it, make it brighter.
    let before = s.preview.dial_state().expect("a dial").lights[0].position;
    let (text, _) = replay(&mut s, "Tab\nK\n+ *2", 100, 30);
    let d = s.preview.dial_state().expect("a dial");
    assert!(d.lights[0].position[1] > before[1] && d.lights[0].position[0] == before[0]);
    assert!((d.lights[0].intensity - 1.2).abs() < 1e-9 && text.contains("1.20"), "{text}");
    snap!("dial_vertex_selected_100x30", text);
    let (text, _) = replay(&mut s, "", 80, 24);
    snap!("dial_vertex_selected_80x24", text);
    // Esc leaves the dial keys; the arrows move the matrix selection again.
    replay(&mut s, "Esc", 100, 30);
    assert!(!s.preview.keys);
}

#[test]
fn saved_keyframes_render_as_previewed() {
    let dir = tempfile::tempdir().unwrap();
    let repo = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(repo.join("volumes/engine_palette.toml"), dir.path().join("engine_palette.toml")).unwrap();
    let body = std::fs::read_to_string(repo.join("volumes/engine_generated.toml")).unwrap();
    let scene_path = dir.path().join("scene.toml");
    std::fs::write(&scene_path, body.replace("generated_size = 160", "generated_size = 40")).unwrap();
    let scene = metamer::render::Scene::load(&scene_path).expect("scene");
    let mut s = state(scene.palette.clone(), ColourMode::TrueColor);
    s.set_preview_scene(scene);
    // Between the lights, light 1 off, keyframe; then further, keyframe; save into the scene.
    replay(&mut s, "g\nL\nJ\n1\na\nH *2\na", 100, 30);
    let keyframes = s.preview.keyframes.clone();
    assert_eq!(keyframes.len(), 2);
    assert!(!keyframes[0].lights[0].on && keyframes[0].slider != keyframes[1].slider);
    let (text, _) = replay(&mut s, "Ctrl-s", 100, 30);
    assert!(text.contains("saved 2 keyframes"), "{text}");
    assert!(s.preview.keyframes.is_empty(), "saved keyframes are no longer pending: {:?}", s.ui.message);
    let saved = metamer::render::Scene::load(&scene_path).expect("the saved scene loads");
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
        // raycast with the designer's current spectra (the exposure comes from the picture, so it is compared at
        // the live preview's size).
        let live = s.preview.ready.as_ref().expect("a preview");
        let mut fresh = Preview::new(Arc::new(saved.clone()), preview_model(&saved, &col), live.weights.clone(), &col);
        fresh.frame(&s.doc.palette, &s.solve.derived, key, lut());
        assert!((live.exposure - fresh.exposure).abs() < 1e-12 * fresh.exposure);
        let worst = got.iter().zip(&want).map(|(a, b)| a.abs_diff(*b)).max().unwrap_or(255);
        assert!(worst <= 1, "keyframe {k}: the render differs from the preview by {worst}/255");
    }
}

/// The demo palette with `n` lights (the demo's three, then black-body lights with longer names).
fn palette_with_lights(n: usize) -> metamer::palette::Palette {
    use metamer::palette::Source;
    use metamer::spectrum::{Normalize, Spectrum};
    let mut p = tui_support::demo_palette();
    let extra = [("candlelight", 1900.0), ("north sky daylight", 12000.0), ("noon", 5500.0)];
    let lum = Colorimetry::default().luminance();
    for (name, kelvin) in extra.iter().take(n.saturating_sub(p.lights.len())) {
        let mut l = p.lights[2].clone();
        l.name = (*name).to_string();
        l.source = Source::Planck(*kelvin);
        l.spectrum = Spectrum::planck(*kelvin).unwrap().normalized(Normalize::Luminance, &lum).unwrap();
        p.lights.push(l);
    }
    p.lights.truncate(n);
    p
}

#[test]
fn dial_labels_never_overlap_at_80x24_and_100x30() {
    for n in [3, 4, 6] {
        for (w, h) in [(80, 24), (100, 30)] {
            let palette = palette_with_lights(n);
            let scene = metamer::render::Scene::builtin(palette.clone(), 32).expect("built-in scene");
            let mut s = state(palette, ColourMode::TrueColor);
            s.preview.graphics = Graphics::halfblocks();
            s.set_preview_scene(scene);
            // The slider between the lights, so it is not on a vertex.
            let (text, buf) = replay(&mut s, "g\nJ *3\nH *2", w, h);
            let dial = metamer::tui::ui::preview_areas(&s, buf.area).expect("the preview is shown").dial;
            assert!(dial.width > 0, "{n} lights at {w}x{h}: no dial panel\n{text}");
            // Every vertex mark is drawn (the slider may hide one): the marks of the panel less those of the
            // intensity list (a digit in the first column, the mark after it).
            let symbol = |x: u16, y: u16| buf.cell((x, y)).map_or("", |c| c.symbol());
            let is_mark = |x: u16, y: u16| matches!(symbol(x, y), "●" | "○");
            let in_list = |x: u16, y: u16| x == dial.x + 1 && symbol(dial.x, y).chars().all(|c| c.is_ascii_digit());
            let marks = (dial.y..dial.y + dial.height)
                .flat_map(|y| (dial.x..dial.x + dial.width).map(move |x| (x, y)))
                .filter(|&(x, y)| is_mark(x, y) && !in_list(x, y))
                .count();
            assert!(marks + 1 >= n, "{n} lights at {w}x{h}: {marks} vertex marks\n{text}");
            snap!(format!("dial_labels_{n}_lights_{w}x{h}"), text);
        }
    }
}

#[test]
fn the_preview_of_an_unsaved_solve_is_what_render_draws_once_saved() {
    use metamer::palette::PaletteFile;
    let dir = tempfile::tempdir().unwrap();
    let start = tui_support::demo_palette();
    let palette_path = dir.path().join("demo.toml");
    PaletteFile::from_palette(&start).save_as(&start, &palette_path).unwrap();
    let on_disk = std::fs::read_to_string(&palette_path).unwrap();
    let scene_text = |palette: &str| {
        format!(
            "palette = \"{palette}\"\nvolume = \"generated:engine_like\"\n\n\
             [[materials]]\nreflectance = \"skin\"\nrange = [18, 75]\nopacity = 0.025\n\n\
             [[materials]]\nreflectance = \"block\"\nrange = [105, 175]\nopacity = 0.12\n\n\
             [[materials]]\nreflectance = \"tissue\"\nrange = [200, 255]\nopacity = 0.6\n\n\
             [render]\ngenerated_size = 40\n"
        )
    };
    std::fs::write(dir.path().join("scene.toml"), scene_text("demo.toml")).unwrap();
    let scene = metamer::render::Scene::load(&dir.path().join("scene.toml")).expect("scene");
    let mut s = metamer::tui::State::new(palette_path.clone(), start.clone(), ColourMode::TrueColor);
    s.preview.graphics = Graphics::halfblocks();
    s.set_preview_scene(scene.clone());
    // With bases trained, as the designer runs (the preview then draws with the basis of the solved spectra).
    let worker = metamer::tui::worker::BasisMode::Train { sidecar: None };
    let mut saver = metamer::tui::replay::MemorySaver::default();
    tui_support::replay_with(&mut s, "wait-solve", 100, 30, &mut saver, worker);
    // The designed reflectances are solved in memory, not saved.
    let block = s.doc.palette.reflectance_index("block").expect("block");
    assert!(s.solve.derived.solved, "the designer shows a solution");
    let solved = s.solve.derived.reflectance_spectra[block];
    assert_ne!(solved, start.reflectances[block].spectrum, "the solve changed the designed reflectance");
    assert_eq!(std::fs::read_to_string(&palette_path).unwrap(), on_disk, "nothing was saved");
    let size = s.preview.ready.as_ref().expect("a preview").size();
    assert_eq!(size.0, size.1);
    // The same spectra in a palette file of their own, rendered by `metamer render`.
    let solved_path = dir.path().join("solved.toml");
    let mut with_solution = s.doc.palette.clone();
    for (e, spectrum) in with_solution.reflectances.iter_mut().zip(&s.solve.derived.reflectance_spectra) {
        e.spectrum = *spectrum;
    }
    for (e, spectrum) in with_solution.lights.iter_mut().zip(&s.solve.derived.light_spectra) {
        e.spectrum = *spectrum;
    }
    PaletteFile::from_palette(&with_solution).save_as(&with_solution, &solved_path).unwrap();
    let reloaded = PaletteFile::load(&solved_path).expect("the solved palette loads").palette;
    assert_eq!(reloaded.reflectances[block].spectrum, solved, "the file holds the solved samples");
    std::fs::write(dir.path().join("solved_scene.toml"), scene_text("solved.toml")).unwrap();
    let out = dir.path().join("frames");
    let frames = metamer::tui::preview::EXPOSURE_FRAMES;
    let k = frames / 3;
    let run = Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["render", "--no-dial", "--frames", &frames.to_string(), "--size", &size.0.to_string()])
        .args(["--frame-range", &format!("{k}..{}", k + 1), "-o"])
        .arg(&out)
        .arg(dir.path().join("solved_scene.toml"))
        .output()
        .expect("the binary runs");
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let want = image::open(out.join(format!("frame_{k:04}.png"))).expect("a frame").to_rgb8().into_raw();
    // The designer's own preview at that frame's dial state.
    s.preview.dial.as_mut().expect("a dial").state = scene.dial.frame_state(k, frames);
    s.relight();
    let got = s.preview.frame.clone();
    assert_eq!(got.len(), want.len());
    let worst = got.iter().zip(&want).map(|(a, b)| a.abs_diff(*b)).max().unwrap_or(255);
    assert!(worst <= 1, "the unsaved design's preview differs from the render by {worst}/255");
    // And it is not the picture of the palette as it was on disk.
    let mut before = Preview::new(
        Arc::new(scene.clone()),
        preview_model(&scene, &Colorimetry::default()),
        s.preview.ready.as_ref().expect("a preview").weights.clone(),
        &Colorimetry::default(),
    );
    let old = before.frame(&start, &Derived::default(), &scene.dial.frame_state(k, frames), lut());
    let off = old.iter().zip(&want).map(|(a, b)| a.abs_diff(*b)).max().unwrap_or(0);
    assert!(off > 8, "the file's spectra would look the same ({off}/255): the test could not tell");
}

#[test]
fn saving_keyframes_keeps_the_scene_as_written() {
    use metamer::tui::keyframes::save_keyframes;
    let dir = tempfile::tempdir().unwrap();
    let repo = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(repo.join("volumes/engine_palette.toml"), dir.path().join("engine_palette.toml")).unwrap();
    let original = "# My engine scene.\n\
        palette = \"engine_palette.toml\"   # the designed palette\n\
        volume = \"generated:engine_like\"\n\n\
        [[materials]]                 # block\n\
        reflectance = \"block\"\nrange = [105, 175]\nopacity = 0.12\n\n\
        [[materials]]\nreflectance = \"inner\"\nrange = [200, 255]\nopacity = 0.6\n\n\
        [camera]\nzoom = 1.0\nazimuth_deg = 35.0   # from the left\n\n\
        [dial]\n# hide first, then the split\npath = [\"hide\", \"split\", \"glow\"]   # the seed's order\n\
        vertices = { glow = [0.5, 1.0] }\n\n\
        [render]\ngenerated_size = 24\n";
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, original).unwrap();
    let scene = metamer::render::Scene::load(&path).expect("scene");
    let mut k = scene.dial.base.clone();
    k.set_slider([0.25, 0.5]).unwrap();
    k.set_on(0, false).unwrap();
    let note = save_keyframes(&path, std::slice::from_ref(&k)).expect("saved");
    assert!(note.contains("saved 1 keyframes") && note.contains("kept as a comment"), "{note}");
    let saved = std::fs::read_to_string(&path).unwrap();
    // Every line the user wrote is still there, in order, except the path, now a comment.
    let mut rest = saved.as_str();
    let moved = ["path = [\"hide\", \"split\", \"glow\"]   # the seed's order", "# hide first, then the split"];
    for line in original.lines().filter(|l| !moved.contains(l)) {
        let at = rest.find(line).unwrap_or_else(|| panic!("`{line}` lost or moved:\n{saved}"));
        rest = &rest[at + line.len()..];
    }
    assert!(saved.contains("palette = \"engine_palette.toml\"   # the designed palette\n"), "{saved}");
    assert!(
        saved.contains("# hide first, then the split\n# path = [\"hide\", \"split\", \"glow\"]   # the seed's order\n"),
        "the path and its comment are kept as comments:\n{saved}"
    );
    assert!(!saved.lines().any(|l| l.starts_with("path")), "a dial has either a path or keyframes:\n{saved}");
    let loaded = metamer::render::Scene::load(&path).expect("the saved scene loads");
    assert_eq!(loaded.palette_path, scene.palette_path, "the palette is the same file");
    assert_eq!(loaded.materials.len(), 2);
    assert_eq!(loaded.dial.keyframe_count(), 1);
    let state = loaded.dial.frame_state(0, 1);
    assert_eq!(state.slider, [0.25, 0.5]);
    assert!(!state.lights[0].on && state.lights[1].on);
    assert_eq!(state.lights[2].position, [0.5, 1.0], "the scene's vertex kept");
    // A second save appends and leaves the first keyframe's text as it was.
    k.set_slider([0.5, 0.5]).unwrap();
    save_keyframes(&path, std::slice::from_ref(&k)).expect("saved again");
    let again = std::fs::read_to_string(&path).unwrap();
    let second = again.rfind("[[dial.keyframes]]").expect("a second keyframe");
    let render = again.find("[render]").expect("[render] kept");
    assert!(second < render, "the keyframes stay in the dial's part of the file:\n{again}");
    assert_eq!(format!("{}{}", &again[..second], &again[render..]), saved, "only the new keyframe is added");
    let loaded = metamer::render::Scene::load(&path).expect("loads");
    assert_eq!(loaded.dial.keyframe_count(), 2);
}
