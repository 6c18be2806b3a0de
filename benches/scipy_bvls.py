#!/usr/bin/env python3
"""Baseline for `metamer solve` speed: scipy's BVLS (lsq_linear(method="bvls")) solving the same bounded
single-reflectance designs one by one, assembled independently from the palette TOML and the CIE tables.

    cargo build --release --example batch_palette && cargo build --release
    target/release/examples/batch_palette batch 1200 /tmp/batch.toml
    python3 benches/scipy_bvls.py /tmp/batch.toml [--metamer target/release/metamer]

Both are timed in alternated rounds (`--repeats`, 10 by default, after one warm-up round): each round one
scipy pass over every design, then metamer's processes, so that a machine whose speed drifts weighs on both
alike. Prints the medians of scipy's passes and of metamer's wall time for the whole file in one process (the
default invocation `metamer solve IN -o OUT --report R.json`, its table going to /dev/null, and the same with
`--quiet --no-subspace`), the solve's own time (`solve_seconds` of a process writing only the report, so that
no output is formatted beside it), the ratio of the medians and the rounds' own ratios (median, range), and
checks that both reach the same objective (sum over designs) within 1e-6 relative. `--json` prints the figures as one JSON object instead (`metamer bench solve` reads it).
Needs numpy and scipy (`pip install scipy`); not part of `cargo test`.
"""
import argparse, json, math, os, subprocess, sys, tempfile, time, tomllib
from statistics import median
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


def timed(cmd):
    """Wall seconds of one whole process (stdout to /dev/null)."""
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t


def scipy_pass(systems, lo, hi):
    """scipy's BVLS over every design one by one: (seconds, objective summed over the designs)."""
    t = time.perf_counter()
    total = 0.0
    for A, b in systems:
        res = lsq_linear(A, b, bounds=(lo, hi), method="bvls")
        total += float(np.sum((A @ res.x - b) ** 2))
    return time.perf_counter() - t, total


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("palette")
    ap.add_argument("--metamer", default=os.path.join(HERE, "..", "target", "release", "metamer"))
    ap.add_argument("--repeats", type=int, default=10, help="timed rounds after one warm-up round (medians reported)")
    ap.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    a = ap.parse_args()
    systems, (lo, hi) = designs(a.palette)
    n = len(systems)
    with tempfile.TemporaryDirectory() as d:
        out, rep_path = os.path.join(d, "out.toml"), os.path.join(d, "r.json")
        base = [a.metamer, "solve", a.palette, "-o", out, "--report", rep_path]
        # The solve alone: its own `solve_seconds` in processes that write only the report. With `-o` the
        # solved palette's text is formatted on the same cores beside the solve's last part, which the
        # report's `solve_seconds` then includes (docs/formats/report.md).
        alone_cmd = [a.metamer, "solve", a.palette, "--report", rep_path, "-q"]
        # Rounds alternate the two solvers, so that a machine whose speed drifts over seconds (a shared or
        # virtual one) weighs on both alike: each round one scipy pass, then the metamer processes, the first of
        # them not counted. A process run straight after the scipy pass, whose memory Python has just churned
        # and freed, took about 30 % longer than one run after another metamer process (a guest that reports
        # its free memory to the host, as ours do, makes those pages' next first touches dear); that one is the
        # warm-up, and the timed processes follow a metamer process as they do when run one after another (as
        # the issue timed them). The first round warms both up (Python's first calls) and is not counted.
        scipy_s, process, quiet, alone, ratios = [], [], [], [], []
        total = None
        for r in range(max(1, a.repeats) + 1):
            s_r, total = scipy_pass(systems, lo, hi)
            timed(base)
            p_r = timed(base)
            rep = json.load(open(rep_path))
            q_r = timed(base + ["--quiet", "--no-subspace"])
            subprocess.run(alone_cmd, check=True, stdout=subprocess.DEVNULL)
            a_r = json.load(open(rep_path))["solve_seconds"]
            if r > 0:
                scipy_s.append(s_r)
                process.append(p_r)
                quiet.append(q_r)
                alone.append(a_r)
                ratios.append(s_r / p_r)
    ours = rep["objective"]
    rel = (ours - total) / max(total, 1e-300)
    scipy_m, best, best_quiet, solve_s = median(scipy_s), median(process), median(quiet), median(alone)
    if a.json:
        print(json.dumps({"designs": n, "rounds": len(ratios), "scipy_seconds": scipy_m, "scipy_objective": total,
                          "process_seconds": best, "process_quiet_seconds": best_quiet, "solve_seconds": solve_s,
                          "ratio_median": median(ratios), "ratio_min": min(ratios), "ratio_max": max(ratios),
                          "objective": ours, "relative_difference": rel}))
    else:
        k = len(ratios)
        print(f"scipy BVLS: {n} designs in {scipy_m:.3f} s = {scipy_m / n * 1e6:.1f} µs per design (median of {k} "
              f"passes, {min(scipy_s):.3f}–{max(scipy_s):.3f} s), objective {total:.9e}")
        print(f"metamer solve -o --report (one process, median of {k}): {best:.4f} s = {best / n * 1e6:.1f} µs per "
              f"design ({min(process):.4f}–{max(process):.4f} s; solve alone {solve_s * 1e3:.2f} ms = "
              f"{solve_s / n * 1e6:.2f} µs per design; with --quiet --no-subspace {best_quiet:.4f} s), "
              f"objective {ours:.9e}")
        print(f"speed-up: {scipy_m / best:.1f}x (process, medians) / {scipy_m / solve_s:.1f}x (solve); per round "
              f"{median(ratios):.1f}x median, {min(ratios):.1f}–{max(ratios):.1f}x over {k} alternated rounds")
        print(f"objective relative difference (metamer - scipy) / scipy: {rel:.2e}")
    if rel > 1e-6:
        sys.exit("metamer's objective is worse than scipy's")


if __name__ == "__main__":
    main()
