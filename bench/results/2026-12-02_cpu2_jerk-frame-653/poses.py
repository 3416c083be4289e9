#!/usr/bin/env python3
"""Each frame's pose in a track at its mid-time against a family draw's truth, mean displacement over the draw's
head points in mm (bench/estimate_family.py's draw and error): at the frame's middle, and the truth's own move
from the frame's start to its end.

    python3 poses.py SEED TRACK.csv
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))  # bench/
import estimate_family as ef  # noqa: E402
import head_frames as hf  # noqa: E402


def dist(points, a, b):
    pa = points @ a[:3, :3].T + a[:3, 3]
    pb = points @ b[:3, :3].T + b[:3, 3]
    return np.sqrt(((pa - pb) ** 2).sum(1)).mean()


def main(seed, csv):
    d = ef.draw(seed)
    rng = np.random.default_rng([seed, 1])
    _, _, bounds, truth = ef.simulate(d, rng)
    points = hf.head_points(rng)[::10]  # the points as the family draws them
    track = hf.track_maps(*hf.read_matrix_csv(csv))
    for k in range(len(bounds) - 1):
        t0, t1 = bounds[k], bounds[k + 1]
        tm = 0.5 * (t0 + t1)
        print(f"frame {k} {t0:6.1f}-{t1:6.1f}: track(mid) vs truth(mid) {dist(points, track(tm), truth(tm)):.2f}  "
              f"truth start->end {dist(points, truth(t0), truth(t1)):.2f}  "
              f"track(mid) vs truth(start) {dist(points, track(tm), truth(t0)):.2f} "
              f"vs truth(end) {dist(points, track(tm), truth(t1)):.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]), sys.argv[2])
