//! The designer as messages: worker replies are messages that change the state only through `update`; the
//! loop blocks on its one channel and handles exactly the messages it is given; file work (save-as, the
//! dial's scene) is effects `update` returns, never done inside it; save-as (a prompt) writes through the
//! atomic writer and refuses inputs and folders.

use crate::tui_support::{self, demo_palette, keys, run_live, state};

use metamer::colorimetry::Colorimetry;
use metamer::design::{self, SolveOptions};
use metamer::palette::PaletteFile;
use metamer::tui::State;
use metamer::tui::app::Popup;
use metamer::tui::colour::ColourMode;
use metamer::tui::edits::FileError;
use metamer::tui::event_loop::FileSaver;
use metamer::tui::msg::{Effect, FileOutcome, Msg, SavedScene};
use metamer::tui::replay::{self, MemorySaver};
use metamer::tui::update::update;
use metamer::tui::worker::{BasisMode, Reply, Solved, WorkerConfig};
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

fn solved(ticket: u64, generation: u64, state: &State) -> Msg {
    let solution = design::solve(&state.doc.palette, None, &Colorimetry::default(), &SolveOptions::default());
    let result = solution.map(Arc::new);
    Msg::Worker(Reply::Solved(Solved { ticket, generation, result, elapsed: Duration::ZERO, feasibility: None }))
}

#[test]
fn a_worker_reply_is_a_message_and_only_update_applies_it() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    // Starting asks for a solve, as data: nothing runs until the loop runs the effect.
    let effects = update(&mut s, Msg::Start { width: 100, height: 30, trains_bases: false });
    let (ticket, generation) = match effects.as_slice() {
        [Effect::Solve { ticket, generation, palette, .. }] => {
            assert_eq!(palette, &s.doc.palette);
            (*ticket, *generation)
        }
        other => panic!("one solve asked for, got {} effects", other.len()),
    };
    assert_eq!(s.solve.running, Some(generation));
    assert!(s.busy() && s.solve.current().is_none());
    // A reply to an older request (a ticket a newer one replaced) changes nothing.
    let reply = solved(ticket - 1, generation, &s);
    let effects = update(&mut s, reply);
    assert!(effects.is_empty());
    assert!(s.solve.current().is_none() && s.solve.running.is_some());
    // The newest request's reply is applied: the solution is shown, nothing is under way.
    let reply = solved(ticket, generation, &s);
    update(&mut s, reply);
    assert!(s.solve.current().is_some(), "the solution is the current palette's");
    assert_eq!(s.solve.running, None);
    assert!(!s.busy());
    // An edit asks for a new solve with a new ticket and generation; the old generation's reply is stale.
    let effects = update(&mut s, Msg::Key(replay::parse_key("u").expect("key")));
    let newer = effects.iter().find_map(|e| match e {
        Effect::Solve { ticket, generation, .. } => Some((*ticket, *generation)),
        _ => None,
    });
    let (t2, g2) = newer.expect("the edit asks for a solve");
    assert!(t2 > ticket && g2 > generation);
    let reply = solved(t2, generation, &s);
    update(&mut s, reply);
    assert!(s.solve.current().is_none(), "a reply for an older palette is not the current solution");
}

#[test]
fn the_loop_blocks_on_its_channel_and_takes_exactly_the_messages_given() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let before = s.ui.selection;
    let mut msgs = keys("Down\nRight\nRight");
    msgs.push(Msg::End);
    let started = Instant::now();
    let taken = run_live(&mut s, msgs, &mut MemorySaver::default());
    assert!(started.elapsed() < Duration::from_secs(20), "the loop returned on End");
    // The inputs, in order and once each; besides them only the start and worker replies (no tick, no
    // timeout turn: nothing is invented while the loop waits).
    let inputs: Vec<&str> = taken.iter().map(String::as_str).filter(|l| l.starts_with("key") || *l == "end").collect();
    assert_eq!(inputs, ["key Down", "key Right", "key Right", "end"], "{taken:?}");
    assert_eq!(taken.first().map(String::as_str), Some("start"));
    let others: Vec<&String> =
        taken.iter().filter(|l| !(l.starts_with("key") || *l == "end" || *l == "start")).collect();
    assert!(others.iter().all(|l| l.starts_with("solved") || l.starts_with("solve started")), "{taken:?}");
    assert_eq!(taken.last().map(String::as_str), Some("end"));
    assert_eq!((s.ui.selection.row, s.ui.selection.col), (before.row + 1, before.col + 2));
    assert_eq!(s.ui.ticks, 0);
}

#[test]
fn the_save_as_prompt() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = tui_support::replay(&mut s, "Ctrl-w", 100, 30);
    assert!(matches!(s.ui.popup, Some(Popup::Prompt(_))));
    snap!("save_as_prompt_100x30", text);
}

fn replay_file(state: &mut State, saver: &mut FileSaver, script: &str) -> String {
    let worker = WorkerConfig { time_limit: Duration::from_secs(30), basis: BasisMode::Off };
    let steps = replay::parse_script(script).expect("valid script");
    let (frames, _) = replay::run(state, steps, 100, 30, false, saver, worker).expect("replay runs");
    frames.last().cloned().unwrap_or_default()
}

const WITH_CSV: &str = r##"name = "small"
[[lights]]
name = "day"
illuminant = "D65"
[[reflectances]]
name = "grey"
csv = "grey.csv"
[[reflectances]]
name = "r"
flat = 0.5
design = true
[[colours]]
light = "day"
reflectance = "r"
target = "#806040"
"##;

fn setup(dir: &Path) -> (std::path::PathBuf, String) {
    let path = dir.join("p.toml");
    std::fs::write(&path, WITH_CSV).unwrap();
    let csv: String = (0..=30).map(|i| format!("{},{}\n", 400 + 10 * i, 0.25)).collect();
    std::fs::write(dir.join("grey.csv"), &csv).unwrap();
    std::fs::create_dir(dir.join("sub")).unwrap();
    (path, csv)
}

fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

#[test]
fn save_as_onto_an_input_or_a_folder_is_refused_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (path, csv) = setup(dir.path());
    let file = PaletteFile::load(&path).unwrap();
    let mut s = State::with_file(file, ColourMode::TrueColor);
    let mut saver = FileSaver;
    let files = listing(dir.path());
    for (target, reason) in [("grey.csv", "same file as the CSV spectrum"), ("sub", "not a regular file")] {
        let typed = dir.path().join(target);
        let screen = replay_file(&mut s, &mut saver, &format!("Ctrl-w\nCtrl-u\n\"{}\"\nEnter", typed.display()));
        match &s.ui.popup {
            Some(Popup::Prompt(p)) => {
                let error = p.error.as_ref().map(|e| e.0.to_string()).unwrap_or_default();
                assert!(error.contains(reason) && error.contains(target), "{target}: {error}");
            }
            _ => panic!("{target}: the prompt stays open with the reason\n{screen}"),
        }
        assert!(screen.contains(reason) || screen.contains("refusing"), "{screen}");
        replay_file(&mut s, &mut saver, "Esc");
        assert!(s.ui.popup.is_none(), "Esc cancels");
        assert_eq!(s.path(), path, "the designer still works on its file");
        assert_eq!(std::fs::read_to_string(dir.path().join("grey.csv")).unwrap(), csv, "the CSV is untouched");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), WITH_CSV, "the palette is untouched");
        assert_eq!(listing(dir.path()), files, "nothing written");
        assert!(listing(&dir.path().join("sub")).is_empty());
    }
}

#[test]
fn after_save_as_the_designer_works_on_the_new_file() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = setup(dir.path());
    let file = PaletteFile::load(&path).unwrap();
    let mut s = State::with_file(file, ColourMode::TrueColor);
    let mut saver = FileSaver;
    let copy = dir.path().join("sub").join("copy.toml");
    let screen = replay_file(&mut s, &mut saver, &format!("wait-solve\nCtrl-w\nCtrl-u\n\"{}\"\nEnter", copy.display()));
    assert!(screen.contains("saved as"), "{screen}");
    assert_eq!(s.path(), copy);
    assert!(!s.is_dirty());
    assert_eq!(std::fs::read_to_string(&path).unwrap(), WITH_CSV, "the old file is untouched");
    let saved = PaletteFile::load(&copy).expect("the copy reads back");
    assert_eq!(
        saved.palette.reflectances[0].spectrum, s.doc.palette.reflectances[0].spectrum,
        "its CSV still resolves"
    );
    // The next save goes to the new file.
    let before = std::fs::read_to_string(&copy).unwrap();
    replay_file(&mut s, &mut saver, "u\nCtrl-s");
    assert_eq!(std::fs::read_to_string(&path).unwrap(), WITH_CSV);
    assert_ne!(std::fs::read_to_string(&copy).unwrap(), before, "the edit went to the new file");
    assert!(PaletteFile::load(&copy).is_ok());
}

#[test]
fn the_outside_change_popup_offers_save_as() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = setup(dir.path());
    let file = PaletteFile::load(&path).unwrap();
    let mut s = State::with_file(file, ColourMode::TrueColor);
    let mut saver = FileSaver;
    let outside = WITH_CSV.replace("#806040", "#204080");
    std::fs::write(&path, &outside).unwrap();
    let screen = replay_file(&mut s, &mut saver, "wait-solve\nCtrl-s");
    assert!(matches!(s.ui.popup, Some(Popup::Conflict { .. })), "{screen}");
    assert!(screen.contains("changed on disk") && screen.contains("save as"), "{screen}");
    // `a` in the popup opens the save-as prompt; the designer's version goes to the typed path.
    let mine = dir.path().join("mine.toml");
    let screen = replay_file(&mut s, &mut saver, &format!("a\nCtrl-u\n\"{}\"\nEnter", mine.display()));
    assert!(screen.contains("saved as"), "{screen}");
    assert_eq!(std::fs::read_to_string(&path).unwrap(), outside, "the outside change is kept");
    assert_eq!(s.path(), mine);
    assert_eq!(PaletteFile::load(&mine).unwrap().palette.colours[0].target, s.doc.palette.colours[0].target);
}

#[test]
fn save_as_onto_an_existing_file_asks_first_and_never_onto_the_sidecar() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = setup(dir.path());
    let file = PaletteFile::load(&path).unwrap();
    let mut s = State::with_file(file, ColourMode::TrueColor);
    let mut saver = FileSaver;
    // The palette's basis sidecar is refused outright.
    let sidecar = dir.path().join("p.basis.json");
    std::fs::write(&sidecar, "{}").unwrap();
    let screen = replay_file(&mut s, &mut saver, &format!("Ctrl-w\nCtrl-u\n\"{}\"\nEnter", sidecar.display()));
    assert!(matches!(s.ui.popup, Some(Popup::Prompt(_))), "{screen}");
    assert_eq!(std::fs::read_to_string(&sidecar).unwrap(), "{}", "the sidecar is untouched");
    replay_file(&mut s, &mut saver, "Esc");
    // Another user file: the first Enter asks, the file stays as it was; the second replaces it.
    let other = dir.path().join("notes.toml");
    std::fs::write(&other, "# mine\n").unwrap();
    let screen = replay_file(&mut s, &mut saver, &format!("Ctrl-w\nCtrl-u\n\"{}\"\nEnter", other.display()));
    match &s.ui.popup {
        Some(Popup::Prompt(p)) => {
            let error = p.error.as_ref().map(|e| e.0.to_string()).unwrap_or_default();
            assert!(error.contains("exists") && error.contains("Enter again"), "{error}");
        }
        _ => panic!("the prompt asks first\n{screen}"),
    }
    assert_eq!(std::fs::read_to_string(&other).unwrap(), "# mine\n", "asked, not replaced");
    assert_eq!(s.path(), path);
    let screen = replay_file(&mut s, &mut saver, "Enter");
    assert!(screen.contains("saved as"), "{screen}");
    assert_eq!(s.path(), other);
    assert!(PaletteFile::load(&other).is_ok(), "the second Enter replaced it with the palette");
}

/// Keys handed to `update` alone — no loop, terminal or file system: what they ask for is the effects.
fn press(s: &mut State, script: &str) -> Vec<Effect> {
    keys(script).into_iter().flat_map(|m| update(s, m)).collect()
}

/// The effects by kind, for assertions.
fn kinds(effects: &[Effect]) -> Vec<&'static str> {
    effects
        .iter()
        .map(|e| match e {
            Effect::Solve { .. } => "solve",
            Effect::TrainBasis { .. } => "train",
            Effect::Raycast { .. } => "raycast",
            Effect::Import { .. } => "import",
            Effect::Save { .. } => "save",
            Effect::SaveAs { .. } => "save as",
            Effect::Reload { .. } => "reload",
            Effect::Restore { .. } => "restore",
            Effect::Recover { .. } => "recover",
            Effect::SaveKeyframes { .. } => "save keyframes",
            Effect::Complete { .. } => "complete",
        })
        .collect()
}

#[test]
fn save_as_is_an_effect_and_the_question_comes_back_as_a_message() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    assert_eq!(kinds(&update(&mut s, Msg::Start { width: 100, height: 30, trains_bases: false })), ["solve"]);
    // A path nobody has: update looks nothing up on disk, it asks the loop to save there.
    let target = "/nonexistent-metamer-dir/notes.toml";
    let effects = press(&mut s, &format!("Ctrl-w\nCtrl-u\n\"{target}\"\nEnter"));
    assert_eq!(kinds(&effects), ["save as"]);
    assert!(matches!(&effects[0], Effect::SaveAs { path, replace: false, .. } if path == Path::new(target)));
    assert!(s.busy(), "the save is under way");
    // The saver found a file there: its answer is a message, and the prompt asks.
    let before = s.doc.palette.clone();
    let result = Err(FileError::Exists(target.into()));
    let outcome = FileOutcome::Saved { before, result, quit_after: false, save_as: Some(target.into()) };
    assert!(update(&mut s, Msg::File(outcome)).is_empty());
    match &s.ui.popup {
        Some(Popup::Prompt(p)) => {
            let error = p.error.as_ref().map(|e| e.0.to_string()).unwrap_or_default();
            assert!(error.contains(target) && error.contains("Enter again"), "{error}");
        }
        _ => panic!("the prompt asks first"),
    }
    // Enter on the same path again: replace it. Another path is asked about afresh.
    let effects = press(&mut s, "Enter");
    assert!(matches!(effects.as_slice(), [Effect::SaveAs { replace: true, .. }]), "{:?}", kinds(&effects));
    let before = s.doc.palette.clone();
    let result = Err(FileError::Exists(target.into()));
    let outcome = FileOutcome::Saved { before, result, quit_after: false, save_as: Some(target.into()) };
    update(&mut s, Msg::File(outcome));
    let effects = press(&mut s, "Backspace\nx\nEnter");
    assert!(matches!(effects.as_slice(), [Effect::SaveAs { replace: false, .. }]), "{:?}", kinds(&effects));
}

#[test]
fn the_dial_s_scene_save_is_an_effect_and_its_outcome_a_message() {
    let mut scene = metamer::render::builtin_scene(16).expect("built-in scene");
    let path = std::path::PathBuf::from("/nonexistent-metamer-dir/scene.toml");
    scene.path = Some(path.clone());
    let mut s = state(scene.palette.clone(), ColourMode::TrueColor);
    s.set_preview_scene(scene);
    update(&mut s, Msg::Start { width: 100, height: 30, trains_bases: false });
    // `g` gives the keys to the dial, `a` adds a keyframe, Ctrl-s asks the loop to write it.
    let effects = press(&mut s, "g\na\nCtrl-s");
    let asked = effects.iter().find_map(|e| match e {
        Effect::SaveKeyframes { path, keyframes } => Some((path.clone(), keyframes.len())),
        _ => None,
    });
    assert_eq!(asked, Some((path.clone(), 1)), "{:?}", kinds(&effects));
    assert!(!path.exists());
    // A keyframe added while the file is written stays to be saved; a second save waits for the first.
    assert!(kinds(&press(&mut s, "Right\na\nCtrl-s")).iter().all(|k| *k != "save keyframes"));
    assert!(s.ui.message.as_ref().is_some_and(|m| m.is_error && m.text.contains("being saved")), "{:?}", s.ui.message);
    assert_eq!(s.preview.keyframes.len(), 2);
    let saved = SavedScene { text: "saved 1 keyframes".into(), count: 1, reloaded: Err("gone".into()) };
    update(&mut s, Msg::SceneSaved(Ok(saved)));
    assert_eq!(s.preview.keyframes.len(), 1, "the written keyframe is no longer pending, the newer one is");
    let m = s.ui.message.clone().expect("a message");
    assert!(m.is_error && m.text.contains("does not load again: gone"), "{m:?}");
    // A failed write keeps the keyframes and says why.
    assert_eq!(kinds(&press(&mut s, "Ctrl-s")).iter().filter(|k| **k == "save keyframes").count(), 1);
    update(&mut s, Msg::SceneSaved(Err("disk full".into())));
    assert_eq!(s.preview.keyframes.len(), 1);
    assert!(s.ui.message.as_ref().is_some_and(|m| m.text == "scene not saved: disk full"), "{:?}", s.ui.message);
}

/// A terminal source as the real one behaves with `--preview auto`: started once the first screen is
/// drawn, it hands over the keys typed before and during the graphics probe, then the probe's answer.
struct ProbingSource {
    frames: std::sync::Arc<std::sync::atomic::AtomicUsize>,
    frames_at_start: Option<usize>,
    typed: Vec<Msg>,
}

impl metamer::tui::event_loop::Events for ProbingSource {
    fn start(&mut self, tx: &std::sync::mpsc::Sender<Msg>) -> std::io::Result<()> {
        self.frames_at_start = Some(self.frames.load(std::sync::atomic::Ordering::SeqCst));
        for m in self.typed.drain(..) {
            tx.send(m).expect("the loop's channel");
        }
        let graphics = metamer::tui::graphics::Graphics::forced(metamer::tui::graphics::PreviewMode::Kitty, (8, 16));
        tx.send(Msg::Graphics { graphics, warning: None }).expect("the loop's channel");
        tx.send(Msg::End).expect("the loop's channel");
        Ok(())
    }
}

#[test]
fn keys_typed_before_the_first_draw_and_during_the_probe_are_all_taken() {
    use metamer::tui::event_loop::{self, Io};
    let scene = metamer::render::builtin_scene(16).expect("built-in scene");
    let mut s = state(scene.palette.clone(), ColourMode::TrueColor);
    s.set_preview_scene(scene);
    s.preview.probing = true;
    let before = s.ui.selection;
    let frames = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let mut source = ProbingSource { frames: frames.clone(), frames_at_start: None, typed: keys("Down\nDown\nRight") };
    let mut terminal = ratatui::Terminal::new(ratatui::backend::TestBackend::new(80, 24)).expect("terminal");
    let mut taken = Vec::new();
    let mut first_screen = None;
    let mut on_frame = |b: &ratatui::buffer::Buffer| {
        if frames.fetch_add(1, std::sync::atomic::Ordering::SeqCst) == 0 {
            first_screen = Some(metamer::tui::ui::buffer_text(b));
        }
    };
    let mut on_msg = |m: &Msg| taken.push(m.label());
    let worker = WorkerConfig { time_limit: Duration::from_secs(30), basis: BasisMode::Off };
    let mut saver = MemorySaver::default();
    let io = Io {
        events: &mut source,
        saver: &mut saver,
        on_frame: Some(&mut on_frame),
        on_msg: Some(&mut on_msg),
        worker,
        tick: None,
    };
    event_loop::run_main_loop(&mut terminal, &mut s, io).expect("the loop runs");
    // The first screen is drawn before the source starts (before the terminal is asked anything), and
    // says the terminal is being asked.
    assert_eq!(source.frames_at_start, Some(1));
    let first = first_screen.expect("a first screen");
    assert!(first.contains("asking the terminal for its graphics"), "{first}");
    // Every key typed is taken, in order, and acts.
    let inputs: Vec<&str> = taken.iter().map(String::as_str).filter(|l| l.starts_with("key")).collect();
    assert_eq!(inputs, ["key Down", "key Down", "key Right"], "{taken:?}");
    assert_eq!((s.ui.selection.row, s.ui.selection.col), (before.row + 2, before.col + 1));
    // The probe's answer is taken; the raycast waited for it (at the kitty protocol's pixel size).
    assert!(taken.iter().any(|l| l == "graphics kitty"), "{taken:?}");
    assert!(!s.preview.probing && s.preview.graphics.name() == "kitty");
    let before_probe = taken.iter().position(|l| l == "graphics kitty").expect("graphics");
    assert!(!taken[..before_probe].iter().any(|l| l == "preview"), "no raycast before the answer: {taken:?}");
}

#[test]
fn q_closes_the_help_and_the_diagnostics_and_quits_only_from_the_main_screen() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    update(&mut s, Msg::Start { width: 80, height: 24, trains_bases: false });
    for open in ["?", "F1", "diagnostics"] {
        match open {
            // (The diagnostics open on `!` when the solver has some.)
            "diagnostics" => s.ui.popup = Some(Popup::Diagnostics { scroll: 0 }),
            key => drop(press(&mut s, key)),
        }
        assert!(matches!(s.ui.popup, Some(Popup::Help { .. } | Popup::Diagnostics { .. })), "{open}");
        press(&mut s, "q");
        assert!(s.ui.popup.is_none() && !s.ui.quit, "q after {open} closes the popup and nothing else");
    }
    press(&mut s, "q");
    assert!(s.ui.quit, "q on the main screen quits (nothing unsaved): {:?}", s.ui.popup);
}

#[test]
fn saving_keeps_the_result_the_user_saw_and_solves_nothing_again() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let effects = update(&mut s, Msg::Start { width: 80, height: 24, trains_bases: false });
    let ticket = match effects.as_slice() {
        [Effect::Solve { ticket, .. }] => *ticket,
        _ => panic!("a solve at start"),
    };
    let reply = solved(ticket, s.solve.generation, &s);
    update(&mut s, reply);
    let seen = s.solve.current().map(|sol| sol.objective).expect("solved");
    // Ctrl-s writes the solved spectra; the file comes back as written.
    let effects = press(&mut s, "Ctrl-s");
    let (palette, before) = match effects.as_slice() {
        [Effect::Save { palette, before, .. }] => (palette.clone(), before.clone()),
        _ => panic!("one save asked for, got {:?}", kinds(&effects)),
    };
    assert_ne!(palette, before, "the designed spectra are written as solved");
    let mut file = s.doc.file.clone();
    file.palette = palette;
    let saved = metamer::tui::msg::Saved { text: "saved".into(), file };
    let effects =
        update(&mut s, Msg::File(FileOutcome::Saved { before, result: Ok(saved), quit_after: false, save_as: None }));
    assert!(kinds(&effects).iter().all(|k| *k != "solve"), "saving solves nothing again: {:?}", kinds(&effects));
    assert!(!s.is_dirty());
    assert_eq!(s.solve.current().map(|sol| sol.objective), Some(seen), "the objective the user saw stays");
    // The next edit solves again, as always.
    assert!(kinds(&press(&mut s, "Down\nu")).contains(&"solve"));
}
