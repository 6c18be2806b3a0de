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
