#!/usr/bin/env python3
"""The walk's own error on long segments, against reading them exactly:
oblique translations of a fixed length L (voxels along
the major axis) on fresh draws (a grid of 40^3 voxels of 2-3 mm, a random
direction, path_cases' sharp spheres or smooth brain), each read by AB (the
paper's walk from PB_AB_WALK_FROM = 6 voxels on, both between 5 and 6), AB
sweep, RM and AB chord (every segment exact) at the defaults, against the
exact time average of the trilinear image along the path: AB with `steps` =
ceil(L / 3), whose pieces are each read exactly. That reference is checked
against scipy (accuracy_case's mean of order-1 resamplings over 60 L times) on the
first draw's L = 6 and 12, inside the grid's middle. Relative RMS and max in
percent (100 ||d|| / ||ref||, 100 max |d| / max |ref|), median / worst over
the draws, exact filter, on --device (host by default).

  long_segments.py [--draws 10] [--seed S] [--objects spheres,brain] [--lengths 2,4,6,8,12,20] [--device host]"""

import argparse
import math
import os
import sys

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from accuracy_case import errors, mean_resampled  # noqa: E402
from path_cases import draw_object  # noqa: E402

METHODS = (("ab", None), ("ab", "sweep"), ("rm", None), ("ab", "chord"))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--draws", type=int, default=10)
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--objects", default="spheres,brain")
    ap.add_argument("--lengths", default="2,4,6,8,12,20")
    ap.add_argument("--device", default="host")
    a = ap.parse_args()
    import petblur
    seed = a.seed if a.seed is not None else int(np.random.SeedSequence().entropy % (1 << 32))
    print(f"seed {seed} (--seed {seed} replays these draws)", flush=True)
    lengths = [float(v) for v in a.lengths.split(",")]
    shape = (40, 40, 40)
    for k, obj in enumerate(a.objects.split(",")):
        rng = np.random.default_rng([seed, k])
        res = {}
        for draw in range(a.draws):
            vox = rng.uniform(2.0, 3.0, 3)
            affine = np.eye(4)
            affine[:3, :3] = np.diag(vox)
            affine[:3, 3] = 0.5 * vox
            x = draw_object(rng, shape, vox, affine, obj)[0]
            u = rng.normal(size=3)
            u /= np.abs(u).max()  # its major component 1: L voxels along the major axis
            for L in lengths:
                m = petblur.Motion.from_axis_angle(translation=tuple(u * L * vox), angle=0.0)
                ref = petblur.BlurOperator(shape, tuple(vox), m, method="ab", filter="exact", device=a.device,
                                           steps=int(math.ceil(L / 3.0))).apply(x)
                if draw == 0 and L in (6.0, 12.0):
                    times = 60 * int(L)
                    s = (np.arange(times) + 0.5) / times
                    sp = mean_resampled(x, affine, np.zeros(3), Rotation.identity(times), np.outer(s, u * L * vox))
                    inner = (slice(12, 28),) * 3
                    e = errors(sp[inner], ref[inner])["rms_pct"]
                    print(f"{obj}: the exact reference against scipy's {times}-time mean, L = {L:g}, the grid's "
                          f"middle: {e:.4f} % RMS", flush=True)
                for method, sampling in METHODS:
                    y = petblur.BlurOperator(shape, tuple(vox), m, method=method, filter="exact", device=a.device,
                                             ab_sampling=sampling).apply(x)
                    e = errors(ref, y)
                    res.setdefault((L, method, sampling), []).append((e["rms_pct"], e["max_pct"]))
        print(f"\n{obj}, {a.draws} draws: RMS % median / worst, max % median / worst, against the exact average\n")
        names = [f"{m}{' ' + s if s else ''}" for m, s in METHODS]
        print("| L (voxels) | " + " | ".join(names) + " |")
        print("|---|" + "---|" * len(names))
        for L in lengths:
            cells = []
            for method, sampling in METHODS:
                v = np.array(res[L, method, sampling])
                cells.append(f"{np.median(v[:, 0]):.2f} / {v[:, 0].max():.2f}, {np.median(v[:, 1]):.2f} / "
                             f"{v[:, 1].max():.2f}")
            print(f"| {L:g} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
