#!/usr/bin/env python3
"""Short translations as taps against the walk (issue 33, item 2): for
translations of growing length on a 256^3 torch CUDA tensor (C order), the
forward and the adjoint as the convolution of the translation's taps
(cl/pb_taps.cl) and as the walk (PETBLUR_SHIFT_TAPS=0), each beside the floor
of one read and one write of the volume (a torch copy_ in the same process).
Also the taps forced past the library's limit (PETBLUR_SHIFT_TAPS=100000), to
show where the walk wins. The tap count is the number of voxels that the
walk's blur of an impulse reaches, counted here with the walk itself.

Columns: the Python call's time (CUDA events around it, median of --runs) and
the library's own device time of the same call (kernel, and the input's copy
into the texture).

  shift_taps.py [--runs 30] [--size 256] [--out shift_taps.csv]"""

import argparse
import csv
import os
import sys

import numpy as np
import torch

import petblur

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from python_torch import ab_slices_at_corners, device_ms, event_ms  # noqa: E402

VS = 2.0
SHIFTS = [(0, 0, 0), (0.5, 0, 0), (1, 0, 0), (1, 1, 1), (2, 2, 2), (3, 1, 0), (0.4, 1.3, 2.7), (3, 3, 3), (4, 0, 0),
          (5, 2, 1), (4, 4, 4), (6, 0, 0), (8, 0, 0), (6, 6, 6), (12, 10, -11)]
MODES = (("taps", None), ("walk", "0"), ("taps forced", "100000"))


def set_limit(value):
    if value is None:
        os.environ.pop("PETBLUR_SHIFT_TAPS", None)
    else:
        os.environ["PETBLUR_SHIFT_TAPS"] = value


def tap_count(t):
    """Voxels the walk's blur of an impulse reaches: the convolution's taps."""
    set_limit("0")
    m = int(2 * max(abs(v) for v in t)) + 9
    impulse = np.zeros((m, m, m), dtype=np.float32)
    impulse[m // 2, m // 2, m // 2] = 1.0
    op = petblur.BlurOperator((m, m, m), VS, petblur.Motion.from_axis_angle(translation=np.array(t) * VS),
                              device="cuda:0")
    return int(np.count_nonzero(op.adjoint(impulse)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--out", default="shift_taps.csv")
    args = ap.parse_args()
    dev = torch.device("cuda:0")
    n = args.size
    x = torch.rand((n, n, n), device=dev)
    dst = torch.empty_like(x)
    floor = event_ms(lambda: dst.copy_(x), args.runs)
    print(f"# {torch.cuda.get_device_name(0)}, AB HARDWARE on {n}^3 float32 C-order torch tensors, "
          f"median of {args.runs} calls; floor (one read, one write) {floor:.3f} ms")
    print("| translation (voxels) | S | taps | " + " | ".join(
        f"{name}: forward ms (kernel + copy) | {name}: adjoint ms" for name, _ in MODES) + " | taps / walk |")
    print("|---|---|---|" + "---|---|" * len(MODES) + "---|")
    rows = []
    for t in SHIFTS:
        S = ab_slices_at_corners(np.array([n, n, n], dtype=float), t, 0.0)
        taps = tap_count(t)
        row = dict(translation=str(t), S=S, taps=taps, floor_ms=floor)
        cells = []
        for name, limit in MODES:
            set_limit(limit)
            op = petblur.BlurOperator((n, n, n), VS, petblur.Motion.from_axis_angle(translation=np.array(t) * VS),
                                      device="cuda:0")
            fwd = event_ms(lambda: op(x), args.runs)
            k_ms, in_ms = device_ms(op, lambda: op(x))
            adj = event_ms(lambda: op.adjoint(x), args.runs)
            row.update({f"{name} forward ms": fwd, f"{name} kernel ms": k_ms, f"{name} copy ms": in_ms,
                        f"{name} adjoint ms": adj})
            cells.append(f"{fwd:.3f} ({k_ms:.3f} + {in_ms:.3f}) | {adj:.3f}")
            del op
        set_limit(None)
        rows.append(row)
        print(f"| {t} | {S} | {taps} | " + " | ".join(cells) +
              f" | {row['taps forward ms'] / row['walk forward ms']:.2f} |", flush=True)
    with open(args.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
