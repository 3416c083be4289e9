#!/usr/bin/env python3
"""Issue 46's cost table: a dynamic study's frames under a slow head drift,
logged as trackers log it, through petblur.FramesOperator: what each log
costs against the memory floor, how many segments a frame gets, and how far
its forward is from dense references.

The study: --frames (24) frames of --frame-s (75) s on a grid of --shape
(220,220,110) voxels of 2 mm, a torch CUDA tensor in C order (--device host:
a numpy array, wall-clock times). The TRUE motion: a slow drift over the
whole study, a smoothed random walk of translation and rotation (knots every
20-40 s, a cubic spline through them, as path_cases' _drift), scaled to 2-5 mm
and 1-3 degrees at its largest, turning about a pivot 20 mm behind and 60 mm
below the grid's centre. The logged tracks of it (--tracks):

  1hz-walk     its 1 Hz samples plus a random walk's sample-to-sample jitter:
               steps of --walk-mm (0.03) per axis and the matching rotation
               (/ HEAD_MM rad), less the walk's own 10 s Gaussian smoothing,
               so the track is a random walk whose smoothing is the drift
  smooth       its 1 Hz samples, no jitter
  20hz-noisy   its 20 Hz samples with 0.05 mm Gaussian translation noise per
               axis and the matching rotation noise, s / HEAD_MM rad per axis
               (bench/path_cases.py's tracker model): a Polaris-like log
  20hz-0.2mm   the same with 0.2 mm

For each track and each bound of --bounds ("default": max_path_error None,
the library's 0.1 voxels): the forward of one activity into every frame
(F.apply) and the adjoint summed over the frames (F.adjoint(y, sum=True)),
each the median of --runs calls timed by CUDA events around the Python call
(bench/python_torch.py's event_ms), and the library's own device time of the
call (its device_ms: kernels, the input's copy into the texture apart); the
memory floor as bench/memory_floor.py's for these frames, one copy of the
frames' volumes (event_ms of dst.copy_(y)), and each call's ratio to it;
the segments AB walks per frame (pb_path_segments, the frame's own plan:
mean and max over the frames). The error of the forward, relative RMS and
max in percent (100 ||d|| / ||ref||, 100 max |d| / max |ref|, over the
frames --error-frames names, all by default), from two dense references on
the same device, each CL (the classical method, the exact filter) with
`steps` set so that the track between its samples is sampled at --ref-hz
(20) or more: (i) the LOGGED track (1 Hz: 20 steps an interval; 20 Hz: 1),
and (ii) the TRUE drift, a petblur.Motion of its samples at --ref-hz without
noise or jitter. The object: the brain of path_cases' draw_object (smoothed
to 4.5 mm FWHM) plus its sharp hot spheres.

Issue 46's targets, checked at the end: the 20 Hz noisy log within 1.3x the
time of its smooth motion (forward and adjoint, at each bound), and the
forward and the summed adjoint of either within 10x the memory floor.

  frames_cost.py [--device cuda:0] [--tracks 1hz-walk,smooth,20hz-noisy] [--bounds default,0.25]
                 [--shape 220,220,110] [--frames 24] [--frame-s 75] [--runs 10] [--seed 46046]
                 [--ref-hz 20] [--error-frames all | 0,11,23] [--out frames_cost.json]
  frames_cost.py --device host --shape 40,40,20 --frames 3 --runs 3     (the quick check on a CPU)

On an H200 (at 97be16e) the default run took 70 s after the package's build
(about 55 s, bash bench/gpu.sh frames: 127 s in all): the CL references,
each sampling every voxel of each frame 1500 times (one per track, and one
of the true drift), 1.6-2.7 s each; the 20 Hz log's AB calls 0.15-1.1 s
each, 16 of them each way per bound. --error-frames 0,11,23 cuts the
references to those frames, made one frame at a time by BlurOperator.

The seed (printed) draws the drift (default_rng([seed, 0])), each track's
jitter or noise (default_rng([seed, 1 + its index in TRACKS])) and the object
(default_rng([seed, 100])), so --seed replays a run with any --tracks."""

import argparse
import ctypes
import json
import math
import os
import statistics
import subprocess
import sys
import time

import numpy as np
from scipy import ndimage
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from path_cases import HEAD_MM, _motion, draw_object  # noqa: E402

VOXEL_MM = 2.0
# name: (rate Hz, tracker noise mm, random-walk jitter)
TRACKS = {"1hz-walk": (1.0, 0.0, True), "smooth": (1.0, 0.0, False), "20hz-noisy": (20.0, 0.05, False),
          "20hz-0.2mm": (20.0, 0.2, False)}
PIVOT_MM = np.array([0.0, -20.0, -60.0])  # the drift's rotation centre from the grid's centre (mm)
WALK_SMOOTH_S = 10.0  # the jitter is the walk less its Gaussian smoothing of this sigma (s)


def drift(rng, seconds):
    """The TRUE motion: a smoothed random walk (knots every 20-40 s, a cubic
    spline through them) of translation and rotation, zero at t = 0, scaled
    to 2-5 mm of translation and 1-3 degrees of turn at its largest over the
    study. Returns pose(t) -> (Rotation, translations (n, 3) mm) and its
    sizes."""
    step = rng.uniform(20.0, 40.0)
    knots = np.arange(0.0, seconds + step, step)
    walk = np.cumsum(rng.normal(size=(knots.size, 6)), axis=0)
    walk -= walk[0]
    spline = CubicSpline(knots, walk, axis=0)
    fine = spline(np.linspace(0.0, seconds, 2001))
    mm, deg = rng.uniform(2.0, 5.0), rng.uniform(1.0, 3.0)
    scale = np.r_[[mm / np.linalg.norm(fine[:, :3], axis=1).max()] * 3,
                  [np.radians(deg) / np.linalg.norm(fine[:, 3:], axis=1).max()] * 3]

    def pose(t):
        f = scale * spline(np.clip(np.asarray(t, float), 0.0, seconds))
        return Rotation.from_rotvec(f[:, 3:]), f[:, :3]
    return pose, {"knot_s": float(step), "max_mm": float(mm), "max_deg": float(deg)}


def log_track(name, true_pose, seconds, rng, walk_mm):
    """The logged samples of track `name` (TRACKS): times, Rotation,
    translations."""
    rate, noise, walk = TRACKS[name]
    n = int(round(seconds * rate)) + 1
    times = np.arange(n) / rate
    rot, tr = true_pose(times)
    if walk:
        steps = rng.normal(0.0, walk_mm, (n, 6))
        steps[:, 3:] /= HEAD_MM
        w = np.cumsum(steps, axis=0)
        w -= ndimage.gaussian_filter1d(w, WALK_SMOOTH_S * rate, axis=0, mode="nearest")
        rot, tr = Rotation.from_rotvec(w[:, 3:]) * rot, tr + w[:, :3]
    if noise:  # path_cases' tracker model
        tr = tr + rng.normal(0.0, noise, (n, 3))
        rot = Rotation.from_rotvec(rng.normal(0.0, noise / HEAD_MM, (n, 3))) * rot
    return times, rot, tr


def phantom(rng, shape, voxel_mm=VOXEL_MM):
    """path_cases' smooth brain (4.5 mm FWHM) plus its sharp hot spheres, in
    the grid frame (voxel centres at (i + 0.5) voxel_mm: one size or one a
    axis, 2 mm by default)."""
    vox = np.broadcast_to(np.asarray(voxel_mm, dtype=float), (3,)).copy()
    affine = np.eye(4)
    affine[:3, :3] = np.diag(vox)
    affine[:3, 3] = 0.5 * vox
    brain = draw_object(rng, shape, vox, affine, "brain")[0]
    spheres = draw_object(rng, shape, vox, affine, "spheres")[0]
    return brain + spheres


def frame_segments(op, motion, bounds):
    """pb_path_segments for each frame [bounds[i], bounds[i+1]] of motion on
    op's grid under op's options (AB's plan of that frame): a list."""
    import petblur._lib as lib
    out = []
    for t0, t1 in zip(bounds[:-1], bounds[1:]):
        g, cm, keep = motion._c_motion(op._shape, op.voxel_size, op._affine, np.array([t0, t1]), warn=False)
        n = ctypes.c_size_t()
        lib.check(lib.lib.pb_path_segments(ctypes.byref(g), ctypes.byref(cm), ctypes.byref(op._options),
                                           ctypes.byref(n)))
        del keep
        out.append(int(n.value))
    return out


class Device:
    """Arrays and timing on a CUDA device (torch tensors, CUDA events) or
    on the host (numpy arrays, wall-clock)."""

    def __init__(self, name, runs):
        self.name, self.runs = name, runs
        self.cuda = name.startswith("cuda")
        if self.cuda:
            import torch
            self.torch = torch
            self.dev = torch.device(name)
            if self.dev.index is not None:
                torch.cuda.set_device(self.dev)

    def array(self, x):
        x = np.ascontiguousarray(x, dtype=np.float32)  # C order, as torch holds it
        return self.torch.from_numpy(x).to(self.dev) if self.cuda else x

    def time(self, op, call):
        """(call ms, kernels ms, input copy ms): median of runs calls, and the
        library's own device time (python_torch.device_ms on CUDA; on the
        host the timed calls' own)."""
        if self.cuda:
            from python_torch import device_ms, event_ms
            return (event_ms(call, self.runs),) + tuple(device_ms(op, call))
        call()
        wall, kern, inp = [], [], []
        for _ in range(self.runs):
            t = time.perf_counter()
            call()
            wall.append(1e3 * (time.perf_counter() - t))
            total, i = op.last_device_ms()
            kern.append(total - i)
            inp.append(i)
        return statistics.median(wall), statistics.median(kern), statistics.median(inp)

    def floor(self, y):
        """One copy of the frames' volumes (memory_floor.py's floor), ms."""
        if self.cuda:
            from python_torch import event_ms
            dst = self.torch.empty_like(y)
            ms = event_ms(lambda: dst.copy_(y), self.runs)
            del dst
            return ms
        dst = np.empty_like(y)
        wall = []
        for _ in range(self.runs + 1):
            t = time.perf_counter()
            np.copyto(dst, y)
            wall.append(1e3 * (time.perf_counter() - t))
        return statistics.median(wall[1:])

    def sync(self):
        if self.cuda:
            self.torch.cuda.synchronize()

    def release(self):
        if self.cuda:
            self.torch.cuda.empty_cache()


class Errors:
    """Relative RMS and max in percent, summed frame by frame in float64
    (on the arrays' own device)."""

    def __init__(self):
        self.dd = self.rr = self.dmax = self.rmax = 0.0
        self.frame_max = []

    def add(self, ref, y):
        if isinstance(ref, np.ndarray):
            r, d = ref.astype(np.float64), y.astype(np.float64) - ref
            dd, rr, dm, rm = float((d * d).sum()), float((r * r).sum()), float(np.abs(d).max()), float(np.abs(r).max())
        else:
            r = ref.double()
            d = y.double() - r
            dd, rr = float((d * d).sum()), float((r * r).sum())
            dm, rm = float(d.abs().max()), float(r.abs().max())
        self.dd, self.rr = self.dd + dd, self.rr + rr
        self.dmax, self.rmax = max(self.dmax, dm), max(self.rmax, rm)
        self.frame_max.append(100.0 * dm / rm if rm > 0 else float("nan"))

    def result(self):
        return {"rms_pct": 100.0 * math.sqrt(self.dd / self.rr), "max_pct": 100.0 * self.dmax / self.rmax,
                "worst_frame_max_pct": max(self.frame_max)}


def references(petblur, dev, shape, x, motion, bounds, frames, steps, all_frames):
    """The dense CL reference of motion for each frame in frames: a list of
    (frame, its blur), made by one FramesOperator where all frames are asked
    for, else one BlurOperator a frame."""
    opts = dict(method="cl", filter="exact", steps=steps, device=dev.name)
    if all_frames:
        F = petblur.FramesOperator(shape, VOXEL_MM, motion, bounds, **opts)
        y = F.apply(x)
        dev.sync()
        return [(f, y[f]) for f in frames]
    out = []
    for f in frames:
        B = petblur.BlurOperator(shape, VOXEL_MM, motion, frame=(bounds[f], bounds[f + 1]), **opts)
        out.append((f, B.apply(x)))
    dev.sync()
    return out


def markdown(rows, refs):
    lines = ["| track | bound | segments/frame mean / max | forward ms | adjoint ms | kernels ms fwd / adj | "
             "floor ms | x floor fwd / adj | vs logged RMS / max % | vs true RMS / max % |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        seg = f"{r['segments_mean']:.1f} / {r['segments_max']}" if r["segments_mean"] is not None else "-"
        lines.append(f"| {r['track']} | {r['bound']} | {seg} | {r['forward_ms']:.3f} | {r['adjoint_ms']:.3f} | "
                     f"{r['forward_kernel_ms']:.3f} / {r['adjoint_kernel_ms']:.3f} | {r['floor_ms']:.3f} | "
                     f"{r['forward_x_floor']:.1f} / {r['adjoint_x_floor']:.1f} | "
                     f"{r['logged']['rms_pct']:.3f} / {r['logged']['max_pct']:.3f} | "
                     f"{r['true']['rms_pct']:.3f} / {r['true']['max_pct']:.3f} |")
    lines += ["", "| track | log | CL steps an interval | reference s | logged track's blur vs the true one's "
              "RMS / max % |", "|---|---|---|---|---|"]
    for name, r in refs.items():
        lines.append(f"| {name} | {r['samples']} samples at {r['rate_hz']:g} Hz, noise {r['noise_mm']:g} mm"
                     f"{', jitter' if r['walk'] else ''} | {r['steps']} | {r['seconds']:.1f} | "
                     f"{r['logged_vs_true']['rms_pct']:.3f} / {r['logged_vs_true']['max_pct']:.3f} |")
    return "\n".join(lines) + "\n"


def targets(rows):
    """Issue 46's targets on the rows there are: lines of text."""
    out = []
    by = {(r["track"], r["bound"]): r for r in rows}
    for (track, bound), r in by.items():
        base = by.get(("smooth", bound))
        if track.startswith("20hz") and base is not None:
            f, a = r["forward_ms"] / base["forward_ms"], r["adjoint_ms"] / base["adjoint_ms"]
            ok = "met" if max(f, a) <= 1.3 else "NOT met"
            out.append(f"{track} at {bound}: {f:.2f}x / {a:.2f}x the smooth motion's forward / adjoint "
                       f"(target <= 1.3x: {ok})")
    for r in rows:
        if r["track"] in ("smooth", "20hz-noisy"):
            worst = max(r["forward_x_floor"], r["adjoint_x_floor"])
            out.append(f"{r['track']} at {r['bound']}: {r['forward_x_floor']:.1f}x / {r['adjoint_x_floor']:.1f}x "
                       f"the memory floor (target <= 10x: {'met' if worst <= 10 else 'NOT met'})")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cuda:0", help="cuda[:N] (torch tensors) or host (numpy arrays)")
    ap.add_argument("--tracks", default="1hz-walk,smooth,20hz-noisy", help=f"of {','.join(TRACKS)}")
    ap.add_argument("--bounds", default="default,0.25", help="path bounds in voxels; 'default': None (0.1)")
    ap.add_argument("--shape", default="220,220,110")
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--frame-s", type=float, default=75.0)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--seed", type=int, default=46046)
    ap.add_argument("--walk-mm", type=float, default=0.03, help="1hz-walk's step per axis (mm)")
    ap.add_argument("--ref-hz", type=float, default=20.0, help="the CL references' samples of the track per second")
    ap.add_argument("--error-frames", default="all", help="'all' or frame indices, e.g. 0,11,23")
    ap.add_argument("--method", default="ab")
    ap.add_argument("--filter", default="hardware")
    ap.add_argument("--out", default="frames_cost.json")
    a = ap.parse_args()
    import petblur
    shape = tuple(int(v) for v in a.shape.split(","))
    names = a.tracks.split(",")
    for n in names:
        if n not in TRACKS:
            ap.error(f"track {n!r}: one of {', '.join(TRACKS)}")
    bounds_opt = [None if b == "default" else float(b) for b in a.bounds.split(",")]
    err_frames = list(range(a.frames)) if a.error_frames == "all" else [int(v) for v in a.error_frames.split(",")]
    all_frames = a.error_frames == "all"
    seconds = a.frames * a.frame_s
    bounds = a.frame_s * np.arange(a.frames + 1)
    dev = Device(a.device, a.runs)
    start = time.perf_counter()
    print(f"seed {a.seed} (--seed {a.seed} replays this run)", flush=True)

    true_pose, size = drift(np.random.default_rng([a.seed, 0]), seconds)
    center = 0.5 * np.array(shape) * VOXEL_MM + PIVOT_MM
    fine = np.arange(int(round(seconds * a.ref_hz)) + 1) / a.ref_hz
    true_motion = _motion(fine, *true_pose(fine), center)
    corner = [f["max_corner_mm"] for f in true_motion.summary(bounds, shape, VOXEL_MM)["frames"]]
    t = time.perf_counter()
    x_np = phantom(np.random.default_rng([a.seed, 100]), shape)
    x = dev.array(x_np)
    del x_np
    gpu = dev.torch.cuda.get_device_name(dev.dev) if dev.cuda else "host"
    print(f"# {gpu}, petblur {getattr(petblur, '__version__', '?')}: {a.frames} frames of {a.frame_s:g} s on "
          f"{'x'.join(map(str, shape))} voxels of {VOXEL_MM:g} mm ({'torch CUDA tensor' if dev.cuda else 'numpy'}, "
          f"C order), method {a.method}, filter {a.filter}; median of {a.runs} calls", flush=True)
    print(f"# the drift: knots every {size['knot_s']:.0f} s, at most {size['max_mm']:.2f} mm and "
          f"{size['max_deg']:.2f} degrees over {seconds:g} s; a frame's largest corner motion "
          f"{np.median(corner):.2f} mm median, {max(corner):.2f} mm max; object made in "
          f"{time.perf_counter() - t:.1f} s", flush=True)

    t = time.perf_counter()
    true_refs = references(petblur, dev, shape, x, true_motion, bounds, err_frames, 1, all_frames)
    print(f"# the true drift's CL reference (its samples at {a.ref_hz:g} Hz, 1 step an interval) in "
          f"{time.perf_counter() - t:.1f} s", flush=True)

    rows, refs, floor = [], {}, None
    for name in names:
        rate, noise, walk = TRACKS[name]
        rng = np.random.default_rng([a.seed, 1 + list(TRACKS).index(name)])
        times, rot, tr = log_track(name, true_pose, seconds, rng, a.walk_mm)
        logged = _motion(times, rot, tr, center)
        steps = max(1, math.ceil(a.ref_hz / rate - 1e-9))
        t = time.perf_counter()
        log_refs = references(petblur, dev, shape, x, logged, bounds, err_frames, steps, all_frames)
        vs = Errors()
        for (f, r), (_, rt) in zip(log_refs, true_refs):
            vs.add(rt, r)
        refs[name] = {"samples": int(len(times)), "rate_hz": rate, "noise_mm": noise, "walk": walk,
                      "walk_mm": a.walk_mm if walk else 0.0, "steps": steps, "seconds": time.perf_counter() - t,
                      "logged_vs_true": vs.result()}
        print(f"{name}: {len(times)} samples, CL reference ({steps} step(s) an interval) in "
              f"{refs[name]['seconds']:.1f} s; its blur {refs[name]['logged_vs_true']['rms_pct']:.3f} % RMS, "
              f"{refs[name]['logged_vs_true']['max_pct']:.3f} % max from the true drift's", flush=True)
        for bound in bounds_opt:
            label = "default" if bound is None else f"{bound:g}"
            t = time.perf_counter()
            F = petblur.FramesOperator(shape, VOXEL_MM, logged, bounds, method=a.method, filter=a.filter,
                                       max_path_error=bound, device=a.device)
            y = F.apply(x)
            dev.sync()
            plan_s = time.perf_counter() - t
            if floor is None:
                floor = dev.floor(y)
            fwd = dev.time(F, lambda: F.apply(x))
            adj = dev.time(F, lambda: F.adjoint(y, sum=True))
            try:
                seg = frame_segments(F, logged, bounds)
            except Exception as e:  # an older package without pb_path_segments
                print(f"  segments not counted: {e}", flush=True)
                seg = None
            e_log, e_true = Errors(), Errors()
            for (f, r), (_, rt) in zip(log_refs, true_refs):
                e_log.add(r, y[f])
                e_true.add(rt, y[f])
            row = {"track": name, "bound": label, "max_path_error": bound,
                   "segments": seg, "segments_mean": float(np.mean(seg)) if seg else None,
                   "segments_max": int(max(seg)) if seg else None,
                   "forward_ms": fwd[0], "forward_kernel_ms": fwd[1], "forward_input_ms": fwd[2],
                   "adjoint_ms": adj[0], "adjoint_kernel_ms": adj[1], "adjoint_input_ms": adj[2],
                   "floor_ms": floor, "forward_x_floor": fwd[0] / floor, "adjoint_x_floor": adj[0] / floor,
                   "plan_and_first_call_s": plan_s, "logged": e_log.result(), "true": e_true.result()}
            rows.append(row)
            segs = f"{row['segments_mean']:.1f} / {row['segments_max']}" if seg else "-"
            print(f"  {label:8s} segments {segs}  forward {fwd[0]:.3f} ms  adjoint {adj[0]:.3f} ms  "
                  f"({row['forward_x_floor']:.1f}x / {row['adjoint_x_floor']:.1f}x the floor {floor:.3f} ms)  "
                  f"vs logged {row['logged']['rms_pct']:.3f} / {row['logged']['max_pct']:.3f} %  "
                  f"vs true {row['true']['rms_pct']:.3f} / {row['true']['max_pct']:.3f} %  "
                  f"(planned and first call {plan_s:.1f} s)", flush=True)
            F = y = None  # the plans and frames freed before the next
            dev.release()
        del log_refs
        dev.release()
    seconds_run = time.perf_counter() - start
    print(f"\n{len(rows)} rows in {seconds_run:.0f} s; errors over frames "
          f"{'all' if all_frames else a.error_frames}\n")
    table = markdown(rows, refs)
    print(table)
    checks = targets(rows)
    for line in checks:
        print(line)
    here = os.path.dirname(os.path.abspath(__file__))
    commit = os.environ.get("PB_COMMIT") or subprocess.run(
        ["git", "-C", here, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    with open(a.out, "w") as f:
        json.dump({"argv": sys.argv[1:], "seed": a.seed, "commit": commit, "device": a.device, "gpu": gpu,
                   "petblur_file": petblur.__file__, "shape": list(shape), "voxel_mm": VOXEL_MM,
                   "frames": a.frames, "frame_s": a.frame_s, "runs": a.runs, "method": a.method, "filter": a.filter,
                   "ref_hz": a.ref_hz, "error_frames": err_frames, "drift": size, "pivot_mm": PIVOT_MM.tolist(),
                   "frame_corner_mm": corner, "seconds": seconds_run, "references": refs, "rows": rows,
                   "targets": checks}, f, indent=1)


if __name__ == "__main__":
    main()
