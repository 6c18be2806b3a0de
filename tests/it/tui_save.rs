//! Saving from the designer: Ctrl-s then q writes a palette that keeps the file's comments and solves to
//! the objective the designer showed.

use metamer::colorimetry::Colorimetry;
use metamer::design::{self, SolveOptions};
use metamer::palette::PaletteFile;
use metamer::tui::State;
use metamer::tui::colour::ColourMode;
use metamer::tui::event_loop::FileSaver;
use metamer::tui::replay;
use metamer::tui::worker::{BasisMode, WorkerConfig};
use std::path::Path;
use std::time::Duration;

#[test]
fn save_then_quit_keeps_comments_and_the_objective() {
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/metamers.toml");
    let dir = tempfile::tempdir().expect("temporary folder");
    let path = dir.path().join("metamers.toml");
    // The example palette with an unknown key, which saving must keep.
    let text = std::fs::read_to_string(&source).expect("the example palette is readable");
    let text = text.replacen("name = \"metamers\"", "name = \"metamers\"\nx_custom_note = \"kept by the designer\"", 1);
    assert!(text.contains("x_custom_note"));
    std::fs::write(&path, &text).expect("write the palette");
    let original = text;

    let file = PaletteFile::load(&path).expect("the example palette loads");
    let mut state = State::with_file(file, ColourMode::TrueColor);
    let mut saver = FileSaver;
    let worker = WorkerConfig { time_limit: Duration::from_secs(30), basis: BasisMode::Off };
    let steps = replay::parse_script("Ctrl-s\nq").expect("valid script");
    let (frames, _) = replay::run(&mut state, steps, 100, 30, true, &mut saver, worker).expect("replay runs");
    assert!(state.ui.quit, "q after saving quits without asking");
    // Frames: opened, after Ctrl-s, after q.
    assert_eq!(frames.len(), 3);
    assert!(frames[1].contains(&format!("saved {}", path.display())), "{}", frames[1]);
    assert!(!frames[1].contains("●"));
    let shown = state.solve.current().expect("the designer solved the palette").objective;

    let saved = std::fs::read_to_string(&path).expect("the palette is still there");
    assert_ne!(saved, original, "designed spectra are stored as samples");
    for line in original.lines().filter(|l| l.trim_start().starts_with('#')) {
        assert!(saved.contains(line), "comment lost: {line}");
    }
    assert!(saved.contains("x_custom_note = \"kept by the designer\""), "unknown key lost");
    let reloaded = PaletteFile::load(&path).expect("the saved palette loads");
    let again = design::solve(&reloaded.palette, None, &Colorimetry::default(), &SolveOptions::default())
        .expect("the saved palette solves");
    // Tolerance: the solver's optimum of a convex design, restarted from that optimum.
    let tolerance = 1e-6 * shown.max(1e-3);
    assert!((again.objective - shown).abs() <= tolerance, "shown {shown}, re-solved {}", again.objective);
}
