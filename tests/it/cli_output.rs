//! Every command's stdout through the one writer (`cli/out.rs`): a closed pipe ends the command quietly
//! (exit 0, nothing on stderr), a failed write (`> /dev/full`: no space left) is one line on stderr and exit
//! 1, never a panic. Each command that prints is run both ways: check, basis (table and `--json`), solve,
//! render and `design --replay` without `--screen`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The commands that print, each with its arguments (files in `dir`).
fn commands(dir: &Path) -> Vec<(&'static str, Vec<String>)> {
    let palette = dir.join("metamers.toml");
    std::fs::copy(repo().join("palettes/metamers.toml"), &palette).expect("copy the example palette");
    let keys = dir.join("keys.txt");
    std::fs::write(&keys, "Down\nRight\n").expect("write keys");
    let p = palette.to_string_lossy().into_owned();
    let frames = dir.join("frames").to_string_lossy().into_owned();
    let s = |v: &[&str]| v.iter().map(|a| a.to_string()).collect::<Vec<_>>();
    vec![
        ("check", s(&["check", &p])),
        ("basis", s(&["basis", &p])),
        ("basis --json", s(&["basis", "--json", &p])),
        ("solve", s(&["solve", &p])),
        ("render", s(&["render", "--frames", "2", "--size", "24", "--builtin-volume-size", "16", "-o", &frames])),
        ("design --replay", s(&["design", &p, "--no-basis", "--size", "40x12", "--replay", &keys.to_string_lossy()])),
    ]
}

fn run(args: &[String], stdout: impl Into<Stdio>) -> Output {
    Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(args)
        .stdout(stdout)
        .stderr(Stdio::piped())
        .output()
        .expect("the binary runs")
}

#[test]
fn a_closed_pipe_ends_every_command_quietly() {
    let dir = tempfile::tempdir().expect("temporary folder");
    for (name, args) in commands(dir.path()) {
        // The reading end is closed before the command starts, so its first write fails with EPIPE.
        let (reader, writer) = std::io::pipe().expect("a pipe");
        drop(reader);
        let out = run(&args, writer);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: status {:?}, stderr:\n{stderr}", out.status);
        assert!(!stderr.contains("panicked") && !stderr.contains("error"), "{name}: stderr:\n{stderr}");
    }
}

#[test]
fn a_full_disk_is_one_error_line_for_every_command() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("skipped: no /dev/full on this system");
        return;
    };
    let dir = tempfile::tempdir().expect("temporary folder");
    for (name, args) in commands(dir.path()) {
        let out = run(&args, full.try_clone().expect("clone /dev/full"));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{name}: stderr:\n{stderr}");
        assert!(!stderr.contains("panicked"), "{name}: stderr:\n{stderr}");
        let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
        assert_eq!(errors, ["error: cannot write to standard output: No space left on device (os error 28)"], "{name}");
    }
}
