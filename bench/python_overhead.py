#!/usr/bin/env python3
"""The Python call's host time on torch CUDA tensors (issue 33): where the
kernel is shorter than the host's work per call, calls queued back to back
run at the host's pace. A 32^3 volume (device work negligible), 2000 calls
of the forward under a translation of taps, timed by the host clock with the
queue drained at the end, and cProfile's largest entries over the same calls.

  python_overhead.py [--calls 2000]"""

import argparse
import cProfile
import pstats
import time

import numpy as np
import torch

import petblur


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--calls", type=int, default=2000)
    args = ap.parse_args()
    x = torch.rand((32, 32, 32), device="cuda:0")
    op = petblur.BlurOperator((32, 32, 32), 2.0, petblur.Motion.from_axis_angle(translation=np.array([2.0, 2, 2])),
                              device="cuda:0")
    for _ in range(50):
        op(x)
    torch.cuda.synchronize()
    t0 = time.perf_counter()
    for _ in range(args.calls):
        op(x)
    torch.cuda.synchronize()
    per_call = (time.perf_counter() - t0) / args.calls * 1e3
    print(f"host time per forward call, 32^3 torch tensor: {per_call:.4f} ms")
    t0 = time.perf_counter()
    for _ in range(args.calls):
        torch.empty_like(x)
    print(f"torch.empty_like alone: {(time.perf_counter() - t0) / args.calls * 1e3:.4f} ms")
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(args.calls):
        op(x)
    torch.cuda.synchronize()
    prof.disable()
    pstats.Stats(prof).sort_stats("tottime").print_stats(18)


if __name__ == "__main__":
    main()
