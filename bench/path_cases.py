#!/usr/bin/env python3
"""Issue 46's validation set: fresh random cases of rigid tracked motion,
each blurred by petblur from its logged track and compared with dense
references made without petblur's operators.

A case is an oblique anisotropic grid (turned 5-30 degrees about a random
axis, LAS or RAS, 2-4 mm voxels per axis), an object (sharp hot spheres on a
cold background, or a smooth brain: cortex, white matter, ventricles and hot
spots smoothed to 4.5 mm FWHM), a TRUE motion (a function of time) and the
LOGGED track a tracker gives of it (its samples at the tracker's rate, with
per-axis Gaussian noise on the translation and the matching rotation noise,
s / 80 mm radians, where the kind has noise). Kinds:

  still        a still head, 20 Hz log, noise 0.05-0.25 mm
  drift-1hz    a slow drift (a smoothed random walk of translation and
               rotation, 0.3-1 voxel over a 20-60 s frame), 1 Hz log, no noise
  drift-20hz   the same kind of drift, 20 Hz log with noise
  nod          2-4 degrees back and forth about the left-right axis through a
               pivot near the neck, 2-5 s period, 20 Hz log with noise
  seizure      8-12 degrees and 1-4 mm in 0.7-1.3 s at a random time inside
               the frame, 20 Hz log with noise
  rotation     20-60 degrees over the frame about a random axis, 10 Hz log
  translation  an oblique translation of 1-3 voxels at constant speed, 1 Hz log
  translation-long  the same 4-12 voxels long (2.3-12 along its major
               axis): one straight segment, mostly longer than AB reads
               exactly (PB_AB_EXACT_TO, 5 voxels along the major axis), so
               the walk's own error shows (docs/methods.md, "Long segments")

The references (accuracy_case.py's resampling): the mean over equally spaced
times of the frame of the activity resampled in world coordinates by scipy's
order-1 map_coordinates (zero outside), (a) under the true motion and (b)
under the logged track interpolated between its samples (LERP, SLERP).
The count of times is at least 400 and 20 per voxel of the longest path a
grid corner walks (the log's jitter included), so that consecutive times are
at most 1/20 voxel apart (a multiple of 3). Each reference reports how far
it is from the midpoint rule of a third of its times (every third time),
and with --doubling how far the reference of twice the times is from it. Errors as accuracy_case.errors: 100 ||d|| / ||ref|| and
100 max |d| / max |ref|. The motion's size: the largest distance between two
positions of a grid corner over the frame under the true motion, in voxels.

  path_cases.py [--device host] [--filters exact,hardware] [--methods ab,ab-sweep,rm] [--kinds ...]
                [--draws N] [--seed S] [--small] [--doubling] [--out DIR]

Each method runs at the defaults (max_path_error=None) on the logged track;
its time is the library's (last_device_ms), the median of 3 forwards after
a warm-up, or of 1 where the warm-up took over a second.

--small: grids of 22-26 voxels a side (the tests' size); else 48-64. Case
(draw d, kind k) is drawn from numpy's default_rng([S, d, k's index in
KINDS]), so --seed S replays every case of a run, with any --kinds."""

import argparse
import ctypes
import json
import os
import subprocess
import sys
import time
from types import SimpleNamespace

import numpy as np
from scipy import ndimage
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from accuracy_case import errors, mean_resampled, method_options, track_poses  # noqa: E402

KINDS = ("still", "drift-1hz", "drift-20hz", "nod", "seizure", "rotation", "translation", "translation-long")
HEAD_MM = 80.0  # rotation noise of s / HEAD_MM rad moves a point this far from the centre by s mm, as the translation's
TRUE_RATE_HZ = 100.0  # the true motion's samples for its petblur.Motion (segment counts only)
MIN_TIMES, TIMES_PER_VOXEL, MAX_TIMES = 400, 20, 20000


def _unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _smoothstep(u):
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3 - 2 * u)


def draw_grid(rng, small):
    """shape, voxel (mm), affine: turned 5-30 degrees about a random axis,
    LAS or RAS, centred within 5 mm of the world's origin."""
    shape = tuple(int(n) for n in (rng.integers(22, 27, 3) if small else rng.integers(48, 65, 3)))
    voxel = rng.uniform(2.0, 4.0, 3)
    las = bool(rng.random() < 0.5)
    turn = Rotation.from_rotvec(np.radians(rng.uniform(5.0, 30.0)) * _unit(rng))
    m = turn.as_matrix() @ np.diag([-1.0 if las else 1.0, 1.0, 1.0]) @ np.diag(voxel)
    a = np.eye(4)
    a[:3, :3] = m
    a[:3, 3] = -m @ ((np.array(shape) - 1) / 2.0) + rng.uniform(-5, 5, 3)
    return shape, voxel, a, "LAS" if las else "RAS"


def _world_points(shape, affine):
    ijk = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), -1).reshape(-1, 3)
    return ijk @ affine[:3, :3].T + affine[:3, 3]


def draw_object(rng, shape, voxel, affine, kind):
    """'spheres': 8-12 hot spheres (4-8) of 1.5-3.5 mean voxels' radius on 0;
    'brain': an ellipsoid of white matter (1) in a cortex (3) with hot spots
    (6) and ventricles (0.2), smoothed to 4.5 mm FWHM. Both inside the ball
    of half the inscribed radius about the grid's centre (plus the spheres'
    radii), so the motions keep them in view."""
    w = _world_points(shape, affine)
    centre = affine[:3, :3] @ ((np.array(shape) - 1) / 2.0) + affine[:3, 3]
    r_in = 0.5 * float(np.min(np.array(shape) * voxel))
    rel = w - centre
    x = np.zeros(len(w))
    if kind == "spheres":
        for _ in range(rng.integers(8, 13)):
            c = 0.5 * r_in * _unit(rng) * rng.random() ** (1 / 3)
            r = min(rng.uniform(1.5, 3.5) * voxel.mean(), 0.25 * r_in)
            x[np.linalg.norm(rel - c, axis=1) <= r] = rng.uniform(4.0, 8.0)
    else:
        axes = 0.6 * r_in * np.array([0.85, 1.0, 0.8]) * rng.uniform(0.9, 1.1, 3)
        e = np.sqrt(((rel / axes) ** 2).sum(1))
        x[e <= 1.0] = 3.0
        x[e <= 0.8] = 1.0
        for side in (-1.0, 1.0):
            v = np.array([0.18 * side, 0.0, 0.05]) * axes
            x[np.sqrt((((rel - v) / (axes * np.array([0.1, 0.35, 0.15]))) ** 2).sum(1)) <= 1.0] = 0.2
        for _ in range(rng.integers(3, 6)):
            c = 0.9 * axes * _unit(rng)
            x[np.linalg.norm(rel - c, axis=1) <= rng.uniform(1.5, 2.5) * voxel.mean()] = 6.0
    x = x.reshape(shape)
    if kind == "brain":
        x = ndimage.gaussian_filter(x, 4.5 / 2.3548 / voxel)
    return x.astype(np.float32), centre, r_in


def _corners(shape, affine):
    ijk = np.array([[i, j, k] for i in (0, shape[0] - 1) for j in (0, shape[1] - 1) for k in (0, shape[2] - 1)], float)
    return ijk @ affine[:3, :3].T + affine[:3, 3]


def _corner_paths(case, rot, tr):
    """Where the grid's corners go under the poses: (poses, 8, 3), in voxel
    index units (so distances are in voxels of the anisotropic grid)."""
    lin = np.linalg.inv(case.affine[:3, :3])
    c = case.center
    p = np.stack([rot.apply(q - c) + c + tr for q in _corners(case.shape, case.affine)], 1)
    return p @ lin.T


def motion_size(case, times=400):
    """The largest distance between two positions of a grid corner over the
    frame under the true motion, in voxels."""
    rot, tr = case.poses("true", np.linspace(*case.frame, times))
    p = _corner_paths(case, rot, tr)
    return float(max(np.linalg.norm(p[:, None, k] - p[None, :, k], axis=-1).max() for k in range(8)))


def path_length(case, which):
    """The longest path a grid corner walks over the frame, in voxels: the
    logged track's polyline through its samples inside the frame (its jitter
    included), or the true motion finely sampled."""
    t0, t1 = case.frame
    if which == "logged":
        inside = case.log_times[(case.log_times > t0) & (case.log_times < t1)]
        ts = np.concatenate([[t0], inside, [t1]])
    else:
        ts = np.linspace(t0, t1, 4000)
    p = _corner_paths(case, *case.poses(which, ts))
    return float(np.linalg.norm(np.diff(p, axis=0), axis=-1).sum(0).max())


def reference_times(case, which):
    """At least MIN_TIMES, TIMES_PER_VOXEL a voxel of the longest corner path,
    a multiple of 3 (reference's check takes every third)."""
    n = max(MIN_TIMES, int(np.ceil(TIMES_PER_VOXEL * path_length(case, which))))
    return min(MAX_TIMES, 3 * -(-n // 3))


def reference(case, which="true", times=None, check=False, doubling=False):
    """The dense blur of case.x over case.frame under the true motion or the
    logged track: the mean over `times` (None: reference_times) equally
    spaced times, the midpoints of equal pieces of the frame.

    check=True also returns how far the reference is from the midpoint rule
    of a third of its times (every third time, the middle one of each three,
    is that rule), as errors(ref, third): for a midpoint rule the error of n
    times is about 1/8 of that change where the blur is smooth in time. With
    doubling=True it also holds errors(ref of 2n times, ref), at twice the
    cost."""
    n = times or reference_times(case, which)
    if check:
        n = 3 * -(-n // 3)
    t0, t1 = case.frame
    ts = t0 + (np.arange(n) + 0.5) * (t1 - t0) / n
    rot, tr = case.poses(which, ts)
    if not check:
        return mean_resampled(case.x, case.affine, case.center, rot, tr)
    rest = np.flatnonzero(np.arange(n) % 3 != 1)
    third = mean_resampled(case.x, case.affine, case.center, rot[1::3], tr[1::3])
    ref = (third + 2.0 * mean_resampled(case.x, case.affine, case.center, rot[rest], tr[rest])) / 3.0
    e = errors(ref, third)
    out = {"times": n, "third_rms_pct": e["rms_pct"], "third_max_pct": e["max_pct"]}
    if doubling:
        e = errors(reference(case, which, 2 * n), ref)
        out.update(doubled_rms_pct=e["rms_pct"], doubled_max_pct=e["max_pct"])
    return ref, out


def draw_short_frame(kind, rng):
    """A small case of `kind` whose frame is cut to 1.5-3 s inside its log,
    as the first frames of a dynamic protocol: too few samples of a 20 Hz
    log to measure the tracker's noise in (src/paths/path_fit.c,
    window_noise)."""
    case = draw_case(kind, rng, small=True)
    length = rng.uniform(1.5, 3.0)
    start = rng.uniform(case.frame[0], case.frame[1] - length)
    case.frame = (start, start + length)
    return case


def noise_floor(case, times=400):
    """The dense blur of the true motion moved by the logged noise's mean
    over the frame (translations' and rotations' means of the log against
    the true motion, both interpolated over `times` midpoints): what no
    reading of a noisy log removes, since white noise's mean over a frame
    is indistinguishable from a motion still within it. A frame of n
    samples keeps it at sigma / sqrt(n) a axis."""
    t0, t1 = case.frame
    ts = t0 + (np.arange(times) + 0.5) * (t1 - t0) / times
    rt, tt = case.poses("true", ts)
    rl, tl = case.poses("logged", ts)
    return mean_resampled(case.x, case.affine, case.center, (rl * rt.inv()).mean() * rt, tt + (tl - tt).mean(0))


def _motion(times, rot, tr, center):
    import petblur
    q = rot.as_quat()
    return petblur.Motion(times, tr, np.column_stack([q[:, 3], q[:, :3]]), center=center)


def _drift(rng, seconds, scale_mm):
    """A smoothed random walk (knots every 2-5 s, a cubic spline through
    them) of translation (mm) and rotation (rad, the same size at HEAD_MM),
    zero at u = 0: a function of u in [0, seconds]."""
    step = rng.uniform(2.0, 5.0)
    knots = np.arange(0.0, seconds + step, step)
    walk = np.cumsum(rng.normal(size=(knots.size, 6)), axis=0)
    walk -= walk[0]
    walk[:, 3:] /= HEAD_MM
    spline = CubicSpline(knots, scale_mm * walk, axis=0)
    return lambda u: spline(np.clip(u, 0.0, seconds))


def draw_case(kind, rng, small):
    """One fresh case of `kind` (KINDS): a SimpleNamespace with shape, voxel,
    affine, orientation, object, x (float32), center (the poses' rotation
    centre, world mm), frame (t0, t1), log_times, log_rotations,
    log_translations, rate_hz, noise_mm, true_pose(u) (u seconds from t0 ->
    Rotation, translations), poses(which, ts), logged and true (petblur
    Motions), size_vox and params."""
    shape, voxel, affine, orientation = draw_grid(rng, small)
    obj = "spheres" if rng.random() < 0.5 else "brain"
    x, centre, r_in = draw_object(rng, shape, voxel, affine, obj)
    c = SimpleNamespace(kind=kind, shape=shape, voxel=voxel, affine=affine, orientation=orientation, object=obj, x=x)
    noise, params = 0.0, {}
    if kind == "still":
        seconds, rate, noise = rng.uniform(10, 30), 20.0, rng.uniform(0.05, 0.25)
        center = centre
        true = lambda u: (Rotation.identity(len(u)), np.zeros((len(u), 3)))  # noqa: E731
    elif kind in ("drift-1hz", "drift-20hz"):
        seconds = rng.uniform(20, 60)
        rate, noise = (1.0, 0.0) if kind == "drift-1hz" else (20.0, rng.uniform(0.05, 0.25))
        center = centre + rng.uniform(-20, 20, 3)
        f = _drift(rng, seconds, 1.0)
        c.center, c.frame = center, (0.0, seconds)
        unit = lambda u: (Rotation.from_rotvec(f(u)[:, 3:]), f(u)[:, :3])  # noqa: E731
        c.poses = lambda which, ts: unit(ts)
        target = rng.uniform(0.3, 1.0)
        k = target / motion_size(c)
        params = {"target_vox": target}
        true = lambda u: (Rotation.from_rotvec(k * f(u)[:, 3:]), k * f(u)[:, :3])  # noqa: E731
    elif kind == "nod":
        seconds, rate, noise = rng.uniform(10, 30), 20.0, rng.uniform(0.05, 0.25)
        amp, period, phase = np.radians(rng.uniform(2, 4)), rng.uniform(2, 5), rng.uniform(0, 2 * np.pi)
        center = centre + np.array([rng.uniform(-5, 5), -rng.uniform(10, 30), -rng.uniform(60, 90)])
        params = {"amplitude_deg": float(np.degrees(amp)), "period_s": period}
        true = lambda u: (Rotation.from_rotvec(  # noqa: E731
            np.outer(amp * np.sin(2 * np.pi * u / period + phase), [1.0, 0.0, 0.0])), np.zeros((len(u), 3)))
    elif kind == "seizure":
        seconds, rate, noise = rng.uniform(20, 30), 20.0, rng.uniform(0.05, 0.25)
        start, length = rng.uniform(0.2, 0.7) * seconds, rng.uniform(0.7, 1.3)
        turn = np.radians(rng.uniform(8, 12)) * _unit(rng)
        move = rng.uniform(1, 4) * _unit(rng)
        center = centre + rng.uniform(-15, 15, 3)
        params = {"turn_deg": float(np.degrees(np.linalg.norm(turn))), "start_s": start, "length_s": length}
        true = lambda u: (Rotation.from_rotvec(np.outer(_smoothstep((u - start) / length), turn)),  # noqa: E731
                          np.outer(_smoothstep((u - start) / length), move))
    elif kind == "rotation":
        seconds, rate = rng.uniform(10, 30), 10.0
        turn = np.radians(rng.uniform(20, 60)) * _unit(rng)
        center = centre + 0.1 * r_in * rng.uniform(-1, 1, 3)
        params = {"turn_deg": float(np.degrees(np.linalg.norm(turn)))}
        true = lambda u: (Rotation.from_rotvec(np.outer(_smoothstep(u / seconds), turn)),  # noqa: E731
                          np.zeros((len(u), 3)))
    elif kind in ("translation", "translation-long"):
        seconds, rate = rng.uniform(10, 30), 1.0
        target = rng.uniform(1, 3) if kind == "translation" else rng.uniform(4, 12)
        move = np.linalg.inv(affine[:3, :3]) @ _unit(rng)
        move = affine[:3, :3] @ (target * move / np.linalg.norm(move))  # target voxels of this grid, in mm
        center = centre
        params = {"target_vox": target}
        true = lambda u: (Rotation.identity(len(u)), np.outer(np.clip(u / seconds, 0, 1), move))  # noqa: E731
    else:
        raise ValueError(f"kind {kind!r}: one of {', '.join(KINDS)}")
    # The frame starts between two samples, and the log covers it.
    t0 = rng.uniform(0.0, 1.0 / rate)
    c.frame, c.center, c.rate_hz, c.noise_mm, c.params = (t0, t0 + seconds), center, rate, noise, params
    c.true_pose = lambda ts: true(np.asarray(ts, float) - t0)
    n = int(np.ceil((t0 + seconds) * rate)) + 1
    c.log_times = np.arange(n) / rate
    rot, tr = c.true_pose(c.log_times)
    c.log_translations = tr + rng.normal(0.0, noise, (n, 3)) if noise else tr
    c.log_rotations = Rotation.from_rotvec(rng.normal(0.0, noise / HEAD_MM, (n, 3))) * rot if noise else rot
    c.poses = lambda which, ts: (c.true_pose(ts) if which == "true" else
                                 track_poses(c.log_times, c.log_rotations, c.log_translations, ts))
    c.logged = _motion(c.log_times, c.log_rotations, c.log_translations, center)
    fine = np.linspace(c.log_times[0], c.log_times[-1], int(np.ceil((c.log_times[-1]) * TRUE_RATE_HZ)) + 1)
    c.true = _motion(fine, *c.true_pose(fine), center)
    c.size_vox = motion_size(c)
    return c


def path_segments(op, motion=None):
    """pb_path_segments: the segments AB and RM walk for `motion` (None: the
    operator's) on the operator's grid under its options."""
    import petblur._lib as lib
    m = op.motion if motion is None else motion
    g, cm, keep = m._c_motion(op._shape, op.voxel_size, op._affine, op._bounds, warn=False)
    n = ctypes.c_size_t()
    lib.check(lib.lib.pb_path_segments(ctypes.byref(g), ctypes.byref(cm), ctypes.byref(op._options), ctypes.byref(n)))
    del keep
    return int(n.value)


def measure(case, refs, method, filter, device, repeats=3):
    """petblur's forward of case.x under the logged track at the defaults:
    errors against each reference, the library's median time (ms) of
    `repeats` forwards after a warm-up (1 where the warm-up took over a
    second: the host on long logs), the wall time, and the segments of the
    logged track and of the true motion."""
    import petblur
    op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, filter=filter,
                              affine=case.affine, device=device, **method_options(method))
    x = np.asfortranarray(case.x)
    t = time.perf_counter()
    y = op(x)  # warm-up: on OpenCL the kernels' build
    if time.perf_counter() - t > 1.0:
        repeats = 1
    ms, wall = [], []
    for _ in range(repeats):
        t = time.perf_counter()
        y = op(x)
        wall.append(1e3 * (time.perf_counter() - t))
        ms.append(op.last_device_ms()[0])
    out = {"method": method, "filter": filter, "ms": float(np.median(ms)), "wall_ms": float(np.median(wall)),
           "segments": path_segments(op), "segments_true": path_segments(op, case.true)}
    for which, ref in refs.items():
        e = errors(ref, y)
        out[f"{which}_rms_pct"], out[f"{which}_max_pct"] = e["rms_pct"], e["max_pct"]
    return out


def describe(case):
    return {"kind": case.kind, "shape": list(case.shape), "voxel_mm": [round(float(v), 3) for v in case.voxel],
            "orientation": case.orientation, "object": case.object, "frame_s": [float(v) for v in case.frame],
            "rate_hz": case.rate_hz, "noise_mm": round(float(case.noise_mm), 4), "log_samples": int(len(case.log_times)),
            "size_vox": case.size_vox, "params": {k: round(float(v), 4) for k, v in case.params.items()}}


def grid_text(case):
    return (f"{'x'.join(map(str, case.shape))} of {'x'.join(f'{v:.1f}' for v in case.voxel)} mm "
            f"{case.orientation}, {case.object}")


def markdown(cases):
    lines = ["| case | kind | grid | motion (vox) | method | filter | vs true RMS % | vs true max % | "
             "vs logged RMS % | vs logged max % | ms | segments (true motion) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in cases:
        for r in c["rows"]:
            lines.append(f"| {c['name']} | {c['kind']} | {c['grid']} | {c['size_vox']:.2f} | {r['method']} | "
                         f"{r['filter']} | {r['true_rms_pct']:.3f} | {r['true_max_pct']:.3f} | "
                         f"{r['logged_rms_pct']:.3f} | {r['logged_max_pct']:.3f} | {r['ms']:.1f} | "
                         f"{r['segments']} ({r['segments_true']}) |")
    lines += ["", "References: times used; how far the midpoint rule of a third of them is from the reference "
              "(RMS % / max %); and, where measured, how far the reference of twice the times is:", "",
              "| case | noise mm | log | true: times | true: 1/3 | true: 2x | logged: times | logged: 1/3 | "
              "logged: 2x | logged vs true | reference s |", "|---|---|---|---|---|---|---|---|---|---|---|"]

    def pct(r, key):
        if key in r:
            r = {key + "_" + k: v for k, v in r[key].items()}
        return f"{r[key + '_rms_pct']:.4f} / {r[key + '_max_pct']:.4f}" if key + "_rms_pct" in r else "-"
    for c in cases:
        t, g = c["reference"]["true"], c["reference"]["logged"]
        lines.append(f"| {c['name']} | {c['noise_mm']:.3f} | {c['log_samples']} at {c['rate_hz']:g} Hz | "
                     f"{t['times']} | {pct(t, 'third')} | {pct(t, 'doubled')} | {g['times']} | {pct(g, 'third')} | "
                     f"{pct(g, 'doubled')} | {pct(c['reference'], 'logged_vs_true')} | "
                     f"{t['seconds'] + g['seconds']:.1f} |")
    return "\n".join(lines) + "\n"


def run_case(name, kind, rng, a):
    case = draw_case(kind, rng, a.small)
    refs, conv = {}, {}
    for which in ("true", "logged"):
        t = time.perf_counter()
        refs[which], conv[which] = reference(case, which, check=True, doubling=a.doubling)
        conv[which]["seconds"] = time.perf_counter() - t
    # What the tracker's noise alone does: the logged track's blur against the true motion's.
    e = errors(refs["true"], refs["logged"])
    conv["logged_vs_true"] = {"rms_pct": e["rms_pct"], "max_pct": e["max_pct"]}
    out = dict(describe(case), name=name, grid=grid_text(case), reference=conv, rows=[])
    print(f"{name}: {out['grid']}, motion {case.size_vox:.2f} voxels, noise {case.noise_mm:.3f} mm (its blur "
          f"{e['rms_pct']:.3f} % RMS, {e['max_pct']:.3f} % max of the true one's), references "
          f"{conv['true']['times']} / {conv['logged']['times']} times in "
          f"{conv['true']['seconds'] + conv['logged']['seconds']:.1f} s (a third of the times within "
          f"{conv['true']['third_max_pct']:.4f} / {conv['logged']['third_max_pct']:.4f} % max)", flush=True)
    for method in a.methods.split(","):
        for filter in a.filters.split(","):
            r = measure(case, refs, method, filter, a.device)
            out["rows"].append(r)
            print(f"  {method:8s} {filter:8s} true {r['true_rms_pct']:7.3f} % RMS {r['true_max_pct']:7.3f} % max   "
                  f"logged {r['logged_rms_pct']:7.3f} / {r['logged_max_pct']:7.3f}   {r['ms']:9.2f} ms  "
                  f"{r['segments']} segments ({r['segments_true']} true)", flush=True)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="host")
    ap.add_argument("--filters", default="exact,hardware")
    ap.add_argument("--methods", default="ab,ab-sweep,rm")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--draws", type=int, default=1)
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--small", action="store_true")
    ap.add_argument("--doubling", action="store_true", help="also the references of twice the times")
    ap.add_argument("--out", default="")
    a = ap.parse_args()
    seed = a.seed if a.seed is not None else int(np.random.SeedSequence().entropy % (1 << 32))
    print(f"seed {seed} (--seed {seed} replays these cases)", flush=True)
    start = time.perf_counter()
    cases = []
    for d in range(a.draws):
        for kind in a.kinds.split(","):
            rng = np.random.default_rng([seed, d, KINDS.index(kind)])
            cases.append(run_case(f"{d}:{kind}", kind, rng, a))
    seconds = time.perf_counter() - start
    print(f"{len(cases)} cases in {seconds:.0f} s")
    table = markdown(cases)
    print(table)
    if a.out:
        os.makedirs(a.out, exist_ok=True)
        here = os.path.dirname(os.path.abspath(__file__))
        commit = subprocess.run(["git", "-C", here, "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True).stdout.strip()
        with open(os.path.join(a.out, "path_cases.json"), "w") as f:
            json.dump({"argv": sys.argv[1:], "seed": seed, "commit": commit, "device": a.device,
                       "small": a.small, "seconds": seconds, "cases": cases}, f, indent=1)
        with open(os.path.join(a.out, "table.md"), "w") as f:
            f.write(table)


if __name__ == "__main__":
    main()
