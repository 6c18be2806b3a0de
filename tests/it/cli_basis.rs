//! `metamer basis` as a user runs it, including the outside accuracy check: the basis printed by
//! `--json` for the 24 ColorChecker reflectances under seven lights, used as `c = e ∘ s` with `e = B⁺E`,
//! `s = B⁺S`, must predict every colour within mean ΔE00 1.0 and p95 2.5.

use metamer::basis::Basis;
use metamer::basis::TrainingSet;
use metamer::basis::accuracy::{self, Model};
use metamer::colorimetry::Colorimetry;
use nalgebra::DMatrix;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn metamer(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_metamer")).args(args).output().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn reference_palette() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/colorchecker_7_lights.toml")
}

#[test]
fn json_basis_meets_the_accuracy_bar_on_colorchecker_under_seven_lights() {
    let dir = tempfile::tempdir().unwrap();
    let palette = dir.path().join("cc.toml");
    std::fs::copy(reference_palette(), &palette).unwrap();
    let out = metamer(&["basis", palette.to_str().unwrap(), "--dimension", "7", "--json", "--no-cache"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["dimension"], 7);
    let columns = json["basis"].as_array().unwrap();
    assert_eq!(columns.len(), 7);
    let mut samples = Vec::new();
    for c in columns {
        let c = c.as_array().unwrap();
        assert_eq!(c.len(), 31);
        samples.extend(c.iter().map(|v| v.as_f64().unwrap()));
    }
    assert!(!palette.with_file_name("cc.basis.json").exists(), "--no-cache wrote a sidecar");

    // Recompute the check independently of the report, from the printed basis alone.
    let colorimetry = Colorimetry::default();
    let basis = Basis::from_matrix(DMatrix::from_column_slice(31, 7, &samples), &colorimetry).unwrap();
    let set = TrainingSet::colorchecker_seven_lights(&colorimetry);
    let mut errors = Vec::new();
    for e in &set.lights {
        let (ec, white) = (basis.coefficients(e), e);
        for s in &set.reflectances {
            let c = ec.component_mul(&basis.coefficients(s));
            let rgb = colorimetry.q_rgb * (&basis.b * c).fixed_rows::<31>(0).into_owned();
            errors.push(colorimetry.delta_e00_under(&colorimetry.rgb(e, s), &rgb, white));
        }
    }
    let stats = accuracy::ErrorStats::from_values(&errors);
    assert_eq!(stats.count, 168);
    assert!(stats.mean <= 1.0 && stats.p95 <= 2.5, "{stats:?}");
    // The report's own figures agree with it.
    let reported = &json["accuracy"]["factor_model"];
    assert!((reported["mean"].as_f64().unwrap() - stats.mean).abs() < 1e-9, "{reported}");
    assert!((reported["p95"].as_f64().unwrap() - stats.p95).abs() < 1e-9, "{reported}");
    let rgb = accuracy::stats(&set, Model::Rgb, &colorimetry);
    assert!((json["accuracy"]["rgb_factor_model"]["mean"].as_f64().unwrap() - rgb.mean).abs() < 1e-9);
}

#[test]
fn the_table_compares_models_and_the_sidecar_is_reused() {
    let dir = tempfile::tempdir().unwrap();
    let palette = dir.path().join("small.toml");
    std::fs::write(
        &palette,
        "name = \"small\"\n[settings]\nbasis_dimension = 5\n\
         [[lights]]\nname = \"day\"\nilluminant = \"D65\"\n\
         [[lights]]\nname = \"shop\"\nilluminant = \"F11\"\n\
         [[reflectances]]\nname = \"a\"\ncolorchecker = \"orange\"\n\
         [[reflectances]]\nname = \"b\"\ncolorchecker = \"cyan\"\n\
         [[reflectances]]\nname = \"c\"\nflat = 0.5\n",
    )
    .unwrap();
    let first = metamer(&["basis", palette.to_str().unwrap()]);
    let stdout = text(&first.stdout);
    assert!(first.status.success(), "{}", text(&first.stderr));
    for needle in [
        "m = 5",
        "6 light × reflectance pairs",
        "RGB factor model",
        "projected on PCA span",
        "unsharpened PCA basis",
        "Λ off-diagonal",
    ] {
        assert!(stdout.contains(needle), "missing {needle:?} in\n{stdout}");
    }
    // Six signals of rank ≤ 6 ≥ 5: no padding; but the sidecar was written and is used the second time.
    assert!(stdout.contains("stored in"), "{stdout}");
    let sidecar = dir.path().join("small.basis.json");
    assert!(sidecar.exists());
    let second = metamer(&["basis", palette.to_str().unwrap()]);
    assert!(text(&second.stdout).contains("loaded from"), "{}", text(&second.stdout));
    // More dimensions than signals: padded, and said so.
    let padded = metamer(&["basis", palette.to_str().unwrap(), "-m", "9", "--no-cache"]);
    assert!(padded.status.success(), "{}", text(&padded.stderr));
    assert!(text(&padded.stdout).contains("padded"), "{}", text(&padded.stdout));
}

#[test]
fn bad_input_is_one_readable_error() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.toml");
    let out = metamer(&["basis", missing.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("missing.toml"), "{}", text(&out.stderr));

    let binary = dir.path().join("binary.toml");
    std::fs::write(&binary, [0u8, 159, 146, 150]).unwrap();
    let out = metamer(&["basis", binary.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("binary.toml"), "{}", text(&out.stderr));

    let reference = reference_palette();
    for m in ["0", "32"] {
        let out = metamer(&["basis", reference.to_str().unwrap(), "--dimension", m, "--no-cache"]);
        assert!(!out.status.success());
        let err = text(&out.stderr);
        assert!(err.contains("--dimension") && err.contains(m), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn refining_b_never_makes_the_factor_model_worse_than_refining_t() {
    // The engine palette's designed lights have no power in whole bands, so many colours are near black and
    // Eq. 7 is far off in the PCA span: the full-Λ term must not be allowed to trade the factor model away.
    let palette = Path::new(env!("CARGO_MANIFEST_DIR")).join("volumes/engine_palette.toml");
    let out = metamer(&["basis", palette.to_str().unwrap(), "--json", "--no-cache"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let a = &json["accuracy"];
    let mean = |k: &str| a[k]["mean"].as_f64().unwrap();
    assert!(mean("factor_model") <= mean("factor_model_pca_span") + 0.05, "{a}");
    assert!(mean("factor_model") < 0.5 && mean("full_lambda_model") < 1.0, "{a}");
}
