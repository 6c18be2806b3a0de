#!/usr/bin/env python3
"""Baseline for `metamer solve` speed: scipy's BVLS (lsq_linear(method="bvls")) solving the same bounded
single-reflectance designs one by one, assembled independently from the palette TOML and the CIE tables.

    cargo build --release --example batch_palette && cargo build --release
    target/release/examples/batch_palette batch 1200 /tmp/batch.toml
    python3 benches/scipy_bvls.py /tmp/batch.toml [--metamer target/release/metamer]

Prints scipy's time per design, metamer's wall time for the whole file in one process (best of 3: the
default invocation `metamer solve IN -o OUT --report R.json`, its table going to /dev/null, and the same with
`--quiet --no-subspace`), the solve's own time (`solve_seconds`, the median of 3 processes writing only the
report, so that no output is formatted beside it) and the ratio, and checks that both reach the same
objective (sum over designs) within 1e-6 relative. `--json` prints the figures as one JSON object instead (`metamer bench solve` reads it).
Needs numpy and scipy (`pip install scipy`); not part of `cargo test`.
"""
import argparse, json, math, os, subprocess, sys, tempfile, time, tomllib
import numpy as np
from scipy.optimize import lsq_linear

HERE = os.path.dirname(os.path.abspath(__file__))


def shared_dir():
    """The folder holding spectra/ with the CIE tables: the repository's own copies in data/ (the same
    published tables), else $METAMER_DATA, else ../shared beside the checkout."""
    candidates = [os.path.join(HERE, "..", "data"), os.environ.get("METAMER_DATA", ""),
                  os.path.join(HERE, "..", "..", "shared")]
    for d in candidates:
        if d and os.path.isfile(os.path.join(d, "spectra", "cie1931_2deg_10nm.csv")):
            return d
    sys.exit("cannot find spectra/cie1931_2deg_10nm.csv in data/, $METAMER_DATA or ../shared")


def q_rgb():
    s = shared_dir()
    rows = [l.split(",") for l in open(os.path.join(s, "spectra", "cie1931_2deg_10nm.csv")) if l[0].isdigit()]
    cmf = np.array([[float(v) for v in r[1:4]] for r in rows if 400 <= float(r[0]) <= 700]).T  # 3x31
    q_xyz = cmf / cmf[1].sum()
    m = np.array([[float(v) for v in l.split()] for l in open(os.path.join(s, "spectra", "srgb_xyz_to_linear_rgb.txt"))
                  if l.strip() and not l.startswith("#")])
    return m @ q_xyz


def designs(path):
    p = tomllib.load(open(path, "rb"))
    st = p.get("settings", {})
    smooth = st.get("smoothness", 0.001)
    lo, hi = st.get("reflectance_bounds", [-math.inf, math.inf])
    lights = {l["name"]: np.array(l["samples"], float) * l.get("scale", 1.0) for l in p["lights"]}
    for l in p["lights"]:
        assert l.get("normalize", "luminance") == "none" and not l.get("design", False), "fixed sample lights expected"
    Q = q_rgb()
    D = (2 * np.eye(31) - np.eye(31, k=1) - np.eye(31, k=-1)) / (math.sqrt(31) * math.sqrt(6))
    cells = {}
    for c in p["colours"]:
        cells.setdefault(c["reflectance"], []).append(c)
    out = []
    for r in p["reflectances"]:
        assert r.get("design", False)
        rows, rhs = [], []
        for c in cells.get(r["name"], []):
            w = c.get("weight", 1.0) / math.sqrt(3)
            rows.append(w * Q * lights[c["light"]][None, :])
            rhs.append(w * np.array(c["target"], float))
        if smooth > 0:
            rows.append(smooth * D)
            rhs.append(np.zeros(31))
        out.append((np.vstack(rows), np.concatenate(rhs)))
    return out, (lo, hi)


def time_process(cmd, repeats):
    best = math.inf
    for _ in range(repeats):
        t = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        best = min(best, time.perf_counter() - t)
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("palette")
    ap.add_argument("--metamer", default=os.path.join(HERE, "..", "target", "release", "metamer"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    a = ap.parse_args()
    systems, (lo, hi) = designs(a.palette)
    t = time.perf_counter()
    total = 0.0
    for A, b in systems:
        res = lsq_linear(A, b, bounds=(lo, hi), method="bvls")
        total += float(np.sum((A @ res.x - b) ** 2))
    scipy_s = time.perf_counter() - t
    n = len(systems)
    with tempfile.TemporaryDirectory() as d:
        out, rep_path = os.path.join(d, "out.toml"), os.path.join(d, "r.json")
        base = [a.metamer, "solve", a.palette, "-o", out, "--report", rep_path]
        best_quiet = time_process(base + ["--quiet", "--no-subspace"], a.repeats)
        best = time_process(base, a.repeats)
        rep = json.load(open(rep_path))
        # The solve alone: its own `solve_seconds` in processes that write only the report. With `-o` the
        # solved palette's text is formatted on the same cores beside the solve's last part, which the
        # report's `solve_seconds` then includes (docs/formats/report.md). The median of the repeats.
        alone = []
        for _ in range(a.repeats):
            subprocess.run([a.metamer, "solve", a.palette, "--report", rep_path, "-q"], check=True,
                           stdout=subprocess.DEVNULL)
            alone.append(json.load(open(rep_path))["solve_seconds"])
        solve_s = sorted(alone)[len(alone) // 2]
    ours = rep["objective"]
    rel = (ours - total) / max(total, 1e-300)
    if a.json:
        print(json.dumps({"designs": n, "scipy_seconds": scipy_s, "scipy_objective": total, "process_seconds": best,
                          "process_quiet_seconds": best_quiet, "solve_seconds": solve_s,
                          "objective": ours, "relative_difference": rel}))
    else:
        print(f"scipy BVLS: {n} designs in {scipy_s:.3f} s = {scipy_s / n * 1e6:.1f} µs per design, objective {total:.9e}")
        print(f"metamer solve -o --report (one process, best of {a.repeats}): {best:.3f} s = {best / n * 1e6:.1f} µs per "
              f"design (solve alone {solve_s * 1e3:.1f} ms; with --quiet --no-subspace {best_quiet:.3f} s), "
              f"objective {ours:.9e}")
        print(f"speed-up: {scipy_s / best:.1f}x (process) / {scipy_s / solve_s:.1f}x (solve)")
        print(f"objective relative difference (metamer - scipy) / scipy: {rel:.2e}")
    if rel > 1e-6:
        sys.exit("metamer's objective is worse than scipy's")


if __name__ == "__main__":
    main()
