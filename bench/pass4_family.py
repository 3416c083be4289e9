#!/usr/bin/env python3
"""Pass 4 of the motion estimate (src/estimate/contrast_poses.c), on a family of fresh series.

The command line's test of pass 4 (tests/test_motion_estimate.py, Together) draws one series of 24 small frames a run;
this draws many (the same setup, seeds given or fresh), runs `petblur motion estimate` on each with the pass on and
off (PETBLUR_ESTIMATE_CONTRAST), and writes the displacement errors of both tracks (mm, mean over each frame, as
head_frames.displacement_errors measures them) per seed, and their distribution, to --out.

    python3 bench/pass4_family.py --petblur build/src/cli/petblur --seeds 16 --jobs 8 --out /tmp/pass4
"""
from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import head_frames as hf  # noqa: E402

# The 24-frame series of tests/test_motion_estimate.py's pass 4 test, which runs one() on one draw
SETUP = hf.Setup(frames=24, shape=(40, 40, 36), voxel=(4.5, 4.5, 4.5), jerk_frame=15, counts=1e6, las=True,
                 oblique_deg=10.0)


def one(petblur: str, seed: int, device: str | None = None, variants: tuple = ()) -> dict:
    """Series `seed` estimated with pass 4 on and off: each track's errors per frame (mm) and whether the pass moved
    the track; each of `variants` (values of PETBLUR_ESTIMATE_CONTRAST) as well, as "on_VALUE"."""
    rng = np.random.default_rng(seed)
    frames, affine, bounds, truth = hf.simulate(SETUP, rng, steps=4, jerk_steps=40)
    points = hf.head_points(rng)
    out = {"seed": seed}
    with tempfile.TemporaryDirectory() as d:
        nii, side = hf.write_series(d, frames, affine, bounds, "f")
        for on in ("1", "0", *variants):
            csv = os.path.join(d, f"t{on}.csv")
            env = dict(os.environ, PETBLUR_ESTIMATE_CONTRAST=on)
            cmd = [petblur, "motion", "estimate", nii, "--frames-from", side, "-o", csv, "-q"]
            if device:
                cmd += ["--device", device]
            r = subprocess.run(cmd, env=env, capture_output=True, text=True)
            if r.returncode:
                raise RuntimeError(f"seed {seed}: {' '.join(cmd)} exited {r.returncode}: {r.stderr[-2000:]}")
            times, maps = hf.read_matrix_csv(csv)
            e = hf.displacement_errors(hf.track_maps(times, maps), truth, bounds, points)
            out["on" if on == "1" else "off" if on == "0" else "on_" + on] = e.tolist()
            if on in ("1", "0"):  # the two tracks compared below
                out["maps_" + on] = maps
    moved, still = out.pop("maps_1"), out.pop("maps_0")
    # Where the series shows no contrast to correct along (the pass's guards), the two tracks are the same
    assert moved.shape == still.shape, (seed, moved.shape, still.shape)
    out["moved"] = bool(np.abs(moved - still).max() > 1e-6)
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--petblur", required=True)
    p.add_argument("--seeds", type=int, default=8, help="fresh seeds to draw (ignored with --seed)")
    p.add_argument("--seed", type=int, action="append", help="a seed to replay (repeatable)")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--device", help="petblur's --device (default: petblur's own choice)")
    p.add_argument("--variant", action="append", default=[], help="another value of PETBLUR_ESTIMATE_CONTRAST to run "
                   "beside 1 and 0 (repeatable): its errors as on_VALUE, its mean and worst frame in the lines")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    seeds = a.seed or [int(s) for s in np.random.SeedSequence().generate_state(a.seeds)]
    os.makedirs(a.out, exist_ok=True)
    rows = []
    with concurrent.futures.ProcessPoolExecutor(a.jobs) as pool:
        for r in pool.map(one, [a.petblur] * len(seeds), seeds, [a.device] * len(seeds),
                          [tuple(a.variant)] * len(seeds)):
            on, off = np.array(r["on"]), np.array(r["off"])
            r.update(mean_on=on.mean(), mean_off=off.mean(), max_on=on.max(), max_off=off.max(),
                     gain=1 - on.mean() / off.mean())
            rows.append(r)
            extra = "".join(f"; {v}: mean {np.mean(r['on_' + v]):.3f}, worst {np.max(r['on_' + v]):.2f}"
                            for v in a.variant)
            print(f"seed {r['seed']}: mean {r['mean_off']:.3f} -> {r['mean_on']:.3f} mm ({100 * r['gain']:+.1f} %), "
                  f"worst {r['max_off']:.2f} -> {r['max_on']:.2f} mm, moved {r['moved']}{extra}", flush=True)
    with open(os.path.join(a.out, "pass4.json"), "w") as f:
        json.dump(rows, f, indent=1)
    g = np.array([r["gain"] for r in rows])
    lines = ["| seed | mean off (mm) | mean on (mm) | gain | worst off | worst on |", "|---|---|---|---|---|---|"]
    lines += [f"| {r['seed']} | {r['mean_off']:.3f} | {r['mean_on']:.3f} | {100 * r['gain']:+.1f} % | "
              f"{r['max_off']:.2f} | {r['max_on']:.2f} |" for r in rows]
    lines += ["", f"gain of the mean over {len(g)} series: median {100 * np.median(g):+.1f} %, "
              f"range {100 * g.min():+.1f} to {100 * g.max():+.1f} %, below 10 %: {int((g < 0.1).sum())}, "
              f"negative: {int((g < 0).sum())}"]
    open(os.path.join(a.out, "pass4.md"), "w").write("\n".join(lines) + "\n")
    print(lines[-1])
    return 0


if __name__ == "__main__":
    sys.exit(main())
