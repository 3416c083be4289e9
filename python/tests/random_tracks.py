"""A fresh random track for the operators' tests: n samples over seconds,
each pose a turn of up to max_deg about a random axis and a shift of up to
max_mm along each axis."""

import numpy as np

import petblur


def random_track(rng, n, seconds, max_deg, max_mm):
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    half = np.radians(rng.uniform(0, max_deg, n)) / 2
    q = np.c_[np.cos(half), np.sin(half)[:, None] * axes]
    return petblur.Motion(np.linspace(0, seconds, n), rng.uniform(-max_mm, max_mm, (n, 3)), q)
