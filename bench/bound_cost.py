#!/usr/bin/env python3
"""What a tighter path bound costs on the GPU (issue 31): AB's and RM's
kernel time (the library's device events, median of 5) on a 256^3 torch
tensor for the paper's eight scenarios and for issue 31's tracked seizure
(bench/accuracy_case.py's 20 Hz track, 601 samples, on this grid), at the
path bounds given, as a ratio to the default's.

  bound_cost.py [--size 256] [--bounds 0.25,0.1,0.05,0.02,0.01] [--methods ab,rm] [--out bound_cost.json]

A method 'ab-sweep' is AB reading two points a slice where its path sweeps
sideways (ab_sampling='sweep')."""

import argparse
import json
import os
import statistics
import sys

import numpy as np
import torch

import petblur

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from accuracy_case import Case, method_options  # noqa: E402
from python_torch import SCENARIOS  # noqa: E402


def kernel_ms(op, x):
    op(x)
    times = []
    for _ in range(5):
        op(x)
        total, upload = op.last_device_ms()
        times.append(total - upload)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--bounds", default="0.25,0.1,0.05,0.02,0.01")
    ap.add_argument("--methods", default="ab,rm")
    ap.add_argument("--out", default="bound_cost.json")
    a = ap.parse_args()
    n, vs = a.size, 2.0
    x = torch.rand((n, n, n), device="cuda:0")
    bounds = [float(b) for b in a.bounds.split(",")]
    motions = [(f"scenario {k}", petblur.Motion.from_axis_angle(translation=np.array(t, float) * vs, angle=deg))
               for k, (t, deg) in enumerate(SCENARIOS, 1)]
    seizure = Case(np.random.default_rng(31), (n, n, n), (vs, vs, vs))
    motions.append(("tracked seizure", petblur.Motion(seizure.times, seizure.translations, seizure.quaternions(),
                                                      center=0.5 * n * vs + np.array([0.0, -20.0, -60.0]))))
    rows = []
    print(f"# {torch.cuda.get_device_name(0)}, {n}^3, kernel ms (ratio to bound {bounds[0]:g})")
    print("| motion | method | " + " | ".join(f"{b:g}" for b in bounds) + " |")
    print("|---|---|" + "---|" * len(bounds))
    for name, m in motions:
        for method in a.methods.split(","):
            ms = [kernel_ms(petblur.BlurOperator((n, n, n), vs, m, max_path_error=b, device="cuda:0",
                                                 **method_options(method)), x) for b in bounds]
            rows.append({"motion": name, "method": method, "bounds": bounds, "kernel_ms": ms})
            print(f"| {name} | {method.upper()} | " + " | ".join(f"{v:.3f} ({v / ms[0]:.2f}x)" for v in ms) + " |",
                  flush=True)
    with open(a.out, "w") as f:
        json.dump({"size": n, "device": torch.cuda.get_device_name(0), "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
