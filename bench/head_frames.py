"""Dynamic PET frames of a moving head, made without petblur's operators.

The truth that `petblur motion estimate` is measured against: a head phantom
defined in world coordinates (mm), three tissues whose uptake changes from
frame to frame, moved by a known rigid track about a pivot near the neck
(drift, a nod, and a jerk inside one frame), resampled by scipy onto the
frames' grid at many instants of each frame, blurred to PET resolution and
drawn with Poisson noise at a short frame's counts.

    frames, affine, bounds, truth = simulate(Setup(...), rng)

frames is [x, y, z, t] float32 in the world of affine (voxel index to RAS+ mm,
nibabel's img.affine); truth(t) gives the 4x4 world map that takes a point of
the reference frame's object (frame 0, which holds still) to where it is at
time t. displacement_errors() measures a track against it as users do: the
displacement of points inside the head, in mm, averaged over each frame.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation, Slerp

# Half-axes of the head (mm): an adult head about 18 x 22 x 20 cm.
HEAD = np.array([72.0, 90.0, 80.0])
# The pivot of nods and jerks: near the neck, below and behind the brain.
PIVOT = np.array([0.0, -20.0, -75.0])


@dataclasses.dataclass
class Setup:
    shape: tuple = (64, 64, 56)
    voxel: tuple = (3.0, 3.0, 3.0)
    frames: int = 24
    frame_seconds: float = 10.0
    oblique_deg: float = 0.0        # the grid turned about an oblique axis in the world
    las: bool = False               # x axis flipped (LAS+ storage, as many scanners write)
    counts: float = 2e6             # counts per frame inside the field of view
    fwhm_mm: float = 5.0            # the scanner's resolution
    jerk_frame: int = 15
    jerk_at: float = 0.43           # fraction of the jerk frame at which the jerk starts
    jerk_deg: float = 10.0
    jerk_mm: float = 8.0
    jerk_seconds: float = 0.5
    nod_deg: float = 3.0
    drift_mm: float = 2.0


def affine_of(s: Setup) -> np.ndarray:
    """Voxel index to world mm, the grid centred on the world's origin."""
    d = np.diag(s.voxel).astype(float)
    if s.las:
        d[0, 0] = -d[0, 0]
    if s.oblique_deg:
        d = Rotation.from_rotvec(np.deg2rad(s.oblique_deg) * np.array([1.0, 0.4, -0.3]) /
                                 np.linalg.norm([1.0, 0.4, -0.3])).as_matrix() @ d
    a = np.eye(4)
    a[:3, :3] = d
    centre_index = (np.array(s.shape) - 1) / 2.0
    a[:3, 3] = -d @ centre_index
    return a


class Truth:
    """The head's motion: 4x4 world maps about the world's origin."""

    def __init__(self, s: Setup):
        self.s = s
        T = s.frame_seconds
        self.t_end = s.frames * T
        self.jerk_t0 = (s.jerk_frame + s.jerk_at) * T

    def __call__(self, t: float) -> np.ndarray:
        s, T = self.s, self.s.frame_seconds
        # drift: a slow slide that starts after the reference frame
        u = np.clip((t - T) / (self.t_end - T), 0.0, 1.0)
        drift = s.drift_mm * u * np.array([0.6, -0.5, 0.62])
        drift_rot = Rotation.from_rotvec(np.deg2rad(1.0) * u * np.array([0.0, 0.0, 1.0]))
        # a nod: down and back up over frames 4 to 10, smooth
        a, b = 4 * T, 10 * T
        nod = np.sin(np.pi * np.clip((t - a) / (b - a), 0.0, 1.0)) ** 2 * s.nod_deg
        nod_rot = Rotation.from_rotvec(np.deg2rad(nod) * np.array([1.0, 0.0, 0.0]))
        # a jerk: 10 degrees and 8 mm in half a second, then held
        j = np.clip((t - self.jerk_t0) / s.jerk_seconds, 0.0, 1.0)
        j = j * j * (3 - 2 * j)
        jerk_axis = np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
        jerk_rot = Rotation.from_rotvec(np.deg2rad(s.jerk_deg) * j * jerk_axis)
        jerk_move = s.jerk_mm * j * np.array([0.8, 0.6, 0.0])
        # about the pivot: p' = R (p - pivot) + pivot + t
        r = (drift_rot * jerk_rot * nod_rot).as_matrix()
        m = np.eye(4)
        m[:3, :3] = r
        m[:3, 3] = PIVOT - r @ PIVOT + drift + jerk_move
        return m


def _tissues(points: np.ndarray) -> np.ndarray:
    """Three tissue maps (grey, white, blood) at world points [N, 3], smooth-edged."""
    def soft(inside, width=1.5):
        return 0.5 * (1.0 + np.tanh(inside / width))

    def ellipsoid(p, c, r):
        q = (p - c) / r
        return (1.0 - np.sqrt(np.sum(q * q, axis=1))) * np.min(r)

    brain = ellipsoid(points, np.array([0, 0, 5.0]), HEAD - np.array([10.0, 10.0, 12.0]))
    white = ellipsoid(points, np.array([0, 0, 8.0]), HEAD - np.array([24.0, 26.0, 30.0]))
    ventricles = np.maximum(ellipsoid(points, np.array([-10.0, 5.0, 15.0]), np.array([6.0, 22.0, 10.0])),
                            ellipsoid(points, np.array([10.0, 5.0, 15.0]), np.array([6.0, 22.0, 10.0])))
    striatum = np.maximum(ellipsoid(points, np.array([-22.0, 12.0, 5.0]), np.array([7.0, 13.0, 9.0])),
                          ellipsoid(points, np.array([22.0, 12.0, 5.0]), np.array([7.0, 13.0, 9.0])))
    cerebellum = ellipsoid(points, np.array([0.0, -50.0, -40.0]), np.array([45.0, 25.0, 18.0]))
    scalp = ellipsoid(points, np.zeros(3), HEAD)
    sinus = ellipsoid(points, np.array([0.0, -62.0, 20.0]), np.array([4.0, 12.0, 40.0]))
    grey = soft(brain) * (1 - soft(white)) + 1.5 * soft(striatum) + soft(cerebellum)
    white_m = soft(white) * (1 - soft(ventricles)) * (1 - soft(striatum))
    blood = 0.3 * soft(scalp) * (1 - soft(brain)) + 2.0 * soft(sinus)
    return np.stack([grey, 0.35 * white_m, blood])


def uptake(t: float) -> np.ndarray:
    """Tissue activities at time t (s): tracer leaves the blood for grey and white matter (grey to
    blood falls from 1 : 2 to 3 : 1 over four minutes)."""
    return np.array([0.6 + 0.4 * (1.0 - np.exp(-t / 60.0)), 0.5 + 0.5 * (1.0 - np.exp(-t / 150.0)),
                     0.3 + 1.2 * np.exp(-t / 30.0)])


def simulate(s: Setup, rng: np.random.Generator, steps: int = 6, jerk_steps: int = 80):
    """Frames [x, y, z, t] float32, their affine, bounds (s) and the truth."""
    affine = affine_of(s)
    truth = Truth(s)
    # the object on a fine world grid, 1.5 mm, once: scipy resamples it at every instant
    fine = 1.5
    extent = HEAD + 12.0
    axes = [np.arange(-e, e + fine / 2, fine) for e in extent]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    tissue = _tissues(grid).reshape((3,) + tuple(len(a) for a in axes)).astype(np.float32)
    origin = np.array([a[0] for a in axes])
    shape = s.shape
    idx = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), axis=-1).reshape(-1, 3)
    world = idx @ affine[:3, :3].T + affine[:3, 3]
    bounds = np.arange(s.frames + 1) * s.frame_seconds
    sigma = s.fwhm_mm / 2.3548 / np.array(s.voxel)
    frames = np.zeros(shape + (s.frames,), np.float32)
    for k in range(s.frames):
        n = jerk_steps if k == s.jerk_frame else steps
        times = bounds[k] + (np.arange(n) + 0.5) / n * s.frame_seconds
        acc = np.zeros(shape, np.float64)
        for t in times:
            m = truth(t)
            # tomograph point w shows the object at M^-1 w
            inv = np.linalg.inv(m)
            obj = world @ inv[:3, :3].T + inv[:3, 3]
            coords = ((obj - origin) / fine).T
            act = uptake(t)
            for c in range(3):
                acc += act[c] * ndimage.map_coordinates(tissue[c], coords, order=1, mode="constant",
                                                        cval=0.0).reshape(shape)
        acc /= n
        acc = ndimage.gaussian_filter(acc, sigma, mode="constant")
        expected = acc * (s.counts / acc.sum())
        noisy = rng.poisson(np.maximum(expected, 0.0)).astype(np.float64)
        # what a reconstruction's post-filter leaves of the noise's grain
        noisy = ndimage.gaussian_filter(noisy, 0.5 * sigma, mode="constant")
        frames[..., k] = noisy / s.frame_seconds
    return frames, affine, bounds, truth


def head_points(rng: np.random.Generator, n: int = 4000) -> np.ndarray:
    """World points inside the brain, where the error is measured."""
    r = HEAD - np.array([10.0, 10.0, 12.0])
    p = rng.uniform(-1, 1, size=(4 * n, 3))
    p = p[np.sum(p * p, axis=1) < 1.0][:n]
    return p * r + np.array([0, 0, 5.0])


def track_maps(times: np.ndarray, maps: np.ndarray):
    """A piecewise-linear track of 4x4 maps (LERP, SLERP), as petblur interpolates one."""
    rot = Slerp(times, Rotation.from_matrix(maps[:, :3, :3]))

    def at(t):
        t = np.clip(t, times[0], times[-1])
        m = np.eye(4)
        m[:3, :3] = rot([t]).as_matrix()[0]
        m[:3, 3] = [np.interp(t, times, maps[:, i, 3]) for i in range(3)]
        return m
    return at


def displacement_errors(track, truth, bounds, points, samples: int = 40) -> np.ndarray:
    """Per frame: the mean over the frame's time and the points of |M(t) p - M_true(t) p|, mm."""
    out = []
    for k in range(len(bounds) - 1):
        times = bounds[k] + (np.arange(samples) + 0.5) / samples * (bounds[k + 1] - bounds[k])
        e = 0.0
        for t in times:
            a, b = track(t), truth(t)
            e += np.mean(np.linalg.norm(points @ (a[:3, :3] - b[:3, :3]).T + (a[:3, 3] - b[:3, 3]), axis=1))
        out.append(e / samples)
    return np.array(out)


def write_series(directory, frames, affine, bounds, name: str = "frames") -> tuple:
    """The frames [x, y, z, t] as NIfTI (name.nii.gz) and their BIDS-PET sidecar (name.json: FrameTimesStart,
    FrameDuration) in directory, as petblur motion estimate --frames-from reads them: their two paths."""
    import json
    import os

    import nibabel as nib  # here: the module's other users need no nibabel
    nii, side = os.path.join(directory, name + ".nii.gz"), os.path.join(directory, name + ".json")
    nib.save(nib.Nifti1Image(frames, affine), nii)
    with open(side, "w") as f:
        json.dump({"FrameTimesStart": bounds[:-1].tolist(), "FrameDuration": np.diff(bounds).tolist()}, f)
    return nii, side


def read_matrix_csv(path) -> tuple:
    """A matrix-csv track (t, r00, r01, r02, tx, ...) read with numpy, not petblur."""
    rows = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    maps = np.tile(np.eye(4), (len(rows), 1, 1))
    maps[:, :3, :] = rows[:, 1:13].reshape(-1, 3, 4)
    return rows[:, 0], maps
