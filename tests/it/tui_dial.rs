//! The designer along the light dial (issue 28): palettes with `[[mixtures]]` and `[[paths]]` open, `M`
//! lists them with the solve's numbers (the same as `metamer solve --report`'s), their values are edited
//! and undone through the document, and `m` in the light dial adds a target at the slider. Updates checked
//! on the state (pure: no terminal, thread or file), screens at 80×24 (insta snapshots under
//! `snapshots/`) with colours checked on cell styles.

use crate::tui_support;

use metamer::colorimetry::{Colorimetry, hex_to_linear};
use metamer::palette::mixing::{dial_mix, light_of};
use metamer::palette::{DialEntry, MixSpec, PaletteFile};
use metamer::render::Scene;
use metamer::tui::State;
use metamer::tui::action::{Action, Direction};
use metamer::tui::app::{Popup, Selection};
use metamer::tui::colour::ColourMode;
use metamer::tui::msg::{Effect, Msg};
use metamer::tui::replay::MemorySaver;
use metamer::tui::update::update;
use metamer::tui::worker::BasisMode;
use std::path::{Path, PathBuf};
use tui_input::InputRequest;

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/dial_mixtures.toml")
}

fn act(s: &mut State, action: Action) -> Vec<Effect> {
    update(s, Msg::Action(action))
}

/// Clear the open prompt, type `text` and submit it.
fn answer(s: &mut State, text: &str) -> Vec<Effect> {
    act(s, Action::Edit(InputRequest::DeleteLine));
    for c in text.chars() {
        act(s, Action::Edit(InputRequest::InsertChar(c)));
    }
    act(s, Action::Submit)
}

fn solves(effects: &[Effect]) -> usize {
    effects.iter().filter(|e| matches!(e, Effect::Solve { .. })).count()
}

fn listed(s: &State) -> Option<usize> {
    match &s.ui.popup {
        Some(Popup::DialList(list)) => Some(list.selected),
        _ => None,
    }
}

fn message(s: &State) -> String {
    s.ui.message.as_ref().map(|m| m.text.clone()).unwrap_or_default()
}

/// A palette with mixtures and paths opens (no refusal) and is solved; `M` lists them; the selected
/// entry's target, use, a path's samples and tolerance are edited (each a new generation, solved), a
/// bad answer keeps the prompt with the reason, delete removes it, and undo in the list steps back to the
/// palette as opened.
#[test]
fn mixtures_and_paths_are_listed_edited_and_undone() {
    let file = PaletteFile::load(&example()).expect("the example loads");
    let opened = file.palette.clone();
    let mut s = State::with_file(file, ColourMode::TrueColor);
    let effects = update(&mut s, Msg::Start { width: 80, height: 24, trains_bases: false });
    assert_eq!(solves(&effects), 1, "opened and solved");
    act(&mut s, Action::DialList);
    assert_eq!(listed(&s), Some(0));
    act(&mut s, Action::Move(Direction::Down));
    assert_eq!(listed(&s), Some(1));
    act(&mut s, Action::HexEntry);
    assert!(matches!(&s.ui.popup, Some(Popup::Prompt(p)) if p.title == "target of petal × dial [0.45, 0.6]"));
    let effects = answer(&mut s, "#102030");
    assert_eq!(solves(&effects), 1, "the edit is solved");
    assert_eq!(s.doc.palette.mixtures[1].target, hex_to_linear("#102030").unwrap());
    assert_eq!(listed(&s), Some(1), "the list is back, the entry still selected");
    act(&mut s, Action::ToggleUse);
    assert!(!s.doc.palette.mixtures[1].enabled);
    assert_eq!(message(&s), "petal × dial [0.45, 0.6]: not used (kept in the file)");
    act(&mut s, Action::Move(Direction::Down));
    act(&mut s, Action::DialSamples);
    answer(&mut s, "5");
    assert_eq!(s.doc.palette.paths[0].samples, 5);
    act(&mut s, Action::DialTolerance);
    let before = s.doc.palette.clone();
    assert_eq!(solves(&answer(&mut s, "0")), 0);
    let Some(Popup::Prompt(p)) = &s.ui.popup else { panic!("the prompt stays") };
    let reason = p.error.as_ref().map(|e| e.0.to_string()).unwrap_or_default();
    assert_eq!(reason, "a tolerance must be a finite ΔE00 > 0, got 0");
    assert_eq!(s.doc.palette, before, "a refused answer changes nothing");
    act(&mut s, Action::Back);
    act(&mut s, Action::DialList);
    act(&mut s, Action::Move(Direction::Down));
    act(&mut s, Action::Move(Direction::Down));
    act(&mut s, Action::DialSamples);
    assert!(matches!(&s.ui.popup, Some(Popup::Prompt(p)) if p.title.starts_with("design samples of leaf along")));
    act(&mut s, Action::Back);
    act(&mut s, Action::DialList);
    act(&mut s, Action::Move(Direction::Down));
    act(&mut s, Action::Move(Direction::Down));
    act(&mut s, Action::Remove);
    assert!(s.doc.palette.paths.is_empty());
    assert_eq!(listed(&s), Some(1), "the selection moves to the last entry left");
    // Undo in the list: the document's history, the list stays open.
    for _ in 0..4 {
        act(&mut s, Action::Undo);
        assert!(listed(&s).is_some());
    }
    assert_eq!(s.doc.palette, opened);
    act(&mut s, Action::Redo);
    assert!(!s.doc.palette.paths.is_empty() && s.doc.palette.mixtures[1].target != opened.mixtures[1].target);
    act(&mut s, Action::Back);
    assert_eq!(listed(&s), None);
}

/// `m` in the light dial adds a target for the selected reflectance at the slider: the palette's own
/// dial position with the lights switched off, its weights what the live dial gives there, its target the
/// colour the reflectance has there now; the new entry is selected in the list. With a vertex moved (the
/// live dial is no longer the palette's) the live weights are written as explicit weights.
#[test]
fn a_target_is_added_at_the_dials_slider() {
    let c = Colorimetry::default();
    let file = PaletteFile::load(&example()).expect("the example loads");
    let palette = file.palette.clone();
    let mut s = State::with_file(file, ColourMode::TrueColor);
    s.set_preview_scene(Scene::builtin(palette.clone(), 8).expect("a built-in scene"));
    update(&mut s, Msg::Start { width: 100, height: 30, trains_bases: false });
    // Nothing selected but a light: refused with the reason.
    s.ui.selection = Selection { col: 1, row: 0 };
    act(&mut s, Action::DialAddMixture);
    assert_eq!(message(&s), "select a reflectance first (a cell of its row, or its swatch)");
    // stone's swatch, the dial's keys, the slider moved, the lamp switched off.
    s.ui.selection = Selection { col: 0, row: 3 };
    act(&mut s, Action::DialKeys);
    for _ in 0..3 {
        act(&mut s, Action::DialSlide { dx: 1, dy: 1, big: false });
    }
    act(&mut s, Action::DialToggle(3));
    let dial = s.preview.dial_state().expect("the live dial").clone();
    let effects = act(&mut s, Action::DialAddMixture);
    assert_eq!(solves(&effects), 1, "the new target is solved");
    let m = s.doc.palette.mixtures.last().expect("a new mixture").clone();
    assert_eq!(s.doc.palette.mixtures.len(), 3);
    assert_eq!(m.spec, MixSpec::Dial { at: dial.slider, off: vec![2] });
    assert_eq!(m.mix, dial_mix(&palette.lights, dial.slider, &[2]).unwrap());
    let live: Vec<(usize, f64)> = dial.weights().into_iter().enumerate().filter(|(_, w)| *w > 0.0).collect();
    for ((i, w), (j, v)) in m.mix.iter().zip(&live) {
        assert!(i == j && (w - v).abs() < 1e-12, "the live dial's weights: {:?} vs {live:?}", m.mix);
    }
    let stone = palette.reflectance_index("stone").unwrap();
    assert_eq!(m.reflectance, stone);
    let now = c.rgb(&light_of(&m.mix, &s.solve.derived.light_spectra), &s.solve.derived.reflectance_spectra[stone]);
    assert!((m.target - now).norm() < 1e-12, "the target is its colour there now");
    assert_eq!(listed(&s), Some(2), "the new entry is selected in the list");
    assert!(message(&s).starts_with("added stone × dial ["), "{}", message(&s));
    // Undo takes it away again.
    act(&mut s, Action::Undo);
    assert_eq!(s.doc.palette.mixtures.len(), 2);
    act(&mut s, Action::Back);
    // A vertex moved: the live mixture is not the palette's dial any more, so its weights are written.
    act(&mut s, Action::DialSelect { forward: true });
    act(&mut s, Action::DialSlide { dx: 0, dy: 1, big: true });
    act(&mut s, Action::DialSelect { forward: false });
    let dial = s.preview.dial_state().expect("the live dial").clone();
    act(&mut s, Action::DialAddMixture);
    let m = s.doc.palette.mixtures.last().expect("a new mixture");
    assert_eq!(m.spec, MixSpec::Weights);
    let weights = dial.weights();
    assert!(m.mix.iter().all(|&(i, w)| (w - weights[i]).abs() < 1e-12), "{:?} vs {weights:?}", m.mix);
    assert!(s.doc.palette.set_dial_weight(DialEntry::Mixture(2), 1.0).is_ok());
}

/// The list's numbers are the solve's: for `palettes/dial_mixtures.toml` the designer shows exactly what
/// `metamer solve --report` writes for its mixtures (target, full and factor-model colours, ΔE00) and its
/// path (worst ΔE00 along the dense check, where, the factor model's worst). Screen at 80×24, the
/// swatches in the solved colours.
#[test]
fn the_lists_numbers_are_metamer_solves() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let palette = dir.path().join("dial_mixtures.toml");
    std::fs::copy(example(), &palette).expect("copy");
    let report = dir.path().join("report.json");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["solve", "--subspace"])
        .arg(&palette)
        .arg("--report")
        .arg(&report)
        .output()
        .expect("metamer runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("json");
    let file = PaletteFile::load(&palette).expect("loads");
    let mut s = State::with_file(file, ColourMode::TrueColor);
    let sidecar = metamer::basis::sidecar_path(&palette);
    let (text, buf) = tui_support::replay_with(
        &mut s,
        "M",
        80,
        24,
        &mut MemorySaver::default(),
        BasisMode::Train { sidecar: Some(sidecar) },
    );
    let r = &s.solve.dial;
    assert!(r.subspace, "the basis of the solved spectra is in");
    let v3 = |v: &serde_json::Value| -> [f64; 3] {
        let a = v.as_array().expect("3 numbers");
        [a[0].as_f64().unwrap(), a[1].as_f64().unwrap(), a[2].as_f64().unwrap()]
    };
    let same = |a: f64, b: f64, what: &str| assert!((a - b).abs() <= 1e-9 * (1.0 + b.abs()), "{what}: {a} vs {b}");
    let mixtures = json["mixtures"].as_array().expect("mixtures");
    assert_eq!(r.mixtures.len(), mixtures.len());
    for (m, j) in r.mixtures.iter().zip(mixtures) {
        for (k, key) in [(0, "target"), (1, "rgb_full"), (2, "rgb_subspace")] {
            let ours = [m.target, m.rgb_full, m.rgb_subspace.expect("factor model")][k];
            for (a, b) in ours.iter().zip(v3(&j[key])) {
                same(*a, b, key);
            }
        }
        same(m.delta_e_full, j["delta_e_full"].as_f64().unwrap(), "delta_e_full");
        same(m.delta_e_subspace.unwrap(), j["delta_e_subspace"].as_f64().unwrap(), "delta_e_subspace");
    }
    let paths = json["paths"].as_array().expect("paths");
    assert_eq!(r.paths.len(), paths.len());
    for (q, j) in r.paths.iter().zip(paths) {
        same(q.worst_delta_e, j["worst_delta_e"].as_f64().unwrap(), "worst_delta_e");
        same(q.worst_t, j["worst_t"].as_f64().unwrap(), "worst_t");
        same(q.worst_delta_e_subspace.unwrap(), j["worst_delta_e_subspace"].as_f64().unwrap(), "worst Vm");
        assert_eq!(q.checked as u64, j["checked"].as_u64().unwrap());
        assert_eq!(!q.is_unmet(), j["met"].as_bool().unwrap());
    }
    // The screen: each entry's numbers as printed, in the solved colours.
    let m0 = &r.mixtures[0];
    let line = format!(
        "target {}  full {} ΔE {:.2}  Vm {} ΔE {:.2}  w 1",
        metamer::colorimetry::linear_to_hex(&m0.target),
        metamer::colorimetry::linear_to_hex(&m0.rgb_full),
        m0.delta_e_full,
        metamer::colorimetry::linear_to_hex(&m0.rgb_subspace.unwrap()),
        m0.delta_e_subspace.unwrap()
    );
    assert!(text.contains(&line), "{line}\n{text}");
    assert!(text.contains("leaf along daylight → reveal (off: lamp) (9 samples, tol 1)"), "{text}");
    snap!("dial_list_80x24", text);
    // The first entry's swatch: ▌ in the target, ▀ in the full colour over the factor model's.
    let rgb = |v: &nalgebra::Vector3<f64>| {
        let c = metamer::colorimetry::linear_to_srgb8(v);
        ratatui::style::Color::Rgb(c[0], c[1], c[2])
    };
    let row = text.lines().position(|l| l.contains("petal × mix {daylight 0.5, lamp 0.5}")).expect("the row") as u16;
    let x = text.lines().nth(usize::from(row)).unwrap().chars().position(|ch| ch == '▌').expect("▌") as u16;
    assert_eq!(buf[(x, row)].fg, rgb(&m0.target));
    assert_eq!(buf[(x + 1, row)].symbol(), "▀");
    assert_eq!(buf[(x + 1, row)].fg, rgb(&m0.rgb_full));
    assert_eq!(buf[(x + 1, row)].bg, rgb(&m0.rgb_subspace.unwrap()));
    let status = text.lines().nth(usize::from(row)).unwrap().trim_end_matches(['│', ' ']).to_string();
    assert!(status.ends_with("met"), "{status}");
}

/// `P` shows the relit preview over the whole terminal (half blocks here), raycast again at that size,
/// with one caption line; every drawn pixel is a pixel of the relit frame; Esc returns to the panels.
#[test]
fn the_preview_fills_the_terminal_and_esc_returns() {
    let palette = tui_support::demo_palette();
    let mut s = tui_support::state(palette.clone(), ColourMode::TrueColor);
    s.set_preview_scene(Scene::builtin(palette, 32).expect("a built-in scene"));
    let (panels, _) = tui_support::replay(&mut s, "", 80, 24);
    let small = s.preview.ready.as_ref().expect("raycast").size();
    let (text, buf) = tui_support::replay(&mut s, "P", 80, 24);
    assert!(s.preview.full);
    let big = s.preview.ready.as_ref().expect("raycast").size();
    assert!(big.0 > small.0 && big.1 > small.1, "raycast again at the terminal's size: {small:?} → {big:?}");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 24);
    assert!(lines[23].starts_with("light dial: ") && lines[23].contains("P or Esc returns"), "{}", lines[23]);
    assert!(!text.contains('│') && !text.contains("matrix"), "no panels:\n{text}");
    // Every half block is two pixels of the frame.
    let frame = &s.preview.frame;
    let pixels: std::collections::HashSet<[u8; 3]> = frame.chunks(3).map(|p| [p[0], p[1], p[2]]).collect();
    let mut blocks = 0;
    for y in 0..23u16 {
        for x in 0..80u16 {
            let cell = &buf[(x, y)];
            if cell.symbol() == "▀" {
                blocks += 1;
                for c in [cell.fg, cell.bg] {
                    let ratatui::style::Color::Rgb(r, g, b) = c else { panic!("a truecolor pixel: {c:?}") };
                    assert!(pixels.contains(&[r, g, b]), "({x}, {y}) is not a pixel of the frame");
                }
            }
        }
    }
    assert!(blocks >= 23 * 40, "the image fills the terminal's height: {blocks} half blocks");
    // The pointer hits nothing the full preview hides: a click where a matrix cell is drawn in the panels
    // selects nothing while the preview covers it, and selects the cell once the panels are back.
    let at = |needle: &str| {
        let (y, line) = panels.lines().enumerate().find(|(_, l)| l.contains(needle)).expect(needle);
        (line[..line.find(needle).unwrap()].chars().count() as u16 + 2, y as u16)
    };
    let (cx, _) = at("tungsten");
    let (_, cy) = at("tissue");
    let click = format!("click {cx} {cy}\nrelease {cx} {cy}");
    let before = s.ui.selection;
    tui_support::replay(&mut s, &click, 80, 24);
    assert_eq!(s.ui.selection, before, "a click on the full preview selected a hidden cell");
    let (back, _) = tui_support::replay(&mut s, "Esc", 80, 24);
    assert!(!s.preview.full);
    assert_eq!(back, panels, "Esc returns to the panels as they were");
    tui_support::replay(&mut s, &click, 80, 24);
    assert_ne!(s.ui.selection, before, "the same click on the panels selects the cell");
}

/// The per-light intensity sliders beside the dial are the preview's: `+` on a selected light relights
/// the frame, says it is view only, and leaves the palette (and its solve) as it was.
#[test]
fn intensity_sliders_are_view_only() {
    let palette = tui_support::demo_palette();
    let mut s = tui_support::state(palette.clone(), ColourMode::TrueColor);
    s.set_preview_scene(Scene::builtin(palette.clone(), 32).expect("a built-in scene"));
    tui_support::replay(&mut s, "g\nTab", 80, 24);
    let frame = s.preview.frame.clone();
    let (text, _) = tui_support::replay(&mut s, "+", 80, 24);
    assert!((s.preview.dial_state().expect("dial").lights[0].intensity - 1.1).abs() < 1e-12);
    assert_ne!(s.preview.frame, frame, "the preview relights");
    assert_eq!(s.doc.palette, palette, "the palette is unchanged");
    assert!(!s.is_dirty());
    assert!(text.contains("daylight ×1.1: view only, the palette is unchanged"), "{text}");
}

/// End to end through the binary: `metamer design --replay` edits a mixture's target and a path's
/// samples in the list and saves (Ctrl-s saves for real in a script); the file keeps its comments and
/// reads back with the edits.
#[test]
fn the_designer_saves_list_edits_into_the_file() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let palette = dir.path().join("dial_mixtures.toml");
    std::fs::copy(example(), &palette).expect("copy");
    let keys = dir.path().join("keys.txt");
    std::fs::write(&keys, "M\nDown\n#\nCtrl-u\n\"#102030\"\nEnter\nDown\nn\nCtrl-u\n\"5\"\nEnter\nCtrl-s\n")
        .expect("write keys");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["design", "--no-basis", "--size", "80x24", "--replay"])
        .arg(&keys)
        .arg(&palette)
        .output()
        .expect("metamer runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let saved = PaletteFile::load(&palette).expect("the saved file loads");
    let mut expected = PaletteFile::load(&example()).expect("the example").palette;
    expected.set_dial_target(DialEntry::Mixture(1), hex_to_linear("#102030").unwrap()).unwrap();
    expected.set_path_samples(0, 5).unwrap();
    // The designed spectra are the solve's; the criteria are the edited ones.
    assert_eq!(saved.palette.mixtures, expected.mixtures);
    assert_eq!(saved.palette.paths, expected.paths);
    let text = std::fs::read_to_string(&palette).expect("read");
    assert!(text.starts_with("# Designing along the light dial"), "{text}");
    assert!(text.contains("dial = [0.45, 0.6]\ntarget = \"#102030\""), "{text}");
    assert!(text.contains("samples = 5\n"), "{text}");
}

/// A light or reflectance that mixtures or paths use is not removed (their weights and routes would
/// change meaning); the refusal says where to delete those criteria in the designer.
#[test]
fn removing_what_a_mixture_uses_points_to_the_list() {
    let file = PaletteFile::load(&example()).expect("the example loads");
    let opened = file.palette.clone();
    let mut s = State::with_file(file, ColourMode::TrueColor);
    update(&mut s, Msg::Start { width: 80, height: 24, trains_bases: false });
    s.ui.selection = Selection { col: 0, row: 2 };
    act(&mut s, Action::Remove);
    assert_eq!(message(&s), "reflectance `leaf` is used by paths[0]: M lists them and x there deletes one");
    assert_eq!(s.doc.palette, opened);
    // Deleted in the list, the reflectance goes.
    act(&mut s, Action::DialList);
    act(&mut s, Action::Move(Direction::Down));
    act(&mut s, Action::Move(Direction::Down));
    act(&mut s, Action::Remove);
    act(&mut s, Action::Back);
    act(&mut s, Action::Remove);
    assert!(s.doc.palette.reflectance_index("leaf").is_none(), "{}", message(&s));
}
