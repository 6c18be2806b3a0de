//! End to end against the pinned contract, the way an outside check sees the product: random convex
//! palettes are written as TOML, solved by the `metamer` binary (`solve --report`), and the report is
//! checked against DESIGN_SPEC §2 assembled here from scratch — colour matching functions, the sRGB matrix,
//! the illuminant tables and light normalisation read from `data/spectra` (not through the library), the
//! subspace criteria (`fit_in_subspace`, `subspace_error`, Eq. 7's Λ) from the basis that
//! `metamer basis --json` prints. Checked per palette:
//! - the fixed lights in the report are the file's lights after normalisation and scale (1e-12 relative);
//! - the reported `objective` is the sum of squares at the reported spectra (1e-9 relative);
//! - every bound holds to 1e-9;
//! - the objective is within 1e-6 relative of the optimum found by clarabel on this assembly.

use crate::common;

use common::{Stacked, oracle_point};
use nalgebra::{DMatrix, DVector, SMatrix};
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

const N: usize = 31;
const OPTIMUM_TOL: f64 = 1e-6;

struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64)
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uniform()
    }
    fn index(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n - 1)
    }
    fn chance(&mut self, p: f64) -> bool {
        self.uniform() < p
    }
}

/// A CSV table from `data/spectra`: header names and 31 rows of values (400..=700 nm).
fn table(name: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/spectra").join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let header: Vec<String> = lines.next().unwrap().split(',').map(|s| s.trim().to_string()).collect();
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|v| v.trim().parse::<f64>().unwrap()).collect()).collect();
    let rows: Vec<Vec<f64>> =
        rows.into_iter().filter(|r| r[0] >= 400.0 && r[0] <= 700.0 && r[0] % 10.0 == 0.0).collect();
    assert_eq!(rows.len(), N, "{name}");
    (header, rows)
}

/// The colorimetry of DESIGN_SPEC §1, from the data files alone.
struct Spec {
    q_xyz: SMatrix<f64, 3, N>,
    q_rgb: SMatrix<f64, 3, N>,
    illuminants: (Vec<String>, Vec<Vec<f64>>),
    patches: (Vec<String>, Vec<Vec<f64>>),
}

impl Spec {
    fn load() -> Spec {
        let (_, cmf) = table("cie1931_2deg_10nm.csv");
        let ysum: f64 = cmf.iter().map(|r| r[2]).sum();
        let q_xyz = SMatrix::<f64, 3, N>::from_fn(|c, k| cmf[k][c + 1] / ysum);
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/spectra/srgb_xyz_to_linear_rgb.txt");
        let text = std::fs::read_to_string(path).unwrap();
        let m: Vec<f64> = text
            .lines()
            .filter(|l| !l.starts_with('#'))
            .flat_map(|l| l.split_whitespace().map(|v| v.parse::<f64>().unwrap()).collect::<Vec<_>>())
            .collect();
        let m = nalgebra::Matrix3::from_row_slice(&m[..9]);
        Spec {
            q_xyz,
            q_rgb: m * q_xyz,
            illuminants: table("illuminants_10nm.csv"),
            patches: table("colorchecker24_10nm.csv"),
        }
    }

    fn column(t: &(Vec<String>, Vec<Vec<f64>>), name: &str) -> DVector<f64> {
        let c = t.0.iter().position(|h| h == name).unwrap();
        DVector::from_fn(N, |k, _| t.1[k][c])
    }
}

fn srgb_decode(v: f64) -> f64 {
    if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
}

struct Entry {
    name: String,
    design: bool,
    /// The spectrum the file describes (after a light's normalisation and scale).
    spectrum: DVector<f64>,
    bounds: (f64, f64),
}

struct Cell {
    light: usize,
    reflectance: usize,
    target: [f64; 3],
    weight: f64,
    free: bool,
    enabled: bool,
}

struct Generated {
    toml: String,
    smoothness: f64,
    subspace_error: f64,
    fit_in_subspace: bool,
    dimension: usize,
    lights: Vec<Entry>,
    reflectances: Vec<Entry>,
    cells: Vec<Cell>,
    free: Option<([f64; 3], [f64; 3])>,
}

fn num(v: f64) -> String {
    if v.is_infinite() { "inf".into() } else { format!("{v:?}") }
}

fn generate(seed: u64, spec: &Spec) -> Generated {
    let mut rng = Lcg(seed.wrapping_mul(0x9E3779B97F4A7C15) ^ 0x5151);
    let mut t = format!("name = \"spec check {seed}\"\n\n[settings]\n");
    let dimension = 5 + rng.index(3);
    let smoothness = [0.0, 0.001, 0.01, 0.1][rng.index(4)];
    let subspace_error = [0.0, 0.0, 0.3, 1.0][rng.index(4)];
    let fit_in_subspace = rng.chance(0.4);
    let refl_bounds = [(0.0, 1.0), (0.0, f64::INFINITY), (f64::NEG_INFINITY, f64::INFINITY)][rng.index(3)];
    let light_bounds = [(0.0, f64::INFINITY), (0.0, 3.0)][rng.index(2)];
    writeln!(t, "basis_dimension = {dimension}\nsmoothness = {smoothness:?}\nsubspace_error = {subspace_error:?}")
        .unwrap();
    writeln!(t, "fit_in_subspace = {fit_in_subspace}").unwrap();
    if refl_bounds.0.is_finite() {
        writeln!(t, "reflectance_bounds = [{}, {}]", num(refl_bounds.0), num(refl_bounds.1)).unwrap();
    }
    writeln!(t, "light_bounds = [{}, {}]", num(light_bounds.0), num(light_bounds.1)).unwrap();

    let mut lights = Vec::new();
    let nl = 2 + rng.index(2);
    let names = ["D65", "A", "F11", "D50", "F2", "LED_B3"];
    for k in 0..nl {
        let ill = names[rng.index(names.len())];
        let raw = Spec::column(&spec.illuminants, ill);
        let normalize = ["luminance", "l2", "none"][rng.index(3)];
        let scale = rng.range(0.5, 2.0);
        let design = k == 0 && rng.chance(0.5);
        let norm = match normalize {
            "luminance" => (spec.q_xyz.row(1) * &raw)[0],
            "l2" => raw.norm(),
            _ => 1.0,
        };
        let spectrum = &raw / norm * scale;
        writeln!(t, "\n[[lights]]\nname = \"L{k}\"\nilluminant = \"{ill}\"\nnormalize = \"{normalize}\"").unwrap();
        writeln!(t, "scale = {scale:?}\ndesign = {design}").unwrap();
        lights.push(Entry { name: format!("L{k}"), design, spectrum, bounds: light_bounds });
    }
    let mut reflectances = Vec::new();
    let nr = 2 + rng.index(3);
    for k in 0..nr {
        let design = rng.chance(0.6);
        writeln!(t, "\n[[reflectances]]\nname = \"R{k}\"\ndesign = {design}").unwrap();
        let spectrum = if rng.chance(0.7) {
            let name = spec.patches.0[1 + rng.index(spec.patches.0.len() - 1)].clone();
            writeln!(t, "colorchecker = \"{name}\"").unwrap();
            Spec::column(&spec.patches, &name)
        } else {
            let v = rng.range(0.1, 0.9);
            writeln!(t, "flat = {v:?}").unwrap();
            DVector::from_element(N, v)
        };
        let mut bounds = refl_bounds;
        if design && rng.chance(0.25) {
            bounds = (rng.range(0.0, 0.1), rng.range(0.6, 1.0));
            writeln!(t, "bounds = [{:?}, {:?}]", bounds.0, bounds.1).unwrap();
        }
        reflectances.push(Entry { name: format!("R{k}"), design, spectrum, bounds });
    }
    let free = rng.chance(0.5).then(|| {
        let lo = [rng.range(0.0, 0.2), rng.range(0.0, 0.2), rng.range(0.0, 0.2)];
        let hi = [rng.range(0.3, 0.9), rng.range(0.3, 0.9), rng.range(0.3, 0.9)];
        (lo, hi)
    });
    let mut cells = Vec::new();
    for (l, light) in lights.iter().enumerate() {
        for (r, reflectance) in reflectances.iter().enumerate() {
            if (light.design && reflectance.design) || !rng.chance(0.8) {
                continue;
            }
            let mut target = [rng.uniform(), rng.uniform(), rng.uniform()];
            let weight = match rng.index(4) {
                0 => 1.0,
                1 => 0.0,
                _ => 10f64.powf(rng.range(-1.0, 1.0)),
            };
            let is_free = free.is_some() && rng.chance(0.25);
            let enabled = rng.chance(0.9);
            writeln!(t, "\n[[colours]]\nlight = \"L{l}\"\nreflectance = \"R{r}\"\nweight = {weight:?}").unwrap();
            if rng.chance(0.3) {
                let bytes: Vec<u8> = target.iter().map(|v| (v * 255.0).round() as u8).collect();
                writeln!(t, "target = \"#{:02x}{:02x}{:02x}\"", bytes[0], bytes[1], bytes[2]).unwrap();
                target = [0, 1, 2].map(|i| srgb_decode(f64::from(bytes[i]) / 255.0));
            } else {
                writeln!(t, "target = [{:?}, {:?}, {:?}]", target[0], target[1], target[2]).unwrap();
            }
            if is_free {
                writeln!(t, "free = \"G\"").unwrap();
            }
            if !enabled {
                writeln!(t, "use = false").unwrap();
            }
            cells.push(Cell { light: l, reflectance: r, target, weight, free: is_free, enabled });
        }
    }
    if let Some((lo, hi)) = free {
        writeln!(t, "\n[[free]]\nname = \"G\"\nlower = {lo:?}\nupper = {hi:?}").unwrap();
    }
    Generated { toml: t, smoothness, subspace_error, fit_in_subspace, dimension, lights, reflectances, cells, free }
}

fn metamer(args: &[&str]) -> Value {
    let out = Command::new(env!("CARGO_BIN_EXE_metamer")).args(args).output().unwrap();
    assert!(out.status.success(), "metamer {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap_or(Value::Null)
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

/// `Q_rgb,m · Λ(Q_m,31 p) · Q_m,31` (3×31) for the basis B (31×m), Eq. 7: `Λ_ij(x) = Σ_k B⁺_i (B_j ∗ B_k) x_k`.
/// Since `Λ(x) y = B⁺((Bx) ∗ (By))`, the map is `Q_rgb,31 P diag(P p) P` with `P = B B⁺` the projector onto
/// span B; that form is evaluated (P from an orthonormal basis of the span, so the columns' scaling
/// cannot cost digits), and Eq. 7 taken literally is checked against it.
fn subspace_operator(spec: &Spec, b: &DMatrix<f64>, bplus: &DMatrix<f64>, p: &DVector<f64>) -> DMatrix<f64> {
    let q_rgb = DMatrix::from_fn(3, N, |r, c| spec.q_rgb[(r, c)]);
    let u = b.clone().qr().q();
    let proj = &u * u.transpose();
    let pp = &proj * p;
    let op = &q_rgb * &proj * DMatrix::from_diagonal(&pp) * &proj;
    // Eq. 7 taken literally cancels like cond(B)³ (trained bases can reach cond 1e5 and lose every digit
    // that way), so the literal cross-check runs on well-conditioned bases only.
    let sv = b.clone().singular_values();
    if sv.max() < 1e3 * sv.min() {
        let m = b.ncols();
        let x = bplus * p;
        let lambda = DMatrix::from_fn(m, m, |i, j| {
            (0..m).map(|k| (0..N).map(|l| bplus[(i, l)] * b[(l, j)] * b[(l, k)]).sum::<f64>() * x[k]).sum::<f64>()
        });
        let literal = &q_rgb * b * lambda * bplus;
        let gap = (&literal - &op).amax() / op.amax().max(1e-300);
        assert!(gap < 1e-6, "Eq. 7 literally and through the projector differ by {gap:.1e}; σ(B) = {sv}");
    }
    op
}

/// The pinned objective as one stacked system over [designed lights, designed reflectances, free group].
fn assemble(g: &Generated, spec: &Spec, basis: Option<&DMatrix<f64>>, fixed: &[DVector<f64>]) -> Stacked {
    let mut n = 0;
    let (mut lower, mut upper) = (Vec::new(), Vec::new());
    let mut offsets = |entries: &[Entry]| -> Vec<Option<usize>> {
        entries
            .iter()
            .map(|e| {
                e.design.then(|| {
                    lower.extend(std::iter::repeat_n(e.bounds.0, N));
                    upper.extend(std::iter::repeat_n(e.bounds.1, N));
                    n += N;
                    n - N
                })
            })
            .collect()
    };
    let light_off = offsets(&g.lights);
    let refl_off = offsets(&g.reflectances);
    let free_off: Vec<usize> = g
        .free
        .iter()
        .map(|(lo, hi)| {
            lower.extend(lo);
            upper.extend(hi);
            n += 3;
            n - 3
        })
        .collect();
    let bplus = basis.map(|b| b.clone().pseudo_inverse(1e-13).unwrap());
    let q_rgb = DMatrix::from_fn(3, N, |r, c| spec.q_rgb[(r, c)]);
    let mut rows: Vec<(Vec<f64>, f64)> = Vec::new();
    let nl = g.lights.len();
    for c in g.cells.iter().filter(|c| c.enabled && c.weight != 0.0) {
        let w = c.weight / 3f64.sqrt();
        // The designed side (if any) is the unknown x; the partner p is fixed.
        let (unknown, partner, other) = match (light_off[c.light], refl_off[c.reflectance]) {
            (Some(o), None) => (Some(o), &fixed[nl + c.reflectance], &fixed[c.light]),
            (None, Some(o)) => (Some(o), &fixed[c.light], &fixed[nl + c.reflectance]),
            // Nothing designed and no free colour: the table of §2 has no row for it.
            (None, None) if !c.free => continue,
            (None, None) => (None, &fixed[c.light], &fixed[nl + c.reflectance]),
            (Some(_), Some(_)) => unreachable!("generated palettes are convex"),
        };
        let full = DMatrix::from_fn(3, N, |r, k| q_rgb[(r, k)] * partner[k]);
        let sub = match (&bplus, basis) {
            (Some(bp), Some(b)) => Some(subspace_operator(spec, b, bp, partner)),
            _ => None,
        };
        let colour_op = if g.fit_in_subspace { sub.clone().unwrap() } else { full.clone() };
        for ch in 0..3 {
            let mut row = vec![0.0; n];
            let mut rhs = 0.0;
            match unknown {
                Some(o) => (0..N).for_each(|k| row[o + k] = w * colour_op[(ch, k)]),
                None => rhs -= w * (0..N).map(|k| colour_op[(ch, k)] * other[k]).sum::<f64>(),
            }
            if c.free {
                row[free_off[0] + ch] = -w;
            } else {
                rhs += w * c.target[ch];
            }
            rows.push((row, rhs));
        }
        // F(p)·x needs a designed x: a fixed cell that only feeds a free colour has no such row.
        if let (Some(o), Some(sub), true) = (unknown, sub, g.subspace_error > 0.0) {
            let f = &full - sub;
            let wf = g.subspace_error * w;
            for ch in 0..3 {
                let mut row = vec![0.0; n];
                (0..N).for_each(|k| row[o + k] = wf * f[(ch, k)]);
                rows.push((row, 0.0));
            }
        }
    }
    let wd = g.smoothness / (31f64.sqrt() * 6f64.sqrt());
    if wd > 0.0 {
        for o in light_off.iter().chain(&refl_off).flatten() {
            for i in 0..N {
                let mut row = vec![0.0; n];
                row[o + i] = 2.0 * wd;
                if i > 0 {
                    row[o + i - 1] = -wd;
                }
                if i + 1 < N {
                    row[o + i + 1] = -wd;
                }
                rows.push((row, 0.0));
            }
        }
    }
    let a = DMatrix::from_fn(rows.len(), n, |r, c| rows[r].0[c]);
    let b = DVector::from_fn(rows.len(), |r, _| rows[r].1);
    Stacked { a, b, lower, upper, light_off, refl_off, free_off }
}

fn scratch(seed: u64) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("metamer-spec-objective-{}-{seed}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn check(seed: u64, spec: &Spec) {
    let g = generate(seed, spec);
    let dir = scratch(seed);
    let palette = dir.join("p.toml");
    std::fs::write(&palette, &g.toml).unwrap();
    let p = palette.to_str().unwrap();
    let basis = (g.fit_in_subspace || g.subspace_error > 0.0).then(|| {
        let j = metamer(&["basis", p, "--json"]);
        assert_eq!(j["dimension"].as_u64(), Some(g.dimension as u64), "seed {seed}");
        let cols: Vec<Vec<f64>> = j["basis"].as_array().unwrap().iter().map(numbers).collect();
        DMatrix::from_fn(N, cols.len(), |r, c| cols[c][r])
    });
    let report_path = dir.join("r.json");
    metamer(&["solve", p, "--report", report_path.to_str().unwrap(), "--quiet"]);
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&report_path).unwrap()).unwrap();
    let spectra = report["spectra"].as_array().unwrap();
    let entries: Vec<&Entry> = g.lights.iter().chain(&g.reflectances).collect();
    assert_eq!(spectra.len(), entries.len(), "seed {seed}");
    // The spectra as the solve used them; fixed ones must be the file's, normalised as §1 says.
    let mut solved = Vec::new();
    for (e, s) in entries.iter().zip(spectra) {
        assert_eq!(s["name"].as_str(), Some(e.name.as_str()), "seed {seed}");
        assert_eq!(s["design"].as_bool(), Some(e.design), "seed {seed} {}", e.name);
        let v = DVector::from_vec(numbers(&s["samples"]));
        if !e.design {
            let gap = (&v - &e.spectrum).amax() / e.spectrum.amax().max(1e-300);
            assert!(gap < 1e-12, "seed {seed}: fixed {} differs from the file's spectrum by {gap:.2e}", e.name);
        }
        solved.push(v);
    }
    let st = assemble(&g, spec, basis.as_ref(), &solved);
    let mut x = DVector::zeros(st.a.ncols());
    for (k, o) in st.light_off.iter().chain(&st.refl_off).enumerate() {
        if let Some(o) = o {
            x.rows_mut(*o, N).copy_from(&solved[k]);
        }
    }
    if let Some(o) = st.free_off.first() {
        let rgb = numbers(&report["free"][0]["rgb"]);
        x.rows_mut(*o, 3).copy_from_slice(&rgb);
    }
    let ours = common::objective(&st, &x);
    let reported = report["objective"].as_f64().unwrap();
    assert!(
        (reported - ours).abs() <= 1e-9 * ours.abs().max(1e-12),
        "seed {seed}: reported objective {reported:.12e}, sum of squares at the reported spectra {ours:.12e}\n{}",
        g.toml
    );
    // An unmet cell's "closest reachable colour" is never farther (ΔE00) than what the solve achieved.
    for d in report["diagnostics"].as_array().into_iter().flatten() {
        let (Some(msg), Some(cell)) = (d["message"].as_str(), d["cell"].as_object()) else { continue };
        let Some(tail) = msg.split("closest reachable colour is ").nth(1) else { continue };
        let closest: f64 = tail.rsplit("ΔE00 ").next().unwrap().trim_end_matches(')').parse().unwrap();
        let achieved = report["cells"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["light"] == cell["light"] && c["reflectance"] == cell["reflectance"])
            .and_then(|c| c["delta_e_full"].as_f64())
            .unwrap();
        assert!(closest <= achieved + 0.005, "seed {seed}: {msg}");
    }
    let violation = common::bound_violation(&st, &x);
    assert!(violation <= 1e-9, "seed {seed}: a bound is violated by {violation:.2e}");
    if st.a.ncols() > 0 {
        let (xo, solved_ok, status) = oracle_point(&st);
        let best = common::objective(&st, &xo);
        assert!(solved_ok || ours <= best, "seed {seed}: oracle {status}");
        assert!(
            ours <= best * (1.0 + OPTIMUM_TOL) + 1e-13,
            "seed {seed}: objective {ours:.12e} above the optimum {best:.12e} ({:.2e} relative)\n{}",
            (ours - best) / best,
            g.toml
        );
    }
    if std::env::var_os("KEEP").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn solve_reports_the_exact_optimum_of_the_spec_objective() {
    let spec = Spec::load();
    let count = std::env::var("METAMER_SPEC_SEEDS").ok().and_then(|v| v.parse().ok()).unwrap_or(40u64);
    let from = std::env::var("METAMER_SPEC_FROM").ok().and_then(|v| v.parse().ok()).unwrap_or(0u64);
    for seed in from..count {
        check(seed, &spec);
    }
    // Seed 215 found two bugs (a basis with columns 10³ apart cost Eq. 7 through coefficients 1e-7 of the
    // objective; a "closest reachable colour" farther than the achieved one).
    check(215, &spec);
}
