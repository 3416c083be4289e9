#!/usr/bin/env python3
"""Motion from the frames, measured: petblur motion estimate beside SimpleITK.

Simulates a dynamic series with bench/head_frames.py (scipy, not petblur's
operators), runs `petblur motion estimate` on it (a 4-D NIfTI and its BIDS-PET
sidecar, as a user would) with and without motion inside frames, and
SimpleITK's rigid registration of every frame to the first (correlation,
three levels: what people call by hand), and states each track's error as the
displacement of points inside the head, mean over each frame, in mm: mean and
worst over frames. Writes results.json and results.md into --out.

    python3 bench/estimate_validation.py --petblur build/src/cli/petblur --out results/ [--setup oblique-las]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import head_frames as hf  # noqa: E402

SETUPS = {
    # the target case: 24 frames of 10 s, 3 mm voxels, a 10 degree 8 mm jerk inside frame 15
    "axial": hf.Setup(),
    # the same head stored LAS on an oblique grid of anisotropic voxels
    "oblique-las": hf.Setup(voxel=(3.0, 3.0, 3.3), shape=(64, 64, 52), las=True, oblique_deg=15.0),
    # the benchmark's size: 128^3 of 1.5 mm
    "fine": hf.Setup(shape=(128, 128, 128), voxel=(1.5, 1.5, 1.5)),
}


def sitk_track(frames, affine, bounds, threads=2, metric="correlation", reference=0):
    """SimpleITK: every frame registered rigidly to frame `reference`, one pose per frame (mid-time), the maps taking
    that frame's object to each frame's; metric "correlation" or "mattes" (Mattes mutual information, 50 bins)."""
    import SimpleITK as sitk

    def image(vol):
        img = sitk.GetImageFromArray(np.ascontiguousarray(vol.transpose(2, 1, 0)).astype(np.float32))
        # ITK's physical space is LPS: nibabel's RAS affine with x and y negated
        lps = np.diag([-1.0, -1.0, 1.0])
        d = lps @ affine[:3, :3]
        spacing = np.linalg.norm(d, axis=0)
        img.SetSpacing(tuple(spacing))
        img.SetDirection(tuple((d / spacing).ravel()))
        img.SetOrigin(tuple(lps @ affine[:3, 3]))
        return img

    sitk.ProcessObject.SetGlobalDefaultNumberOfThreads(threads)
    fixed = image(frames[..., reference])
    maps = []
    lps = np.diag([-1.0, -1.0, 1.0, 1.0])
    for k in range(frames.shape[-1]):
        if k == reference:
            maps.append(np.eye(4))
            continue
        moving = image(frames[..., k])
        reg = sitk.ImageRegistrationMethod()
        if metric == "mattes":
            reg.SetMetricAsMattesMutualInformation(numberOfHistogramBins=50)
        else:
            reg.SetMetricAsCorrelation()
        reg.SetInterpolator(sitk.sitkLinear)
        reg.SetOptimizerAsRegularStepGradientDescent(learningRate=1.0, minStep=1e-4, numberOfIterations=200,
                                                     gradientMagnitudeTolerance=1e-8)
        reg.SetOptimizerScalesFromPhysicalShift()
        reg.SetShrinkFactorsPerLevel([4, 2, 1])
        reg.SetSmoothingSigmasPerLevel([2, 1, 0])
        reg.SmoothingSigmasAreSpecifiedInPhysicalUnitsOff()
        init = sitk.CenteredTransformInitializer(fixed, moving, sitk.Euler3DTransform(),
                                                 sitk.CenteredTransformInitializerFilter.GEOMETRY)
        reg.SetInitialTransform(init, inPlace=False)
        t = reg.Execute(fixed, moving)
        # t maps fixed points (the reference frame's object) to moving points (frame k): the object's motion, in LPS
        t = sitk.CompositeTransform(t).GetNthTransform(0) if isinstance(t, sitk.CompositeTransform) else t
        e = sitk.Euler3DTransform(t) if t.GetName() == "Euler3DTransform" else t
        m = np.eye(4)
        m[:3, :3] = np.array(e.GetMatrix()).reshape(3, 3)
        c = np.array(e.GetCenter())
        m[:3, 3] = np.array(e.GetTranslation()) + c - m[:3, :3] @ c
        maps.append(lps @ m @ lps)
    mids = 0.5 * (bounds[:-1] + bounds[1:])
    times = np.concatenate([[bounds[0]], mids, [bounds[-1]]])
    maps = np.concatenate([[maps[0]], maps, [maps[-1]]])
    return times, maps


def run_petblur(petblur, folder, extra, device):
    out = os.path.join(folder, "track%s.csv" % ("-frames" if extra else ""))
    started = time.perf_counter()
    subprocess.run([petblur, "motion", "estimate", os.path.join(folder, "frames.nii.gz"), "--frames-from",
                    os.path.join(folder, "frames.json"), "-o", out, "--device", device, "-q"] + extra, check=True)
    return out, time.perf_counter() - started


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--petblur", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--setup", default="axial", choices=sorted(SETUPS))
    ap.add_argument("--device", default="auto")
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--no-sitk", action="store_true")
    a = ap.parse_args()

    os.makedirs(a.out, exist_ok=True)
    seed = a.seed if a.seed is not None else int(np.random.SeedSequence().entropy % 2**32)
    rng = np.random.default_rng(seed)
    s = SETUPS[a.setup]
    frames, affine, bounds, truth = hf.simulate(s, rng)
    hf.write_series(a.out, frames, affine, bounds)
    points = hf.head_points(rng)
    results = {"setup": a.setup, "seed": seed, "frames": s.frames, "shape": list(s.shape), "voxel_mm": list(s.voxel),
               "jerk_frame": s.jerk_frame, "methods": {}}

    def record(name, times, maps, seconds):
        err = hf.displacement_errors(hf.track_maps(times, maps), truth, bounds, points)
        results["methods"][name] = {"mean_mm": float(err.mean()), "max_mm": float(err.max()),
                                    "worst_frame": int(err.argmax()), "jerk_frame_mm": float(err[s.jerk_frame]),
                                    "seconds": seconds, "per_frame_mm": [round(float(x), 3) for x in err]}
        print("%-28s mean %.3f mm  max %.3f mm (frame %d)  jerk frame %.3f mm  %.1f s" % (
            name, err.mean(), err.max(), err.argmax(), err[s.jerk_frame], seconds), flush=True)

    record("no correction", np.array([bounds[0], bounds[-1]]), np.array([np.eye(4)] * 2), 0.0)
    for extra, name in (([], "petblur"), (["--frame-poses-only"], "petblur, one pose per frame")):
        path, sec = run_petblur(a.petblur, a.out, extra, a.device)
        record(name, *hf.read_matrix_csv(path), sec)
    if not a.no_sitk:
        started = time.perf_counter()
        times, maps = sitk_track(frames, affine, bounds)
        record("SimpleITK (correlation)", times, maps, time.perf_counter() - started)
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    with open(os.path.join(a.out, "results.md"), "w") as f:
        f.write("| method | mean mm | max mm | worst frame | jerk frame mm | seconds |\n|---|---|---|---|---|---|\n")
        for name, r in results["methods"].items():
            f.write("| %s | %.3f | %.3f | %d | %.3f | %.1f |\n" % (name, r["mean_mm"], r["max_mm"], r["worst_frame"],
                                                                 r["jerk_frame_mm"], r["seconds"]))


if __name__ == "__main__":
    main()
