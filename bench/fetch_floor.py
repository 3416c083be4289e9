#!/usr/bin/env python3
"""The texture-fetch floor of memory_floor.py's turning cases (issue 33): AB
makes one trilinear fetch per slice of a voxel's path, so a blur makes
sum over voxels of S fetches, S the slices its chord crosses along its major
axis (bench_measure.c's count; the default path bound leaves these small turns
one chord). Counted here exactly, voxel by voxel, on the host, and divided by
the texture unit's trilinear rate that bench/fetch_rate.cu measured on the
H100 (488 G fetches/s, docs/performance.md "What bounds AB").

  fetch_floor.py"""

import math

import numpy as np

RATE = 488e9  # trilinear 3-D fetches per second, H100 (bench/fetch_rate.cu)
CASES = [(256, (0, 0, 0), 3.0), (512, (1, 1, 1), 2.0), (700, (1, 1, 1), 2.0)]


def slices(n, t, deg):
    """S of every voxel of one z-slice (a turn about z moves every slice
    alike): the chord from the voxel's centre to where the motion's end takes
    it, in texel coordinates."""
    a = math.radians(deg)
    R = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1.0]])
    c = 0.5 * n
    y, x = np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5, indexing="ij")
    p = np.stack([x.ravel(), y.ravel(), np.full(x.size, 0.5)], 1)
    b = (p - c - np.array(t, dtype=float)) @ R + c  # R^T (p - c - t) + c
    m = np.argmax(np.abs(b - p), 1)
    i = np.arange(len(p))
    lo = np.minimum(p[i, m], b[i, m]) - 0.5
    hi = np.maximum(p[i, m], b[i, m]) - 0.5
    return np.where(hi - lo < 1e-4, 1, np.ceil(hi - 1e-6) - np.floor(lo + 1e-6) + 1)


def main():
    print("| case | grid | mean S | largest S | fetches | fetch floor ms (488 G/s) |")
    print("|---|---|---|---|---|---|")
    for n, t, deg in CASES:
        S = slices(n, t, deg)
        fetches = S.mean() * n ** 3
        print(f"| {t} + {deg:g} degrees | {n}^3 | {S.mean():.2f} | {int(S.max())} | {fetches / 1e9:.3f} G | "
              f"{fetches / RATE * 1e3:.3f} |")


if __name__ == "__main__":
    main()
