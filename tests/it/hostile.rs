//! Hostile files and paths (issue: nothing the user owns is destroyed, every read is bounded, no panic, no
//! hang, no NaN passed as success). One test group per class; property tests where a class is large
//! (non-regular targets, spellings of one file, huge numbers).

use metamer::colorimetry::Colorimetry;
use metamer::design::{self, SolveOptions};
use metamer::fsio::{self, FsError, Kind, Outputs};
use metamer::palette::PaletteFile;
use metamer::render::{Camera, MaterialClass, RaycastOptions, raycast};
use metamer::tui::State;
use metamer::tui::colour::ColourMode;
use metamer::tui::event_loop::{FileSaver, Saver, mine_path, recovery_path};
use metamer::tui::replay;
use metamer::tui::worker::{BasisMode, WorkerConfig};
use metamer::volume::Volume;
use proptest::prelude::*;
use std::os::unix::fs::{FileTypeExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const EXAMPLE: &str = include_str!("../../palettes/metamers.toml");

/// A small palette that solves in milliseconds.
const SMALL: &str = r##"name = "small"
[[lights]]
name = "day"
illuminant = "D65"
[[reflectances]]
name = "r"
flat = 0.5
design = true
[[colours]]
light = "day"
reflectance = "r"
target = "#806040"
"##;

fn metamer(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_metamer")).current_dir(dir).args(args).output().expect("metamer runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn mkfifo(path: &Path) {
    let status = Command::new("mkfifo").arg(path).status().expect("mkfifo runs");
    assert!(status.success(), "mkfifo {}", path.display());
}

/// Run `f` on a thread and fail (instead of hanging the suite) when it takes more than `limit`.
fn within<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(limit).unwrap_or_else(|_| panic!("did not finish within {limit:?} (a hang)"))
}

// ---------------------------------------------------------------------------------------------- reads

#[test]
fn reads_refuse_fifos_devices_and_folders_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("f");
    mkfifo(&fifo);
    for (path, found) in [
        (fifo.clone(), "a FIFO"),
        (PathBuf::from("/dev/zero"), "a character device"),
        (dir.path().to_path_buf(), "a directory"),
    ] {
        for kind in [Kind::Palette, Kind::Csv, Kind::Volume, Kind::KeyScript, Kind::Sidecar, Kind::Scene] {
            let p = path.clone();
            let e = within(Duration::from_secs(5), move || fsio::read(&p, kind)).unwrap_err();
            assert!(matches!(e, FsError::NotRegularInput { .. }), "{e}");
            let text = e.to_string();
            assert!(text.contains(found) && text.contains(kind.label()), "{text}");
        }
    }
}

#[test]
fn a_sparse_file_over_the_cap_is_refused_from_its_size() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.csv");
    let f = std::fs::File::create(&path).unwrap();
    f.set_len(2 << 30).unwrap();
    let started = Instant::now();
    let e = fsio::read(&path, Kind::Csv).unwrap_err();
    assert!(matches!(e, FsError::TooLarge { size, .. } if size == 2 << 30), "{e}");
    // Reading 2 GB of zeros would take far longer than this.
    assert!(started.elapsed() < Duration::from_millis(500), "{:?}", started.elapsed());
    // Exactly at the cap is read; one byte over is not.
    let small = dir.path().join("small");
    std::fs::write(&small, vec![b'x'; 100]).unwrap();
    assert_eq!(fsio::read_capped(&small, Kind::Text, 100).unwrap().len(), 100);
    assert!(matches!(fsio::read_capped(&small, Kind::Text, 99), Err(FsError::TooLarge { .. })));
}

#[test]
fn palettes_naming_hostile_csv_files_fail_fast_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("fifo.csv"));
    std::fs::File::create(dir.path().join("sparse.csv")).unwrap().set_len(1 << 31).unwrap();
    for csv in ["/dev/zero", "fifo.csv", "sparse.csv"] {
        let text = SMALL.replace("flat = 0.5\ndesign = true", &format!("csv = \"{csv}\""));
        let path = dir.path().join("p.toml");
        std::fs::write(&path, text).unwrap();
        let p = path.clone();
        let e = within(Duration::from_secs(5), move || PaletteFile::load(&p)).unwrap_err().to_string();
        assert!(e.contains("reflectances[0].csv") && e.contains(csv), "{e}");
    }
}

#[test]
fn a_palette_fifo_and_a_sidecar_fifo_do_not_hang_solve() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("fifo.toml"));
    let o = metamer(dir.path(), &["solve", "fifo.toml"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("fifo.toml: the palette is a FIFO"), "{}", stderr(&o));
    // The sidecar is read automatically: as a FIFO it is ignored (and not replaced), never waited on.
    std::fs::write(dir.path().join("p.toml"), SMALL).unwrap();
    let sidecar = dir.path().join("p.basis.json");
    mkfifo(&sidecar);
    let d = dir.path().to_path_buf();
    let o = within(Duration::from_secs(120), move || metamer(&d, &["solve", "p.toml", "--subspace", "-q"]));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::symlink_metadata(&sidecar).unwrap().file_type().is_fifo(), "the FIFO is not replaced");
}

#[test]
fn palette_parse_memory_is_bounded_by_the_input() {
    // 100 000 inline tables in 600 kB would take about 150 MB to parse: refused before parsing.
    let junk = vec!["{a=1}"; 100_000].join(",");
    let text = format!("junk = [{junk}]\n{EXAMPLE}");
    let started = Instant::now();
    let e = PaletteFile::parse(&text, Path::new("inline.toml")).unwrap_err().to_string();
    assert!(e.contains("inline.toml") && e.contains("tables") && e.contains("limit"), "{e}");
    assert!(started.elapsed() < Duration::from_secs(2));
    // Real palettes are far inside the budget: the example with its comments parses.
    PaletteFile::parse(EXAMPLE, Path::new("metamers.toml")).expect("the example parses");
}

// --------------------------------------------------------------------------------------------- writes

/// A non-regular file of the given kind at `path` (a socket needs its listener kept alive).
fn make_non_regular(kind: u8, path: &Path) -> Option<std::os::unix::net::UnixListener> {
    match kind {
        0 => mkfifo(path),
        1 => std::fs::create_dir(path).unwrap(),
        _ => return Some(std::os::unix::net::UnixListener::bind(path).unwrap()),
    }
    None
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Any non-regular target (FIFO, folder, socket), named directly or through a symbolic link, is
    /// refused, and stays what it was.
    #[test]
    fn writes_refuse_non_regular_targets(kind in 0u8..3, via_link in any::<bool>(), bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("target");
        let _keep = make_non_regular(kind, &target);
        let before = std::fs::symlink_metadata(&target).unwrap();
        let named = if via_link {
            let link = dir.path().join("link");
            std::os::unix::fs::symlink(&target, &link).unwrap();
            link
        } else {
            target.clone()
        };
        let e = fsio::write_atomic(&named, &bytes).unwrap_err();
        prop_assert!(matches!(e, FsError::NotRegularOutput { .. }), "{}", e);
        let after = std::fs::symlink_metadata(&target).unwrap();
        prop_assert_eq!(before.ino(), after.ino());
        prop_assert_eq!(before.file_type(), after.file_type());
        // No temporary file is left behind.
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten()
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp")).collect();
        prop_assert!(left.is_empty());
    }

    /// Every spelling of one file (`./x`, `sub/../x`, a symbolic link, a hard link) is the same output as
    /// the input; different files are not.
    #[test]
    fn same_file_is_found_whatever_the_spelling(spelling in 0u8..4, exists in any::<bool>()) {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("sub")).unwrap();
        let input = d.join("p.toml");
        if exists {
            std::fs::write(&input, "x").unwrap();
        }
        let other = match spelling {
            0 => d.join(".").join("p.toml"),
            1 => d.join("sub/../p.toml"),
            2 if exists => { let l = d.join("l.toml"); std::os::unix::fs::symlink(&input, &l).unwrap(); l }
            3 if exists => { let l = d.join("h.toml"); std::fs::hard_link(&input, &l).unwrap(); l }
            _ => d.join("sub/../p.toml"),
        };
        let mut files = Outputs::new();
        files.input("palette", &input);
        let e = files.output("report", &other).unwrap_err();
        prop_assert!(matches!(e, FsError::SameFile { .. }), "{}", e);
        prop_assert!(e.to_string().contains("the same file as the palette"));
        prop_assert!(files.output("report", &d.join("r.json")).is_ok());
        prop_assert!(files.output("screen", &d.join("sub/../r.json")).is_err(), "two outputs, one file");
    }
}

#[test]
fn symlinks_to_regular_files_are_followed_and_kept() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("real.toml");
    std::fs::write(&target, "old").unwrap();
    let link = dir.path().join("link.toml");
    std::os::unix::fs::symlink("real.toml", &link).unwrap();
    fsio::write_atomic(&link, b"new").unwrap();
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link is kept");
    assert_eq!(std::fs::read(&target).unwrap(), b"new");
}

#[test]
fn new_files_follow_the_umask_and_in_place_saves_keep_the_mode() {
    let dir = tempfile::tempdir().unwrap();
    // What the umask makes of 0666, measured with an ordinary create.
    let probe = dir.path().join("probe");
    {
        use std::os::unix::fs::OpenOptionsExt;
        std::fs::OpenOptions::new().write(true).create_new(true).mode(0o666).open(&probe).unwrap();
    }
    let expected = std::fs::metadata(&probe).unwrap().permissions().mode() & 0o777;
    let fresh = dir.path().join("new.json");
    fsio::write_atomic(&fresh, b"{}").unwrap();
    assert_eq!(std::fs::metadata(&fresh).unwrap().permissions().mode() & 0o777, expected);

    let kept = dir.path().join("kept.toml");
    std::fs::write(&kept, "a").unwrap();
    std::fs::set_permissions(&kept, std::fs::Permissions::from_mode(0o640)).unwrap();
    let owner = std::fs::metadata(&kept).unwrap();
    fsio::write_atomic(&kept, b"b").unwrap();
    let after = std::fs::metadata(&kept).unwrap();
    assert_eq!(after.permissions().mode() & 0o777, 0o640);
    assert_eq!((after.uid(), after.gid()), (owner.uid(), owner.gid()));
    assert_eq!(std::fs::read(&kept).unwrap(), b"b");
}

#[test]
fn cli_outputs_that_name_an_input_are_refused_and_nothing_changes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.toml"), SMALL).unwrap();
    std::os::unix::fs::symlink("p.toml", d.join("link.toml")).unwrap();
    std::fs::write(d.join("keys.txt"), "Down\n").unwrap();
    std::fs::write(d.join("x.json"), "previous").unwrap();
    for args in [
        &["solve", "p.toml", "--report", "p.toml"][..],
        &["solve", "p.toml", "--report", "./link.toml"],
        &["solve", "p.toml", "-o", "x.json", "--report", "x.json"],
        &["solve", "p.toml", "-o", "p.basis.json"],
        &["design", "p.toml", "--replay", "keys.txt", "--screen", "p.toml"],
        &["design", "p.toml", "--replay", "keys.txt", "--screen", "keys.txt"],
    ] {
        let o = metamer(d, args);
        assert!(!o.status.success(), "{args:?} must fail");
        assert!(stderr(&o).contains("refusing to write") && stderr(&o).contains("same file"), "{}", stderr(&o));
        assert_eq!(std::fs::read_to_string(d.join("p.toml")).unwrap(), SMALL, "{args:?}");
        assert_eq!(std::fs::read_to_string(d.join("keys.txt")).unwrap(), "Down\n");
        assert_eq!(std::fs::read_to_string(d.join("x.json")).unwrap(), "previous");
    }
    // The one intended same-file case, an in-place solve, still works.
    let o = metamer(d, &["solve", "p.toml", "-o", "p.toml", "--no-subspace", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A FIFO as the report is refused and left a FIFO.
    mkfifo(&d.join("r.json"));
    let o = metamer(d, &["solve", "p.toml", "--report", "r.json", "--no-subspace", "-q"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("r.json: refusing to write: it is a FIFO"), "{}", stderr(&o));
}

#[test]
fn render_refuses_a_contact_sheet_onto_a_frame() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("frames")).unwrap();
    std::fs::write(d.join("frames/frame_0001.png"), "keep").unwrap();
    let o = metamer(
        d,
        &[
            "render",
            "--frames",
            "2",
            "--size",
            "8",
            "-o",
            "frames",
            "--contact-sheet",
            "frames/../frames/frame_0001.png",
        ],
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("same file as the frame"), "{}", stderr(&o));
    assert_eq!(std::fs::read(d.join("frames/frame_0001.png")).unwrap(), b"keep");
}

#[test]
fn render_refuses_outputs_onto_the_volume() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let palette = concat!(env!("CARGO_MANIFEST_DIR"), "/volumes/engine_palette.toml");
    std::fs::copy(palette, d.join("engine_palette.toml")).unwrap();
    let scene = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/volumes/engine.toml")).unwrap();
    let scene = scene.replace(
        "\"../../shared/volumes/engine.nhdr\"",
        "\"frame_0000.png\"\n[raw]\ndims = [4, 4, 4]\ntype = \"uint8\"",
    );
    std::fs::write(d.join("s.toml"), scene).unwrap();
    let volume: Vec<u8> = (0..64u8).map(|i| i * 4).collect();
    std::fs::write(d.join("frame_0000.png"), &volume).unwrap();
    // The volume is named by the first frame, then by the contact sheet (through another spelling).
    let frames = metamer(d, &["render", "s.toml", "--frames", "2", "--size", "8", "-o", "."]);
    let sheet = metamer(
        d,
        &[
            "render",
            "s.toml",
            "--frames",
            "2",
            "--size",
            "8",
            "-o",
            "out",
            "--contact-sheet",
            "./out/../frame_0000.png",
        ],
    );
    for o in [frames, sheet] {
        assert!(!o.status.success(), "{} {}", stderr(&o), String::from_utf8_lossy(&o.stdout));
        assert!(stderr(&o).contains("same file as the volume"), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read(d.join("frame_0000.png")).unwrap(), volume, "the volume is untouched");
    // The same scene renders when nothing names the volume (the refusal is not a broken scene).
    let ok = metamer(d, &["render", "s.toml", "--frames", "2", "--size", "8", "-o", "out", "--contact-sheet", "c.png"]);
    assert!(ok.status.success(), "{}", stderr(&ok));
}

// ----------------------------------------------------------------------------------------- designer

fn replay_with(state: &mut State, script: &str) -> Vec<String> {
    let worker = WorkerConfig { time_limit: Duration::from_secs(30), basis: BasisMode::Off };
    let steps = replay::parse_script(script).expect("valid script");
    let (frames, _) = replay::run(state, steps, 100, 30, true, &mut FileSaver, worker).expect("replay runs");
    frames
}

#[test]
fn an_outside_change_is_not_overwritten_silently() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.toml");
    std::fs::write(&path, SMALL).unwrap();
    let mut state = State::with_file(PaletteFile::load(&path).unwrap(), ColourMode::TrueColor);
    // Another program rewrites the file while it is open.
    let outside = SMALL.replace("#806040", "#204080");
    std::fs::write(&path, &outside).unwrap();
    let frames = replay_with(&mut state, "wait-solve\nCtrl-s");
    let last = frames.last().unwrap();
    assert!(last.contains("changed on disk"), "{last}");
    assert_eq!(std::fs::read_to_string(&path).unwrap(), outside, "the outside change is kept");
    let mine = PaletteFile::load(&mine_path(&path)).expect("the designer's version is saved aside");
    assert_eq!(mine.palette.colours[0].target, state.doc.palette.colours[0].target);
    // Ctrl-s again overwrites (the user chose to).
    let frames = replay_with(&mut state, "Ctrl-s");
    assert!(frames.last().unwrap().contains("saved"), "{}", frames.last().unwrap());
    assert_ne!(std::fs::read_to_string(&path).unwrap(), outside);
}

#[test]
fn reload_reads_the_outside_change() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.toml");
    std::fs::write(&path, SMALL).unwrap();
    let mut state = State::with_file(PaletteFile::load(&path).unwrap(), ColourMode::TrueColor);
    let outside = SMALL.replace("#806040", "#204080");
    std::fs::write(&path, &outside).unwrap();
    replay_with(&mut state, "Ctrl-r\nwait-solve");
    let expected = PaletteFile::parse(&outside, &path).unwrap().palette;
    assert_eq!(state.doc.palette, expected);
    assert_eq!(state.doc.history.undo.len(), 1, "the reload can be undone");
    assert!(!state.is_dirty(), "the reloaded file is the one on screen");
}

#[test]
fn csv_import_runs_off_the_ui_thread_and_esc_cancels_it() {
    use crate::tui_support;
    use metamer::tui::msg::Msg;
    use metamer::tui::replay::MemorySaver;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    let path = d.join("p.toml");
    std::fs::write(&path, SMALL).unwrap();
    mkfifo(&d.join("slow.csv"));
    let rows: String = (0..=30).map(|i| format!("{},{}\n", 400 + 10 * i, 0.25)).collect();
    std::fs::write(d.join("grey.csv"), rows).unwrap();
    let palette = PaletteFile::load(&path).unwrap().palette;
    // R, the last entry of the list (import CSV…), the path, Enter.
    let import = |file: &str| format!("R\nPageDown *3\nEnter\n\"{file}\"\nEnter\n");
    within(Duration::from_secs(20), move || {
        // Live: the import starts and the loop takes the next key at once (Esc, queued behind it), which
        // cancels it; the reply, whenever it comes, is dropped.
        let mut state = State::new(path.clone(), palette.clone(), ColourMode::TrueColor);
        let mut msgs = tui_support::keys(&format!("{}Esc\n", import("slow.csv")));
        msgs.push(Msg::End);
        let taken = tui_support::run_live(&mut state, msgs, &mut MemorySaver::default());
        assert!(taken.iter().rev().nth(1).is_some_and(|l| l == "key Esc"), "{taken:?}");
        assert!(state.doc.import.is_none());
        assert!(state.ui.message.as_ref().is_some_and(|m| m.text.contains("import of slow.csv cancelled")));
        assert_eq!(state.doc.palette, palette);
        // Not cancelled (a replay waits for the import), the FIFO's refusal arrives as an error naming it.
        let mut state = State::new(path.clone(), palette.clone(), ColourMode::TrueColor);
        let steps = replay::parse_script(&import("slow.csv")).unwrap();
        let worker = WorkerConfig { time_limit: Duration::from_secs(30), basis: BasisMode::Off };
        replay::run(&mut state, steps, 100, 30, false, &mut MemorySaver::default(), worker.clone()).unwrap();
        let m = state.ui.message.clone().expect("a message");
        assert!(m.is_error && m.text.contains("slow.csv") && m.text.contains("FIFO"), "{}", m.text);
        assert_eq!(state.doc.palette, palette);
        // A regular CSV is added when its reply arrives.
        let steps = replay::parse_script(&import("grey.csv")).unwrap();
        replay::run(&mut state, steps, 100, 30, false, &mut MemorySaver::default(), worker).unwrap();
        assert_eq!(state.doc.palette.reflectances.len(), palette.reflectances.len() + 1);
        assert!(state.doc.palette.reflectances.iter().any(|r| r.name == "grey"));
    });
}

#[test]
fn a_recovery_copy_is_written_beside_the_palette() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.toml");
    std::fs::write(&path, SMALL).unwrap();
    let file = PaletteFile::load(&path).unwrap();
    let mut edited = file.palette.clone();
    edited.reflectances[0].name = "renamed".into();
    let at = FileSaver.recover(&file, &edited).expect("recovery copy written");
    assert_eq!(at, recovery_path(&path));
    assert_eq!(PaletteFile::load(&at).unwrap().palette.reflectances[0].name, "renamed");
    assert_eq!(std::fs::read_to_string(&path).unwrap(), SMALL, "the palette itself is untouched");
}

// ----------------------------------------------------------------------------------------- numbers

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// A huge or infinite value in any numeric key is an error naming that key, or the solve gives finite
    /// numbers; never a panic, never NaN as success.
    #[test]
    fn huge_numbers_are_errors_or_finite(which in 0usize..7, exponent in 15i32..309, inf in any::<bool>()) {
        let v = if inf { "inf".to_string() } else { format!("1e{exponent}") };
        let (text, key) = match which {
            0 => (SMALL.replace("flat = 0.5", &format!("flat = {v}")), "reflectances[0]"),
            1 => (SMALL.replace("[[lights]]", &format!("[settings]\nreflectance_bounds = [{v}, {v}]\n[[lights]]")), "settings.reflectance_bounds"),
            2 => (format!("{SMALL}weight = {v}\n"), "colours[0].weight"),
            3 => (SMALL.replace("target = \"#806040\"", &format!("target = [{v}, 0.1, 0.1]")), "colours[0].target"),
            4 => (SMALL.replace("flat = 0.5", &format!("flat = 0.5\nscale = {v}")), "reflectances[0]"),
            5 => (SMALL.replace("design = true", &format!("design = true\nbounds = [{v}, {v}]")), "reflectances[0].bounds"),
            _ => (SMALL.replace("[[lights]]", &format!("[settings]\nsmoothness = {v}\n[[lights]]")), "settings.smoothness"),
        };
        match PaletteFile::parse(&text, Path::new("n.toml")) {
            Err(e) => prop_assert!(e.to_string().contains(key), "{} should name {}", e, key),
            Ok(file) => {
                match design::solve(&file.palette, None, &Colorimetry::default(), &SolveOptions::default()) {
                    Ok(s) => {
                        prop_assert!(s.objective.is_finite(), "objective {}", s.objective);
                        for e in &s.palette.reflectances {
                            prop_assert!(e.spectrum.as_slice().iter().all(|x| x.is_finite()));
                        }
                    }
                    Err(e) => prop_assert!(!e.to_string().is_empty()),
                }
            }
        }
    }
}

#[test]
fn a_huge_time_limit_saturates() {
    let file = PaletteFile::parse(SMALL, Path::new("s.toml")).unwrap();
    let options = SolveOptions { time_limit: Duration::MAX, cancel: None };
    let s = design::solve(&file.palette, None, &Colorimetry::default(), &options).expect("solves");
    assert!(s.objective.is_finite());
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("p.toml"), SMALL).unwrap();
    let o = metamer(dir.path(), &["solve", "p.toml", "--time-limit", "1e300", "--no-subspace", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn nrrd_spacings_are_validated() {
    for spacing in ["1 1 1e-308", "1 1 1e200", "1 1 nan", "1 1 inf", "1 1 -1", "1 1 1000"] {
        let mut bytes = format!(
            "NRRD0004\ntype: unsigned char\ndimension: 3\nsizes: 2 2 2\nspacings: {spacing}\nencoding: raw\n\n"
        )
        .into_bytes();
        bytes.extend([0u8; 8]);
        let e = metamer::volume::nrrd::from_bytes(Path::new("v.nrrd"), &bytes).unwrap_err().to_string();
        assert!(e.contains("v.nrrd") && e.contains("spacing"), "{spacing}: {e}");
    }
}

#[test]
fn ray_steps_are_bounded_whatever_the_spacing() {
    // Built directly (bypassing the reader's checks): the renderer's own bound must stop the rays.
    let dims = [8, 8, 8];
    let data: Vec<f32> = (0..512).map(|i| (i % 7) as f32).collect();
    for spacing in [[1.0, 1.0, 1e-300], [1e200, 1.0, 1.0], [1e-12, 1e12, 1.0]] {
        let volume =
            Volume { dims, spacing, voxels: data.clone().into(), value_range: [0.0, 6.0], converted_from: None };
        let materials = vec![MaterialClass::new([1.0, 6.0], 0.01)];
        let options = RaycastOptions { width: 16, height: 16, ..RaycastOptions::default() };
        let (_, stats) =
            within(Duration::from_secs(20), move || raycast(&volume, &materials, None, &Camera::default(), &options));
        // At most MAX_ANISOTROPY × diagonal / step (+ rounding) steps per ray: the box's diagonal is 7√3.
        let per_ray = (stats.samples + stats.skipped) as f64 / 256.0;
        let bound = metamer::volume::MAX_ANISOTROPY * 7.0 * 3f64.sqrt() + 3.0;
        assert!(per_ray <= bound, "{spacing:?}: {per_ray} steps per ray, bound {bound}");
    }
}

// ---------------------------------------------------------------------------------------- terminal

#[test]
fn control_characters_never_reach_the_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A light named with an OSC title sequence and a clear-screen, then a cell naming an unknown light
    // with another escape: both are echoed in messages.
    let text = SMALL
        .replace("name = \"day\"", "name = \"day\\u001b]0;pwned\\u0007\\u001b[2J\"")
        .replace("light = \"day\"", "light = \"x\\u001b[2Jy\"");
    std::fs::write(d.join("p.toml"), text).unwrap();
    for args in [&["check", "p.toml"][..], &["solve", "p.toml"]] {
        let o = metamer(d, args);
        assert!(!o.status.success());
        assert!(!o.stderr.contains(&0x1b) && !o.stdout.contains(&0x1b), "{:?}", stderr(&o));
        assert!(stderr(&o).contains("\\u{1b}"), "{}", stderr(&o));
    }
    // And a path with control characters, in a read error.
    let o = metamer(d, &["check", "no\u{1b}[2Jsuch.toml"]);
    assert!(!o.status.success());
    assert!(!o.stderr.contains(&0x1b), "{}", stderr(&o));
}

#[test]
fn the_next_open_offers_the_recovery_copy() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.toml"), SMALL).unwrap();
    std::fs::write(d.join("keys.txt"), "wait-solve\n").unwrap();
    let screen = |d: &Path| {
        let o = metamer(d, &["design", "p.toml", "--no-basis", "--replay", "keys.txt", "--size", "160x30"]);
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    assert!(!screen(d).contains("interrupted session"));
    std::fs::write(recovery_path(&d.join("p.toml")), SMALL).unwrap();
    let s = screen(d);
    assert!(s.contains("unsaved work from an interrupted session is in p.recovery.toml"), "{s}");
}

mod inputs;
mod outputs;
mod sizes;
