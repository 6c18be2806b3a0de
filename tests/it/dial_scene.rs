//! The `[dial]` table of scene files: keyframes, vertex overrides, lights switched off, and their errors
//! (docs/formats/dial.md).

use metamer::render::RenderError;
use metamer::render::Scene;
use metamer::render::Sweep;
use std::path::{Path, PathBuf};

/// A scene next to the shipped engine palette, over the generated volume (no data files needed).
fn scene(dial: &str) -> Result<Scene, RenderError> {
    let text = format!(
        "palette = \"engine_palette.toml\"\nvolume = \"generated:engine_like\"\n\
         [[materials]]\nreflectance = \"block\"\nrange = [100, 175]\nopacity = 0.1\n\
         [render]\ngenerated_size = 24\n{dial}"
    );
    let path: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("volumes/dial_test_scene.toml");
    Scene::parse(&text, &path)
}

fn error(dial: &str) -> (String, String) {
    match scene(dial) {
        Err(RenderError::Scene { key, reason, .. }) => (key, reason),
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!("the scene parsed:\n{dial}"),
    }
}

#[test]
fn keyframes_resolve_vertices_switches_and_moves() {
    let s = scene(
        "[dial]\nvertices = { glow = [0.5, 1.0] }\n\
         [[dial.keyframes]]\nat = \"hide\"\n\
         [[dial.keyframes]]\nat = [0.5, 0.3]\noff = [\"split\"]\n\
         [[dial.keyframes]]\nat = \"glow\"\nmove = { hide = [-1.0, 0.0] }\nintensity = { glow = 0.5 }\n\
         [[dial.keyframes]]\nat = \"glow\"\non = [\"split\"]\n",
    )
    .unwrap();
    let Sweep::Keyframes(k) = &s.dial.sweep else { panic!("not a keyframe dial") };
    assert_eq!(k.len(), 4);
    let (hide, split, glow) = (0, 1, 2);
    assert_eq!(s.dial.base.lights[glow].position, [0.5, 1.0]);
    assert_eq!(k[0].slider, s.dial.base.lights[hide].position);
    assert!(k[0].lights.iter().all(|l| l.on));
    assert!(!k[1].lights[split].on && !k[2].lights[split].on && k[3].lights[split].on);
    assert_eq!(k[2].slider, [0.5, 1.0]);
    assert_eq!(k[1].lights[hide].position, [0.0, 0.0]);
    assert_eq!(k[2].lights[hide].position, [-1.0, 0.0]);
    assert_eq!(k[3].lights[glow].intensity, 0.5);
    // At the glow vertex the light is glow alone, at half intensity.
    let e = k[2].light();
    let g = s.palette.lights[glow].spectrum;
    assert!((0..31).all(|i| (e.0[i] - 0.5 * g.0[i]).abs() < 1e-12));
}

#[test]
fn path_keeps_its_meaning_and_takes_vertex_overrides() {
    let s = scene("[dial]\npath = [\"split\", \"hide\"]\nvertices = { hide = [2.0, 2.0] }\n").unwrap();
    assert_eq!(s.dial.sweep, Sweep::Path(vec![1, 0]));
    let mid = s.dial.state_at(0.5);
    assert_eq!(mid.weights(), vec![0.5, 0.5, 0.0]);
    assert_eq!(mid.slider, [1.5, 1.0]);
}

#[test]
fn bad_dials_name_the_key_and_the_reason() {
    let (k, r) = error("[dial]\n[[dial.keyframes]]\nat = \"sunset\"\n");
    assert_eq!(k, "dial.keyframes[0].at");
    assert!(r.contains("`sunset` is not a light") && r.contains("hide, split, glow"), "{r}");
    let (k, r) = error("[dial]\n[[dial.keyframes]]\nat = \"hide\"\noff = [\"hide\", \"nope\"]\n");
    assert_eq!(k, "dial.keyframes[0].off[1]");
    assert!(r.contains("`nope`"), "{r}");
    let (k, r) = error("[dial]\n[[dial.keyframes]]\nat = [nan, 0.0]\n");
    assert_eq!(k, "dial.keyframes[0].at");
    assert!(r.contains("NaN") && r.contains("finite"), "{r}");
    let (k, _) = error("[dial]\nvertices = { glow = [inf, 0.0] }\n");
    assert_eq!(k, "dial.vertices.glow");
    let (k, _) = error("[dial]\n[[dial.keyframes]]\nat = \"hide\"\nmove = { glow = [0.0, nan] }\n");
    assert_eq!(k, "dial.keyframes[0].move.glow");
    let (k, r) = error(
        "[dial]\n[[dial.keyframes]]\nat = \"hide\"\noff = [\"hide\"]\n\
         [[dial.keyframes]]\nat = \"glow\"\noff = [\"split\", \"glow\"]\n",
    );
    assert_eq!(k, "dial.keyframes[1].off");
    assert!(r.contains("every light off"), "{r}");
    let (k, r) = error("[dial]\npath = [\"hide\"]\n[[dial.keyframes]]\nat = \"hide\"\n");
    assert_eq!(k, "dial");
    assert!(r.contains("not both"), "{r}");
    let (k, _) = error("[dial]\nkeyframes = []\n");
    assert_eq!(k, "dial.keyframes");
    let (k, _) = error("[dial]\n[[dial.keyframes]]\nat = \"hide\"\nintensity = { hide = -1.0 }\n");
    assert_eq!(k, "dial.keyframes[0].intensity.hide");
    let (_, r) = error("[dial]\n[[dial.keyframes]]\nat = \"h\\u0007\"\n");
    assert!(r.contains("\\u{7}") && !r.contains('\u{7}'), "{r}");
    let (k, _) = error("[dial]\n[[dial.keyframes]]\nat = \"hide\"\nswitch = 1\n");
    assert!(k.starts_with("line"), "{k}");
}

/// Dials that would render black with exit 0 (issue 31, item 8) are refused like `off = [all]`: points so
/// far out that the light mix's squared distances overflow, and every light that is on at intensity 0.
#[test]
fn degenerate_dials_are_refused_like_every_light_off() {
    let (k, r) = error("[dial]\n[[dial.keyframes]]\nat = [1e200, 0.0]\n[[dial.keyframes]]\nat = \"hide\"\n");
    assert_eq!(k, "dial.keyframes[0].at");
    assert!(r.contains("outside the dial") && r.contains("overflow"), "{r}");
    let (k, _) = error("[dial]\nvertices = { glow = [0.0, -1e200] }\n");
    assert_eq!(k, "dial.vertices.glow");
    let (k, _) = error("[dial]\n[[dial.keyframes]]\nat = \"hide\"\nmove = { split = [3e6, 0.0] }\n");
    assert_eq!(k, "dial.keyframes[0].move.split");
    let all_zero = "intensity = { hide = 0.0, split = 0.0, glow = 0.0 }";
    let (k, r) = error(&format!("[dial]\n[[dial.keyframes]]\nat = \"hide\"\n{all_zero}\n"));
    assert_eq!(k, "dial.keyframes[0].intensity");
    assert!(r.contains("intensity 0") && r.contains("black"), "{r}");
    // Off and zero together leave nothing lit either; one light at 0.0 with another on is fine.
    let (k, _) =
        error("[dial]\n[[dial.keyframes]]\nat = \"hide\"\noff = [\"split\", \"glow\"]\nintensity = { hide = 0.0 }\n");
    assert_eq!(k, "dial.keyframes[0].intensity");
    let ok = scene(
        "[dial]\n[[dial.keyframes]]\nat = [1e5, -1e5]\nintensity = { hide = 0.0 }\n[[dial.keyframes]]\nat = \"glow\"\n",
    );
    assert!(ok.is_ok(), "{:?}", ok.err());
}

/// Frames with the dial are byte-identical between two factor-model runs, and the dial touches only
/// the lower-right panel (compared with a run without it).
#[test]
fn dial_frames_are_deterministic_and_the_dial_stays_lower_right() {
    use metamer::colorimetry::Colorimetry;
    use metamer::render::DialOverlay;
    use metamer::render::Mode;
    use metamer::render::{Acceleration, colour_model, render_views};
    use metamer::render::{SweepOptions, sweep_exposure, write_sweep};
    let scene = metamer::render::builtin_scene(32).unwrap();
    let col = Colorimetry::default();
    // The smallest frames get no dial (its names would be under 6 px): 224² has one.
    let size = 224;
    let dir = tempfile::tempdir().unwrap();
    let reflectances: Vec<_> = scene.materials.iter().map(|m| m.spectrum).collect();
    let frames = 4;
    let exposure = sweep_exposure(&col, &reflectances, &scene.dial, frames, 1.0);
    let run = |name: &str, dial: bool| -> Vec<Vec<u8>> {
        let model = colour_model(&scene, Mode::Factor, &col).unwrap();
        let view = render_views(&scene, vec![model], size, size, Acceleration::default(), None).pop().unwrap();
        let mut options = SweepOptions::new(frames, exposure, dir.path().join(name));
        options.overlay = dial.then(|| DialOverlay::new(&scene.dial, &col, size, size));
        let report = write_sweep(&view.image, &view.model, &scene.dial, &options, &|| {}).unwrap();
        report.written.iter().map(|p| std::fs::read(p).unwrap()).collect()
    };
    let (a, b, plain) = (run("a", true), run("b", true), run("plain", false));
    assert_eq!(a, b, "two runs with the dial differ");
    for (with, without) in a.iter().zip(&plain) {
        let w = image::load_from_memory(with).unwrap().to_rgb8();
        let p = image::load_from_memory(without).unwrap().to_rgb8();
        let changed: Vec<(u32, u32)> =
            w.enumerate_pixels().filter(|(x, y, px)| p.get_pixel(*x, *y) != *px).map(|(x, y, _)| (x, y)).collect();
        assert!(changed.len() > 300, "the dial drew only {} pixels", changed.len());
        assert!(changed.iter().all(|&(x, y)| x >= size as u32 / 2 && y >= size as u32 / 2));
    }
}
