#!/usr/bin/env python3
"""One call of a memory_floor.py case, for Nsight Compute (bench/gpu.sh profile):
the kernels a case launches, with nothing else on the GPU. Issue 33 asks what
bounds the cases that stand furthest from their floor; ncu's counters of
these kernels say it.

  frames-forward   the 24 drifting frames of 220x220x110, forward (24 launches)
  frames-adjoint   the same frames' adjoint, summed (24 launches)
  turn             3 degrees about z on 256^3, forward
  turn512, turn700 (1,1,1) voxels and 2 degrees on 512^3 and 700^3, forward

  profile_floor.py CASE [--calls 1]"""

import argparse
import os
import sys

import numpy as np
import torch

import petblur

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from distributed_frames import track as drift  # noqa: E402


VS = 2.0  # mm, memory_floor.py's voxels


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("case", choices=["frames-forward", "frames-adjoint", "turn", "turn512", "turn700"])
    ap.add_argument("--calls", type=int, default=1)
    args = ap.parse_args()
    dev = torch.device("cuda:0")
    if args.case == "turn":
        n = 256
        x = torch.rand((n, n, n), device=dev)
        op = petblur.BlurOperator((n, n, n), VS, petblur.Motion.from_axis_angle(angle=3.0), device="cuda:0")
        call = lambda: op(x)  # noqa: E731
    elif args.case in ("turn512", "turn700"):
        n = int(args.case[4:])
        x = torch.rand((n, n, n), device=dev)
        m = petblur.Motion.from_axis_angle(translation=(VS, VS, VS), angle=2.0)
        op = petblur.BlurOperator((n, n, n), VS, m, device="cuda:0")
        call = lambda: op(x)  # noqa: E731
    else:
        frames, shape = 24, (220, 220, 110)
        F = petblur.FramesOperator(shape, VS, drift(frames, 10.0), 10.0 * np.arange(frames + 1), device="cuda:0")
        x = torch.rand(shape, device=dev)
        y = torch.rand((frames,) + shape, device=dev)
        call = (lambda: F.apply(x)) if args.case == "frames-forward" else (lambda: F.adjoint(y, sum=True))  # noqa
    for _ in range(args.calls):
        call()
    torch.cuda.synchronize()


if __name__ == "__main__":
    main()
