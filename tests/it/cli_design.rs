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
    assert!(screen.contains("leaf × tungsten"), "{screen}");
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
