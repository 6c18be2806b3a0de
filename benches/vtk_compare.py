#!/usr/bin/env python3
"""Render the GE engine CT with VTK's best volume mapper on exactly the view of `metamer render
volumes/engine.toml`, at matched step and exposure, time both, and write a side-by-side crop pair at 1:1.

Not a test. Needs `pip install vtk numpy pillow` (vtk 9.x) and ../shared/volumes/engine.nhdr (or
$METAMER_DATA/volumes/engine.nhdr, or pass the .nhdr path). Run from the crate root:

    cargo build --release
    python3 benches/vtk_compare.py --run-metamer target/release/metamer -o target/vtk_compare/vtk_engine.png \
        --pair docs/figures/vtk_compare.png

`--run-metamer` writes target/vtk_compare/engine_step05.toml (volumes/engine.toml with `[render] step = 0.5`,
`shading = "headlight"`; with `--step 1`, engine_step1.toml at step 1: metamer always runs at VTK's step) and renders frame 1 of 3 (the dial's "split" light, where the block, the inner
parts and the smoke differ) with `--no-dial`, timed as VTK's frame is: `--repeat` rounds, each an untimed
then a timed metamer process, then an untimed then a timed VTK frame; the medians and each round's ratio are
printed. `--metamer FRAME.png` compares a frame made otherwise.

Sweep: `--sweep 48` (with `--run-metamer`) also times a dial sweep of 48 frames both ways: VTK re-renders
the view 48 times, the materials' colours moved between two sets from frame to frame (VTK has no relight,
so every frame is a raycast), each frame grabbed and written as PNG; metamer is timed as whole
`metamer render --frames 48` processes (volume read, one raycast, 48 relit PNG frames; median of
`--repeat` after one warm-up). The ratio is printed without and with VTK's own set-up (reading the volume,
building the pipeline). Beside wall times, both sides' CPU time (user + system, all threads: VTK's renders
in this process, metamer's whole processes) is printed, which the machine's other load does not inflate.

Mapper: `--mapper gpu` (the default) is vtkGPUVolumeRayCastMapper, VTK's best: it runs on software GL
(Mesa llvmpipe through EGL offscreen) where no GPU is present; `smart` is vtkSmartVolumeMapper, `fixed`
the CPU vtkFixedPointVolumeRayCastMapper. Both sides sample every 0.5 voxel with per-ray jittering
(VTK `SetUseJittering(1)`, metamer's default jitter), trilinear, shaded ambient 0.3 + diffuse 0.7 from a
headlight, opacities engine.toml's per voxel step (VTK's scalar opacity unit distance 1 voxel, so both
correct them for the 0.5 step).

Exposure: metamer exposes each sweep automatically; VTK's fixed RGB colours have no exposure. VTK's
frame is therefore scaled in linear light by one gain so that the 99th percentile of its covered
pixels' luminance matches metamer's (the gain is printed), then compared.

The view is metamer's (crates/metamer-core/src/render/raycast/view.rs): an orthographic camera at the
scene's azimuth 30° and elevation 20°, framing the bounding box of the voxels that belong to a material
(classify.rs `MaterialRows`: values 20–95, 100–175, 185–255) by their own projection — each run of
them along x projected at its two ends, grown by half a voxel — centred, the larger projected side
plus 4 % filling the frame. Here that view is computed with numpy and set as VTK's focal point, direction, view-up and parallel scale (no
ResetCamera, which would refit the whole grid).

Colours are fixed RGB (VTK has no post-illumination): the materials get roughly their colours under
"split" (block green, inner parts amber, smoke white). What VTK cannot do here, and metamer does: relight
the raycast image for another light without raycasting again (one 3×m matrix per pixel per frame), and
render the materials' spectra, so metamers (equal colours under one light, different under another) and
metameric blacks come out of the palette's design, not of per-frame colour tables.
"""
import argparse
import gzip
import os
import resource
import statistics
import time

import numpy as np
import vtk
from vtk.util import numpy_support

# engine.toml: (value range, opacity per voxel step, colour under "split").
MATERIALS = [
    ((20, 95), 0.03, (0.9, 0.9, 0.9)),
    ((100, 175), 0.1, (0.35, 0.6, 0.3)),
    ((185, 255), 0.7, (0.95, 0.7, 0.25)),
]
AZIMUTH, ELEVATION = 30.0, 20.0


def cpu_seconds(who=resource.RUSAGE_SELF):
    """User + system CPU seconds used so far by this process (or by its finished children): on a machine
    shared with other work, CPU time is what the other load does not inflate."""
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def read_nhdr(path):
    header = {}
    with open(path) as f:
        for line in f:
            if ":" in line:
                k, v = line.split(":", 1)
                header[k.strip()] = v.strip()
    dims = [int(x) for x in header["sizes"].split()]
    spacing = [float(x) for x in header.get("spacings", "1 1 1").split()]
    data_file = os.path.join(os.path.dirname(path), header["data file"])
    with (gzip.open(data_file) if header.get("encoding") == "gzip" else open(data_file, "rb")) as f:
        raw = f.read()
    return np.frombuffer(raw, dtype=np.uint8), dims, spacing


def material_mask(data, dims):
    """Per voxel (numpy order z, y, x): whether its value lies in some material's range."""
    v = data.reshape(dims[2], dims[1], dims[0])
    mask = np.zeros(v.shape, dtype=bool)
    for (lo, hi), _, _ in MATERIALS:
        mask |= (v >= lo) & (v <= hi)
    return mask


def material_bounds(mask):
    """Index bounds (lo, hi) as (x, y, z), inclusive, of the voxels in some material's range."""
    lo, hi = [], []
    for axis in (2, 1, 0):  # x, y, z: reduce over the other two numpy axes
        any_ = mask.any(axis=tuple(a for a in range(3) if a != axis))
        idx = np.nonzero(any_)[0]
        lo.append(int(idx[0]))
        hi.append(int(idx[-1]))
    return lo, hi


def metamer_view(dims, spacing, mask, aspect=1.0, zoom=1.0):
    """metamer's orthographic camera (view.rs, fit to the materials): focal point, eye direction,
    view-up and the image's vertical half extent (VTK's parallel scale). As in view.rs, the framed
    voxels are projected by their runs along x (each row's first and last material voxel), each grown
    by a voxel's half width seen along right and up."""
    az, el = np.radians(AZIMUTH), np.radians(ELEVATION)
    eye = np.array([np.sin(az) * np.cos(el), -np.cos(az) * np.cos(el), np.sin(el)])
    view = -eye
    world_up = np.array([0.0, 1.0, 0.0]) if abs(np.cos(el)) < 1e-6 else np.array([0.0, 0.0, 1.0])
    right = np.cross(view, world_up)
    right /= np.linalg.norm(right)
    up = np.cross(right, view)
    sp = np.array(spacing)
    lo, hi = material_bounds(mask)
    lo_w = np.maximum(np.array(lo) - 0.5, 0.0) * sp
    hi_w = np.minimum(np.array(hi) + 0.5, np.array(dims) - 1.0) * sp
    box_centre = 0.5 * (lo_w + hi_w)
    rows = mask.any(axis=2)  # (z, y)
    zs, ys = np.nonzero(rows)
    first = mask[zs, ys].argmax(axis=1)
    last = dims[0] - 1 - mask[zs, ys][:, ::-1].argmax(axis=1)
    ends = np.concatenate([np.stack([first, ys, zs], 1), np.stack([last, ys, zs], 1)]) * sp - box_centre
    r, u = ends @ right, ends @ up
    hr, hu = 0.5 * np.abs(right * sp).sum(), 0.5 * np.abs(up * sp).sum()
    r0, r1, u0, u1 = r.min() - hr, r.max() + hr, u.min() - hu, u.max() + hu
    centre = box_centre + 0.5 * (r0 + r1) * right + 0.5 * (u0 + u1) * up
    half = max(0.5 * (r1 - r0), 0.5 * (u1 - u0) / aspect, sp.min()) * 1.04 / zoom
    # metamer's vertical half extent is half · height / width.
    return centre, eye, up, half * aspect, (lo, hi)


def covered_box(rgb, threshold):
    """Bounding box (x0, y0, x1, y1), end exclusive, of pixels whose largest channel reaches `threshold`."""
    ys, xs = np.nonzero(rgb[..., :3].max(axis=-1) >= threshold)
    return (int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1) if len(xs) else None


MAPPER_NAME = "GPU raycast"


def srgb_decode(c):
    c = c / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def srgb_encode(c):
    c = np.clip(c, 0.0, 1.0)
    return np.round(255.0 * np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)).astype(np.uint8)


def luminance(rgb8):
    lin = srgb_decode(rgb8[..., :3].astype(np.float64))
    return lin @ np.array([0.2126, 0.7152, 0.0722]), lin


def match_exposure(ours, theirs, threshold=10):
    """VTK's frame scaled in linear light so the 99th percentile of its covered pixels' luminance equals
    metamer's; returns the scaled frame and the gain."""
    ly_o, _ = luminance(ours)
    ly_t, lin_t = luminance(theirs)
    po = np.percentile(ly_o[ours[..., :3].max(axis=-1) >= threshold], 99)
    pt = np.percentile(ly_t[theirs[..., :3].max(axis=-1) >= threshold], 99)
    gain = po / pt if pt > 0 else 1.0
    return srgb_encode(lin_t * gain), gain


def scene_name(step):
    """engine_step05.toml for step 0.5, engine_step1.toml for 1, engine_step0.25.toml for 0.25, …"""
    tag = "05" if step == 0.5 else f"{step:g}"
    return f"engine_step{tag}.toml"


def write_scene(here, step):
    """target/vtk_compare/engine_step05.toml (or engine_step1.toml, …): volumes/engine.toml at `step`
    voxels with a headlight (the settings VTK is given); returns (its path, the output folder)."""
    root = os.path.normpath(os.path.join(here, ".."))
    out = os.path.join(root, "target", "vtk_compare")
    os.makedirs(out, exist_ok=True)
    src = open(os.path.join(root, "volumes", "engine.toml")).read()
    lines = []
    for line in src.splitlines():
        if line.startswith("palette = "):
            line = f"palette = {os.path.join(root, 'volumes', 'engine_palette.toml')!r}".replace("'", '"')
        elif line.startswith("volume = "):
            line = f"volume = {os.path.normpath(os.path.join(root, 'volumes', line.split('=', 1)[1].strip().strip(chr(34))))!r}".replace("'", '"')
        lines.append(line)
    scene = os.path.join(out, scene_name(step))
    with open(scene, "w") as f:
        f.write("\n".join(lines) + f'\n\n[render]\nstep = {step!r}\nshading = "headlight"\n')
    return scene, out


def timed_process(cmd):
    """`cmd` run once as a whole process: (wall seconds, CPU seconds of user + system over all its threads,
    its stdout)."""
    import subprocess

    t, c = time.perf_counter(), cpu_seconds(resource.RUSAGE_CHILDREN)
    run = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return time.perf_counter() - t, cpu_seconds(resource.RUSAGE_CHILDREN) - c, run.stdout


def timed_runs(cmd, repeat):
    """`cmd` run as one warm-up, then `repeat` timed runs (at least one): the timed runs' `timed_process`."""
    return [timed_process(cmd) for _ in range(max(1, repeat) + 1)][1:]


def summary_ms(stdout):
    """A `metamer render` summary's raycast ms and relight + PNG ms per frame."""
    import re

    m = re.search(r"raycast ([0-9.]+) ms.*\(([0-9.]+) ms/frame\)", stdout)
    return float(m.group(1)), float(m.group(2))


def metamer_frame_cmd(binary, here, size, step, volume):
    """The command rendering frame 1 of 3 of volumes/engine.toml at `step` (VTK's) with a headlight, of the
    volume VTK reads (`volume`), and the frame it writes. Each run is a whole process: the volume read, its own
    raycast with its field blocks built (where VTK's warm-up builds its gradient tables once for all its
    frames)."""
    scene, out = write_scene(here, step)
    frames = os.path.join(out, "metamer")
    cmd = [binary, "render", scene, "--volume", volume, "--frames", "3", "--frame-range", "1..2", "--size",
           str(size), "--no-dial", "--force", "-o", frames]
    return cmd, os.path.join(frames, "frame_0001.png")


def metamer_frame(cmd):
    """One timed `metamer_frame_cmd` process: (its summary's raycast ms, its relight + PNG ms per frame, its CPU
    seconds, its stdout)."""
    _, cpu, out = timed_process(cmd)
    return (*summary_ms(out), cpu, out)


def metamer_sweep(binary, here, size, frames, repeat, step, volume):
    """Wall seconds of whole `metamer render` processes writing a sweep of `frames` frames of the
    headlight scene at `step` (`repeat` runs after one warm-up; the median): reading the volume, the one
    raycast, every relit frame and its PNG. Also returns the median of the summaries' relight + PNG per frame."""
    scene, out = write_scene(here, step)
    cmd = [binary, "render", scene, "--volume", volume, "--frames", str(frames), "--size", str(size), "--no-dial",
           "--force", "-o", os.path.join(out, "metamer_sweep")]
    runs = timed_runs(cmd, repeat)
    print(runs[-1][2].strip().splitlines()[1])
    times = [w for w, _, _ in runs]
    per_frame = statistics.median(summary_ms(out)[1] for _, _, out in runs)
    return statistics.median(times), times, statistics.median(c for _, c, _ in runs), per_frame


def vtk_sweep(win, colour, frames, out_dir):
    """VTK's sweep: `frames` re-renders, each with the materials' colours of its own light (the colour
    table moved between two sets of colours, as a light dial would), grabbed and written as PNG like
    metamer's frames. Returns the seconds."""
    os.makedirs(out_dir, exist_ok=True)
    other = [(0.95, 0.85, 0.6), (0.2, 0.45, 0.7), (0.9, 0.3, 0.2)]
    t, cpu = time.perf_counter(), cpu_seconds()
    for k in range(frames):
        w = k / max(1, frames - 1)
        colour.RemoveAllPoints()
        for ((lo_v, hi_v), _, rgb), rgb2 in zip(MATERIALS, other):
            c = [(1 - w) * a + w * b for a, b in zip(rgb, rgb2)]
            colour.AddRGBPoint(lo_v, *c)
            colour.AddRGBPoint(hi_v, *c)
        win.Render()
        grab = vtk.vtkWindowToImageFilter()
        grab.SetInput(win)
        grab.Update()
        writer = vtk.vtkPNGWriter()
        writer.SetFileName(os.path.join(out_dir, f"frame_{k:04}.png"))
        writer.SetInputConnection(grab.GetOutputPort())
        writer.Write()
    return time.perf_counter() - t, cpu_seconds() - cpu


def write_pair(ours, theirs, box, path):
    """The same 1:1 crop of both frames side by side, labelled, as one PNG."""
    from PIL import Image, ImageDraw

    x0, y0, x1, y1 = box
    a = Image.fromarray(ours[y0:y1, x0:x1, :3])
    b = Image.fromarray(theirs[y0:y1, x0:x1, :3])
    band = 18
    pair = Image.new("RGB", (a.width * 2 + 6, a.height + band), (16, 16, 16))
    pair.paste(a, (0, band))
    pair.paste(b, (a.width + 6, band))
    d = ImageDraw.Draw(pair)
    d.text((4, 3), "metamer", fill=(230, 230, 230))
    d.text((a.width + 10, 3), f"VTK {vtk.vtkVersion.GetVTKVersion()} {MAPPER_NAME}, matched exposure", fill=(230, 230, 230))
    pair.save(path, optimize=True)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser()
    data_dir = os.environ.get("METAMER_DATA") or os.path.join(here, "..", "..", "shared")
    ap.add_argument("nhdr", nargs="?", default=os.path.join(data_dir, "volumes", "engine.nhdr"))
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--repeat", type=int, default=5, help="timed renders after one warm-up (median reported)")
    ap.add_argument("-o", "--output", default=os.path.join(here, "..", "target", "vtk_compare", "vtk_engine.png"),
                    help="VTK's frame (default target/vtk_compare/vtk_engine.png, beside the scenes it writes)")
    ap.add_argument("--metamer", help="metamer's frame of the same view: compare the covered-pixel boxes")
    ap.add_argument("--run-metamer", metavar="BINARY", help="render metamer's frame with this binary (see above)")
    ap.add_argument("--mapper", choices=["gpu", "smart", "fixed"], default="gpu")
    ap.add_argument("--step", type=float, default=0.5, help="sample distance in voxels (both renderers)")
    ap.add_argument("--pair", help="write a side-by-side 1:1 crop of both frames here (needs --metamer)")
    ap.add_argument("--crop", default="0.80,0.45,256", help="crop centre (fractions of the frame) and side")
    ap.add_argument("--sweep", type=int, metavar="FRAMES",
                    help="also time a sweep of FRAMES frames: VTK re-rendering (and writing) each frame against "
                         "whole `metamer render --frames FRAMES` processes (needs --run-metamer)")
    args = ap.parse_args()
    metamer_ms = None
    # The sweep's relight + PNG per frame (with --sweep): what an extra frame costs, the first frame's set-up
    # spread over the sweep.
    sweep_frame_ms = None
    if args.run_metamer:
        metamer_cmd, args.metamer = metamer_frame_cmd(args.run_metamer, here, args.size, args.step, args.nhdr)
    setup_start = time.perf_counter()
    data, dims, spacing = read_nhdr(args.nhdr)
    centre, eye, up, scale, (lo, hi) = metamer_view(dims, spacing, material_mask(data, dims))
    print(f"material bounds {lo}..{hi}; focal point {np.round(centre, 2).tolist()}, parallel scale {scale:.2f}")

    img = vtk.vtkImageData()
    img.SetDimensions(*dims)
    img.SetSpacing(*spacing)
    img.GetPointData().SetScalars(numpy_support.numpy_to_vtk(data, deep=True, array_type=vtk.VTK_UNSIGNED_CHAR))
    opacity = vtk.vtkPiecewiseFunction()
    colour = vtk.vtkColorTransferFunction()
    for (lo_v, hi_v), a, rgb in MATERIALS:
        opacity.AddPoint(lo_v - 0.5, 0.0)
        opacity.AddPoint(lo_v, a)
        opacity.AddPoint(hi_v, a)
        opacity.AddPoint(hi_v + 0.5, 0.0)
        colour.AddRGBPoint(lo_v, *rgb)
        colour.AddRGBPoint(hi_v, *rgb)
    prop = vtk.vtkVolumeProperty()
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(min(spacing))
    prop.SetColor(colour)
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOn()
    prop.SetAmbient(0.3)
    prop.SetDiffuse(0.7)
    prop.SetSpecular(0.0)
    global MAPPER_NAME
    if args.mapper == "gpu":
        mapper = vtk.vtkGPUVolumeRayCastMapper()
        mapper.SetUseJittering(1)
        MAPPER_NAME = "GPU raycast (software GL), jittered"
    elif args.mapper == "smart":
        mapper = vtk.vtkSmartVolumeMapper()
        mapper.SetRequestedRenderModeToDefault()
        MAPPER_NAME = "smart volume mapper"
    else:
        mapper = vtk.vtkFixedPointVolumeRayCastMapper()
        MAPPER_NAME = "fixed-point CPU raycast"
    mapper.SetInputData(img)
    if args.mapper != "smart":
        mapper.SetSampleDistance(args.step * min(spacing))
        mapper.SetAutoAdjustSampleDistances(0)
    volume = vtk.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)

    ren = vtk.vtkRenderer()
    ren.AddVolume(volume)
    ren.SetBackground(0, 0, 0)
    win = vtk.vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.AddRenderer(ren)
    win.SetSize(args.size, args.size)
    cam = ren.GetActiveCamera()
    cam.ParallelProjectionOn()
    cam.SetFocalPoint(*centre)
    cam.SetPosition(*(centre + 4.0 * np.linalg.norm(np.array(dims) * spacing) * eye))
    cam.SetViewUp(*up)
    cam.SetParallelScale(scale)
    ren.ResetCameraClippingRange()
    setup = time.perf_counter() - setup_start
    win.Render()  # warm-up (builds the mapper's gradient tables)
    # With --run-metamer the two renderers take turns, metamer's processes then VTK's frames in each round, so
    # that a machine whose speed drifts over seconds (a shared or virtual one: VTK's median here moved from
    # 126 to 183 ms between runs minutes apart) weighs on both alike; each round's own ratio is printed too.
    # In a round each renderer runs once untimed before its timed run, so that the timed one follows its own
    # kind as in a run of either alone (without it, 9 rounds: VTK's frame 189.6 ms, metamer's raycast 143.1 ms;
    # with it, minutes later: 127.2 and 119.1 ms).
    times, vtk_cpus, metamer_runs = [], [], []
    for _ in range(max(1, args.repeat)):
        if args.run_metamer:
            metamer_frame(metamer_cmd)
            metamer_runs.append(metamer_frame(metamer_cmd))
            win.Render()
        t, cpu = time.perf_counter(), cpu_seconds()
        win.Render()
        times.append(time.perf_counter() - t)
        vtk_cpus.append(cpu_seconds() - cpu)
    vtk_cpu = statistics.mean(vtk_cpus)
    if args.run_metamer:
        raycasts = [r[0] for r in metamer_runs]
        print(metamer_runs[-1][3].strip().splitlines()[1])
        metamer_ms = (statistics.median(raycasts), statistics.median(r[1] for r in metamer_runs))
        metamer_cpu = statistics.median(r[2] for r in metamer_runs)
        ratios = [r / (t * 1e3) for r, t in zip(raycasts, times)]
        print(f"metamer's raycast: median {metamer_ms[0]:.1f} ms of {len(raycasts)} processes, each after an untimed one "
              f"({', '.join(f'{r:.1f}' for r in raycasts)}); whole process (volume read, raycast, one frame): "
              f"median {metamer_cpu:.2f} s CPU")
        print(f"paired: metamer's raycast / VTK's frame in each of {len(ratios)} alternated rounds: median "
              f"{statistics.median(ratios):.2f}×, {min(ratios):.2f}–{max(ratios):.2f}×; medians' ratio "
              f"{metamer_ms[0] / (statistics.median(times) * 1e3):.2f}×")
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(win)
    grab.Update()
    writer = vtk.vtkPNGWriter()
    os.makedirs(os.path.dirname(os.path.abspath(args.output)), exist_ok=True)
    writer.SetFileName(args.output)
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()
    print(
        f"VTK {vtk.vtkVersion.GetVTKVersion()} {MAPPER_NAME} {args.size}², step {args.step}: median {statistics.median(times) * 1e3:.1f} ms"
        f" of {len(times)} (min {min(times) * 1e3:.1f}), {vtk_cpu * 1e3:.0f} ms CPU per render (mean), load "
        f"{os.getloadavg()[0]:.1f} -> {args.output}"
    )
    if args.run_metamer:
        print(
            f"CPU time: metamer's whole process {metamer_cpu * 1e3:.0f} ms (volume read, raycast, one frame) against "
            f"VTK's {vtk_cpu * 1e3:.0f} ms per render: metamer / VTK {metamer_cpu / vtk_cpu:.2f}×"
        )

    if args.sweep:
        if not args.run_metamer:
            raise SystemExit("--sweep needs --run-metamer BINARY")
        vtk_s, vtk_cpu = vtk_sweep(win, colour, args.sweep, os.path.join("target", "vtk_compare", "vtk_sweep"))
        m_s, m_all, m_cpu, sweep_frame_ms = metamer_sweep(
            args.run_metamer, here, args.size, args.sweep, args.repeat, args.step, args.nhdr
        )
        print(
            f"sweep of {args.sweep} frames at {args.size}², step {args.step}: VTK {vtk_s:.2f} s for the re-renders "
            f"(+ {setup:.2f} s reading the volume and setting up the pipeline) = "
            f"{(vtk_s + setup):.2f} s; metamer whole process median {m_s:.2f} s of {len(m_all)} "
            f"({', '.join(f'{t:.2f}' for t in m_all)}): VTK / metamer {vtk_s / m_s:.1f}× "
            f"(re-renders only), {(vtk_s + setup) / m_s:.1f}× (with VTK's set-up); load {os.getloadavg()[0]:.1f}"
        )
        print(
            f"sweep CPU time (user + system, all threads): VTK {vtk_cpu:.2f} s for the re-renders, metamer's whole "
            f"process median {m_cpu:.2f} s: VTK / metamer {vtk_cpu / m_cpu:.1f}×"
        )

    if args.metamer:
        from PIL import Image

        ours = np.asarray(Image.open(args.metamer).convert("RGB"))
        theirs = np.asarray(Image.open(args.output).convert("RGB"))
        if ours.shape != theirs.shape:
            raise SystemExit(f"{args.metamer} is {ours.shape[1]}×{ours.shape[0]}, VTK's frame {args.size}²")
        theirs, gain = match_exposure(ours, theirs)
        Image.fromarray(theirs).save(args.output)
        print(f"VTK frame scaled by {gain:.3f} in linear light to metamer's exposure -> {args.output}")
        if metamer_ms:
            relit = (f"{sweep_frame_ms:.2f} ms per relit frame of the {args.sweep}-frame sweep (relight + PNG)"
                     if sweep_frame_ms is not None else
                     f"{metamer_ms[1]:.1f} ms for the one relit frame of the timed runs (relight + PNG, its "
                     f"set-up included; --sweep gives the per-frame figure of a sweep)")
            print(f"metamer {args.size}², step {args.step}: raycast {metamer_ms[0]:.1f} ms once per view, then "
                  f"{relit}; VTK raycasts every frame")
        for threshold in (10, 40):
            a, b = covered_box(ours, threshold), covered_box(theirs, threshold)
            diff = max(abs(p - q) for p, q in zip(a, b)) if a and b else None
            print(f"covered pixels (max channel ≥ {threshold}): metamer box {a}, VTK box {b}, largest difference {diff} px")
        if args.pair:
            fx, fy, side = args.crop.split(",")
            cx, cy, side = int(float(fx) * args.size), int(float(fy) * args.size), int(side)
            box = (cx - side // 2, cy - side // 2, cx - side // 2 + side, cy - side // 2 + side)
            write_pair(ours, theirs, box, args.pair)
            print(f"crop {box} of both -> {args.pair} ({os.path.getsize(args.pair) // 1024} KB)")


if __name__ == "__main__":
    main()
