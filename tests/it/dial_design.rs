//! Designing along the light dial (issue #28): targets under mixtures of lights (`[[mixtures]]`) and a
//! colour kept along a dial path (`[[paths]]`) — read, solved in the stacked system, checked against
//! independent formulations, reported, and refused with a named key when wrong (docs/formats/palette.md).

use crate::common::{kkt_residual, stack, stacked_solution};
use metamer::colorimetry::Colorimetry;
use metamer::design::NonlinearProblem;
use metamer::design::{self, Criterion, SolveOptions};
use metamer::design::{Design, Layout};
use metamer::palette::mixing::light_of;
use metamer::palette::{ColourCell, Kind, Palette, Source, SpectrumEntry, TargetNotation};
use metamer::palette::{PaletteError, PaletteFile};
use metamer::render::Scene;
use metamer::spectrum::{Normalize, Spectrum};
use nalgebra::Vector3;
use std::path::Path;

const LIGHTS: &str = r##"
[settings]
smoothness = 0.001
reflectance_bounds = [0.0, 1.0]

[[lights]]
name = "day"
illuminant = "D65"
dial = [0.0, 0.0]

[[lights]]
name = "warm"
illuminant = "A"
dial = [1.0, 0.0]

[[lights]]
name = "cool"
illuminant = "F11"
dial = [0.5, 0.87]

[[reflectances]]
name = "petal"
colorchecker = "moderate_red"
design = true

[[reflectances]]
name = "leaf"
colorchecker = "foliage"
design = true

[[reflectances]]
name = "stone"
colorchecker = "neutral_5"

[[colours]]
light = "day"
reflectance = "petal"
target = "#b84a50"
"##;

fn parse(text: &str) -> Result<PaletteFile, PaletteError> {
    PaletteFile::parse(text, Path::new("/nonexistent/mix.toml"))
}

fn palette(extra: &str) -> Palette {
    parse(&format!("{LIGHTS}{extra}")).unwrap_or_else(|e| panic!("{e}")).palette
}

fn col() -> Colorimetry {
    Colorimetry::default()
}

/// `p` with every mixture cell replaced by an ordinary cell under a new light whose samples are the
/// mixed spectrum, built here from the weights (normalize = none, scale 1).
fn as_ordinary_lights(p: &Palette) -> Palette {
    let mut q = p.clone();
    let spectra: Vec<Spectrum> = p.lights.iter().map(|e| e.spectrum).collect();
    for (k, m) in p.mixtures.iter().enumerate() {
        let mut e = Spectrum::flat(0.0);
        for &(i, w) in &m.mix {
            for j in 0..31 {
                e.0[j] += w * spectra[i].0[j];
            }
        }
        q.lights.push(SpectrumEntry {
            name: format!("mixed{k}"),
            kind: Kind::Light,
            source: Source::Samples(e.to_vec()),
            normalize: Normalize::None,
            scale: 1.0,
            design: false,
            bounds: None,
            dial: None,
            spectrum: e,
        });
        q.colours.push(ColourCell {
            light: q.lights.len() - 1,
            reflectance: m.reflectance,
            target: m.target,
            notation: TargetNotation::Linear,
            weight: m.weight,
            free: m.free,
            enabled: m.enabled,
        });
    }
    q.mixtures.clear();
    q
}

const MIXTURES: &str = r##"
[[mixtures]]
reflectance = "petal"
dial = [0.5, 0.1]
target = "#cc6040"

[[mixtures]]
reflectance = "petal"
dial = [0.3, 0.3]
off = ["cool"]
target = "#c25a48"
weight = 2.0

[[mixtures]]
reflectance = "leaf"
mix = { day = 0.3, cool = 0.7 }
free = "g"

[[colours]]
light = "warm"
reflectance = "leaf"
free = "g"

[[free]]
name = "g"
lower = [0.05, 0.1, 0.02]
upper = [0.2, 0.4, 0.2]
"##;

#[test]
fn a_mixture_cell_solves_exactly_as_its_mixed_light_given_as_an_ordinary_light() {
    let c = col();
    let p = palette(MIXTURES);
    assert_eq!(p.mixtures.len(), 3);
    let q = as_ordinary_lights(&p);
    let opts = SolveOptions::default();
    let a = design::solve(&p, None, &c, &opts).unwrap();
    let b = design::solve(&q, None, &c, &opts).unwrap();
    for (x, y) in a.palette.reflectances.iter().zip(&b.palette.reflectances) {
        let d = (x.spectrum.0 - y.spectrum.0).amax();
        assert!(d < 1e-9, "{}: mixture and explicit light differ by {d:e}", x.name);
    }
    assert!((a.objective - b.objective).abs() <= 1e-9 * (1.0 + b.objective), "{} vs {}", a.objective, b.objective);
    assert!((a.free[0] - b.free[0]).amax() < 1e-9);
    // The mixture cells report what the ordinary cells report.
    for (k, r) in a.mixtures.iter().enumerate() {
        let o = &b.cells[p.colours.len() + k];
        assert!((r.rgb_full - o.rgb_full).amax() < 1e-9, "mixture {k}");
        assert!((r.delta_e_full - o.delta_e_full).abs() < 1e-6, "mixture {k}");
        assert!((r.target - o.target).amax() < 1e-9);
    }
    // Independent optimality: the KKT residual of the mixture solution in the explicit palette's own
    // stacked system (assembled by the test helper, not the engine).
    let st = stack(&q, &c);
    let mut in_b = b.clone();
    for (e, s) in in_b.palette.reflectances.iter_mut().zip(&a.palette.reflectances) {
        e.spectrum = s.spectrum;
    }
    in_b.free = a.free.clone();
    let kkt = kkt_residual(&st, &stacked_solution(&st, &in_b));
    assert!(kkt < 1e-6, "KKT residual {kkt:e}");
}

#[test]
fn a_dial_mixture_is_the_light_the_renderers_dial_gives_at_that_point() {
    let p = palette(MIXTURES);
    let spectra: Vec<Spectrum> = p.lights.iter().map(|e| e.spectrum).collect();
    let scene = Scene::builtin(p.clone(), 16).unwrap();
    let mut state = scene.dial.base.clone();
    state.set_slider([0.5, 0.1]).unwrap();
    let dial = state.light();
    let mine = light_of(&p.mixtures[0].mix, &spectra);
    assert!((dial.0 - mine.0).amax() < 1e-12);
    // Switched off in the mixture = switched off on the dial.
    state.set_slider([0.3, 0.3]).unwrap();
    state.set_on(2, false).unwrap();
    assert!((state.light().0 - light_of(&p.mixtures[1].mix, &spectra).0).amax() < 1e-12);
    assert!(p.mixtures[1].mix.iter().all(|&(i, _)| i != 2));
    // Explicit weights are used as given.
    assert_eq!(p.mixtures[2].mix, vec![(0, 0.3), (2, 0.7)]);
}

/// A designed light in a mixture on a fixed reflectance: the residual `w₁ Q(E₁∘R) + w₂ Q(E₂∘R) − T` is the
/// ordinary cell `Q(E₁ ∘ w₁R) − (T − w₂ Q(E₂∘R))`.
#[test]
fn a_designed_light_in_a_mixture_equals_a_shifted_ordinary_cell() {
    let c = col();
    let text = r##"
[settings]
smoothness = 0.002
light_bounds = [0.0, inf]

[[lights]]
name = "made"
illuminant = "D65"
design = true
dial = [0.0, 0.0]

[[lights]]
name = "lamp"
illuminant = "A"
dial = [1.0, 0.0]

[[reflectances]]
name = "grey"
flat = 0.5

[[reflectances]]
name = "red"
colorchecker = "red"

[[colours]]
light = "made"
reflectance = "grey"
target = [0.4, 0.4, 0.4]

[[mixtures]]
reflectance = "red"
mix = { made = 0.6, lamp = 0.4 }
target = [0.3, 0.08, 0.04]
weight = 1.5
"##;
    let p = parse(text).unwrap().palette;
    let (w1, w2) = (0.6, 0.4);
    let red = p.reflectances[1].spectrum;
    let lamp = p.lights[1].spectrum;
    let mut q = p.clone();
    q.mixtures.clear();
    let mut scaled = red;
    scaled.0 *= w1;
    q.reflectances.push(SpectrumEntry {
        name: "w1 red".into(),
        source: Source::Samples(scaled.to_vec()),
        spectrum: scaled,
        ..p.reflectances[1].clone()
    });
    let shifted = Vector3::new(0.3, 0.08, 0.04) - c.rgb(&lamp, &red) * w2;
    q.colours.push(ColourCell {
        light: 0,
        reflectance: 2,
        target: shifted,
        notation: TargetNotation::Linear,
        weight: 1.5,
        free: None,
        enabled: true,
    });
    let opts = SolveOptions::default();
    let a = design::solve(&p, None, &c, &opts).unwrap();
    let b = design::solve(&q, None, &c, &opts).unwrap();
    let d = (a.palette.lights[0].spectrum.0 - b.palette.lights[0].spectrum.0).amax();
    assert!(d < 1e-9, "designed light differs by {d:e}");
    let st = stack(&q, &c);
    let mut in_b = b.clone();
    in_b.palette.lights[0].spectrum = a.palette.lights[0].spectrum;
    assert!(kkt_residual(&st, &stacked_solution(&st, &in_b)) < 1e-6);
}

/// Both a light of the mixture and the reflectance designed: the joint solver's bilinear terms. The
/// objective is checked against a direct evaluation and the gradient against finite differences.
#[test]
fn bilinear_mixture_rows_have_the_right_value_and_gradient_and_the_joint_solve_lowers_them() {
    let c = col();
    let text = format!(
        "{}\n{}",
        LIGHTS
            .replace("illuminant = \"A\"", "illuminant = \"A\"\ndesign = true")
            .replace("smoothness = 0.001", "smoothness = 0.0"),
        r##"
[[mixtures]]
reflectance = "leaf"
dial = [0.6, 0.2]
target = [0.1, 0.25, 0.05]

[[mixtures]]
reflectance = "petal"
mix = { warm = 0.5, cool = 0.5 }
target = [0.35, 0.1, 0.05]
"##
    );
    let p = parse(&text).unwrap().palette;
    let design = Design::new(&p, None, &c).unwrap();
    let v = design.start_values();
    // The objective by hand: Σ (ω/√3)² ‖Q(E_mix ∘ S) − T‖² over the cell and the mixtures.
    let mut f = 0.0;
    let d = |e: &Spectrum, s: &Spectrum, t: &Vector3<f64>, w: f64| (c.rgb(e, s) - t).norm_squared() * w * w / 3.0;
    let cell = &p.colours[0];
    f += d(&v.lights[cell.light], &v.reflectances[cell.reflectance], &cell.target, cell.weight);
    for m in &p.mixtures {
        f += d(&light_of(&m.mix, &v.lights), &v.reflectances[m.reflectance], &m.target, m.weight);
    }
    assert!((design.objective(&v) - f).abs() <= 1e-12 * (1.0 + f), "{} vs {f}", design.objective(&v));
    let units = design.units();
    let layout = Layout::new(&units);
    let terms: Vec<usize> = (0..design.terms.len()).collect();
    let prob = NonlinearProblem { design: &design, layout: &layout, terms: &terms, base: &v };
    let x = layout.gather(&v);
    let g = prob.grad(&x);
    let mut worst: f64 = 0.0;
    for i in 0..x.len() {
        let h = 1e-6 * (1.0 + x[i].abs());
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[i] += h;
        xm[i] -= h;
        let fd = (prob.value(&xp) - prob.value(&xm)) / (2.0 * h);
        worst = worst.max((fd - g[i]).abs() / (1.0 + g[i].abs()));
    }
    assert!(worst < 1e-6, "gradient mismatch {worst:e}");
    let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap();
    assert!(sol.objective < 1e-2 * f, "joint solve: {} from {f}", sol.objective);
    assert!(sol.mixtures.iter().all(|r| r.delta_e_full < 1.0), "{:?}", sol.mixtures);
}

/// Three lights; the path runs from `day` to `warm`, so `cool` keeps a small Shepard weight between them.
/// "petal" must look different under `cool` alone: two samples (the ends) cannot see that, the dense
/// check must; enough samples keep the path within tolerance.
fn path_palette(samples: usize) -> Palette {
    // Unbounded reflectances: the colour equations alone decide what is reachable.
    let lights = LIGHTS.replace("reflectance_bounds = [0.0, 1.0]", "");
    let criteria = format!(
        r##"
[[colours]]
light = "cool"
reflectance = "petal"
target = "#a06070"
weight = 0.01

[[paths]]
reflectance = "petal"
through = ["day", "warm"]
target = "#b84a50"
samples = {samples}
tolerance = 1.0
"##
    );
    parse(&format!("{lights}{criteria}")).unwrap().palette
}

#[test]
fn too_few_path_samples_are_caught_by_the_dense_check_and_enough_keep_the_path() {
    let c = col();
    let few = design::solve(&path_palette(2), None, &c, &SolveOptions::default()).unwrap();
    let r = &few.paths[0];
    assert_eq!((r.samples, r.checked), (2, 17));
    assert!(r.worst_at_samples < 1.0, "the ends are met: {r:?} {:?}", few.cells);
    assert!(r.is_unmet() && r.worst_delta_e > 1.0, "between the ends it strays: {r:?}");
    let d = few.diagnostics.iter().find(|d| d.criterion == Some(Criterion::Path(0))).expect("a path diagnostic");
    assert!(d.is_unmet() && d.message.contains("raise `samples`"), "{}", d.message);

    let many = design::solve(&path_palette(17), None, &c, &SolveOptions::default()).unwrap();
    let r = &many.paths[0];
    assert!(!r.is_unmet() && r.worst_delta_e <= 1.0, "{r:?}");
    // The dense check, redone here through the renderer's dial over the solved spectra.
    let scene = Scene::builtin(many.palette.clone(), 16).unwrap();
    let base = scene.dial.base.clone();
    let (day, warm) = (base.lights[0].position, base.lights[1].position);
    let petal = many.palette.reflectances[0].spectrum;
    let target = many.palette.paths[0].target;
    let mut worst: f64 = 0.0;
    for k in 0..=200 {
        let t = k as f64 / 200.0;
        let mut s = base.clone();
        s.set_slider([day[0] + (warm[0] - day[0]) * t, day[1] + (warm[1] - day[1]) * t]).unwrap();
        let e = s.light();
        worst = worst.max(c.delta_e00_under(&target, &c.rgb(&e, &petal), &e));
    }
    assert!(worst <= 1.0 + 1e-6, "independent dense check: {worst}");
    assert!((worst - r.worst_delta_e).abs() < 0.1, "reported {} vs {worst}", r.worst_delta_e);
}

#[test]
fn an_unreachable_mixture_is_explained_like_an_unmet_cell() {
    let c = col();
    let p = palette("[[mixtures]]\nreflectance = \"leaf\"\ndial = [0.5, 0.0]\ntarget = [0.9, 0.02, 0.9]\n");
    let sol = design::solve(&p, None, &c, &SolveOptions::default()).unwrap();
    let d = sol.diagnostics.iter().find(|d| d.criterion == Some(Criterion::Mixture(0))).expect("a diagnostic");
    assert!(d.is_unmet(), "{d:?}");
    assert!(d.message.contains("leaf × dial(0.5, 0)"), "{}", d.message);
    assert!(d.message.contains("closest reachable colour"), "{}", d.message);
}

/// The error names the file, the key, and the reason.
fn expect_error(extra: &str, key: &str, reason: &str) {
    match parse(&format!("{LIGHTS}{extra}")) {
        Err(e) => {
            let msg = e.to_string();
            assert_eq!(e.key(), Some(key), "wrong key in: {msg}");
            assert!(msg.contains("/nonexistent/mix.toml"), "no file in: {msg}");
            assert!(msg.contains(reason), "expected `{reason}` in: {msg}");
        }
        Ok(_) => panic!("expected an error at {key} ({reason}), but it parsed:\n{extra}"),
    }
}

#[test]
fn bad_mixtures_and_paths_are_refused_with_file_key_and_reason() {
    let m = |body: &str| format!("[[mixtures]]\nreflectance = \"petal\"\ntarget = \"#808080\"\n{body}\n");
    expect_error(&m("mix = { day = 0.5, sun = 0.5 }"), "mixtures[0].mix.sun", "unknown light `sun`");
    expect_error(&m("mix = { day = -0.5, warm = 1.0 }"), "mixtures[0].mix.day", "must not be negative");
    expect_error(&m("mix = { day = 0.0, warm = 0.0 }"), "mixtures[0].mix", "sum to 0");
    expect_error(&m("mix = { day = 1.0 }\ndial = [0.0, 0.0]"), "mixtures[0]", "not both");
    expect_error(&m(""), "mixtures[0]", "missing");
    expect_error(&m("mix = { day = 1.0 }\noff = [\"warm\"]"), "mixtures[0].off", "goes with `dial");
    expect_error(&m("dial = [0.2, 0.2]\noff = [\"day\", \"nope\"]"), "mixtures[0].off[1]", "unknown light `nope`");
    expect_error(&m("dial = [0.2, 0.2]\noff = [\"day\", \"warm\", \"cool\"]"), "mixtures[0].off", "every light off");
    expect_error(&m("dial = [0.2]"), "mixtures[0].dial", "expected 2 numbers");
    expect_error(&m("dial = [1e9, 0.0]"), "mixtures[0].dial", "outside the dial");
    expect_error(
        "[[mixtures]]\nreflectance = \"stem\"\ndial = [0.0, 0.0]\ntarget = \"#808080\"\n",
        "mixtures[0].reflectance",
        "unknown reflectance",
    );
    expect_error(&m("dial = [0.2, 0.2]\nfree = \"nope\""), "mixtures[0].free", "unknown free group");
    // A dial position needs lights placed on the dial.
    let unplaced = format!(
        "{}[[mixtures]]\nreflectance = \"petal\"\ndial = [0.2, 0.2]\ntarget = \"#808080\"\n",
        LIGHTS.replace("dial = [", "# dial = [")
    );
    match parse(&unplaced) {
        Err(e) => {
            assert_eq!(e.key(), Some("mixtures[0].dial"));
            assert!(e.to_string().contains("no light of the palette has `dial"), "{e}");
        }
        Ok(_) => panic!("a dial position without placed lights parsed"),
    }
    let q = |body: &str| format!("[[paths]]\nreflectance = \"petal\"\ntarget = \"#808080\"\n{body}\n");
    expect_error(&q("through = [\"day\"]"), "paths[0].through", "at least 2 positions");
    expect_error(&q("through = [\"day\", \"sun\"]"), "paths[0].through[1]", "unknown light `sun`");
    expect_error(&q("through = [\"day\", [0.5]]"), "paths[0].through[1]", "expected 2 numbers");
    expect_error(&q("lights = [\"day\", \"warm\"]\nthrough = [\"day\", \"warm\"]"), "paths[0]", "not both");
    expect_error(&q("lights = [\"day\", \"warm\"]\noff = [\"cool\"]"), "paths[0].off", "goes with `through`");
    expect_error(&q("lights = [\"day\", \"warm\"]\nsamples = 1"), "paths[0].samples", "give 2 to 1024");
    expect_error(&q("lights = [\"day\", \"warm\"]\ntolerance = 0"), "paths[0].tolerance", "> 0");
    expect_error(&q(""), "paths[0]", "missing");
}

#[test]
fn the_shipped_example_palette_reads_and_solves_every_criterion() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/dial_mixtures.toml");
    let file = PaletteFile::load(&path).unwrap();
    assert!(file.warnings.is_empty(), "{:?}", file.warnings);
    let p = &file.palette;
    assert!(!p.mixtures.is_empty() && !p.paths.is_empty());
    let sol = design::solve(p, None, &col(), &SolveOptions::default()).unwrap();
    let unmet: Vec<&str> = sol.diagnostics.iter().filter(|d| d.is_unmet()).map(|d| d.message.as_str()).collect();
    assert!(unmet.is_empty(), "the example's criteria are all met: {unmet:#?}");
}

fn example_path() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("palettes/dial_mixtures.toml")
}

#[test]
fn solve_shows_mixture_cells_and_paths_in_the_table_and_the_report() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let report = dir.path().join("report.json");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["solve", "--no-subspace"])
        .arg(example_path())
        .arg("--report")
        .arg(&report)
        .output()
        .expect("metamer runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{}", String::from_utf8_lossy(&out.stderr));
    // Rows like the cells': the mixture's name in the light column, then target, full colour, ΔE00.
    let row = text.lines().find(|l| l.starts_with("mix(daylight 0.5, lamp 0.5) petal")).expect("the mix row");
    assert!(row.contains("#c25541"), "{row}");
    assert!(text.lines().any(|l| l.starts_with("dial(0.45, 0.6) petal")), "{text}");
    let path =
        text.lines().find(|l| l.starts_with("path leaf along dial path(daylight → reveal, off lamp)")).expect("path");
    assert!(path.contains("over 129 positions (9 design samples"), "{path}");
    assert!(text.contains("2 mixtures (0 with remarks), 1 paths (0 with remarks)"), "{text}");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("json");
    let mixtures = json["mixtures"].as_array().expect("mixtures");
    assert_eq!(mixtures.len(), 2);
    assert_eq!(mixtures[0]["name"], "petal × mix(daylight 0.5, lamp 0.5)");
    assert_eq!(mixtures[0]["mix"]["lamp"], 0.5);
    assert_eq!(mixtures[1]["dial"], serde_json::json!([0.45, 0.6]));
    for m in mixtures {
        assert!(m["delta_e_full"].as_f64().expect("ΔE00") < 1.0, "{m}");
        assert_eq!(m["rgb_full"].as_array().map(Vec::len), Some(3));
    }
    let paths = json["paths"].as_array().expect("paths");
    assert_eq!(paths[0]["checked"], 129);
    assert_eq!(paths[0]["met"], true);
    assert!(paths[0]["worst_delta_e"].as_f64().expect("worst") <= 1.0);
}

/// `metamer design` opens a palette with mixtures and paths (it refused them before the designer showed
/// them) and `M` lists them; a reload that finds such tables added on disk reads them.
#[test]
fn the_designer_opens_palettes_with_dial_criteria() {
    use metamer::tui::event_loop::{FileSaver, Saver};
    let dir = tempfile::tempdir().expect("temporary folder");
    let palette = dir.path().join("dial_mixtures.toml");
    std::fs::copy(example_path(), &palette).expect("copy");
    let keys = dir.path().join("keys.txt");
    std::fs::write(&keys, "M\n").expect("write keys");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_metamer"))
        .args(["design", "--no-basis", "--size", "80x24", "--replay"])
        .arg(&keys)
        .arg(&palette)
        .output()
        .expect("metamer runs");
    let screen = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for entry in ["petal × mix {daylight 0.5, lamp 0.5}", "petal × dial [0.45, 0.6]", "leaf along daylight → reveal"]
    {
        assert!(screen.contains(entry), "{entry}:\n{screen}");
    }
    let file = dir.path().join("p.toml");
    std::fs::write(&file, LIGHTS).expect("write");
    let opened = PaletteFile::load(&file).expect("plain palette");
    std::fs::write(&file, format!("{LIGHTS}{MIXTURES}")).expect("write");
    let reloaded = FileSaver.reload(&opened).expect("the reload reads the new tables");
    assert_eq!(reloaded.palette.mixtures.len(), 3);
}
