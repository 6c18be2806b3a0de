#!/usr/bin/env python3
"""Render the GE engine CT with VTK's CPU raycaster (vtkFixedPointVolumeRayCastMapper) on the view of
volumes/engine.toml, for a side-by-side look at sampling artefacts and a timing against `metamer render`.

Not a test. Needs `pip install vtk` and ../shared/volumes/engine.nhdr (or pass the .nhdr path):

    python3 benches/vtk_compare.py [ENGINE.nhdr] [--size 1024] [-o vtk_engine.png]
    cargo run --release -- render volumes/engine.toml --frames 1 --size 1024 -o /tmp/ours

Colours are fixed RGB (VTK has no post-illumination): the three materials of engine.toml get their
colours under the dial's "split" light roughly; only geometry, sampling and shading are compared.
"""
import argparse
import gzip
import os
import time

import vtk
from vtk.util import numpy_support
import numpy as np


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
    raw = gzip.open(data_file).read() if header.get("encoding") == "gzip" else open(data_file, "rb").read()
    return np.frombuffer(raw, dtype=np.uint8), dims, spacing


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser()
    ap.add_argument("nhdr", nargs="?", default=os.path.join(here, "..", "..", "shared", "volumes", "engine.nhdr"))
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("-o", "--output", default="vtk_engine.png")
    args = ap.parse_args()
    data, dims, spacing = read_nhdr(args.nhdr)
    img = vtk.vtkImageData()
    img.SetDimensions(*dims)
    img.SetSpacing(*spacing)
    img.GetPointData().SetScalars(numpy_support.numpy_to_vtk(data, deep=True, array_type=vtk.VTK_UNSIGNED_CHAR))

    # engine.toml: smoke 20–95 α 0.03, block 100–175 α 0.1, inner 185–255 α 0.7 (per voxel step).
    opacity = vtk.vtkPiecewiseFunction()
    colour = vtk.vtkColorTransferFunction()
    for lo, hi, a, rgb in [(20, 95, 0.0, (0, 0, 0)), (100, 175, 0.1, (0.35, 0.6, 0.3)), (185, 255, 0.7, (0.95, 0.7, 0.25))]:
        opacity.AddPoint(lo - 0.5, 0.0)
        opacity.AddPoint(lo, a)
        opacity.AddPoint(hi, a)
        opacity.AddPoint(hi + 0.5, 0.0)
        colour.AddRGBPoint(lo, *rgb)
        colour.AddRGBPoint(hi, *rgb)
    prop = vtk.vtkVolumeProperty()
    prop.SetScalarOpacity(opacity)
    prop.SetColor(colour)
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOn()
    prop.SetAmbient(0.3)
    prop.SetDiffuse(0.7)
    prop.SetSpecular(0.0)
    mapper = vtk.vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(img)
    mapper.SetSampleDistance(1.0)
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
    centre = [0.5 * (d - 1) * s for d, s in zip(dims, spacing)]
    cam.SetFocalPoint(*centre)
    # metamer: azimuth about +z from looking along +y, elevation towards +z.
    az, el = np.radians(30.0), np.radians(20.0)
    eye = np.array([np.sin(az) * np.cos(el), -np.cos(az) * np.cos(el), np.sin(el)])
    cam.SetPosition(*(np.array(centre) + 1000 * eye))
    cam.SetViewUp(0, 0, 1)
    ren.ResetCamera()
    win.Render()  # warm-up (builds the mapper's gradient tables)
    t = time.perf_counter()
    win.Render()
    seconds = time.perf_counter() - t
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(win)
    grab.Update()
    writer = vtk.vtkPNGWriter()
    writer.SetFileName(args.output)
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()
    print(f"VTK {vtk.vtkVersion.GetVTKVersion()} fixed-point raycast {args.size}²: {seconds * 1e3:.1f} ms -> {args.output}")


if __name__ == "__main__":
    main()
