#!/usr/bin/env python3
"""The motion estimate's time, one build against another on one series.

Makes one series of bench/estimate_validation.py's setups (bench/head_frames.py;
its points inside the head drawn from seed + 1, so the errors differ from
estimate_validation.py's for the same seed in the third digit) and times `petblur motion estimate` on it with each program given, in turn,
--reps rounds, so that a machine whose speed drifts (the GPU machine's cores are
shared) weighs on every program alike. Prints each run's wall seconds (the
program's whole run, the 4-D NIfTI read included, as users time it) and each
program's median; writes times.json into --out. A program given as
NAME=PATH[:VAR=VALUE,...] runs with those environment variables.

    python3 bench/estimate_time.py --setup fine --out /tmp/t new=build/src/cli/petblur old=/old/petblur
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import estimate_validation as ev  # noqa: E402
import head_frames as hf  # noqa: E402


def program(spec):
    name, _, rest = spec.partition("=")
    path, _, env = rest.partition(":")
    extra = dict(kv.split("=", 1) for kv in env.split(",") if kv)
    return name, path, extra


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("programs", nargs="+", metavar="NAME=PATH[:VAR=VALUE,...]")
    ap.add_argument("--out", required=True)
    ap.add_argument("--setup", default="fine", choices=sorted(ev.SETUPS))
    ap.add_argument("--device", default="auto")
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--reps", type=int, default=3)
    a = ap.parse_args()

    os.makedirs(a.out, exist_ok=True)
    seed = a.seed if a.seed is not None else int(np.random.SeedSequence().entropy % 2**32)
    frames, affine, bounds, truth = hf.simulate(ev.SETUPS[a.setup], np.random.default_rng(seed))
    hf.write_series(a.out, frames, affine, bounds)
    points = hf.head_points(np.random.default_rng(seed + 1))
    runs = {name: [] for name, _, _ in map(program, a.programs)}
    errors = {}
    for rep in range(a.reps):
        for name, path, extra in map(program, a.programs):
            track = os.path.join(a.out, "track-%s.csv" % name)
            started = time.perf_counter()
            subprocess.run([path, "motion", "estimate", os.path.join(a.out, "frames.nii.gz"), "--frames-from",
                            os.path.join(a.out, "frames.json"), "-o", track, "--device", a.device, "-q"],
                           check=True, env={**os.environ, **extra})
            runs[name].append(time.perf_counter() - started)
            err = hf.displacement_errors(hf.track_maps(*hf.read_matrix_csv(track)), truth, bounds, points)
            errors[name] = [float(err.mean()), float(err.max())]  # the same every round: the track is
            print("round %d  %-12s %6.1f s  mean %.3f mm  worst frame %.3f mm" % (
                rep, name, runs[name][-1], err.mean(), err.max()), flush=True)
    for name, t in runs.items():
        print("%-12s median %.1f s (%s)" % (name, statistics.median(t), ", ".join("%.1f" % x for x in t)))
    with open(os.path.join(a.out, "times.json"), "w") as f:
        json.dump({"setup": a.setup, "seed": seed, "seconds": runs, "mean_worst_mm": errors}, f, indent=1)


if __name__ == "__main__":
    main()
