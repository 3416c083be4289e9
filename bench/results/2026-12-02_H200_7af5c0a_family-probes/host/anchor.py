#!/usr/bin/env python3
"""How much of a family draw's error is frame 0's pose (issue 47): each track scored against the draw's truth as it
is, with the one constant map composed that fits it best to the truth (the anchor bound: frame 0's pose known
relative to the rest; not an estimator), and re-expressed relative to its own frame 0 (a track of another
--reference). bench/estimate_family.py's draws and error.

    python3 anchor.py score SEED TRACK.csv ...          # tracks made already (a line each, per-frame mm)
    python3 anchor.py run PETBLUR OUT.jsonl SEED ...    # petblur motion estimate at its defaults on each draw
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", ".."))  # bench/
import estimate_family as ef  # noqa: E402
import head_frames as hf  # noqa: E402


def draw(seed):
    d = ef.draw(seed)
    rng = np.random.default_rng([seed, 1])
    frames, affine, bounds, truth = ef.simulate(d, rng)
    return d, frames, affine, bounds, truth, hf.head_points(rng)  # the points as the family draws them


def errors(times, maps, truth, bounds, points):
    return hf.displacement_errors(hf.track_maps(times, maps), truth, bounds, points)


def rigid(x):
    g = np.eye(4)
    g[:3, :3] = Rotation.from_rotvec(x[:3]).as_matrix()
    g[:3, 3] = x[3:]
    return g


def anchored(times, maps, truth, bounds, points):
    """The track composed with the constant map G (M(t) G) that brings it nearest the truth, 8 times a frame."""
    track = hf.track_maps(times, maps)
    ts = np.concatenate([bounds[k] + (np.arange(8) + 0.5) / 8 * (bounds[k + 1] - bounds[k])
                         for k in range(len(bounds) - 1)])
    pairs = [(track(t), truth(t)) for t in ts]
    pts = points[::10]

    def residual(x):
        g = rigid(x)
        return np.concatenate([(pts @ (a @ g)[:3, :3].T + (a @ g)[:3, 3] - pts @ b[:3, :3].T - b[:3, 3]).ravel()
                               for a, b in pairs])
    g = rigid(least_squares(residual, np.zeros(6)).x)
    return np.array([m @ g for m in maps])


def line(name, e):
    return "%-14s %.3f  %s" % (name, e.mean(), " ".join("%.2f" % v for v in e))


def score(seed, tracks):
    _, _, _, bounds, truth, points = draw(seed)
    print(line("truth's means", errors(*ef.frame_means(truth, bounds), truth, bounds, points)))
    for c in tracks:
        times, maps = hf.read_matrix_csv(c)
        name = os.path.basename(c)[:9]
        m0 = hf.track_maps(times, maps)(0.5 * (bounds[0] + bounds[1]))
        print(line(name, errors(times, maps, truth, bounds, points)))
        print(line("anchored " + name[:5], errors(times, anchored(times, maps, truth, bounds, points), truth, bounds,
                                                    points)))
        print(line("rel. 0 " + name[:7], errors(times, np.array([m @ np.linalg.inv(m0) for m in maps]), truth,
                                                  bounds, points)))


def run(petblur, out, seeds):
    for seed in seeds:
        d, frames, affine, bounds, truth, points = draw(seed)
        with tempfile.TemporaryDirectory() as tmp:
            nii, side = hf.write_series(tmp, frames, affine, bounds, "f")
            csv = os.path.join(tmp, "t.csv")
            subprocess.run([petblur, "motion", "estimate", nii, "--frames-from", side, "-o", csv, "-q"], check=True)
            times, maps = hf.read_matrix_csv(csv)
        e0 = errors(times, maps, truth, bounds, points)
        e1 = errors(times, anchored(times, maps, truth, bounds, points), truth, bounds, points)
        row = {"seed": seed, "from_injection": d.start_s == 0.0, "mean_mm": round(float(e0.mean()), 3),
               "anchored_mm": round(float(e1.mean()), 3), "per_frame_mm": [round(float(x), 3) for x in e0],
               "anchored_per_frame_mm": [round(float(x), 3) for x in e1]}
        print(json.dumps(row), flush=True)
        with open(out, "a") as f:
            f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "score":
        score(int(sys.argv[2]), sys.argv[3:])
    elif len(sys.argv) > 3 and sys.argv[1] == "run":
        run(sys.argv[2], sys.argv[3], [int(s) for s in sys.argv[4:]])
    else:
        sys.exit(__doc__)
