#!/usr/bin/env python3
"""petblur from Python on a 256^3 PyTorch CUDA tensor, for the paper's eight
scenarios, against the C library's own device time and against the loop a
PyTorch user would write (bench/peers.py: affine_grid + grid_sample at the
same S).

Each call is timed with CUDA events recorded on the current stream around the
Python call (back to back, median of --runs). Its floor is the C kernel time
of the same call (pb_context_last_kernel_ms less the input's copy, from the
library's own events) plus one device-to-device copy of the volume (torch's
copy_, timed alike): a Python call may cost at most 1.2 times that. The
grid_sample loop must take at least 15 times as long as the Python call.

  python_torch.py [--size 256] [--runs 30] [--out results.csv]

Tensors in C order (PyTorch's default; petblur runs the transposed grid) and in
Fortran order (x fastest, the C library's own layout) are both measured."""

import argparse
import csv
import math
import os
import statistics
import sys

import numpy as np
import torch

import petblur

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fetch_floor import chord_slices  # noqa: E402
from library_time import device_ms  # noqa: E402,F401 (its callers import it from here)
from peers import TorchPeer  # noqa: E402

# src/cli/bench/scenarios.h: translations in voxels, rotations in degrees about z.
SCENARIOS = [((2, 2, 2), 0), ((12, 10, -11), 0), ((-20, 30, 15), 0), ((-20, 30, 0), 0), ((0, 0, 0), 10),
             ((0, 0, 0), 60), ((2.5, -3.2, -0.7), -5), ((42, 21, 12), 20)]


def ab_slices_at_corners(n, t, deg):
    """AB's most slices on one voxel's path (bench_measure.c's ab_slices), at
    the grid's corners, where a turn about the centre moves voxels furthest:
    the S of the paper's sample count."""
    c = 0.5 * n
    a = math.radians(deg)
    R = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1.0]])
    corners = np.array(np.meshgrid(*[[0.5, m - 0.5] for m in n])).T.reshape(-1, 3)
    ends = (corners - c - np.array(t)) @ R + c  # R^T (corner - c - t) + c: the object points at the frame's end
    return int(chord_slices(corners, ends).max())


def event_ms(fn, runs):
    """Median of CUDA-event times around fn(), calls queued back to back."""
    fn()
    torch.cuda.synchronize()
    pairs = []
    for _ in range(runs):
        a, b = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
        a.record()
        fn()
        b.record()
        pairs.append((a, b))
    torch.cuda.synchronize()
    return statistics.median(a.elapsed_time(b) for a, b in pairs)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--out", default="python_torch.csv")
    args = ap.parse_args()
    n = args.size
    dev = torch.device("cuda:0")
    vs = 2.0
    x_c = torch.rand((n, n, n), device=dev)
    x_f = x_c.permute(2, 1, 0).contiguous().permute(2, 1, 0)  # x fastest
    copy_dst = torch.empty_like(x_c)
    copy_ms = event_ms(lambda: copy_dst.copy_(x_c), args.runs)
    peer = TorchPeer()
    rows = []
    print(f"# {torch.cuda.get_device_name(0)}, {n}^3 float32, median of {args.runs} calls; d2d copy {copy_ms:.3f} ms")
    print("| scenario | S | direction | order | Python call ms | C kernel ms | kernel + copy ms | ratio (<= 1.2) | "
          "grid_sample ms | speed-up (>= 15) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for k, (t, deg) in enumerate(SCENARIOS, 1):
        m = petblur.Motion.from_axis_angle(translation=np.array(t, dtype=float) * vs, angle=deg)
        op = petblur.BlurOperator((n, n, n), vs, m, device="cuda:0")
        S = ab_slices_at_corners(np.array([n, n, n], dtype=float), t, deg)
        case = {"nx": n, "ny": n, "nz": n, "vx": vs, "vy": vs, "vz": vs, "tx": t[0], "ty": t[1], "tz": t[2],
                "rot_deg": deg}
        thetas = peer.thetas(case, S)
        vol = x_c.permute(2, 1, 0).contiguous()[None, None]  # (N, C, D=z, H=y, W=x), dense, as a user holds it
        with torch.no_grad():
            gs_ms = event_ms(lambda: peer.blur(vol, thetas), max(3, args.runs // 5))
        for direction in ("forward", "adjoint"):
            for order, x in (("C", x_c), ("F", x_f)):
                call = (lambda: op.adjoint(x)) if direction == "adjoint" else (lambda: op(x))
                py_ms = event_ms(call, args.runs)
                k_ms = device_ms(op, call)[0]
                floor = k_ms + copy_ms
                row = {"scenario": k, "S": S, "direction": direction, "order": order, "python_ms": py_ms,
                       "kernel_ms": k_ms, "copy_ms": copy_ms, "floor_ms": floor, "ratio": py_ms / floor,
                       "grid_sample_ms": gs_ms if direction == "forward" else "",
                       "speedup": gs_ms / py_ms if direction == "forward" else ""}
                rows.append(row)
                gs = f"{gs_ms:.3f} | {gs_ms / py_ms:.1f}" if direction == "forward" else "- | -"
                print(f"| {k} | {S} | {direction} | {order} | {py_ms:.3f} | {k_ms:.3f} | {floor:.3f} | "
                      f"{py_ms / floor:.2f} | {gs} |", flush=True)
    with open(args.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    worst = max(r["ratio"] for r in rows)
    slowest = min(r["speedup"] for r in rows if r["speedup"] != "")
    print(f"\nworst ratio to kernel + copy: {worst:.2f} (target <= 1.2: {'met' if worst <= 1.2 else 'NOT met'}); "
          f"smallest speed-up over grid_sample: {slowest:.1f}x (target >= 15: {'met' if slowest >= 15 else 'NOT met'})")


if __name__ == "__main__":
    main()
