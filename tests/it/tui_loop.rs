//! The designer as messages: worker replies are messages that change the state only through `update`; the
//! loop blocks on its one channel and handles exactly the messages it is given; save-as (a prompt) writes
//! through the atomic writer and refuses inputs and folders.

use crate::tui_support::{self, demo_palette, keys, run_live, state};

use metamer::colorimetry::Colorimetry;
use metamer::design::{self, SolveOptions};
use metamer::palette::file::PaletteFile;
use metamer::tui::State;
use metamer::tui::app::Popup;
use metamer::tui::colour::ColourMode;
use metamer::tui::event_loop::FileSaver;
use metamer::tui::msg::{Effect, Msg};
use metamer::tui::replay::{self, MemorySaver};
use metamer::tui::update::update;
use metamer::tui::worker::{BasisMode, Reply, Solved, WorkerConfig};
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

macro_rules! snap {
    ($name:expr, $text:expr) => {
        insta::with_settings!({ snapshot_path => "../../snapshots", prepend_module_to_snapshot => false }, {
            insta::assert_snapshot!($name, $text);
        })
    };
}

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
    assert!(others.iter().all(|l| l.starts_with("solved")), "{taken:?}");
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
