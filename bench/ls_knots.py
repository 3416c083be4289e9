#!/usr/bin/env python3
"""Chords through the samples against least-squares knots, at the same segments (issue 46: segments chosen by their
effect on the image).

A merged chord through two of the track's samples leaves the track between them on one side: every voxel's time
average is shifted by up to the path bound, and on a sharp edge (a step of most of the largest value across one voxel)
the blur is first-order sensitive to that shift. A continuous polyline fitted to the track by least squares over the
hat functions of the same knots has residuals orthogonal to every hat, so their time mean is zero and the first-order
error cancels. This draws fresh cases of bench/path_cases.py's kinds, puts knots every K seconds of the frame, and
blurs (AB, exact filter, host, a 0.001-voxel bound so petblur walks the knots as given) the polyline through the
logged samples and the least-squares one, each against the logged track's dense reference; petblur's own plan at the
default bound and at 0.03 voxels is the baseline. Relative RMS / max in percent.

    python3 bench/ls_knots.py --kinds drift-1hz,nod,rotation --seeds 3 --out DIR
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import path_cases as pc  # noqa: E402


def run_case(kind, seed, spacings, device):
    import petblur
    case = pc.draw_case(kind, np.random.default_rng(seed), small=True)
    x = np.asfortranarray(case.x)
    ref = pc.reference(case, "logged")
    t0, t1 = case.frame

    def blur(m, bound):
        op = petblur.BlurOperator(case.shape, case.voxel, m, frame=case.frame, method="ab", filter="exact",
                                  affine=case.affine, device=device, max_path_error=bound)
        return pc.errors(ref, op(x))

    row = {"seed": seed, "kind": kind, "case": pc.describe(case), "default": blur(case.logged, None),
           "bound 0.03": blur(case.logged, 0.03)}
    ts = np.linspace(t0, t1, 4001)
    rot, tr = case.poses("logged", ts)
    mid = rot[len(ts) // 2]
    vals = np.column_stack([tr, (mid.inv() * rot).as_rotvec()])

    def motion(kt, kv):
        return pc._motion(kt, mid * Rotation.from_rotvec(kv[:, 3:]), kv[:, :3], case.center)

    for k in spacings:
        kt = np.unique(np.concatenate([np.arange(t0, t1, k), [t1]]))
        kr, ktr = case.poses("logged", kt)
        through = np.column_stack([ktr, (mid.inv() * kr).as_rotvec()])
        hats = np.stack([np.interp(ts, kt, np.eye(len(kt))[j]) for j in range(len(kt))], 1)
        fitted = np.linalg.lstsq(hats, vals, rcond=None)[0]
        row[f"every {k:g} s"] = {"segments": len(kt) - 1, "through samples": blur(motion(kt, through), 1e-3),
                                 "least squares": blur(motion(kt, fitted), 1e-3)}
    return row


def fmt(e):
    return f"{e['rms_pct']:.3f} / {e['max_pct']:.3f}"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--kinds", default="drift-1hz,nod,rotation")
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--spacings", default="2,3,5,8", help="knots every K seconds")
    p.add_argument("--device", default="host")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    spacings = [float(s) for s in a.spacings.split(",")]
    seeds = [int(s) for s in np.random.SeedSequence().generate_state(a.seeds)]
    os.makedirs(a.out, exist_ok=True)
    rows, lines = [], ["| kind | seed | default bound | bound 0.03 | " +
                       " | ".join(f"every {k:g} s: through -> LS" for k in spacings) + " |",
                       "|---|---|---|---|" + "---|" * len(spacings)]
    for kind in a.kinds.split(","):
        for seed in seeds:
            r = run_case(kind, seed, spacings, a.device)
            rows.append(r)
            cells = [f"{r[f'every {k:g} s']['segments']} seg: {fmt(r[f'every {k:g} s']['through samples'])} -> "
                     f"{fmt(r[f'every {k:g} s']['least squares'])}" for k in spacings]
            lines.append(f"| {kind} | {seed} | {fmt(r['default'])} | {fmt(r['bound 0.03'])} | " +
                         " | ".join(cells) + " |")
            print(lines[-1], flush=True)
    with open(os.path.join(a.out, "ls_knots.json"), "w") as f:
        json.dump(rows, f, indent=1)
    open(os.path.join(a.out, "ls_knots.md"), "w").write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
