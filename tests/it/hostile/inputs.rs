//! Outputs onto any file a command read (issue: "an output path that names an input destroys it"): the set
//! of inputs is what the readers actually read ([`fsio::record_reads`]), so a NRRD header's detached data
//! file, a palette's CSV sources and the scene count, through hard links and chains of symbolic links too.

use super::{metamer, mkfifo, stderr, within};
use metamer::fsio::{self, Kind};
use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::time::{Duration, Instant};

/// A 4×4×4 uint8 volume: a detached NRRD header naming `data` (relative to the header).
fn nrrd_header(data: &str) -> String {
    format!("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nspacings: 1 1 1\nencoding: raw\ndata file: {data}\n")
}

fn voxels() -> Vec<u8> {
    (0..64u8).map(|i| i * 4).collect()
}

/// A CSV reflectance of 31 samples.
pub(super) fn csv() -> String {
    (0..=30).map(|i| format!("{},{}\n", 400 + 10 * i, 0.2 + 0.01 * f64::from(i))).collect()
}

/// In `d`: `s.toml` (the engine scene over `v.nhdr`), `p.toml` (the engine palette plus a reflectance read
/// from `refl.csv`), `v.nhdr` naming the data file `data`.
pub(super) fn scene_dir(d: &Path, data: &str) {
    let palette = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/volumes/engine_palette.toml")).unwrap();
    std::fs::write(d.join("p.toml"), format!("{palette}\n[[reflectances]]\nname = \"measured\"\ncsv = \"refl.csv\"\n"))
        .unwrap();
    std::fs::write(d.join("refl.csv"), csv()).unwrap();
    let scene = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/volumes/engine.toml")).unwrap();
    let scene = scene
        .replace("\"engine_palette.toml\"", "\"p.toml\"")
        .replace("\"../../shared/volumes/engine.nhdr\"", "\"v.nhdr\"");
    std::fs::write(d.join("s.toml"), scene).unwrap();
    std::fs::write(d.join("v.nhdr"), nrrd_header(data)).unwrap();
    if let Some(parent) = Path::new(data).parent() {
        std::fs::create_dir_all(d.join(parent)).unwrap();
    }
    std::fs::write(d.join(data), voxels()).unwrap();
}

fn render(d: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["render", "s.toml", "--frames", "2", "--size", "8"];
    args.extend_from_slice(extra);
    metamer(d, &args)
}

fn assert_refused(o: &std::process::Output, other: &str) {
    assert!(!o.status.success(), "must fail: {}", String::from_utf8_lossy(&o.stdout));
    let e = stderr(o);
    assert!(e.contains("refusing to write") && e.contains(&format!("same file as the {other}")), "{e}");
}

#[test]
fn record_reads_lists_a_nrrd_data_file_and_reads_on_other_threads() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("v.nhdr"), nrrd_header("v.raw")).unwrap();
    std::fs::write(d.join("v.raw"), voxels()).unwrap();
    let (volume, read) = fsio::record_reads(|| metamer::volume::Volume::open(&d.join("v.nhdr")));
    assert_eq!(volume.unwrap().dims, [4, 4, 4]);
    let names: Vec<_> = read.iter().map(|(p, k)| (p.file_name().unwrap().to_owned(), *k)).collect();
    assert_eq!(names, [("v.nhdr".into(), Kind::Volume), ("v.raw".into(), Kind::Volume)]);
    // A read on another thread (the palette reads its CSV sources on rayon's) is recorded too.
    std::fs::write(d.join("a.csv"), csv()).unwrap();
    let path = d.join("a.csv");
    let ((), read) = fsio::record_reads(|| {
        std::thread::scope(|s| {
            s.spawn(|| fsio::read(&path, Kind::Csv).unwrap());
        })
    });
    assert!(read.iter().any(|(p, k)| p == &path && *k == Kind::Csv), "{read:?}");
    // Nothing is recorded outside a recording, and a recording sees only what happened inside it.
    fsio::read(&path, Kind::Csv).unwrap();
    let ((), read) = fsio::record_reads(|| ());
    assert!(read.iter().all(|(p, _)| p != &path), "{read:?}");
}

#[test]
fn render_refuses_outputs_onto_the_nrrd_data_file_and_the_csv_sources() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_dir(d, "out/frame_0001.png");
    let frozen = |d: &Path| {
        ["s.toml", "p.toml", "refl.csv", "v.nhdr", "out/frame_0001.png"].map(|f| std::fs::read(d.join(f)).unwrap())
    };
    let before = frozen(d);
    // The data file is the second frame; then the contact sheet is the data file, a hard link to it, a
    // chain of two symbolic links to it, the CSV source.
    std::fs::hard_link(d.join("out/frame_0001.png"), d.join("hard.png")).unwrap();
    std::os::unix::fs::symlink("out/frame_0001.png", d.join("l1")).unwrap();
    std::os::unix::fs::symlink("l1", d.join("l2.png")).unwrap();
    assert_refused(&render(d, &["-o", "out"]), "volume file");
    for sheet in ["out/frame_0001.png", "hard.png", "l2.png", "./out/../out/frame_0001.png"] {
        assert_refused(&render(d, &["-o", "elsewhere", "--contact-sheet", sheet]), "volume file");
    }
    assert_refused(&render(d, &["-o", "elsewhere", "--contact-sheet", "refl.csv"]), "CSV spectrum");
    assert_eq!(frozen(d), before, "every input is byte-identical");
    assert!(!d.join("elsewhere").exists() || std::fs::read_dir(d.join("elsewhere")).unwrap().next().is_none());
    // The same scene renders when no output is an input.
    let ok = render(d, &["-o", "elsewhere", "--contact-sheet", "c.png"]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    assert_eq!(frozen(d), before);
}

#[test]
fn design_replay_refuses_a_screen_onto_a_file_the_scene_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_dir(d, "v.raw");
    std::fs::write(d.join("keys.txt"), "Down\n").unwrap();
    std::fs::write(d.join("other.toml"), super::SMALL).unwrap();
    for (screen, other) in [("v.raw", "volume file"), ("refl.csv", "CSV spectrum"), ("p.toml", "palette")] {
        let o = metamer(
            d,
            &["design", "other.toml", "--replay", "keys.txt", "--scene", "s.toml", "--no-basis", "--screen", screen],
        );
        assert_refused(&o, other);
    }
    assert_eq!(std::fs::read(d.join("v.raw")).unwrap(), voxels());
    assert_eq!(std::fs::read_to_string(d.join("refl.csv")).unwrap(), csv());
}

#[test]
fn bench_checks_its_outputs_before_it_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("b")).unwrap();
    std::fs::write(d.join("b/README.md"), "mine\n").unwrap();
    // The README to update is the report's own file; the volume's data file is one of the report files.
    std::fs::write(d.join("b/v.nhdr"), nrrd_header("render.md")).unwrap();
    std::fs::write(d.join("b/render.md"), voxels()).unwrap();
    std::os::unix::fs::symlink("b/README.md", d.join("readme-link.md")).unwrap();
    let cases: [(&[&str], &str); 3] = [
        (&["bench", "solve", "--quick", "-o", "b", "--readme", "b/README.md"], "benchmark report"),
        (&["bench", "solve", "--quick", "-o", "b", "--readme", "readme-link.md"], "benchmark report"),
        (&["bench", "render", "--quick", "-o", "b", "--volume", "b/v.nhdr"], "volume file"),
    ];
    for (args, other) in cases {
        let start = Instant::now();
        let o = metamer(d, args);
        assert_refused(&o, other);
        assert!(start.elapsed() < Duration::from_secs(5), "{args:?} refused only after {:?}", start.elapsed());
    }
    assert_eq!(std::fs::read_to_string(d.join("b/README.md")).unwrap(), "mine\n");
    assert_eq!(std::fs::read(d.join("b/render.md")).unwrap(), voxels());
    // A repetition count that would never finish is refused at once.
    for runs in ["0", "18446744073709551615"] {
        let start = Instant::now();
        let o = metamer(d, &["bench", "solve", "--quick", "-o", "c", "--runs", runs]);
        assert!(!o.status.success() && stderr(&o).contains("--runs"), "{}", stderr(&o));
        assert!(start.elapsed() < Duration::from_secs(5));
    }
}

#[test]
fn a_sidecar_linked_to_an_input_never_overwrites_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.toml"), super::SMALL).unwrap();
    std::fs::write(d.join("c.csv"), csv()).unwrap();
    // A symbolic link: the write would land on the palette (or another file); it is not made.
    for target in ["p.toml", "c.csv"] {
        let _ = std::fs::remove_file(d.join("p.basis.json"));
        std::os::unix::fs::symlink(target, d.join("p.basis.json")).unwrap();
        let o = metamer(d, &["basis", "p.toml", "-m", "1"]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(String::from_utf8_lossy(&o.stdout).contains("not stored"), "{}", String::from_utf8_lossy(&o.stdout));
        assert_eq!(std::fs::read_to_string(d.join("p.toml")).unwrap(), super::SMALL);
        assert_eq!(std::fs::read_to_string(d.join("c.csv")).unwrap(), csv());
    }
    // A hard link is the palette itself (one file, two names): not replaced either, the link is kept.
    std::fs::remove_file(d.join("p.basis.json")).unwrap();
    std::fs::hard_link(d.join("p.toml"), d.join("p.basis.json")).unwrap();
    let o = metamer(d, &["basis", "p.toml", "-m", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("not stored") && out.contains("same file as the palette"), "{out}");
    assert_eq!(std::fs::read_to_string(d.join("p.toml")).unwrap(), super::SMALL);
    assert_eq!(std::fs::read_to_string(d.join("p.basis.json")).unwrap(), super::SMALL);
}

#[test]
fn a_scene_that_is_a_fifo_or_too_large_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    mkfifo(&d.join("s.toml"));
    let o = within(Duration::from_secs(10), move || metamer(&d, &["render", "s.toml", "--frames", "1", "--size", "8"]));
    assert!(!o.status.success());
    assert!(stderr(&o).contains("is a FIFO, not a regular file"), "{}", stderr(&o));
    let d = dir.path();
    let big = std::fs::File::create(d.join("big.toml")).unwrap();
    big.set_len(Kind::Scene.cap() + 1).unwrap();
    let o = metamer(d, &["render", "big.toml", "--frames", "1", "--size", "8"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("more than the limit"), "{}", stderr(&o));
}

#[test]
fn scene_numbers_that_overflow_are_refused_before_any_volume_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_dir(d, "v.raw");
    let scene = std::fs::read_to_string(d.join("s.toml")).unwrap();
    let generated = scene.replace("\"v.nhdr\"", "\"generated:engine_like\"");
    for (text, key) in [
        (format!("{scene}\n[render]\nexposure = 1e308\n"), "render.exposure"),
        (format!("{scene}\n[render]\nexposure = 1e-308\n"), "render.exposure"),
        // A generated volume of the largest size takes seconds to build: a bad key must not wait for it.
        (format!("{generated}\n[render]\ngenerated_size = 100000\n"), "render.generated_size"),
    ] {
        std::fs::write(d.join("x.toml"), &text).unwrap();
        let start = Instant::now();
        let o = metamer(d, &["render", "x.toml", "--frames", "1", "--size", "8", "-o", "out"]);
        assert!(!o.status.success(), "{key}: {}", String::from_utf8_lossy(&o.stdout));
        assert!(stderr(&o).contains(key), "{}", stderr(&o));
        assert!(start.elapsed() < Duration::from_secs(3), "{key} refused after {:?}", start.elapsed());
    }
}

#[test]
fn keyframe_saves_keep_the_scene_mode_and_refuse_a_fifo() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), "palette = \"p.toml\"\n").unwrap();
    std::fs::set_permissions(d.join("s.toml"), std::fs::Permissions::from_mode(0o640)).unwrap();
    metamer::tui::keyframes::save_keyframes(&d.join("s.toml"), &[]).unwrap();
    let mode = std::fs::metadata(d.join("s.toml")).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o640, "the in-place save keeps the mode");
    assert!(std::fs::read_to_string(d.join("s.toml")).unwrap().contains("palette = \"p.toml\""));
    let fifo = d.join("f.toml");
    mkfifo(&fifo);
    let e = within(Duration::from_secs(5), move || metamer::tui::keyframes::save_keyframes(&fifo, &[])).unwrap_err();
    assert!(e.contains("FIFO"), "{e}");
}

/// A file of `len` bytes (sparse past `start`) beginning with `start`.
fn sparse(path: &Path, start: &[u8], len: u64) {
    std::fs::write(path, start).unwrap();
    std::fs::OpenOptions::new().write(true).open(path).unwrap().set_len(len).unwrap();
}

#[test]
fn huge_sparse_volume_files_are_refused_from_their_size() {
    const GIB: u64 = 1 << 30;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let attached = format!("{}\n", nrrd_header("x").replace("data file: x\n", ""));
    type Make = Box<dyn Fn(&Path)>;
    let cases: Vec<(&str, Make, &str)> = vec![
        // A detached header with no end: only its first MiB is read.
        ("h.nhdr", Box::new(|p: &Path| sparse(p, nrrd_header("v.raw").as_bytes(), GIB)), "does not end"),
        // An attached NRRD whose data are far more than its sizes need.
        (
            "a.nrrd",
            Box::new(move |p: &Path| sparse(p, attached.as_bytes(), GIB)),
            "header's sizes, type and encoding allow",
        ),
        // A detached data file far larger than the header's sizes need.
        (
            "d.nhdr",
            Box::new(|p: &Path| {
                std::fs::write(p, nrrd_header("d.raw")).unwrap();
                sparse(&p.with_file_name("d.raw"), b"", GIB);
            }),
            "header's sizes, type and encoding allow",
        ),
    ];
    for (name, make, reason) in cases {
        let path = d.join(name);
        make(&path);
        let start = Instant::now();
        let e = within(Duration::from_secs(10), move || metamer::volume::Volume::open(&path)).unwrap_err().to_string();
        assert!(e.contains(reason), "{name}: {e}");
        assert!(start.elapsed() < Duration::from_secs(2), "{name}: refused after {:?}", start.elapsed());
    }
    // A raw volume named by a scene: refused from its size too.
    let raw = d.join("r.raw");
    sparse(&raw, b"", GIB);
    let start = Instant::now();
    let e = metamer::volume::raw::read(
        &raw,
        [4, 4, 4],
        metamer::volume::ScalarType::U8,
        metamer::volume::Endian::Little,
        [1.0; 3],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("not read"), "{e}");
    assert!(start.elapsed() < Duration::from_secs(2));
    // The normal files still read.
    std::fs::write(d.join("ok.nhdr"), nrrd_header("ok.raw")).unwrap();
    std::fs::write(d.join("ok.raw"), voxels()).unwrap();
    assert_eq!(metamer::volume::Volume::open(&d.join("ok.nhdr")).unwrap().voxels.get(1), 4.0);
    let mut attached = format!("{}\n", nrrd_header("x").replace("data file: x\n", "")).into_bytes();
    attached.extend(voxels());
    std::fs::write(d.join("ok.nrrd"), attached).unwrap();
    assert_eq!(metamer::volume::Volume::open(&d.join("ok.nrrd")).unwrap().voxels.get(2), 8.0);
}

#[test]
fn header_text_in_errors_is_short_and_escaped() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.nhdr");
    let junk = format!("NRRD0004\ntype: \u{1b}]0;PWN\u{7}{}\n", "y".repeat(500_000));
    std::fs::write(&path, junk).unwrap();
    let e = metamer::volume::Volume::open(&path).unwrap_err().to_string();
    assert!(e.contains("type") && e.contains("\\u{1b}"), "{e}");
    assert!(!e.contains('\u{1b}') && e.len() < 400, "{} bytes: {}", e.len(), &e[..e.len().min(400)]);
}

#[test]
fn bench_output_list_names_every_file_a_suite_writes() {
    // The up-front check is only as complete as the list: a quick basis run writes nothing else.
    let dir = tempfile::tempdir().unwrap();
    let o = metamer(dir.path(), &["bench", "basis", "--quick", "--runs", "1", "-o", "b"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let listed = metamer::bench::output_files(metamer::bench::report::Suite::Basis);
    for entry in std::fs::read_dir(dir.path().join("b")).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        assert!(name == metamer::bench::REPORT_FILE || listed.contains(&name.as_str()), "{name} is not listed");
    }
}
