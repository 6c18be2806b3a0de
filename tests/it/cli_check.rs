//! `metamer check` as a user runs it: the built binary, its exit codes and messages.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn metamer(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_metamer")).args(args).env_remove("NO_COLOR").output().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn example_palettes() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    v
}

#[test]
fn every_example_palette_checks() {
    let palettes = example_palettes();
    for required in ["metamers.toml", "metameric_black.toml", "constancy.toml"] {
        assert!(palettes.iter().any(|p| p.ends_with(required)), "palettes/{required} is missing");
    }
    for path in &palettes {
        let out = metamer(&["check", path.to_str().unwrap()]);
        let stdout = text(&out.stdout);
        assert!(out.status.success(), "{}: {}", path.display(), text(&out.stderr));
        assert!(stdout.contains("ok: "), "{stdout}");
        assert!(stdout.contains("(on flat white)"), "{stdout}");
        // Piped output is plain text with hex values.
        assert!(!stdout.contains('\x1b'), "escape codes in piped output: {stdout}");
        assert!(stdout.contains("#"), "{stdout}");
        let file = metamer::palette::PaletteFile::load(path).unwrap();
        for light in &file.palette.lights {
            assert!(stdout.contains(&light.name), "light {} not shown: {stdout}", light.name);
        }
        for r in &file.palette.reflectances {
            assert!(stdout.contains(&r.name), "reflectance {} not shown: {stdout}", r.name);
        }
        assert!(text(&out.stderr).is_empty(), "{}", text(&out.stderr));
    }
}

#[test]
fn the_metamers_example_is_shown_cell_by_cell() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/metamers.toml");
    let out = metamer(&["check", path.to_str().unwrap()]);
    let stdout = text(&out.stdout);
    // Targets, free groups and the marker of designed spectra appear.
    assert!(stdout.contains("→ #b45c3d"), "{stdout}");
    assert!(stdout.contains("free grey"), "{stdout}");
    assert!(stdout.contains("petal *"), "{stdout}");
    assert!(stdout.contains("\"metamers\": 3 lights (0 designed), 4 reflectances (3 designed)"), "{stdout}");
}

/// Each target in its reflectance's row and its light's column, on a palette with more reflectances than
/// lights (a place looked up as (light, reflectance) the wrong way round would move or lose them): `b`'s only
/// cell is under the second light, `c` has none and so no target line.
#[test]
fn targets_are_shown_at_their_reflectance_and_light() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.toml");
    let mut toml = String::from("name = \"places\"\n");
    for (light, source) in [("day", "D65"), ("lamp", "A")] {
        toml.push_str(&format!("[[lights]]\nname = \"{light}\"\nilluminant = \"{source}\"\n"));
    }
    for (r, source) in
        [("a", "flat = 0.5\ndesign = true"), ("b", "colorchecker = \"red\""), ("c", "colorchecker = \"blue\"")]
    {
        toml.push_str(&format!("[[reflectances]]\nname = \"{r}\"\n{source}\n"));
    }
    for (light, r, target) in [("day", "a", "#112233"), ("lamp", "b", "#445566")] {
        toml.push_str(&format!("[[colours]]\nlight = \"{light}\"\nreflectance = \"{r}\"\ntarget = \"{target}\"\n"));
    }
    std::fs::write(&path, toml).unwrap();
    let out = metamer(&["check", "--color", "never", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    let row = |name: &str| lines.iter().position(|l| l.starts_with(name)).unwrap_or_else(|| panic!("{name}: {stdout}"));
    let columns = |line: &str| line.split('│').map(str::trim).map(str::to_string).collect::<Vec<_>>();
    assert_eq!(columns(lines[row("a *") + 1]), ["target", "→ #112233", ""], "{stdout}");
    assert_eq!(columns(lines[row("b ") + 1]), ["target", "", "→ #445566  ="], "{stdout}");
    assert!(lines[row("c ") + 1].starts_with('*'), "no target line under c: {stdout}");
}

#[test]
fn colour_swatches_on_request_and_never_with_no_color() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/metamers.toml");
    let p = path.to_str().unwrap();
    let out = metamer(&["check", "--color", "always", p]);
    assert!(text(&out.stdout).contains("\x1b[48;2;"), "no truecolor swatch");
    let out = metamer(&["check", "--color", "never", p]);
    assert!(!text(&out.stdout).contains('\x1b'));
    let out = Command::new(env!("CARGO_BIN_EXE_metamer")).args(["check", p]).env("NO_COLOR", "1").output().unwrap();
    assert!(out.status.success());
    assert!(!text(&out.stdout).contains('\x1b'));
}

#[test]
fn invalid_files_fail_with_file_key_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p.to_str().unwrap().to_string()
    };
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            write("unknown_light.toml", b"[[lights]]\nname = \"d\"\nflat = 1\n[[reflectances]]\nname = \"r\"\nflat = 1\n[[colours]]\nlight = \"x\"\nreflectance = \"r\"\ntarget = \"#000000\"\n"),
            vec!["unknown_light.toml", "colours[0].light", "unknown light `x`"],
        ),
        (write("empty.toml", b""), vec!["empty.toml", "empty"]),
        (write("binary.toml", &[0x7f, b'E', b'L', b'F', 0, 0xff, 0xfe]), vec!["binary.toml", "not a text file"]),
        (write("syntax.toml", b"name = \"x\"\n[[lights]\n"), vec!["syntax.toml", "line 2"]),
        (
            write("samples.toml", b"[[lights]]\nname = \"d\"\nsamples = [1.0, 2.0]\n"),
            vec!["samples.toml", "lights[0].samples", "expected 31 samples"],
        ),
    ];
    for (path, needles) in &cases {
        let out = metamer(&["check", path]);
        let stderr = text(&out.stderr);
        assert!(!out.status.success(), "{path} passed");
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        for n in needles {
            assert!(stderr.contains(n), "`{n}` missing from: {stderr}");
        }
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    // A mix: the valid file is still printed, the run fails and names the bad one.
    let good = Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/metamers.toml");
    let out = metamer(&["check", good.to_str().unwrap(), &cases[0].0]);
    assert!(!out.status.success());
    assert!(text(&out.stdout).contains("ok: "));
    assert!(text(&out.stderr).contains("1 of 2 palettes are invalid"), "{}", text(&out.stderr));
    let out = metamer(&["check", "/nonexistent/palette.toml"]);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("/nonexistent/palette.toml: cannot read the palette"), "{}", text(&out.stderr));
}

#[test]
fn usage_and_help() {
    let out = metamer(&["check"]);
    assert_eq!(out.status.code(), Some(2), "a missing argument is a usage error");
    assert!(text(&out.stderr).contains("PALETTE"));
    let out = metamer(&["check", "--help"]);
    assert!(out.status.success());
    let help = text(&out.stdout);
    assert!(help.contains("design matri"), "{help}");
    assert!(help.contains("NO_COLOR"), "{help}");
}
