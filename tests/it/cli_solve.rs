//! `metamer solve`'s table and report for a newcomer: a legend line above the table, and designed spectra
//! that are not physical (a reflectance outside [0, 1], a light below 0) flagged in the table, on their own
//! line and in the JSON report, while physical designs are not flagged.

use std::path::Path;
use std::process::Command;

fn solve(palette: &Path, report: &Path) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["solve", palette.to_str().unwrap(), "--report", report.to_str().unwrap()])
        .output()
        .expect("metamer runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    stdout
}

/// (name, unphysical) of every spectrum, and the cells' unphysical flags, from a JSON report.
fn flags(report: &Path) -> (Vec<(String, bool)>, Vec<bool>) {
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    let spectra = r["spectra"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s["name"].as_str().unwrap().to_string(), s["unphysical"].as_bool().unwrap()))
        .collect();
    let cells = r["cells"].as_array().unwrap().iter().map(|c| c["unphysical"].as_bool().unwrap()).collect();
    (spectra, cells)
}

#[test]
fn unphysical_designs_are_flagged_in_the_table_and_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/metameric_black.toml")).unwrap();
    assert!(text.contains("reflectance_bounds = [-inf, inf]"));

    // Bounds off: the metameric black "ghost" needs negative samples.
    let off = dir.path().join("off.toml");
    std::fs::write(&off, &text).unwrap();
    let report = dir.path().join("off.json");
    let table = solve(&off, &report);
    let lines: Vec<&str> = table.lines().collect();
    assert!(lines[0].starts_with("columns: light, reflectance"), "{table}");
    let header = lines.iter().position(|l| l.starts_with("light ")).expect("column header");
    assert!(lines[..header].iter().any(|l| l.contains("unphysical =")), "legend explains unphysical: {table}");
    assert!(lines[..header].iter().any(|l| l.contains("KKT residual =")), "legend explains the summary: {table}");
    for l in &lines[header + 1..] {
        if l.starts_with("daylight       ghost") || l.starts_with("sodium         ghost") {
            assert!(l.ends_with("unphysical"), "{l}");
        } else if l.starts_with("daylight       bone") || l.starts_with("sodium         bone") {
            assert!(!l.contains("unphysical"), "{l}");
        }
    }
    let named = lines.iter().find(|l| l.starts_with("unphysical: ")).expect("an unphysical line");
    assert!(named.contains("\"ghost\"") && named.contains("outside [0, 1]"), "{named}");
    let (spectra, cells) = flags(&report);
    for (name, bad) in &spectra {
        assert_eq!(*bad, name == "ghost", "{name}");
    }
    assert!(cells.iter().any(|c| *c));

    // Bounds on: nothing is flagged.
    let on = dir.path().join("on.toml");
    std::fs::write(&on, text.replace("reflectance_bounds = [-inf, inf]", "reflectance_bounds = [0.0, 1.0]")).unwrap();
    let report = dir.path().join("on.json");
    let table = solve(&on, &report);
    assert!(!table.lines().any(|l| l.ends_with("unphysical") || l.starts_with("unphysical: ")), "{table}");
    let (spectra, cells) = flags(&report);
    assert!(spectra.iter().all(|(_, bad)| !bad) && cells.iter().all(|c| !c), "{spectra:?} {cells:?}");
}

#[test]
fn help_names_the_format_pages_and_they_exist() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let help = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_metamer")).args(args).output().expect("metamer runs");
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let top = help(&["--help"]);
    // Every page under docs/formats/ is named by the top-level help, so a new page cannot be left out.
    let mut pages: Vec<String> = std::fs::read_dir(repo.join("docs/formats"))
        .expect("docs/formats/ is readable")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".md"))
        .map(|name| format!("docs/formats/{name}"))
        .collect();
    pages.sort();
    assert!(pages.len() >= 5, "docs/formats/ holds only {pages:?}");
    pages.push("docs/DESIGN_SPEC.md".to_owned());
    let missing: Vec<&String> = pages.iter().filter(|rel| !top.contains(rel.as_str())).collect();
    assert!(missing.is_empty(), "`metamer --help` does not name {missing:?}:\n{top}");
    for page in ["palette.md", "scene.md", "report.md"] {
        let rel = format!("docs/formats/{page}");
        let text = std::fs::read_to_string(repo.join(&rel)).unwrap_or_else(|e| panic!("{rel}: {e}"));
        assert!(text.starts_with("# ") && text.contains("| key |"), "{rel} is not a key reference");
    }
    assert!(help(&["solve", "--help"]).contains("docs/formats/report.md"));
    assert!(help(&["render", "--help"]).contains("docs/formats/scene.md"));
    assert!(top.contains("METAMER_DATA"));
}

#[test]
fn report_diagnostics_carry_their_kind() {
    let dir = tempfile::tempdir().unwrap();
    // Bounded reflectances: a pure green under D65 and pure magenta under A of one surface cannot both be
    // met (unmet); "spare" is designed but used by no cell (unused).
    let text = r#"
[settings]
reflectance_bounds = [0.0, 1.0]

[[lights]]
name = "day"
illuminant = "D65"

[[lights]]
name = "lamp"
illuminant = "A"

[[reflectances]]
name = "paint"
flat = 0.5
design = true

[[reflectances]]
name = "spare"
flat = 0.5
design = true

[[colours]]
light = "day"
reflectance = "paint"
target = [0.0, 0.9, 0.0]

[[colours]]
light = "lamp"
reflectance = "paint"
target = [0.9, 0.0, 0.9]
"#;
    let palette = dir.path().join("p.toml");
    std::fs::write(&palette, text).unwrap();
    let report = dir.path().join("r.json");
    let table = solve(&palette, &report);
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let diagnostics = r["diagnostics"].as_array().unwrap();
    let kinds: Vec<&str> = diagnostics.iter().map(|d| d["kind"].as_str().unwrap()).collect();
    for kind in ["unmet", "unused"] {
        assert!(kinds.contains(&kind), "no {kind} in {kinds:?}\n{table}");
    }
    for d in diagnostics {
        let kind = d["kind"].as_str().unwrap();
        assert!(d.get("stopped").is_none(), "{d}");
        // The table tags exactly the unmet remarks UNMET.
        let message = d["message"].as_str().unwrap();
        let line = table.lines().find(|l| l.ends_with(message)).unwrap_or_else(|| panic!("{message}\n{table}"));
        assert_eq!(line.starts_with("UNMET: "), kind == "unmet", "{line}");
        if kind == "unused" {
            assert!(d["cell"].is_null() && message.contains("spare"), "{d}");
        }
    }
}

#[test]
fn both_outputs_are_written_or_neither() {
    // The solved palette and the report are staged (written and synced beside their targets) in parallel
    // and put in place together: a report that cannot be written leaves the palette as it was, and the
    // staged palette's temporary file is removed.
    let dir = tempfile::tempdir().unwrap();
    let palette = dir.path().join("metamers.toml");
    std::fs::copy(Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/metamers.toml"), &palette).unwrap();
    let before = std::fs::read(&palette).unwrap();
    let report = dir.path().join("no such folder").join("r.json");
    let p = palette.to_str().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["solve", p, "--no-subspace", "-o", p, "--report", report.to_str().unwrap()])
        .output()
        .expect("metamer runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("cannot write the report"), "{stderr}");
    assert!(out.stdout.is_empty(), "nothing is printed when an output fails");
    assert_eq!(std::fs::read(&palette).unwrap(), before, "the palette is left as it was");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, [std::ffi::OsString::from("metamers.toml")], "no temporary file is left");
    // With both outputs writable, both are written.
    let report = dir.path().join("r.json");
    let out = Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["solve", p, "--no-subspace", "-o", p, "--report", report.to_str().unwrap()])
        .output()
        .expect("metamer runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_ne!(std::fs::read(&palette).unwrap(), before, "the solved palette is written");
    assert!(report.is_file());
}

#[cfg(unix)]
#[test]
fn a_read_only_palette_is_replaced_only_with_force() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let palette = dir.path().join("metamers.toml");
    std::fs::copy(Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/metamers.toml"), &palette).unwrap();
    std::fs::set_permissions(&palette, std::fs::Permissions::from_mode(0o444)).unwrap();
    let before = std::fs::read(&palette).unwrap();
    let p = palette.to_str().unwrap();
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_metamer"))
            .args(["solve", p, "--no-subspace", "-o", p])
            .args(extra)
            .output()
            .expect("metamer runs")
    };
    let out = run(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("refusing to replace a read-only file"), "{stderr}");
    assert_eq!(std::fs::read(&palette).unwrap(), before, "the read-only palette is left as it was");
    let out = run(&["--force"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_ne!(std::fs::read(&palette).unwrap(), before, "--force replaces it");
    assert_eq!(std::fs::metadata(&palette).unwrap().permissions().mode() & 0o777, 0o444, "and keeps its mode");
}
