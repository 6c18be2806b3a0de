//! `metamer render` end to end: the built-in default, frame ranges that combine with whole sweeps,
//! every mode, scene files over a generated volume, and bad scenes (one readable error, no panic).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn metamer(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_metamer")).args(args).output().expect("the binary runs")
}

fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn frame(dir: &Path, k: usize) -> PathBuf {
    dir.join(format!("frame_{k:04}.png"))
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn builtin_sweep_writes_frames_and_contact_sheet_and_split_ranges_combine() {
    let dir = tempfile::tempdir().unwrap();
    let all = dir.path().join("all");
    let sheet = dir.path().join("sheet.png");
    let (a, s) = (all.to_str().unwrap(), sheet.to_str().unwrap());
    let out = metamer(&[
        "render",
        "--frames",
        "5",
        "--size",
        "40",
        "--builtin-volume-size",
        "32",
        "-o",
        a,
        "--contact-sheet",
        s,
    ]);
    ok(&out);
    // The summary says what the derived fields took: blocks built, the most resident and the cap (a 32³
    // volume's blocks fit the 64 MiB floor, so none is evicted and the store is pinned).
    let summary = String::from_utf8_lossy(&out.stdout);
    let fields = summary.split("derived fields ").nth(1).unwrap_or_default();
    let built: u64 = fields.split(' ').next().and_then(|n| n.parse().ok()).unwrap_or(0);
    assert!(built > 0 && fields.contains("resident of a 64 MiB cap (0 evicted), pinned store\n"), "{summary}");
    assert!(summary.contains("peak memory ") && summary.contains(" MiB\n"), "{summary}");
    for k in 0..5 {
        let img = image::open(frame(&all, k)).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (40, 40));
    }
    assert!(!frame(&all, 5).exists());
    assert!(image::open(&sheet).is_ok());
    // The light changes along the dial: first and last frames differ, and the volume is visible.
    let first = image::open(frame(&all, 0)).unwrap().to_rgb8();
    let last = image::open(frame(&all, 4)).unwrap().to_rgb8();
    assert_ne!(first, last);
    assert!(last.pixels().any(|p| p.0 != [0, 0, 0]));
    // Frames 2..4 rendered alone are byte-identical to the same frames of the whole sweep.
    let part = dir.path().join("part");
    let p = part.to_str().unwrap();
    ok(&metamer(&[
        "render",
        "--frames",
        "5",
        "--size",
        "40",
        "--builtin-volume-size",
        "32",
        "-o",
        p,
        "--frame-range",
        "2..4",
    ]));
    assert!(!frame(&part, 1).exists() && !frame(&part, 4).exists());
    for k in 2..4 {
        assert_eq!(std::fs::read(frame(&part, k)).unwrap(), std::fs::read(frame(&all, k)).unwrap(), "frame {k}");
    }
}

#[test]
fn png_compression_changes_the_file_not_the_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let run = |c: Option<&str>| {
        let out = dir.path().join(c.unwrap_or("unset"));
        let mut args = vec!["render", "--frames", "2", "--size", "96", "--builtin-volume-size", "48", "-o"];
        args.push(out.to_str().unwrap());
        if let Some(c) = c {
            args.extend(["--png-compression", c]);
        }
        ok(&metamer(&args));
        std::fs::read(frame(&out, 1)).unwrap()
    };
    let (unset, fast, default, best) = (run(None), run(Some("fast")), run(Some("default")), run(Some("best")));
    // fast is the default.
    assert_eq!(unset, fast);
    let pixels = |b: &[u8]| image::load_from_memory(b).unwrap().to_rgb8();
    assert!(pixels(&default) == pixels(&fast) && pixels(&best) == pixels(&fast));
    assert_ne!(best, fast, "best must be another encoding");
    assert!(best.len() <= fast.len() && default.len() <= fast.len(), "{} {} {}", fast.len(), default.len(), best.len());
    let bad = metamer(&["render", "--png-compression", "tiny", "-o", dir.path().join("x").to_str().unwrap()]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && err.contains("--png-compression") && err.contains("best"), "{err}");
}

/// A long sweep split across machines (README, "Splitting a long sweep across machines"): `--frame-range`
/// shards written into one folder hold exactly the files of one run, byte for byte, and
/// `--sheet-from-frames` assembles their contact sheet after, byte-identical to the one-run sheet (frames
/// without the dial, which a one-run sheet draws anew into each tile).
#[test]
fn shards_of_a_sweep_concatenate_to_one_run_and_their_sheet_assembles_after() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = |out: &Path, extra: &[&str]| {
        let mut args = vec!["render", "--frames", "7", "--size", "40", "--builtin-volume-size", "32"];
        args.extend_from_slice(&["-o", out.to_str().unwrap()]);
        args.extend_from_slice(extra);
        metamer(&args)
    };
    let names = |p: &Path| {
        let mut v: Vec<_> = std::fs::read_dir(p).unwrap().map(|e| e.unwrap().file_name()).collect();
        v.sort();
        v
    };
    let (one, shards) = (d.join("one"), d.join("shards"));
    let (one_sheet, shard_sheet) = (d.join("one.png"), d.join("shards.png"));
    ok(&run(&one, &["--no-dial", "--contact-sheet", one_sheet.to_str().unwrap()]));
    for r in ["0..2", "2..5", "5.."] {
        ok(&run(&shards, &["--no-dial", "--frame-range", r]));
    }
    assert_eq!(names(&shards), names(&one));
    assert_eq!(names(&one).len(), 7);
    for k in 0..7 {
        assert!(std::fs::read(frame(&shards, k)).unwrap() == std::fs::read(frame(&one, k)).unwrap(), "frame {k}");
    }
    let assembled =
        run(&shards, &["--no-dial", "--contact-sheet", shard_sheet.to_str().unwrap(), "--sheet-from-frames"]);
    ok(&assembled);
    assert!(String::from_utf8_lossy(&assembled.stdout).contains("of 7 frames 0..7 of 7"));
    assert!(std::fs::read(&one_sheet).unwrap() == std::fs::read(&shard_sheet).unwrap(), "sheets differ");
    // A shard's frames missing: the sheet is refused naming the frame, not assembled with a hole.
    std::fs::remove_file(frame(&shards, 3)).unwrap();
    let sheet = d.join("holes.png");
    let o = run(&shards, &["--no-dial", "--contact-sheet", sheet.to_str().unwrap(), "--sheet-from-frames"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("frame_0003.png"), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!sheet.exists());
    // A frame larger than any `--size` is refused before it is decoded.
    image::RgbImage::new(4097, 1).save(frame(&shards, 3)).unwrap();
    let o = run(&shards, &["--no-dial", "--contact-sheet", sheet.to_str().unwrap(), "--sheet-from-frames"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("at most 4096²"), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A scene over the generated volume with the repository's engine palette copied beside it.
pub(crate) fn write_scene(dir: &Path, body: &str) -> PathBuf {
    std::fs::copy(repo().join("volumes/engine_palette.toml"), dir.join("engine_palette.toml")).unwrap();
    let p = dir.join("scene.toml");
    std::fs::write(&p, body).unwrap();
    p
}

pub(crate) const GOOD: &str = r#"
palette = "engine_palette.toml"
volume = "generated:engine_like"
[[materials]]
reflectance = "block"
range = [105, 175]
opacity = 0.2
[[materials]]
reflectance = "inner"
range = [200, 255]
opacity = 0.6
[camera]
azimuth_deg = 10.0
elevation_deg = 30.0
[dial]
path = ["hide", "split"]
[render]
generated_size = 24
"#;

#[test]
fn scene_file_renders_in_every_mode() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), GOOD);
    for mode in ["factor", "full", "rgb"] {
        let out = dir.path().join(mode);
        let o = metamer(&[
            "render",
            scene.to_str().unwrap(),
            "--frames",
            "2",
            "--size",
            "24",
            "-o",
            out.to_str().unwrap(),
            "--mode",
            mode,
        ]);
        ok(&o);
        assert!(String::from_utf8_lossy(&o.stdout).contains("dial path: hide → split)"), "{o:?}");
        assert!(frame(&out, 1).exists());
    }
    // A keyframe sweep: the summary names the keyframes in order (each by its light, or its point and
    // the lights off), one frame each.
    let keyframed = GOOD.replace(
        "[dial]\npath = [\"hide\", \"split\"]\n",
        "[[dial.keyframes]]\nat = \"hide\"\n[[dial.keyframes]]\nat = \"glow\"\n\
         [[dial.keyframes]]\nat = [0.25, 0.5]\noff = [\"split\"]\n",
    );
    assert_ne!(keyframed, GOOD);
    let scene = write_scene(dir.path(), &keyframed);
    let out = dir.path().join("keyframes");
    let o = metamer(&["render", scene.to_str().unwrap(), "--keyframes", "--size", "24", "-o", out.to_str().unwrap()]);
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let line = stdout.lines().next().unwrap_or_default();
    assert!(line.starts_with("3 frames 0..3 of 3 "), "{line}");
    assert!(line.contains("keyframes: hide → glow → [0.25, 0.50] (split off))"), "{line}");
    assert!(frame(&out, 2).exists() && !frame(&out, 3).exists());
    // Under "hide" block and inner parts are metamers: the full and factor frames agree closely.
    let full = image::open(frame(&dir.path().join("full"), 0)).unwrap().to_rgb8();
    let factor = image::open(frame(&dir.path().join("factor"), 0)).unwrap().to_rgb8();
    let worst = full
        .pixels()
        .zip(factor.pixels())
        .flat_map(|(a, b)| (0..3).map(move |c| (i32::from(a.0[c]) - i32::from(b.0[c])).abs()))
        .max()
        .unwrap();
    assert!(worst <= 6, "factor and full frames differ by {worst} codes");
}

#[test]
fn bad_scenes_are_one_readable_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "unknown reflectance",
            GOOD.replace("reflectance = \"inner\"", "reflectance = \"piston\""),
            "materials[1].reflectance",
        ),
        ("bad opacity", GOOD.replace("opacity = 0.6", "opacity = 1.5"), "materials[1].opacity"),
        ("inverted range", GOOD.replace("[200, 255]", "[255, 200]"), "materials[1].range"),
        ("unknown light", GOOD.replace("\"split\"]", "\"dusk\"]"), "dial.path[1]"),
        ("unknown key", GOOD.replace("[camera]", "[camera]\nfov = 3"), "fov"),
        ("missing volume", GOOD.replace("generated:engine_like", "nowhere.nhdr"), "nowhere.nhdr"),
        ("missing palette", GOOD.replace("engine_palette.toml", "gone.toml"), "gone.toml"),
        (
            "no materials",
            "palette = \"engine_palette.toml\"\nvolume = \"generated:engine_like\"\nmaterials = []\n".into(),
            "materials",
        ),
        ("empty", String::new(), "empty"),
        ("syntax", "palette = [".into(), "line"),
    ];
    for (what, body, needle) in cases {
        let scene = write_scene(d, &body);
        let o = metamer(&[
            "render",
            scene.to_str().unwrap(),
            "--frames",
            "2",
            "--size",
            "16",
            "-o",
            d.join("out").to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{what}: should fail");
        assert!(err.contains("scene.toml") || err.contains(needle), "{what}: {err}");
        assert!(err.contains(needle), "{what}: error does not name `{needle}`: {err}");
        assert!(!err.contains("panicked"), "{what}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{what}: one line expected: {err}");
    }
    // Binary garbage as a scene, and a missing scene file.
    let bin = d.join("bin.toml");
    std::fs::write(&bin, [0xffu8, 0, 1, 2]).unwrap();
    for p in [bin, d.join("absent.toml")] {
        let o = metamer(&["render", p.to_str().unwrap(), "-o", d.join("out").to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains(p.file_name().unwrap().to_str().unwrap()) && !err.contains("panicked"),
            "{err}"
        );
    }
    // Bad command-line values.
    for args in [vec!["--frames", "0"], vec!["--frames", "4", "--frame-range", "3..9"], vec!["--size", "2"]] {
        let mut all = vec!["render", "-o", "unused"];
        all.extend(args.iter());
        let o = metamer(&all);
        assert!(!o.status.success() && !String::from_utf8_lossy(&o.stderr).contains("panicked"));
    }
}

#[test]
fn builtin_scene_matches_the_generated_engine_scene_file() {
    use metamer::render::{Scene, builtin_scene};
    let file = Scene::load(&repo().join("volumes/engine_generated.toml")).expect("scene file loads");
    let builtin = builtin_scene(160).expect("built-in scene");
    assert_eq!(file.materials, builtin.materials);
    assert_eq!(file.camera, builtin.camera);
    assert_eq!(file.dial, builtin.dial);
    assert_eq!(file.settings, builtin.settings);
    assert_eq!(file.volume.dims, builtin.volume.dims);
    assert_eq!(file.palette.reflectances, builtin.palette.reflectances);
}

/// A small detached NRRD `engine.nhdr` + `engine.raw` (8³ bytes) in `dir`.
pub(crate) fn write_tiny_engine(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let header = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: raw\ndata file: engine.raw\n";
    std::fs::write(dir.join("engine.nhdr"), header).unwrap();
    std::fs::write(dir.join("engine.raw"), (0..512u32).map(|i| (i % 256) as u8).collect::<Vec<u8>>()).unwrap();
    dir.join("engine.nhdr")
}

#[test]
fn scene_volume_from_the_command_line_or_the_data_folder_and_a_missing_one_says_how_to_get_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = write_scene(d, &GOOD.replace("generated:engine_like", "no_data_here/engine.nhdr"));
    let out = d.join("out");
    let render = |extra: &[&str], data: Option<&Path>| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_metamer"));
        c.args(["render", scene.to_str().unwrap(), "--frames", "2", "--size", "16", "-o", out.to_str().unwrap()]);
        c.args(extra);
        match data {
            Some(p) => c.env("METAMER_DATA", p),
            None => c.env_remove("METAMER_DATA"),
        };
        c.output().expect("the binary runs")
    };
    // Missing: one line naming the scene, its `volume` key, where it looked and how to get the dataset.
    let o = render(&[], None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    for needle in [
        "scene.toml",
        "volume",
        "no_data_here/engine.nhdr",
        "--volume",
        "METAMER_DATA",
        "volvis.org",
        "http://klacansky.com/open-scivis-datasets/engine/",
    ] {
        assert!(err.contains(needle), "missing volume error does not name `{needle}`: {err}");
    }
    assert!(!err.contains("os error"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    // A data folder without the file says where it looked.
    let empty = d.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let o = render(&[], Some(&empty));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("empty") && err.contains("METAMER_DATA="), "{err}");

    // --volume PATH replaces the key.
    let tiny = write_tiny_engine(&d.join("elsewhere"));
    let o = render(&["--volume", tiny.to_str().unwrap()], None);
    ok(&o);
    assert!(frame(&out, 1).exists());
    let o = render(&["--volume", d.join("absent.nhdr").to_str().unwrap()], None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--volume") && err.contains("absent.nhdr"), "{err}");

    // A header whose data file is missing: the I/O error is said once, not once per layer.
    let broken = d.join("broken");
    write_tiny_engine(&broken);
    std::fs::remove_file(broken.join("engine.raw")).unwrap();
    let o = render(&["--volume", broken.join("engine.nhdr").to_str().unwrap()], None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("engine.raw"), "{err}");
    assert_eq!(err.matches("(os error").count(), 1, "{err}");

    // METAMER_DATA=DIR finds the key's file name in DIR or DIR/volumes.
    std::fs::remove_dir_all(&out).unwrap();
    let data = d.join("data");
    write_tiny_engine(&data.join("volumes"));
    ok(&render(&[], Some(&data)));
    assert!(frame(&out, 1).exists());
    ok(&render(&[], Some(&data.join("volumes"))));
}

/// A long sweep whose frames come faster than the disk takes them: the frames wait for the thread that
/// commits them in a bounded queue, each holding its temporary file open, so the sweep needs a fixed number
/// of file descriptors, not one per frame waiting (600 tiny frames under a limit of 40 open files: an
/// unbounded queue ran out of them after 10–20 frames on this project's machines).
#[cfg(unix)]
#[test]
fn a_long_sweep_holds_a_bounded_number_of_files_open() {
    use std::os::unix::process::CommandExt;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frames");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_metamer"));
    cmd.args(["render", "--frames", "600", "--size", "32", "--builtin-volume-size", "24", "--no-dial", "-o"]);
    cmd.arg(&out);
    // SAFETY: the closure runs in the child between fork and exec and calls only `setrlimit`, which is
    // async-signal-safe; it reads nothing of the parent's state.
    unsafe {
        cmd.pre_exec(|| {
            let limit = libc::rlimit { rlim_cur: 40, rlim_max: 40 };
            if libc::setrlimit(libc::RLIMIT_NOFILE, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let o = cmd.output().expect("the binary runs");
    ok(&o);
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 600, "every frame and nothing else");
}

/// Start a long sweep of the built-in scene into `out` (with `ignore_sigint`, as a shell starts a command
/// run with `&`: SIGINT ignored), and wait until it has written `frames` frames (None if it ended first).
#[cfg(unix)]
fn sweep_until(out: &Path, frames: usize, ignore_sigint: bool, total: &str) -> (std::process::Child, bool) {
    use std::os::unix::process::CommandExt;
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_metamer"));
    cmd.args(["render", "--frames", total, "--size", "96", "--builtin-volume-size", "24", "--no-dial", "-o"]);
    cmd.arg(out).stdout(std::process::Stdio::null()).stderr(std::process::Stdio::null());
    if ignore_sigint {
        // SAFETY: the closure runs in the child between fork and exec and calls only `signal`, which is
        // async-signal-safe; it reads nothing of the parent's state.
        unsafe {
            cmd.pre_exec(|| {
                libc::signal(libc::SIGINT, libc::SIG_IGN);
                Ok(())
            });
        }
    }
    let mut child = cmd.spawn().expect("the binary runs");
    let frame_count = || {
        std::fs::read_dir(out)
            .map_or(0, |d| d.flatten().filter(|e| !e.file_name().to_string_lossy().starts_with('.')).count())
    };
    loop {
        if frame_count() >= frames {
            return (child, true);
        }
        if child.try_wait().expect("the child can be waited for").is_some() {
            return (child, false);
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
}

/// Ctrl-C (or SIGTERM, SIGHUP) in the middle of a sweep: the process ends as killed by the signal, and the
/// frames it was writing leave no hidden temporary file (`.frame_NNNN.png.XXXXXX.tmp`) behind; every frame
/// in the folder is whole. Four interruptions at different points: without the removal on signals, most of
/// them left one to three such files on this project's machines.
#[cfg(unix)]
#[test]
fn an_interrupted_sweep_leaves_whole_frames_and_no_temporary_file() {
    use std::os::unix::process::ExitStatusExt;
    for (k, (after, signal)) in
        [(5, libc::SIGINT), (40, libc::SIGINT), (120, libc::SIGTERM), (250, libc::SIGHUP)].into_iter().enumerate()
    {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join(format!("frames{k}"));
        let (mut child, running) = sweep_until(&out, after, false, "100000");
        assert!(running, "the sweep ended before {after} frames");
        // SAFETY: `kill` sends a signal to the child this test started and still holds (not yet reaped).
        assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, signal) }, 0);
        let status = child.wait().unwrap();
        assert_eq!(status.signal(), Some(signal), "ended by the signal: {status:?}");
        let names: Vec<String> =
            std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        let hidden: Vec<&String> = names.iter().filter(|n| n.starts_with('.')).collect();
        assert!(hidden.is_empty(), "after signal {signal}: temporary files left: {hidden:?}");
        assert!(names.len() >= after);
        for n in &names {
            assert!(image::open(out.join(n)).is_ok(), "{n} is not a whole PNG");
        }
    }
}

/// A sweep started with SIGINT ignored (a command run with `&` from a script) keeps ignoring it: the removal
/// on signals takes only the signals the process was started to act on.
#[cfg(unix)]
#[test]
fn a_sweep_started_ignoring_sigint_keeps_ignoring_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frames");
    let (mut child, running) = sweep_until(&out, 3, true, "400");
    if running {
        // SAFETY: as above, the child is this test's and not yet reaped.
        assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) }, 0);
    }
    let status = child.wait().unwrap();
    assert!(status.success(), "{status:?}");
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 400, "every frame and nothing else");
}
