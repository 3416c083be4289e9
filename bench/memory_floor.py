#!/usr/bin/env python3
"""The cases a reconstruction runs most, against what memory allows (issue
33): each beside its floor, one read and one write of every output volume at
the device-to-device copy bandwidth measured in the same process (a torch
copy_ of a volume of that size), on a torch CUDA tensor in C order.

  256^3: identity, a (1,1,1)- and a (2,2,2)-voxel shift, 3 degrees about z;
  512^3 and 700^3: (1,1,1) voxels and 2 degrees;
  24 frames of 220x220x110 under a slow drift (FramesOperator): the forward of
  one activity into every frame, and the adjoint summed over the frames
  (floor: one copy of the 24 volumes each).

Columns: the Python call (CUDA events around it, median of --runs), the C
library's own device time of the same call (its events: the kernels, plus the
input's copy into the texture, given apart), the floor, and their ratio; for
the single-volume cases CuPy's affine_transform loop at the same S
(bench/peers.py) and petblur's lead over it. Issue 33's targets: every case
<= 2x its floor, >= 15x the CuPy loop.

  memory_floor.py [--runs 30] [--out memory_floor.csv]"""

import argparse
import csv
import os
import sys

import numpy as np
import torch

import petblur

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from distributed_frames import track as drift  # noqa: E402
from peers import CupyPeer  # noqa: E402
from python_torch import ab_slices_at_corners, device_ms, event_ms  # noqa: E402

VS = 2.0
# (name, grid, translation in voxels, degrees about z)
CASES = [("identity", 256, (0, 0, 0), 0.0), ("shift (1,1,1)", 256, (1, 1, 1), 0.0),
         ("shift (2,2,2)", 256, (2, 2, 2), 0.0), ("3 degrees", 256, (0, 0, 0), 3.0),
         ("(1,1,1) + 2 degrees", 512, (1, 1, 1), 2.0), ("(1,1,1) + 2 degrees", 700, (1, 1, 1), 2.0)]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--out", default="memory_floor.csv")
    args = ap.parse_args()
    dev = torch.device("cuda:0")
    try:
        peer = CupyPeer()
    except ImportError as e:
        peer = None
        print(f"CuPy peer not measured: {e}")
    rows = []
    print(f"# {torch.cuda.get_device_name(0)}, float32 C-order torch tensors, median of {args.runs} calls")
    print("| case | grid | S | Python call ms | kernel ms | input copy ms | floor ms | call / floor | "
          "CuPy loop ms | lead |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, n, t, deg in CASES:
        x = torch.rand((n, n, n), device=dev)
        dst = torch.empty_like(x)
        floor = event_ms(lambda: dst.copy_(x), args.runs)
        m = petblur.Motion.from_axis_angle(translation=np.array(t, dtype=float) * VS, angle=deg)
        op = petblur.BlurOperator((n, n, n), VS, m, device="cuda:0")
        S = ab_slices_at_corners(np.array([n, n, n], dtype=float), t, deg)
        call_ms = event_ms(lambda: op(x), args.runs)
        k_ms, in_ms = device_ms(op, lambda: op(x))
        cupy_ms = ""
        if peer is not None and n <= 512:
            case = {"nx": n, "ny": n, "nz": n, "vx": VS, "vy": VS, "vz": VS, "tx": t[0], "ty": t[1], "tz": t[2],
                    "rot_deg": deg}
            import cupy
            maps = peer.maps(case, S)
            vol = cupy.asarray(x)  # the tensor's memory (CUDA array interface); both queue on the legacy stream
            cupy_ms = event_ms(lambda: peer.blur(vol, maps), max(3, args.runs // 5))
            del vol
        rows.append(dict(case=name, grid=f"{n}^3", S=S, python_ms=call_ms, kernel_ms=k_ms, input_copy_ms=in_ms,
                         floor_ms=floor, ratio=call_ms / floor, cupy_ms=cupy_ms,
                         lead=(cupy_ms / call_ms) if cupy_ms != "" else ""))
        r = rows[-1]
        cp = f"{cupy_ms:.3f} | {cupy_ms / call_ms:.1f}x" if cupy_ms != "" else "- | -"
        print(f"| {name} | {n}^3 | {S} | {call_ms:.3f} | {k_ms:.3f} | {in_ms:.3f} | {floor:.3f} | "
              f"{r['ratio']:.1f} | {cp} |", flush=True)
        del x, dst, op
        torch.cuda.empty_cache()

    frames, shape = 24, (220, 220, 110)
    F = petblur.FramesOperator(shape, VS, drift(frames, 10.0), 10.0 * np.arange(frames + 1), device="cuda:0")
    x = torch.rand(shape, device=dev)
    y = F.apply(x)
    dst = torch.empty_like(y)
    floor = event_ms(lambda: dst.copy_(y), args.runs)  # the 24 volumes in one copy
    del dst
    for name, call in (("24 frames: forward", lambda: F.apply(x)),
                       ("24 frames: adjoint summed", lambda: F.adjoint(y, sum=True))):
        call_ms = event_ms(call, args.runs)
        k_ms, in_ms = device_ms(F, call)
        rows.append(dict(case=name, grid="220x220x110", S="", python_ms=call_ms, kernel_ms=k_ms, input_copy_ms=in_ms,
                         floor_ms=floor, ratio=call_ms / floor, cupy_ms="", lead=""))
        print(f"| {name} | 220x220x110 | - | {call_ms:.3f} | {k_ms:.3f} | {in_ms:.3f} | {floor:.3f} | "
              f"{call_ms / floor:.1f} | - | - |", flush=True)
    with open(args.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    worst = max(r["ratio"] for r in rows)
    leads = [r["lead"] for r in rows if r["lead"] != ""]
    print(f"\nworst call / floor: {worst:.1f} (target <= 2)" +
          (f"; smallest lead over the CuPy loop: {min(leads):.1f}x (target >= 15)" if leads else ""))


if __name__ == "__main__":
    main()
