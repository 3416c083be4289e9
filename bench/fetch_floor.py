#!/usr/bin/env python3
"""The texture-fetch floor of memory_floor.py's turning cases (issue 33): AB
makes one trilinear fetch per slice of a voxel's path, so a blur makes
sum over voxels of S fetches, S the slices its chord crosses along its major
axis (bench_measure.c's count; the default path bound leaves these small turns
one chord, 700^3's too now that it measures curvature across the turn's axis,
and each of the 24 drifting frames one chord from its start pose to its end
pose). Counted here exactly, voxel by voxel, on the host, and
divided by the texture unit's trilinear rate that bench/fetch_rate.cu
measured on the H100 (488 G fetches/s, docs/performance.md "What bounds AB").

  fetch_floor.py"""

import math

import numpy as np

RATE = 488e9  # trilinear 3-D fetches per second, H100 (bench/fetch_rate.cu)
CASES = [(256, (0, 0, 0), 3.0), (512, (1, 1, 1), 2.0), (700, (1, 1, 1), 2.0)]


def turn(deg):
    a = math.radians(deg)
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1.0]])


def slices(shape, t0, deg0, t1, deg1):
    """S of every voxel of one z-slice (a turn about z moves every slice
    alike) of a grid of shape (voxels): the chord between where the poses
    (t voxels, deg about z through the centre) take the voxel's centre, in
    texel coordinates."""
    c = 0.5 * np.array(shape, dtype=float)
    y, x = np.meshgrid(np.arange(shape[1]) + 0.5, np.arange(shape[0]) + 0.5, indexing="ij")
    p = np.stack([x.ravel(), y.ravel(), np.full(x.size, 0.5)], 1)
    a = (p - c - np.array(t0, dtype=float)) @ turn(deg0) + c  # R^T (p - c - t) + c
    b = (p - c - np.array(t1, dtype=float)) @ turn(deg1) + c
    return chord_slices(a, b)


def chord_slices(a, b):
    """The slices AB visits on each chord a[i]-b[i] (texel coordinates, rows
    of points) along its major axis (bench_measure.c's ab_slices): 1 for a
    chord too short to walk."""
    m = np.argmax(np.abs(b - a), 1)
    i = np.arange(len(a))
    lo = np.minimum(a[i, m], b[i, m]) - 0.5
    hi = np.maximum(a[i, m], b[i, m]) - 0.5
    return np.where(hi - lo < 1e-4, 1, np.ceil(hi - 1e-6) - np.floor(lo + 1e-6) + 1)


def main():
    print("| case | grid | mean S | largest S | fetches | fetch floor ms (488 G/s) |")
    print("|---|---|---|---|---|---|")
    for n, t, deg in CASES:
        S = slices((n, n, n), (0, 0, 0), 0.0, t, deg)
        fetches = S.mean() * n ** 3
        print(f"| {t} + {deg:g} degrees | {n}^3 | {S.mean():.2f} | {int(S.max())} | {fetches / 1e9:.3f} G | "
              f"{fetches / RATE * 1e3:.3f} |")
    # distributed_frames.track: 3 degrees of yaw and (2, 3, 1.5) mm over 24 frames, 2 mm voxels.
    frames, shape, vs = 24, (220, 220, 110), 2.0
    total, largest, means = 0.0, 0, []
    for f in range(frames):
        u0, u1 = f / frames, (f + 1) / frames
        S = slices(shape, np.array([2.0, 3.0, 1.5]) * u0 / vs, 3.0 * u0, np.array([2.0, 3.0, 1.5]) * u1 / vs,
                   3.0 * u1)
        total += S.mean() * np.prod(shape)
        largest = max(largest, int(S.max()))
        means.append(S.mean())
    print(f"| 24 frames of a drift | 220x220x110 | {np.mean(means):.2f} | {largest} | {total / 1e9:.3f} G | "
          f"{total / RATE * 1e3:.3f} |")


if __name__ == "__main__":
    main()
