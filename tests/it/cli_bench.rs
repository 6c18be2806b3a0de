//! `metamer bench … --quick` writes a complete report: README.md with the headline table, each suite's
//! tables, the Pareto fronts, the ratios against in-process baselines and the condition numbers, and the
//! PNG plots it links to. (A smoke test of the benchmark code; speed figures live in the report, never in
//! assertions.)

use metamer::bench::report::{self, ReportOptions, Suite};

#[test]
fn quick_report_of_every_suite_is_complete() {
    let dir = tempfile::tempdir().unwrap();
    let options = ReportOptions { out_dir: dir.path().to_path_buf(), quick: true, runs: Some(1), volume: None };
    let report = report::run(&Suite::ALL, &options).expect("report");
    let md = std::fs::read_to_string(dir.path().join("README.md")).unwrap();
    assert_eq!(md, report.markdown);
    for needle in [
        "## Headline figures",
        "## Design engine",
        "## Spectral factor model",
        "## Renderer",
        "Pareto front (time, mean ΔE*ab)",
        "blocks vs one dense system",
        "bounded [0,1] vs unbounded",
        "### Condition numbers of the design systems met",
        "weights 1e-8, 1, 1e8",
        "vs full 31-sample",
        "Pareto front (relight cost, mean ΔE00)",
    ] {
        assert!(md.contains(needle), "missing `{needle}` in\n{md}");
    }
    // Every image the report links exists and is a real PNG.
    let links: Vec<&str> =
        md.match_indices("](").map(|(i, _)| &md[i + 2..i + 2 + md[i + 2..].find(')').unwrap()]).collect();
    assert!(links.len() >= 6, "{links:?}");
    for l in links {
        let img = image::open(dir.path().join(l)).unwrap_or_else(|e| panic!("{l}: {e}"));
        assert!(img.width() >= 600, "{l}");
    }
    assert!(report.headlines.len() >= 5, "{:?}", report.headlines);
    // The renderer's report: throughput, the large u16 workload with its memory against the budget, the
    // time-against-error table with its Pareto plot, and the VTK ratio or why it was not measured.
    let render = std::fs::read_to_string(dir.path().join("render.md")).unwrap();
    for needle in [
        "ns per sample per core (M samples/s per core)",
        "## A large generated volume: u16 128×128×96 (",
        "budget 1.5 × voxels + 160 MiB",
        "against a high-quality reference (every step on, step 0.25, --ss 2)",
        "| default at step 0.5 |",
        "## VTK",
    ] {
        assert!(render.contains(needle), "missing `{needle}` in\n{render}");
    }
    // VTK's frame against metamer's raycast, both at the same step: the scene's own and 0.5 voxels, each row
    // ending with the alternated rounds' ratios, `median× (least–greatest×)`.
    let vtk_rows: Vec<&str> = render
        .split("## VTK")
        .nth(1)
        .unwrap_or("")
        .lines()
        .take_while(|l| !l.starts_with("## "))
        .filter(|l| l.starts_with("| ") && l.ends_with("×) |"))
        .collect();
    assert!(
        render.contains("Not measured: ")
            || (vtk_rows.iter().any(|l| l.contains(" | 1 | ")) && vtk_rows.iter().any(|l| l.contains(" | 0.5 | "))),
        "{render}"
    );
    // The large row reports a peak memory and the field cache, measured, not placeholders.
    let large =
        render.lines().find(|l| l.starts_with("| 96×96 |")).unwrap_or_else(|| panic!("no large row:\n{render}"));
    assert!(large.contains(" MiB |") && large.contains(" of 64 MiB |") && !large.contains("| – |"), "{large}");
    // Every quality row has a finite error (the reference is a different raycast, so at least one is > 0).
    let p99: Vec<f64> = render
        .lines()
        .skip_while(|l| !l.starts_with("| configuration |"))
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .filter_map(|l| l.trim_end_matches('|').rsplit('|').next()?.trim().parse().ok())
        .collect();
    assert!(p99.len() >= 9 && p99.iter().all(|e| e.is_finite()) && p99.iter().any(|e| *e > 0.0), "{p99:?}");
    let plot = image::open(dir.path().join("render_pareto_quality.png")).expect("the Pareto plot");
    assert!(plot.width() >= 600);
}

#[test]
fn cli_rejects_an_unknown_suite() {
    use clap::Parser;
    let err = metamer::cli::Cli::try_parse_from(["metamer", "bench", "everything"]).unwrap_err();
    assert!(err.to_string().contains("solve"), "{err}");
}

#[test]
fn bench_says_which_tracked_files_it_rewrote() {
    use std::process::Command;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let git = |args: &[&str]| Command::new("git").args(args).current_dir(d).output().expect("git runs");
    assert!(git(&["init", "-q"]).status.success());
    let readme = format!("# x\n\n{}\n{}\n", report::README_BEGIN, report::README_END);
    std::fs::write(d.join("README.md"), readme).unwrap();
    assert!(git(&["add", "README.md"]).status.success());
    let out = Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["bench", "basis", "--quick", "--runs", "1", "-o", "out", "--readme", "README.md"])
        .current_dir(d)
        .output()
        .expect("metamer runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    let line =
        stdout.lines().find(|l| l.starts_with("rewrote ")).unwrap_or_else(|| panic!("no `rewrote` line:\n{stdout}"));
    // README.md is tracked; the report in out/ is new and untracked, so it is not listed.
    assert!(line.starts_with("rewrote 1 file(s) tracked by git") && line.ends_with(": README.md"), "{line}");
}
