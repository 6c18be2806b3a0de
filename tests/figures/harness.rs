//! The harness's own promise (README, section Tests): this binary run again with the data folder pointed
//! at an empty folder reports a data test as ignored, by name and with the reason, and passes; with
//! `CI=true` the same test runs and fails, naming where the data was looked for.

use std::process::{Command, Output};

/// One data test of this binary, run alone with `METAMER_DATA` at an empty folder.
fn run_without_data(ci: bool) -> (Output, String) {
    let exe = std::env::current_exe().expect("the test binary's path");
    let empty = tempfile::tempdir().expect("a temporary folder");
    let mut c = Command::new(exe);
    c.args(["--exact", "shared_volumes::every_public_volume_reads", "--test-threads", "1"])
        .env("METAMER_DATA", empty.path())
        .env("CI", if ci { "true" } else { "false" });
    let out = c.output().expect("the test binary runs again");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    (out, text)
}

pub(crate) fn missing_data_is_reported_as_ignored_by_name_and_fails_under_ci() {
    let (out, text) = run_without_data(false);
    assert!(out.status.success(), "without the data the run passes: {text}");
    let line = text.lines().find(|l| l.contains("shared_volumes::every_public_volume_reads")).unwrap_or("");
    assert!(line.contains("ignored (needs the public volumes: METAMER_DATA="), "named and ignored: {text}");
    assert!(text.contains("0 passed; 0 failed; 1 ignored"), "counted as ignored, not passed: {text}");

    let (out, text) = run_without_data(true);
    assert!(!out.status.success(), "under CI=true a missing data folder fails: {text}");
    assert!(text.contains("every_public_volume_reads") && text.contains("holds no volumes/"), "{text}");
    assert!(text.contains("0 passed; 1 failed"), "{text}");
}
