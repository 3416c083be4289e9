#!/usr/bin/env python3
"""Motion from the frames on a family of fresh series (issue 47): petblur motion estimate beside SimpleITK.

Each draw is a dynamic head series made with scipy from parameters drawn at random, with its known truth:

- the grid: voxels of 2-4 mm (anisotropic), stored RAS or LAS, turned 0-20 degrees about a random oblique axis;
- the frames: a protocol from injection (early frames of 2-10 s, then 30-60 s, while the tracer arrives) or a late
  scan of equal frames of 2-60 s;
- the motion about a pivot near the neck: a slow drift, one or two nods, one or two jerks of 3-12 degrees and 2-10 mm
  in 0.3-1.5 s at random times and axes, inside a frame or across a frame boundary;
- the tracer: grey and white matter, blood and one to three lesions, each with its own curve (rising, washing out or
  steady), Poisson counts of a few to tens per head voxel in the average frame (as the frame's length: a 2 s frame
  from injection gets few), the scanner's resolution 4-6 mm.

petblur runs as a user runs it (`petblur motion estimate` on a 4-D NIfTI and its BIDS-PET sidecar, defaults); the peer
is SimpleITK's rigid registration of every frame to the frame petblur took as its reference (its default chooses one;
three levels, correlation or Mattes mutual information: --sitk-metric). The error is what users measure: the
displacement of points inside the head between the estimated and the true motion, mean over each frame's time, in mm;
per draw its mean and worst frame. Each track is judged relative to its own reference frame R: the truth re-expressed
against its mean pose over R (the truth holds still over frame 0, so relative to frame 0 that is the truth as drawn).
Beside them, the best that one pose a frame can do (the truth's mean pose over each frame, joined by lines between the
frames' middles), which motion inside frames can beat, and the same poses through a monotone cubic as the estimate's
track joins still frames (`frame_means_curved`). Writes draws.jsonl (one line a draw, as it finishes) and family.md into --out.

    python3 bench/estimate_family.py --petblur build/src/cli/petblur --draws 20 --jobs 2 --out /tmp/family
    python3 bench/estimate_family.py ... --seed 123 --seed 456          # replay draws
"""
from __future__ import annotations

import argparse
import concurrent.futures
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import estimate_validation as ev  # noqa: E402
import head_frames as hf  # noqa: E402

# Early frames of a scan from injection (s), a common shape of dynamic protocols (e.g. 6 x 10, 4 x 30, then 60 s)
EARLY = ((2.0, 10.0, 4, 8), (30.0, 30.0, 3, 5), (60.0, 60.0, 3, 8))


@dataclasses.dataclass
class Draw:
    seed: int
    shape: tuple
    voxel: tuple
    las: bool
    oblique_deg: float
    oblique_axis: tuple
    bounds: tuple            # frame boundaries, s from the scan's start
    start_s: float           # the scan's start after injection, s
    counts_per_voxel: float  # counts a head voxel gets in a frame, on average
    fwhm_mm: float
    pivot: tuple
    drift_mm: tuple
    drift_deg: float
    nods: list               # (start s, length s, degrees, axis)
    jerks: list              # (start s, length s, degrees, axis, mm, direction)
    curves: list             # per tissue: (early level, late level, time constant s)
    lesions: list            # (centre mm, radius mm)


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def draw(seed: int) -> Draw:
    rng = np.random.default_rng(seed)
    voxel = tuple(float(v) for v in np.round(rng.uniform(2.0, 4.0, 3), 2))
    # the field of view holds the head (about 170 x 210 x 190 mm) with a margin
    shape = tuple(int(np.ceil(e / v)) + 6 for e, v in zip(2 * hf.HEAD + 20.0, voxel))
    if rng.random() < 0.5:  # from injection
        bounds, t = [0.0], 0.0
        for lo, hi, nmin, nmax in EARLY:
            for _ in range(int(rng.integers(nmin, nmax + 1))):
                t += float(np.round(rng.uniform(lo, hi)))
                bounds.append(t)
        start = 0.0
    else:  # a late scan of equal frames
        length = float(np.round(rng.uniform(2.0, 60.0), 1))
        n = int(rng.integers(12, 25))
        bounds = list(np.arange(n + 1) * length)
        start = float(rng.uniform(600.0, 3600.0))
    bounds = tuple(float(b) for b in bounds)
    t0, t1 = bounds[1], bounds[-1]  # the truth holds still over frame 0

    def when(length):
        return float(rng.uniform(t0, max(t0, t1 - length)))

    nods = []
    for _ in range(int(rng.integers(1, 3))):
        length = float(rng.uniform(0.1, 0.4) * (t1 - t0))
        nods.append((when(length), length, float(rng.uniform(2.0, 6.0) * rng.choice([-1, 1])),
                     tuple(_unit([1.0, *rng.normal(0, 0.3, 2)]))))
    jerks = []
    for _ in range(int(rng.integers(1, 3))):
        length = float(rng.uniform(0.3, 1.5))
        if rng.random() < 0.5:  # centred on a frame boundary after frame 0
            b = bounds[int(rng.integers(2, len(bounds) - 1))]
            at = b - length / 2
        else:  # inside a frame
            k = int(rng.integers(1, len(bounds) - 1))
            at = bounds[k] + rng.uniform(0.1, 0.9) * max(bounds[k + 1] - bounds[k] - length, 0.0)
        jerks.append((float(at), length, float(rng.uniform(3.0, 12.0) * rng.choice([-1, 1])),
                      tuple(_unit(rng.normal(size=3))), float(rng.uniform(2.0, 10.0)),
                      tuple(_unit(rng.normal(size=3)))))
    kinds = {"rises": lambda: (rng.uniform(0.2, 0.6), 1.0, rng.uniform(60, 600)),
             "washes out": lambda: (1.0, rng.uniform(0.2, 0.6), rng.uniform(20, 300)),
             "steady": lambda: (1.0, 1.0, 1.0)}
    curves = []
    for tissue in ("grey", "white", "blood", "lesions"):
        kind = "washes out" if tissue == "blood" else str(rng.choice(list(kinds)))
        e, late, tau = kinds[kind]()
        curves.append((float(e), float(late), float(tau)))
    lesions = []
    for _ in range(int(rng.integers(1, 4))):
        c = rng.uniform(-1, 1, 3) * (hf.HEAD - 35.0) + np.array([0.0, 0.0, 5.0])
        lesions.append((tuple(float(x) for x in c), float(rng.uniform(4.0, 8.0))))
    return Draw(seed=seed, shape=shape, voxel=voxel, las=bool(rng.random() < 0.5),
                oblique_deg=float(rng.uniform(0.0, 20.0)), oblique_axis=tuple(_unit(rng.normal(size=3))),
                bounds=bounds, start_s=start, counts_per_voxel=float(np.exp(rng.uniform(np.log(3), np.log(40)))),
                fwhm_mm=float(rng.uniform(4.0, 6.0)),
                pivot=tuple(float(x) for x in hf.PIVOT + rng.normal(0, [10.0, 10.0, 10.0])),
                drift_mm=tuple(float(x) for x in rng.normal(0, 1.5, 3)), drift_deg=float(rng.uniform(-2.0, 2.0)),
                nods=nods, jerks=jerks, curves=curves, lesions=lesions)


def affine_of(d: Draw) -> np.ndarray:
    """Voxel index to world mm, the grid centred on the world's origin."""
    m = np.diag(d.voxel).astype(float)
    if d.las:
        m[0, 0] = -m[0, 0]
    m = Rotation.from_rotvec(np.deg2rad(d.oblique_deg) * np.array(d.oblique_axis)).as_matrix() @ m
    a = np.eye(4)
    a[:3, :3] = m
    a[:3, 3] = -m @ ((np.array(d.shape) - 1) / 2.0)
    return a


class Truth:
    """The head's motion: 4x4 world maps about the world's origin, still over frame 0."""

    def __init__(self, d: Draw):
        self.d = d

    def __call__(self, t: float) -> np.ndarray:
        d = self.d
        t0, t1 = d.bounds[1], d.bounds[-1]
        u = float(np.clip((t - t0) / (t1 - t0), 0.0, 1.0))
        r = Rotation.from_rotvec(np.deg2rad(d.drift_deg * u) * np.array([0.0, 0.0, 1.0]))
        move = u * np.array(d.drift_mm)
        for at, length, deg, axis in d.nods:  # down and back up, smooth
            s = np.sin(np.pi * np.clip((t - at) / length, 0.0, 1.0)) ** 2
            r = Rotation.from_rotvec(np.deg2rad(deg * s) * np.array(axis)) * r
        for at, length, deg, axis, mm, direction in d.jerks:  # and held
            j = np.clip((t - at) / length, 0.0, 1.0)
            j = j * j * (3 - 2 * j)
            r = Rotation.from_rotvec(np.deg2rad(deg * j) * np.array(axis)) * r
            move = move + mm * j * np.array(direction)
        p = np.array(d.pivot)
        m = np.eye(4)
        m[:3, :3] = r.as_matrix()
        m[:3, 3] = p - m[:3, :3] @ p + move
        return m

    def changes(self, t0: float, t1: float) -> bool:
        """Whether a jerk or a nod moves the head inside [t0, t1] (more time steps there)."""
        spans = [(a, a + n) for a, n, *_ in self.d.nods + self.d.jerks]
        return any(a < t1 and b > t0 for a, b in spans)


def uptake(d: Draw, t: float) -> np.ndarray:
    """Each tissue's activity at scan time t: from its early level to its late one with its time constant."""
    s = d.start_s + t
    return np.array([late + (e - late) * np.exp(-s / tau) for e, late, tau in d.curves])


def _lesions(d: Draw, points: np.ndarray) -> np.ndarray:
    out = np.zeros(len(points))
    for c, r in d.lesions:
        q = np.linalg.norm(points - np.array(c), axis=1)
        out = np.maximum(out, 0.5 * (1.0 + np.tanh((r - q) / 1.0)))
    return 3.0 * out


class Scene:
    """A draw's head seen on its frames' grid: the tissues on a fine world grid, the grid's voxel centres in the
    world, the scanner's blur (sigma, voxels) and the voxels inside the head. What simulate renders frames from, and
    bench/estimate_floor.py its frames' expected counts."""

    def __init__(self, d: Draw):
        self.d, self.fine = d, 1.5
        axes = [np.arange(-e, e + self.fine / 2, self.fine) for e in hf.HEAD + 12.0]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        self.tissue = np.concatenate([hf._tissues(grid), _lesions(d, grid)[None]]).reshape(
            (4,) + tuple(len(a) for a in axes)).astype(np.float32)
        self.origin = np.array([a[0] for a in axes])
        affine = affine_of(d)
        idx = np.stack(np.meshgrid(*[np.arange(n) for n in d.shape], indexing="ij"), axis=-1).reshape(-1, 3)
        self.world = idx @ affine[:3, :3].T + affine[:3, 3]
        self.sigma = d.fwhm_mm / 2.3548 / np.array(d.voxel)
        self.head = np.count_nonzero(hf._tissues(self.world).sum(axis=0) > 0.5)

    def sample(self, m: np.ndarray, t: float, levels: np.ndarray = None) -> np.ndarray:
        """The activity at scan time t (each tissue at levels; default its uptake then), the head where the 4x4
        world map m puts it, at the grid's voxels, before the scanner's blur."""
        inv = np.linalg.inv(m)
        coords = (((self.world @ inv[:3, :3].T + inv[:3, 3]) - self.origin) / self.fine).T
        levels = uptake(self.d, t) if levels is None else levels
        activity = np.tensordot(levels.astype(np.float32), self.tissue, axes=1)
        return ndimage.map_coordinates(activity, coords, order=1, mode="constant").reshape(self.d.shape)


def instants(truth: Truth, t0: float, t1: float, steps: int = 4, moving_steps: int = 40) -> np.ndarray:
    """The instants a frame from t0 to t1 is rendered at: moving_steps where the head moves inside it, else steps
    (the uptake's change alone)."""
    n = moving_steps if truth.changes(t0, t1) else steps
    return t0 + (np.arange(n) + 0.5) / n * (t1 - t0)


def simulate(d: Draw, rng: np.random.Generator, steps: int = 4, moving_steps: int = 40, truth: Truth = None):
    """Frames [x, y, z, t] float32 (Bq/mL-like: counts per second), their affine, bounds and the truth (the draw's
    own unless given)."""
    affine, truth, scene = affine_of(d), truth or Truth(d), Scene(d)
    sigma, head = scene.sigma, scene.head
    b = np.array(d.bounds)
    lengths = np.diff(b)
    frames = np.zeros(d.shape + (len(b) - 1,), np.float32)
    for k in range(len(b) - 1):
        ts = instants(truth, b[k], b[k + 1], steps, moving_steps)
        acc = np.zeros(d.shape, np.float64)
        for t in ts:
            acc += scene.sample(truth(t), t)
        acc = ndimage.gaussian_filter(acc / len(ts), sigma, mode="constant")
        # counts as the frame's length: the average frame's counts_per_voxel, a short early frame's few
        expected = acc * (d.counts_per_voxel * head * lengths[k] / lengths.mean() / acc.sum())
        noisy = ndimage.gaussian_filter(rng.poisson(np.maximum(expected, 0.0)).astype(np.float64), 0.5 * sigma,
                                        mode="constant")
        frames[..., k] = noisy / (b[k + 1] - b[k])
    return frames, affine, b, truth


def mean_map(maps: np.ndarray) -> np.ndarray:
    """The mean of 4x4 rigid maps: their rotations' mean and their translations' mean."""
    m = np.eye(4)
    m[:3, :3] = Rotation.from_matrix(maps[:, :3, :3]).mean().as_matrix()
    m[:3, 3] = maps[:, :3, 3].mean(axis=0)
    return m


def frame_means(truth: Truth, bounds, samples: int = 40):
    """The best one pose a frame can do: the truth's mean pose over each frame, at the frame's middle, interpolated
    between them as the SimpleITK track is. What bounds a method that gives each frame one pose; motion inside
    frames (pass 3) can do better."""
    maps = [mean_map(np.array([truth(t) for t in bounds[k] + (np.arange(samples) + 0.5) / samples *
                               (bounds[k + 1] - bounds[k])])) for k in range(len(bounds) - 1)]
    mids = 0.5 * (bounds[:-1] + bounds[1:])
    return np.concatenate([[bounds[0]], mids, [bounds[-1]]]), np.array([maps[0]] + maps + [maps[-1]])


def curved(times, maps, keys: int = 8):
    """A track's keys with a monotone cubic between consecutive frames' middles (scipy's PchipInterpolator per
    component on a chart about the first key: translations and rotation vectors), keys - 1 poses on it between each
    two, as the estimate lays its track through still frames (src/estimate/track_curve.c). For frame_means' track,
    whose every key is a middle but the series' ends, which hold the first and last frames' poses."""
    from scipy.interpolate import PchipInterpolator
    times, maps = np.asarray(times, float), np.asarray(maps, float)
    base = Rotation.from_matrix(maps[0, :3, :3])
    comp = np.array([np.concatenate([m[:3, 3], (base.inv() * Rotation.from_matrix(m[:3, :3])).as_rotvec()])
                     for m in maps])
    f = PchipInterpolator(times, comp, axis=0)
    inner = [times[0]]
    for k in range(1, len(times)):
        if 1 < k < len(times) - 1:  # between two middles
            inner += list(times[k - 1] + (np.arange(1, keys) / keys) * (times[k] - times[k - 1]))
        inner.append(times[k])
    t = np.array(inner)
    out = np.tile(np.eye(4), (len(t), 1, 1))
    v = f(t)
    out[:, :3, :3] = (base * Rotation.from_rotvec(v[:, 3:])).as_matrix()
    out[:, :3, 3] = v[:, :3]
    return t, out


def frame_table(out: str, frames: int) -> dict:
    """What the program's table a frame says: moving (a path followed), unfollowed (the share of one pose's
    residual a path it does not follow explains, 0 where it names none) and jumped (a step laid at its start: the
    track holds each neighbour's pose to the boundary)."""
    lines = out.splitlines()
    head = next(i for i, line in enumerate(lines) if line.split()[:2] == ["frame", "start"])
    moving, unfollowed, jumped = [], [], []
    for k, line in enumerate(lines[head + 1:head + 1 + frames]):
        f, _, _, _, _, said = line.split(maxsplit=5)
        if int(f) != k:
            raise RuntimeError(f"the frame table's line {k} is {line!r}")
        moving.append(said.startswith("from "))
        unfollowed.append(float(said.split("explains ")[1].split()[0]) / 100 if said.startswith("not followed")
                          else 0.0)
        jumped.append("(the head jumped at its start)" in said)
    return {"moving": moving, "unfollowed": unfollowed, "jumped": jumped}


def step_distances(jumped: list, bounds, jerks) -> list:
    """For each boundary the track steps at (jumped[b]: before frame b), [b, s]: s seconds from the boundary to the
    nearest jerk's motion (0 where a jerk moves across it); a step far from every jerk is laid where the head moved
    otherwise (a nod's fast part) or not at all."""
    out = []
    for b, j in enumerate(jumped):
        if not j:
            continue
        t = float(bounds[b])
        gaps = [max(at - t, t - (at + length), 0.0) for at, length, *_ in jerks]
        out.append([b, round(min(gaps), 2) if gaps else None])
    return out


def reference_said(out: str) -> int:
    """The frame the program's summary says the track is relative to."""
    line = next(x for x in out.splitlines() if x.strip().startswith("relative to frame "))
    return int(line.split()[3])


def one(petblur: str, seed: int, device: str, metric: str, threads: int, variants: dict = None,
        sitk: dict = None, sitk_reference: int = None) -> dict:
    """Draw `seed`, simulate it, estimate with petblur and SimpleITK: a dict of the draw and both errors; with
    variants ({name: {VARIABLE: value}}), petblur again under each variant's environment, in row["variants"]; with
    sitk (a row of an earlier run's draws.jsonl for the same seed), its SimpleITK result instead of running it."""
    d = draw(seed)
    rng = np.random.default_rng([seed, 1])
    frames, affine, bounds, truth = simulate(d, rng)
    points = hf.head_points(rng)
    row = {"seed": seed, "frames": len(bounds) - 1, "shape": list(d.shape), "voxel_mm": list(d.voxel),
           "frame_s": [round(float(x), 1) for x in (np.diff(bounds).min(), np.diff(bounds).max())],
           "from_injection": d.start_s == 0.0, "counts_per_voxel": round(d.counts_per_voxel, 1),
           "jerks": [(round(a, 1), round(n, 2), round(g, 1), round(m, 1)) for a, n, g, _, m, _ in d.jerks],
           "nods": [(round(a, 1), round(n, 1), round(g, 1)) for a, n, g, _ in d.nods]}

    means = frame_means(truth, bounds)

    def errors(times, maps, reference=0):
        """Relative to frame `reference`: a point of that frame's object lies at the truth's mean pose over it, so
        the track's maps, which start there, are compared after that pose."""
        track, anchor = hf.track_maps(times, maps), means[1][1 + reference]
        e = hf.displacement_errors(lambda t: track(t) @ anchor, truth, bounds, points)
        return {"mean_mm": round(float(e.mean()), 3), "max_mm": round(float(e.max()), 3),
                "worst_frame": int(e.argmax()), "per_frame_mm": [round(float(x), 3) for x in e],
                "reference": reference}

    row["frame_means"] = errors(*means)
    row["frame_means_curved"] = errors(*curved(*means))
    with tempfile.TemporaryDirectory() as tmp:
        nii, side = hf.write_series(tmp, frames, affine, bounds, "f")
        csv = os.path.join(tmp, "t.csv")
        started = time.perf_counter()
        if petblur is None:  # SimpleITK alone (--sitk-only), for a GPU run to take with --sitk-from
            row["petblur"] = {"mean_mm": float("nan"), "max_mm": float("nan"), "seconds": 0.0}
        else:
            r = subprocess.run([petblur, "motion", "estimate", nii, "--frames-from", side, "-o", csv,
                                "--device", device], capture_output=True, text=True)
            if r.returncode:
                raise RuntimeError(f"seed {seed}: petblur motion estimate exited {r.returncode}: "
                                   f"{r.stderr[-2000:]}")
            said, track = reference_said(r.stdout), hf.read_matrix_csv(csv)
            row["petblur"] = dict(errors(*track, said), seconds=round(time.perf_counter() - started, 1),
                                  frames=frame_table(r.stdout, len(bounds) - 1))
            row["petblur"]["steps"] = step_distances(row["petblur"]["frames"]["jumped"], bounds, d.jerks)
        for name, env in (variants or {}).items():
            if os.path.exists(csv):
                os.remove(csv)  # a variant that writes nothing must not be scored on the run before
            started = time.perf_counter()
            options = [x for k, v in env.items() if k.startswith("--") for x in (k, v)]
            r = subprocess.run([petblur, "motion", "estimate", nii, "--frames-from", side, "-o", csv,
                                "--device", device, *options], capture_output=True, text=True,
                               env=dict(os.environ, **{k: v for k, v in env.items() if not k.startswith("--")}))
            if r.returncode:
                raise RuntimeError(f"seed {seed}, variant {name}: petblur exited {r.returncode}: {r.stderr[-2000:]}")
            row.setdefault("variants", {})[name] = dict(errors(*hf.read_matrix_csv(csv), reference_said(r.stdout)),
                                                        seconds=round(time.perf_counter() - started, 1))
    # SimpleITK against the frame petblur took (or was told to take: sitk_reference)
    ref = sitk_reference if sitk_reference is not None else row["petblur"].get("reference", 0)
    row["none"] = errors(np.array([bounds[0], bounds[-1]]), np.array([np.eye(4)] * 2), ref)
    if sitk is not None:
        row["sitk"] = sitk
        return row
    started = time.perf_counter()
    row["sitk"] = dict(errors(*ev.sitk_track(frames, affine, bounds, threads, metric, ref), ref),
                       seconds=round(time.perf_counter() - started, 1))
    return row


def trust_summary(rows: list) -> list:
    """The frames the program's report says to trust less (motion shown inside that the track does not follow)
    beside the others, by their error: whether the report points at the frames that are off."""
    rows = [r for r in rows if "frames" in r["petblur"]]
    if not rows:
        return []
    kinds = {"followed (a path inside)": [], "not followed (reported)": [], "held still, none reported": []}
    worst_flagged, over1, over1_flagged = 0, 0, 0
    for r in rows:
        e, t = r["petblur"]["per_frame_mm"], r["petblur"]["frames"]
        for k, x in enumerate(e):
            flagged = t["unfollowed"][k] > 0
            kinds["followed (a path inside)" if t["moving"][k] else "not followed (reported)" if flagged
                  else "held still, none reported"].append(x)
            over1 += x > 1.0
            over1_flagged += x > 1.0 and flagged
        worst_flagged += t["unfollowed"][int(np.argmax(e))] > 0
    lines = ["", "Frames by what the report says of them (petblur's error a frame, mm):", "",
             "| frames | count | median | 90th percentile | worst |", "|---|---|---|---|---|"]
    for name, v in kinds.items():
        spread = " | ".join("%.3f" % x for x in np.percentile(v, [50, 90, 100])) if v else "- | - | -"
        lines.append("| %s | %d | %s |" % (name, len(v), spread))
    lines += ["", "Frames reported not followed: the draw's worst frame in %d of %d draws; %d of the %d frames over "
              "1 mm." % (worst_flagged, len(rows), over1_flagged, over1)]
    return lines + step_summary(rows)


def step_summary(rows: list) -> list:
    """The steps the track lays at boundaries (the report's "the head jumped at its start"), by how far the nearest
    true jerk's motion lies from the boundary, with the error of the frames either side against the true mean pose
    a frame through a monotone cubic (frame_means_curved): whether a step is laid where the head jumped."""
    rows = [r for r in rows if "steps" in r["petblur"]]
    if not rows:
        return []
    near, far = [], []
    for r in rows:
        e, bound = r["petblur"]["per_frame_mm"], r["frame_means_curved"]["per_frame_mm"]
        for b, gap in r["petblur"]["steps"]:
            side = (r["seed"], b, e[b - 1] + e[b], bound[b - 1] + bound[b])
            (near if gap is not None and gap <= 1.0 else far).append(side)
    lines = ["", "Steps laid at a boundary (the frames either side, the sum of their errors against the true mean "
             "pose a frame through a monotone cubic, mm):", "",
             "| steps | count | petblur, median | the bound, median | draw: boundary (petblur / bound) |",
             "|---|---|---|---|---|"]
    for name, v in (("within 1 s of a true jerk's motion", near), ("farther from every jerk", far)):
        listed = ", ".join("%d: %d (%.2f / %.2f)" % x for x in v[:8]) + (", ..." if len(v) > 8 else "")
        lines.append("| %s | %d | %s | %s | %s |" % (name, len(v), "%.3f" % np.median([x[2] for x in v]) if v else "-",
                                                    "%.3f" % np.median([x[3] for x in v]) if v else "-", listed or "-"))
    return lines


def summary(rows: list, metric: str) -> str:
    lines = [f"{len(rows)} draws; SimpleITK: every frame to petblur's reference frame, {metric}, three levels; "
             "each track judged relative to its reference frame", "",
             "| seed | frames | voxel mm | frame s | from injection | counts/voxel | jerks (at s, s, deg, mm) | "
             "reference | petblur mean / worst mm | SimpleITK mean / worst mm | true mean pose a frame mean / worst mm | "
             "none mean / worst mm | petblur s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append("| %d | %d | %s | %s | %s | %.1f | %s | %s | %.3f / %.3f | %.3f / %.3f | %.3f / %.3f | %.2f / %.2f "
                     "| %.1f |" % (
            r["seed"], r["frames"], "x".join("%.2f" % v for v in r["voxel_mm"]), "-".join("%g" % v for v in
                                                                                            r["frame_s"]),
            "yes" if r["from_injection"] else "no", r["counts_per_voxel"],
            "; ".join("%g, %g, %g, %g" % tuple(j) for j in r["jerks"]), r["petblur"].get("reference", "-"),
            r["petblur"]["mean_mm"],
            r["petblur"]["max_mm"],
            r["sitk"]["mean_mm"], r["sitk"]["max_mm"], r["frame_means"]["mean_mm"], r["frame_means"]["max_mm"],
            r["none"]["mean_mm"], r["none"]["max_mm"],
            r["petblur"]["seconds"]))
    pm = np.array([r["petblur"]["mean_mm"] for r in rows])
    pw = np.array([r["petblur"]["max_mm"] for r in rows])
    sm = np.array([r["sitk"]["mean_mm"] for r in rows])
    q = lambda v: "%.3f / %.3f / %.3f" % tuple(np.percentile(v, [50, 90, 100]))  # noqa: E731
    ran = not (np.isnan(pm).any() or np.isnan(sm).any())
    lines += ["", "| | median / 90th percentile / worst draw |", "|---|---|",
              f"| petblur mean mm | {q(pm)} |", f"| petblur worst frame mm | {q(pw)} |",
              f"| SimpleITK mean mm | {q(sm)} |",
              f"| true mean pose a frame, mean mm | {q(np.array([r['frame_means']['mean_mm'] for r in rows]))} |",
              *([f"| the same through a monotone cubic, mean mm | "
                 f"{q(np.array([r['frame_means_curved']['mean_mm'] for r in rows]))} |"]
                if all("frame_means_curved" in r for r in rows) else []),
              f"| petblur mean / SimpleITK's | {q(pm / sm)} |", ""]
    if not ran:  # a run with --no-sitk or --sitk-only: its targets are judged where both columns are merged
        lines.append("Issue 47's targets: not judged here (petblur or SimpleITK was not run; merge with --summarize).")
    else:
        lines.append("Issue 47's targets: median draw within 0.4 mm mean (%s) and 1.0 mm worst frame (%s); no draw "
                     "above 0.6 mm mean (%s); every draw at or below SimpleITK's mean (%d of %d)." % (
                         "met" if np.median(pm) <= 0.4 else "NOT met", "met" if np.median(pw) <= 1.0 else "NOT met",
                         "met" if pm.max() <= 0.6 else "NOT met", int(np.sum(pm <= sm)), len(rows)))
    lines += trust_summary(rows)
    # a variant of every draw only: runs merged for --summarize may each have run other variants
    names = sorted(set.intersection(*(set(r.get("variants", {})) for r in rows))) if rows else []
    if names:
        inj = np.array([r["from_injection"] for r in rows])
        lines += ["", "Variants (the same draws; petblur under each's environment):", "",
                  "| variant | mean, median / 90th / worst draw | worst frame, median | mean from injection, median "
                  "| mean late, median | at or below SimpleITK | below the default's mean |", "|---|---|---|---|---|---|---|"]
        for name in ["default"] + names:
            vm = pm if name == "default" else np.array([r["variants"][name]["mean_mm"] for r in rows])
            vw = pw if name == "default" else np.array([r["variants"][name]["max_mm"] for r in rows])
            lines.append("| %s | %s | %.3f | %s | %s | %s | %d of %d |" % (
                name, q(vm), np.median(vw), "%.3f" % np.median(vm[inj]) if inj.any() else "-",
                "%.3f" % np.median(vm[~inj]) if (~inj).any() else "-",
                "%d of %d" % (np.sum(vm <= sm), len(rows)) if ran else "-", int(np.sum(vm < pm)), len(rows)))
    return "\n".join(lines) + "\n"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--petblur", help="the program (not needed with --sitk-only)")
    p.add_argument("--draws", type=int, default=20, help="fresh draws (ignored with --seed)")
    p.add_argument("--seed", type=int, action="append", help="a draw to replay (repeatable)")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--device", default="auto", help="petblur's --device")
    p.add_argument("--sitk-metric", choices=("correlation", "mattes"), default="correlation")
    p.add_argument("--sitk-threads", type=int, default=2)
    p.add_argument("--variant", action="append", default=[], metavar="NAME:VAR=VALUE[,VAR=VALUE]",
                   help="petblur again on each draw with these environment variables (repeatable; to compare "
                        "estimator changes on the same draws)")
    p.add_argument("--sitk-from", metavar="DRAWS.JSONL", help="SimpleITK's results of an earlier run (its "
                   "draws.jsonl) for the draws it holds, not run again; replay its seeds with --seed")
    p.add_argument("--references-from", metavar="DRAWS.JSONL", help="with --sitk-only: register each draw's frames "
                   "to the reference frame petblur took in that run (its draws.jsonl), as a GPU run with --no-sitk "
                   "wrote it")
    p.add_argument("--no-sitk", action="store_true", help="petblur alone (its variants against its default): "
                   "SimpleITK's columns are NaN")
    p.add_argument("--sitk-only", action="store_true", help="SimpleITK alone, petblur's columns NaN: run it where "
                   "SimpleITK is (the host) for the seeds a GPU run then replays with --sitk-from")
    p.add_argument("--summarize", metavar="DRAWS.JSONL", help="no draws: the summary of an earlier run's rows, "
                   "SimpleITK's taken from --sitk-from where that holds the seed (a GPU run with --no-sitk beside a "
                   "host run with --sitk-only)")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    if not a.sitk_only and not a.petblur and not a.summarize:
        p.error("--petblur is needed (unless --sitk-only or --summarize)")
    if a.sitk_only and (a.no_sitk or a.sitk_from or a.variant):
        p.error("--sitk-only runs SimpleITK alone: not with --no-sitk, --sitk-from or --variant")
    references = {}
    if a.references_from:
        with open(a.references_from) as f:
            references = {r["seed"]: r["petblur"]["reference"] for r in map(json.loads, f)}
    earlier = {}
    if a.sitk_from:
        with open(a.sitk_from) as f:
            earlier = {r["seed"]: r["sitk"] for r in map(json.loads, f) if r.get("sitk")}
    variants = {}
    for v in a.variant:
        name, colon, assignments = v.partition(":")
        pairs = [x.split("=", 1) for x in assignments.split(",") if x]
        if not colon or not name or name == "default" or name in variants or not pairs or \
                any(len(x) != 2 or not x[0] for x in pairs):
            p.error(f"--variant {v!r}: give NAME:VAR=VALUE[,VAR=VALUE], a new NAME other than 'default'")
        variants[name] = dict(pairs)
    if a.summarize:
        with open(a.summarize) as f:
            rows = sorted(map(json.loads, f), key=lambda r: r["seed"])
        for r in rows:
            r["sitk"] = earlier.get(r["seed"], r["sitk"])
            if not np.isnan(r["sitk"]["mean_mm"]) and r["sitk"].get("reference", 0) != r["petblur"].get("reference", 0):
                p.error(f"seed {r['seed']}: SimpleITK's track is relative to frame {r['sitk'].get('reference', 0)}, "
                        f"petblur's to frame {r['petblur'].get('reference', 0)}: run --sitk-only with "
                        "--references-from the petblur run")
        os.makedirs(a.out, exist_ok=True)
        with open(os.path.join(a.out, "draws.jsonl"), "w") as f:
            f.writelines(json.dumps(r) + "\n" for r in rows)
        text = summary(rows, a.sitk_metric)
        with open(os.path.join(a.out, "family.md"), "w") as f:
            f.write(text)
        print(text)
        return 0
    seeds = a.seed or [int(s) for s in np.random.SeedSequence().generate_state(a.draws)]
    os.makedirs(a.out, exist_ok=True)
    rows = []
    with concurrent.futures.ProcessPoolExecutor(a.jobs) as pool, open(os.path.join(a.out, "draws.jsonl"), "w") as f:
        futures = [pool.submit(one, None if a.sitk_only else a.petblur, s, a.device, a.sitk_metric, a.sitk_threads,
                               variants,
                               {"mean_mm": float("nan"), "max_mm": float("nan"), "seconds": 0.0} if a.no_sitk
                               else earlier.get(s), references.get(s)) for s in seeds]
        for fut in concurrent.futures.as_completed(futures):
            r = fut.result()
            rows.append(r)
            f.write(json.dumps(r) + "\n")
            f.flush()
            print("seed %d: petblur %.3f / %.3f mm, SimpleITK %.3f / %.3f mm, none %.2f / %.2f mm (%d frames)" % (
                r["seed"], r["petblur"]["mean_mm"], r["petblur"]["max_mm"], r["sitk"]["mean_mm"],
                r["sitk"]["max_mm"], r["none"]["mean_mm"], r["none"]["max_mm"], r["frames"]) + "".join(
                "; %s %.3f / %.3f mm" % (n, x["mean_mm"], x["max_mm"]) for n, x in r.get("variants", {}).items()),
                flush=True)
    rows.sort(key=lambda r: r["seed"])
    text = summary(rows, a.sitk_metric)
    with open(os.path.join(a.out, "family.md"), "w") as f:
        f.write(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
