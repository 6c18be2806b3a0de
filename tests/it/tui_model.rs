//! The designer's update step as a pure function: each test feeds messages to one sub-model through
//! `update` and checks the effects it asks for and the state it leaves — no terminal, no thread, no file
//! (the replies the loop would send are built here).

use crate::tui_support::{demo_palette, state};

use metamer::design::DesignError;
use metamer::palette::PaletteFile;
use metamer::render::Scene;
use metamer::tui::State;
use metamer::tui::action::{Action, Direction};
use metamer::tui::app::{Popup, Selection};
use metamer::tui::colour::ColourMode;
use metamer::tui::msg::{Effect, FileOutcome, Msg, Saved, SavedScene};
use metamer::tui::update::update;
use metamer::tui::worker::{Reply, Solved};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// A designer on the demo palette that has started on a 100×30 terminal (its first solve asked for).
fn started() -> (State, Vec<Effect>) {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let effects = update(&mut s, Msg::Start { width: 100, height: 30, trains_bases: false });
    (s, effects)
}

/// The generations of the solves among `effects`.
fn solves(effects: &[Effect]) -> Vec<u64> {
    effects
        .iter()
        .filter_map(|e| if let Effect::Solve { generation, .. } = e { Some(*generation) } else { None })
        .collect()
}

fn message(s: &State) -> String {
    s.ui.message.as_ref().map(|m| m.text.clone()).unwrap_or_default()
}

/// The document: an edit is a new generation (solved), a save and a reload are effects whose outcomes
/// come back as messages, and a save that writes the solution's spectra keeps the solution (no new solve).
#[test]
fn the_document_asks_for_its_file_work_and_every_new_palette_is_solved() {
    let (mut s, effects) = started();
    assert_eq!(solves(&effects), [0], "the opening palette is solved once");
    assert!(update(&mut s, Msg::Resize { width: 100, height: 30 }).is_empty(), "nothing new to solve");

    let effects = update(&mut s, Msg::Action(Action::ToggleFitInSubspace));
    assert_eq!(solves(&effects), [1], "an edit is generation 1, solved");
    assert_eq!(effects.len(), 1);
    assert!(s.is_dirty());

    // Save: one effect carrying the palette on screen; nothing is written here.
    let effects = update(&mut s, Msg::Action(Action::Save));
    let [Effect::Save { file, palette, before, quit_after: false, overwrite: false }] = effects.as_slice() else {
        panic!("one save effect");
    };
    assert_eq!(*before, s.doc.palette);
    let mut written = file.clone();
    written.palette = palette.clone();
    let saved = Saved { text: "saved palettes/demo.toml".into(), file: written };
    let outcome = FileOutcome::Saved { before: before.clone(), result: Ok(saved), quit_after: false, save_as: None };
    let effects = update(&mut s, Msg::File(outcome));
    assert!(effects.is_empty(), "the palette is the one written: nothing to solve");
    assert!(!s.is_dirty());
    assert!(message(&s).starts_with("saved palettes/demo.toml"), "{}", message(&s));

    // Reload: the effect, then the file read back as a message; the palette on screen goes to the undo
    // history, the new one is solved.
    let effects = update(&mut s, Msg::Action(Action::Reload));
    assert!(matches!(effects.as_slice(), [Effect::Reload { .. }]));
    let mut on_disk = PaletteFile::from_palette(&demo_palette());
    on_disk.path = Some(PathBuf::from("palettes/demo.toml"));
    let effects = update(&mut s, Msg::File(FileOutcome::Reloaded(Ok(on_disk))));
    assert_eq!(solves(&effects), [2]);
    assert_eq!(s.doc.palette, demo_palette());
    assert_eq!(message(&s), "reloaded from disk (z undoes the reload)");
    let effects = update(&mut s, Msg::Action(Action::Undo));
    assert_eq!(solves(&effects), [3], "undo is a new generation");
    assert!(s.doc.palette.settings.fit_in_subspace != demo_palette().settings.fit_in_subspace);

    // A save whose written palette differs from the one on screen (the solution's designed spectra): the
    // palette becomes the written one, in a new generation that keeps the request: no new solve.
    let before = s.doc.palette.clone();
    let mut written = s.doc.file.clone();
    written.palette = before.clone();
    written.palette.reflectances[1].spectrum = metamer::spectrum::Spectrum::flat(0.4);
    let saved = Saved { text: "saved".into(), file: written.clone() };
    let outcome = FileOutcome::Saved { before, result: Ok(saved), quit_after: false, save_as: None };
    let effects = update(&mut s, Msg::File(outcome));
    assert!(solves(&effects).is_empty(), "saving changes no result");
    assert_eq!(s.doc.palette, written.palette);
    assert_eq!(s.solve.generation, 4);
    assert!(!s.is_dirty());
}

/// The interface: moves, focus and popups change what is selected and shown, and ask for nothing.
#[test]
fn the_interface_s_keys_ask_for_no_effect() {
    let (mut s, _) = started();
    assert_eq!(s.ui.selection, Selection { col: 1, row: 1 });
    for action in [Action::Move(Direction::Down), Action::Move(Direction::Right), Action::FocusNext] {
        assert!(update(&mut s, Msg::Action(action)).is_empty(), "{action:?}");
    }
    assert_eq!(s.ui.selection, Selection { col: 2, row: 2 });
    assert_eq!(s.ui.focus, metamer::tui::app::Focus::Sliders);
    assert!(update(&mut s, Msg::Action(Action::Help)).is_empty());
    assert!(matches!(s.ui.popup, Some(Popup::Help { scroll: 0 })));
    assert!(update(&mut s, Msg::Action(Action::Move(Direction::Down))).is_empty());
    assert!(matches!(s.ui.popup, Some(Popup::Help { scroll: 1 })), "the popup scrolls");
    assert!(update(&mut s, Msg::Action(Action::Back)).is_empty());
    assert!(s.ui.popup.is_none());
    let ticks = s.ui.ticks;
    assert!(update(&mut s, Msg::Tick(Instant::now())).is_empty());
    assert_eq!(s.ui.ticks, ticks + 1);
    // Removing the selected light's column moves the selection back inside the matrix.
    update(&mut s, Msg::Action(Action::Back));
    update(&mut s, Msg::Action(Action::Move(Direction::Right)));
    update(&mut s, Msg::Action(Action::Move(Direction::Up)));
    for _ in 0..3 {
        update(&mut s, Msg::Action(Action::Move(Direction::Up)));
    }
    assert_eq!(s.ui.selection, Selection { col: 3, row: 0 }, "the third light's swatch");
    let effects = update(&mut s, Msg::Action(Action::Remove));
    assert_eq!(solves(&effects), [1]);
    assert_eq!(s.ui.selection, Selection { col: 2, row: 0 });
}

/// The solve: a reply to a replaced request is dropped, the newest one's failure is shown; the loop's
/// clock comes in as messages.
#[test]
fn the_solve_takes_only_the_newest_reply() {
    let (mut s, _) = started();
    let effects = update(&mut s, Msg::Action(Action::ToggleFitInSubspace));
    assert_eq!(solves(&effects), [1]);
    let failed = |ticket, generation| {
        let result = Err(DesignError::Invalid(format!("ticket {ticket}")));
        Msg::Worker(Reply::Solved(Solved { ticket, generation, result, elapsed: Duration::ZERO, feasibility: None }))
    };
    assert!(update(&mut s, failed(1, 0)).is_empty(), "the first request was replaced");
    assert!(s.solve.error.is_none() && s.solve.running == Some(1));
    let t0 = Instant::now();
    assert!(update(&mut s, Msg::SolveStarted { ticket: 2, at: t0 }).is_empty());
    assert!(update(&mut s, Msg::Tick(t0 + Duration::from_secs(2))).is_empty());
    assert!(update(&mut s, failed(2, 1)).is_empty());
    assert_eq!(s.solve.running, None);
    assert!(matches!(&s.solve.error, Some(DesignError::Invalid(t)) if t == "ticket 2"));
}

/// The preview: the raycast at the panel's size and the keyframes' write are effects; the replies come
/// back as messages.
#[test]
fn the_preview_asks_for_its_raycast_and_its_scene_write() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let mut scene = Scene::builtin(demo_palette(), 8).expect("a built-in scene");
    let path = PathBuf::from("scenes/never-written.toml");
    scene.path = Some(path.clone());
    s.set_preview_scene(scene);
    let effects = update(&mut s, Msg::Start { width: 100, height: 30, trains_bases: false });
    let sizes: Vec<_> =
        effects.iter().filter_map(|e| if let Effect::Raycast { size, .. } = e { Some(*size) } else { None }).collect();
    assert_eq!(sizes.len(), 1, "one raycast at the panel's size");
    assert!(sizes[0].0 >= 2 && sizes[0].0 == sizes[0].1, "{sizes:?}");
    assert!(s.busy(), "the raycast is under way");
    assert!(update(&mut s, Msg::Resize { width: 100, height: 30 }).is_empty(), "asked for once");

    assert!(update(&mut s, Msg::Action(Action::DialSaveScene)).is_empty());
    assert_eq!(message(&s), "no keyframes yet: `a` adds one");
    assert!(update(&mut s, Msg::Action(Action::DialKeyframe)).is_empty());
    assert!(message(&s).starts_with("keyframe 1 added"), "{}", message(&s));
    let effects = update(&mut s, Msg::Action(Action::DialSaveScene));
    let [Effect::SaveKeyframes { path: to, keyframes }] = effects.as_slice() else { panic!("one scene write") };
    assert_eq!((to, keyframes.len()), (&path, 1));
    assert!(update(&mut s, Msg::Action(Action::DialSaveScene)).is_empty());
    assert_eq!(message(&s), "the scene is being saved");
    let saved = SavedScene { text: "1 keyframe written".into(), count: 1, reloaded: Err("gone".into()) };
    assert!(update(&mut s, Msg::SceneSaved(Ok(saved))).is_empty());
    assert!(s.preview.keyframes.is_empty(), "the written keyframes are in the file");
    assert_eq!(message(&s), "1 keyframe written, but it does not load again: gone");
}
