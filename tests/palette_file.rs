//! Palette files: loading and validation (every bad input gives one error naming file, key and reason),
//! saving (comments, key order and unknown keys kept; atomic; a failed save never destroys the original).

use metamer::colorimetry::{Colorimetry, hex_to_linear};
use metamer::palette::file::{PaletteError, PaletteFile};
use metamer::palette::{Kind, Source, TargetNotation};
use metamer::spectrum::{Normalize, Spectrum};
use std::path::{Path, PathBuf};

const VALID: &str = r##"# A small palette used by the tests.
name = "test palette"

[settings]
basis_dimension = 5          # m
smoothness = 0.01
reflectance_bounds = [0.0, 1.0]
light_bounds = [0.0, inf]

[[lights]]
name = "daylight"
illuminant = "D65"
dial = [0.0, 1.0]

[[lights]]
name = "warm"
planck = 2700.0
normalize = "l2"
scale = 2.0
design = true
bounds = [0.0, 5.0]

[[reflectances]]
name = "block"
colorchecker = "dark_skin"
design = true

[[reflectances]]
name = "grey"
flat = 0.5

[[colours]]
light = "daylight"
reflectance = "block"
target = "#6a7b5c"
weight = 2.0

[[colours]]
light = "warm"
reflectance = "block"
target = [0.1, 0.2, 0.3]
free = "A"
use = false

[[free]]
name = "A"
lower = [0.0, 0.0, 0.0]
upper = [1.0, 1.0, 1.0]
"##;

fn path() -> PathBuf {
    PathBuf::from("/nonexistent/test.toml")
}

fn parse(text: &str) -> Result<PaletteFile, PaletteError> {
    PaletteFile::parse(text, &path())
}

/// Replace `from` (which must occur) in the valid palette.
fn mutate(from: &str, to: &str) -> String {
    assert!(VALID.contains(from), "test setup: `{from}` not in the valid palette");
    VALID.replacen(from, to, 1)
}

#[test]
fn valid_palette_resolves_every_field() {
    let file = parse(VALID).unwrap();
    let p = &file.palette;
    let c = Colorimetry::default();
    assert_eq!(p.name, "test palette");
    assert_eq!(p.settings.basis_dimension, 5);
    assert_eq!(p.settings.smoothness, 0.01);
    assert_eq!(p.settings.subspace_error, 0.0);
    assert_eq!(p.settings.light_bounds.upper, f64::INFINITY);
    assert_eq!(p.lights.len(), 2);
    // Luminance normalisation: Y of the light on flat white is 1 (to 1e-12).
    let y = c.xyz(&p.lights[0].spectrum, &Spectrum::flat(1.0))[1];
    assert!((y - 1.0).abs() < 1e-12, "Y = {y}");
    assert_eq!(p.lights[0].dial, Some([0.0, 1.0]));
    // L2 normalisation then scale 2: norm 2.
    assert!((p.lights[1].spectrum.l2_norm() - 2.0).abs() < 1e-12);
    assert_eq!(p.lights[1].normalize, Normalize::L2);
    assert!(p.lights[1].design);
    assert_eq!(p.lights[1].bounds.map(|b| b.upper), Some(5.0));
    assert_eq!(p.lights[1].source, Source::Planck(2700.0));
    // Reflectances are never normalised.
    assert_eq!(p.reflectances[0].spectrum, Spectrum::colorchecker("dark_skin").unwrap());
    assert_eq!(p.reflectances[1].spectrum, Spectrum::flat(0.5));
    assert_eq!(p.reflectances[0].kind, Kind::Reflectance);
    assert_eq!(p.colours.len(), 2);
    assert_eq!(p.colours[0].target, hex_to_linear("#6a7b5c").unwrap());
    assert_eq!(p.colours[0].notation, TargetNotation::Hex);
    assert_eq!(p.colours[0].weight, 2.0);
    assert!(p.colours[0].enabled);
    assert_eq!(p.colours[1].notation, TargetNotation::Linear);
    assert_eq!(p.colours[1].free, Some(0));
    assert!(!p.colours[1].enabled);
    assert_eq!((p.colours[1].light, p.colours[1].reflectance), (1, 0));
    assert!(file.warnings.is_empty(), "{:?}", file.warnings);
}

#[test]
fn defaults_apply_when_keys_are_absent() {
    let text = "[[lights]]\nname = \"e\"\nflat = 1.0\n[[reflectances]]\nname = \"r\"\nflat = 0.5\n";
    let p = parse(text).unwrap().palette;
    assert_eq!(p.name, "test", "the name defaults to the file stem");
    assert_eq!(p.settings, metamer::palette::Settings::default());
    assert_eq!(p.lights[0].normalize, Normalize::Luminance);
    assert_eq!(p.lights[0].scale, 1.0);
    assert!(!p.lights[0].design);
    assert!(p.lights[0].bounds.is_none());
}

#[test]
fn target_on_a_fixed_cell_is_not_an_error() {
    let text = mutate(
        "name = \"block\"\ncolorchecker = \"dark_skin\"\ndesign = true",
        "name = \"block\"\ncolorchecker = \"dark_skin\"",
    );
    let text = text.replace("design = true\nbounds", "bounds");
    let p = parse(&text).unwrap().palette;
    assert!(!p.lights[0].design && !p.reflectances[0].design);
    assert_eq!(p.colours.len(), 2);
}

#[test]
fn unknown_keys_are_kept_with_a_warning() {
    let text = mutate("weight = 2.0", "weight = 2.0\ncomment_for_me = \"hello\"");
    let file = parse(&text).unwrap();
    assert_eq!(file.warnings.len(), 1);
    assert!(file.warnings[0].contains("colours[0].comment_for_me"), "{:?}", file.warnings);
}

#[test]
fn the_standard_grid_may_be_declared() {
    let ok = format!("wavelengths = {{ start = 400.0, step = 10.0, count = 31 }}\n{VALID}");
    assert!(parse(&ok).is_ok());
    let bad = format!("wavelengths = {{ start = 380.0, step = 5.0, count = 81 }}\n{VALID}");
    expect_invalid(&bad, "wavelengths", "standard grid");
}

/// The error is `Invalid`, names the file, the key and a reason containing `reason`.
fn expect_invalid(text: &str, key: &str, reason: &str) {
    match parse(text) {
        Err(e @ PaletteError::Invalid { .. }) => {
            let msg = e.to_string();
            assert_eq!(e.key(), Some(key), "wrong key in: {msg}");
            assert!(msg.contains("/nonexistent/test.toml"), "no file in: {msg}");
            assert!(msg.contains(reason), "expected `{reason}` in: {msg}");
        }
        Err(e) => panic!("expected an Invalid error at {key}, got: {e}"),
        Ok(_) => panic!("expected an error at {key} ({reason}), but it parsed"),
    }
}

#[test]
fn bad_references_and_duplicates() {
    expect_invalid(&mutate("light = \"warm\"", "light = \"cold\""), "colours[1].light", "unknown light `cold`");
    expect_invalid(
        &mutate("reflectance = \"block\"\ntarget = \"#", "reflectance = \"blok\"\ntarget = \"#"),
        "colours[0].reflectance",
        "unknown reflectance `blok` (known: block, grey)",
    );
    expect_invalid(&mutate("free = \"A\"", "free = \"B\""), "colours[1].free", "unknown free group `B`");
    expect_invalid(&mutate("name = \"warm\"", "name = \"daylight\""), "lights[1].name", "duplicate light name");
    expect_invalid(&mutate("name = \"grey\"", "name = \"block\""), "reflectances[1].name", "duplicate reflectance");
    expect_invalid(&mutate("light = \"warm\"", "light = \"daylight\""), "colours[1]", "duplicate cell");
    let two_groups = format!("{VALID}\n[[free]]\nname = \"A\"\n");
    expect_invalid(&two_groups, "free[1].name", "duplicate free group");
    expect_invalid(&mutate("light = \"warm\"\n", ""), "colours[1].light", "missing");
    expect_invalid(&mutate("target = \"#6a7b5c\"\n", ""), "colours[0].target", "missing");
    expect_invalid(&mutate("name = \"grey\"\n", ""), "reflectances[1].name", "missing");
    expect_invalid(&mutate("name = \"grey\"", "name = \"  \""), "reflectances[1].name", "empty");
}

#[test]
fn bad_numbers() {
    expect_invalid(&mutate("flat = 0.5", "samples = [0.5, 0.5]"), "reflectances[1].samples", "expected 31 samples");
    expect_invalid(&mutate("flat = 0.5", "flat = nan"), "reflectances[1].flat", "NaN");
    expect_invalid(&mutate("flat = 0.5", "flat = inf"), "reflectances[1].flat", "finite");
    let mut samples = vec!["0.5"; 31];
    samples[7] = "-inf";
    expect_invalid(
        &mutate("flat = 0.5", &format!("samples = [{}]", samples.join(", "))),
        "reflectances[1].samples[7]",
        "finite",
    );
    expect_invalid(&mutate("weight = 2.0", "weight = -1.0"), "colours[0].weight", "negative");
    expect_invalid(&mutate("weight = 2.0", "weight = nan"), "colours[0].weight", "NaN");
    expect_invalid(&mutate("bounds = [0.0, 5.0]", "bounds = [5.0, 0.0]"), "lights[1].bounds", "inverted");
    expect_invalid(&mutate("bounds = [0.0, 5.0]", "bounds = [nan, 5.0]"), "lights[1].bounds[0]", "NaN");
    expect_invalid(&mutate("bounds = [0.0, 5.0]", "bounds = [1.0]"), "lights[1].bounds", "expected 2 numbers");
    expect_invalid(
        &mutate("reflectance_bounds = [0.0, 1.0]", "reflectance_bounds = [1.0, 0.0]"),
        "settings.reflectance_bounds",
        "inverted",
    );
    expect_invalid(&mutate("upper = [1.0, 1.0, 1.0]", "upper = [1.0, -1.0, 1.0]"), "free[0].lower", "inverted");
    expect_invalid(&mutate("scale = 2.0", "scale = inf"), "lights[1].scale", "finite");
    expect_invalid(&mutate("dial = [0.0, 1.0]", "dial = [0.0, nan]"), "lights[0].dial[1]", "NaN");
    expect_invalid(&mutate("smoothness = 0.01", "smoothness = -0.01"), "settings.smoothness", "negative");
    expect_invalid(
        &mutate("basis_dimension = 5", "basis_dimension = 0"),
        "settings.basis_dimension",
        "between 1 and 31",
    );
    expect_invalid(
        &mutate("basis_dimension = 5", "basis_dimension = 32"),
        "settings.basis_dimension",
        "between 1 and 31",
    );
    expect_invalid(&mutate("planck = 2700.0", "planck = 0.0"), "lights[1].planck", "above 0");
    expect_invalid(&mutate("planck = 2700.0", "planck = -5"), "lights[1].planck", "above 0");
    expect_invalid(&mutate("target = [0.1, 0.2, 0.3]", "target = [0.1, nan, 0.3]"), "colours[1].target[1]", "NaN");
    expect_invalid(&mutate("target = [0.1, 0.2, 0.3]", "target = [0.1, 0.2]"), "colours[1].target", "expected 3");
}

#[test]
fn bad_names_and_types() {
    expect_invalid(&mutate("#6a7b5c", "#6a7b5"), "colours[0].target", "bad hex colour `#6a7b5`");
    expect_invalid(&mutate("#6a7b5c", "6a7b5c"), "colours[0].target", "bad hex");
    expect_invalid(&mutate("#6a7b5c", "#6a7bzz"), "colours[0].target", "bad hex");
    expect_invalid(&mutate("illuminant = \"D65\"", "illuminant = \"D66\""), "lights[0].illuminant", "valid: D65");
    expect_invalid(
        &mutate("colorchecker = \"dark_skin\"", "colorchecker = \"darkskin\""),
        "reflectances[0].colorchecker",
        "dark_skin",
    );
    expect_invalid(
        &mutate("flat = 0.5", "flat = 0.5\ncolorchecker = \"red\""),
        "reflectances[1]",
        "more than one source",
    );
    expect_invalid(&mutate("flat = 0.5\n", ""), "reflectances[1]", "no source");
    expect_invalid(
        &mutate("normalize = \"l2\"", "normalize = \"max\""),
        "lights[1].normalize",
        "unknown normalisation",
    );
    expect_invalid(&mutate("flat = 0.5", "flat = 0.5\nnormalize = \"l2\""), "reflectances[1].normalize", "never");
    expect_invalid(
        &mutate("weight = 2.0", "weight = \"heavy\""),
        "colours[0].weight",
        "expected a number, found a string",
    );
    expect_invalid(&mutate("use = false", "use = 0"), "colours[1].use", "expected true or false");
    expect_invalid(&mutate("design = true\nbounds", "design = \"yes\"\nbounds"), "lights[1].design", "true or false");
    expect_invalid(&mutate("target = [0.1, 0.2, 0.3]", "target = 7"), "colours[1].target", "expected \"#rrggbb\"");
    expect_invalid(&mutate("name = \"test palette\"", "name = 3"), "name", "expected a string");
    expect_invalid(&mutate("[settings]", "settings = 3\n[unused]"), "settings", "expected a table");
    expect_invalid("lights = 3\n", "lights", "array of tables");
    expect_invalid("lights = [1, 2]\n", "lights[0]", "expected a table");
    expect_invalid(&mutate("basis_dimension = 5", "basis_dimension = 5.5"), "settings.basis_dimension", "integer");
}

#[test]
fn zero_lights_cannot_be_normalised() {
    expect_invalid(&mutate("illuminant = \"D65\"", "flat = 0.0"), "lights[0].normalize", "zero luminance");
    expect_invalid(&mutate("planck = 2700.0", "flat = 0.0"), "lights[1].normalize", "zero L2 norm");
    // Without normalisation a zero light is allowed (it is simply dark).
    assert!(parse(&mutate("illuminant = \"D65\"", "flat = 0.0\nnormalize = \"none\"")).is_ok());
}

#[test]
fn syntax_errors_name_line_and_column() {
    let text = mutate("weight = 2.0", "weight = = 2.0");
    let e = parse(&text).unwrap_err();
    let line = text.lines().position(|l| l.starts_with("weight = =")).unwrap() + 1;
    match &e {
        PaletteError::Syntax { line: l, column, .. } => {
            assert_eq!(*l, line, "{e}");
            assert!(*column > 1, "{e}");
        }
        other => panic!("expected a syntax error, got {other}"),
    }
    assert!(e.to_string().contains("test.toml"), "{e}");
    assert!(matches!(parse("[[lights]\nname = 1"), Err(PaletteError::Syntax { line: 1, .. })));
}

#[test]
fn empty_and_binary_files_are_rejected() {
    assert!(matches!(parse(""), Err(PaletteError::Empty { .. })));
    assert!(matches!(parse("  \n\t\n"), Err(PaletteError::Empty { .. })));
    assert!(matches!(parse("# only a comment\n"), Err(PaletteError::Empty { .. })));
    let e = PaletteFile::parse_bytes(&[0x89, b'P', b'N', b'G', 0, 0xff], &path()).unwrap_err();
    assert!(matches!(e, PaletteError::Binary { .. }), "{e}");
    assert!(e.to_string().contains("not a text file"));
    let e = PaletteFile::parse_bytes(b"name = \"x\"\0\0", &path()).unwrap_err();
    assert!(matches!(e, PaletteError::Binary { .. }), "{e}");
    let e = PaletteFile::load(Path::new("/nonexistent/missing.toml")).unwrap_err();
    assert!(matches!(e, PaletteError::Read { .. }), "{e}");
    assert!(e.to_string().contains("missing.toml"));
}
