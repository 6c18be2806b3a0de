//! `metamer design --replay`: the headless key-script runner as users call it.

use std::path::Path;
use std::process::Command;

fn metamer() -> Command {
    Command::new(env!("CARGO_BIN_EXE_metamer"))
}

fn example(dir: &Path) -> std::path::PathBuf {
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/metamers.toml");
    let path = dir.join("metamers.toml");
    std::fs::copy(source, &path).expect("copy the example palette");
    path
}

#[test]
fn replay_writes_the_final_screen() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let palette = example(dir.path());
    let keys = dir.path().join("keys.txt");
    std::fs::write(&keys, "# open the help, close it, move\n?\nEsc\nDown *2\nRight\n").expect("write keys");
    let out = dir.path().join("screen.txt");
    let status = metamer()
        .args(["design", palette.to_str().unwrap_or_default(), "--no-basis", "--size", "80x24", "--replay"])
        .arg(&keys)
        .arg("--screen")
        .arg(&out)
        .status()
        .expect("metamer runs");
    assert!(status.success());
    let screen = std::fs::read_to_string(&out).expect("screen written");
    assert_eq!(screen.lines().count(), 24);
    assert!(screen.lines().all(|l| l.chars().count() <= 80));
    for name in ["daylight", "tungsten", "fluorescent", "white", "petal", "leaf", "sky"] {
        assert!(screen.contains(name), "{name} missing from\n{screen}");
    }
    assert!(screen.contains("tungsten × leaf"), "the cell named light first, as everywhere: {screen}");
    assert!(!dir.path().join("metamers.basis.json").exists(), "--no-basis trains nothing");
}

#[test]
fn every_frame_writes_one_screen_per_frame() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let palette = example(dir.path());
    let keys = dir.path().join("keys.txt");
    std::fs::write(&keys, "Down\nDown\n").expect("write keys");
    let output = metamer()
        .args(["design", palette.to_str().unwrap_or_default(), "--no-basis", "--every-frame", "--replay"])
        .arg(&keys)
        .output()
        .expect("metamer runs");
    assert!(output.status.success());
    let text = String::from_utf8_lossy(&output.stdout);
    assert_eq!(text.matches("── frame ").count(), 3, "{text}");
}

#[test]
fn bad_scripts_and_files_are_reported_with_their_names() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let palette = example(dir.path());
    let keys = dir.path().join("keys.txt");
    std::fs::write(&keys, "Down\nnot-a-key\n").expect("write keys");
    let output = metamer()
        .args(["design", palette.to_str().unwrap_or_default(), "--replay"])
        .arg(&keys)
        .output()
        .expect("metamer runs");
    assert!(!output.status.success());
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(err.contains("keys.txt") && err.contains("line 2") && err.contains("not-a-key"), "{err}");

    let missing = dir.path().join("missing.toml");
    let output = metamer()
        .args(["design", missing.to_str().unwrap_or_default(), "--replay"])
        .arg(&keys)
        .output()
        .expect("metamer runs");
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("missing.toml"));

    // Without a terminal and without --replay it says what to do instead of panicking.
    let output = metamer().args(["design", palette.to_str().unwrap_or_default()]).output().expect("metamer runs");
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("--replay"));
    // … and prints only its error: nothing on stdout (no stray ESC[?1049l from leaving an alternate screen
    // it never entered), no escape sequence on stderr.
    assert!(output.stdout.is_empty(), "stdout: {:?}", String::from_utf8_lossy(&output.stdout));
    assert!(!output.stderr.contains(&0x1b), "stderr: {:?}", String::from_utf8_lossy(&output.stderr));
}

#[test]
fn design_takes_volume_as_render_does_and_the_missing_volume_error_names_it() {
    use crate::render_cli::{GOOD, write_scene, write_tiny_engine};
    let dir = tempfile::tempdir().expect("temporary folder");
    let d = dir.path();
    let palette = example(d);
    let scene = write_scene(d, &GOOD.replace("generated:engine_like", "no_data_here/engine.nhdr"));
    let keys = d.join("keys.txt");
    std::fs::write(&keys, "Down\n").expect("write keys");
    let design = |extra: &[&str]| {
        let mut c = metamer();
        c.args(["design", palette.to_str().unwrap_or_default(), "--no-basis", "--size", "80x24", "--scene"]);
        c.arg(&scene).args(extra).arg("--replay").arg(&keys).env_remove("METAMER_DATA");
        c.output().expect("metamer runs")
    };
    // The scene's volume is missing: the error names the option `design` has.
    let o = design(&[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--volume PATH") && err.contains("no_data_here"), "{err}");
    // --volume PATH replaces the scene's `volume`, as for `render`.
    let tiny = write_tiny_engine(&d.join("elsewhere"));
    let o = design(&["--volume", tiny.to_str().unwrap_or_default()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let screen = String::from_utf8_lossy(&o.stdout);
    assert!(screen.contains("light dial"), "{screen}");
    // Without a scene file it is refused, naming why.
    let o = metamer()
        .args(["design", palette.to_str().unwrap_or_default(), "--scene", "builtin", "--volume"])
        .arg(&tiny)
        .arg("--replay")
        .arg(&keys)
        .output()
        .expect("metamer runs");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--volume needs a scene file"), "{err}");
}

/// The designer in a terminal of its own (a pseudo-terminal of 100 × 30), told to end by `signal` after one
/// unsaved change: it restores the terminal (leaves the alternate screen), writes the change to
/// `NAME.recovery.toml` and exits with status 1 saying so — for SIGTERM, SIGHUP and SIGINT alike (in raw
/// mode Ctrl-C is a key; a SIGINT comes from another program, whose default action would leave the terminal
/// raw and lose the change).
#[cfg(target_os = "linux")]
fn ended_by(signal: libc::c_int) {
    use std::io::{Read, Write};
    use std::os::fd::{FromRawFd, OwnedFd};
    use std::os::unix::process::CommandExt;
    use std::sync::{Arc, Mutex};
    use std::time::{Duration, Instant};
    let dir = tempfile::tempdir().expect("temporary folder");
    let palette = example(dir.path());
    let (mut master, mut slave) = (0, 0);
    let size = libc::winsize { ws_row: 30, ws_col: 100, ws_xpixel: 0, ws_ypixel: 0 };
    // SAFETY: `openpty` writes the two descriptors it opens into the integers given; the other pointers are
    // null (no name wanted, default terminal settings) or a valid window size.
    let opened = unsafe { libc::openpty(&mut master, &mut slave, std::ptr::null_mut(), std::ptr::null(), &size) };
    assert_eq!(opened, 0, "a pseudo-terminal: {}", std::io::Error::last_os_error());
    // SAFETY: both descriptors were just opened by `openpty` and are owned here only.
    let (master, slave) = unsafe { (OwnedFd::from_raw_fd(master), OwnedFd::from_raw_fd(slave)) };
    let mut cmd = metamer();
    cmd.args(["design", palette.to_str().unwrap_or_default(), "--no-basis"])
        .stdin(slave.try_clone().expect("dup"))
        .stdout(slave.try_clone().expect("dup"))
        .stderr(slave);
    // SAFETY: between fork and exec the child only makes itself a session leader and takes its standard
    // input (the pseudo-terminal) as its controlling terminal: two async-signal-safe calls.
    unsafe {
        cmd.pre_exec(|| {
            if libc::setsid() < 0 || libc::ioctl(0, libc::TIOCSCTTY, 0) < 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let mut child = cmd.spawn().expect("metamer runs");
    drop(cmd);
    let screen = Arc::new(Mutex::new(Vec::<u8>::new()));
    let mut reader = std::fs::File::from(master.try_clone().expect("dup"));
    let sink = Arc::clone(&screen);
    std::thread::spawn(move || {
        let mut buf = [0u8; 65536];
        // Ends with an error (EIO) once the child's side is closed.
        while let Ok(n @ 1..) = reader.read(&mut buf) {
            sink.lock().unwrap().extend_from_slice(&buf[..n]);
        }
    });
    let seen = |from: usize, what: &str| {
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let text = String::from_utf8_lossy(&screen.lock().unwrap()[from..]).into_owned();
            if text.contains(what) {
                return;
            }
            assert!(Instant::now() < deadline, "no {what:?} on the screen: {text}");
            std::thread::sleep(Duration::from_millis(10));
        }
    };
    // The screen is drawn cell by cell where it changed (a word may come in pieces): the designer is taken to
    // be idle once it has drawn and then written nothing for a while (the solving spinner moves every 80 ms).
    let settled = |from: usize| {
        let deadline = Instant::now() + Duration::from_secs(30);
        let (mut len, mut since) = (0, Instant::now());
        loop {
            let now = screen.lock().unwrap().len();
            if now != len {
                (len, since) = (now, Instant::now());
            } else if len > from && since.elapsed() > Duration::from_millis(500) {
                return len;
            }
            assert!(Instant::now() < deadline, "the designer did not settle");
            std::thread::sleep(Duration::from_millis(10));
        }
    };
    let from = settled(0);
    // `d r`: the selected cell's reflectance (white) becomes designed, and the palette is solved again.
    std::fs::File::from(master).write_all(b"dr").expect("keys");
    let from = settled(from);
    // SAFETY: `kill` sends a signal to the child this test started and has not reaped.
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, signal) }, 0);
    let deadline = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        assert!(Instant::now() < deadline, "the designer did not end on signal {signal}");
        std::thread::sleep(Duration::from_millis(10));
    };
    assert_eq!(status.code(), Some(1), "signal {signal}: {status:?}");
    seen(from, "\u{1b}[?1049l");
    seen(from, "ended by a signal; unsaved work was written to");
    let recovery = std::fs::read_to_string(dir.path().join("metamers.recovery.toml")).expect("the recovery copy");
    let original = std::fs::read_to_string(&palette).expect("the palette");
    assert_ne!(recovery, original, "the change is in the recovery copy");
}

#[cfg(target_os = "linux")]
#[test]
fn the_designer_ends_cleanly_on_sigterm_sighup_and_sigint() {
    for signal in [libc::SIGTERM, libc::SIGHUP, libc::SIGINT] {
        ended_by(signal);
    }
}
