#!/usr/bin/env python3
"""The motion study's small version (examples/motion_study, what python/tests/test_motion_study.py runs once a CI run)
over a family of fresh seeds: each seed's NRMSE of models (a), (b), (e) and (g) and the estimated track's error, and
the ratios the test asserts ((b)/(a), (e)/(b), (g)/(e)), as median and range. Writes family.json and family.md.

    python3 bench/study_family.py --seeds 16 --jobs 8 --device opencl --matrix M.npz --out DIR
"""
from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import subprocess
import sys

import numpy as np

STUDY = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "motion_study", "study.py")


def one(seed: int, device: str, matrix: str, out: str) -> dict:
    d = os.path.join(out, str(seed))
    cmd = [sys.executable, STUDY, "--preset", "small", "--methods", "abeg", "--seed", str(seed), "--device", device,
           "--out", d] + (["--matrix", matrix] if matrix else [])
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode:
        return {"seed": seed, "error": (r.stdout + r.stderr)[-2000:]}
    with open(os.path.join(d, "results.json")) as f:
        res = json.load(f)
    nrmse = {m: res["results"][m]["history"][-1]["nrmse"] for m in "abeg"}
    est = res["estimate"]
    return {"seed": seed, "nrmse": nrmse, "b/a": nrmse["b"] / nrmse["a"], "e/b": nrmse["e"] / nrmse["b"],
            "g/e": nrmse["g"] / nrmse["e"], "track_mean_mm": est["mean_mm"], "track_max_mm": est["max_mm"],
            "worst_frame": est["worst_frame"], "per_frame_mm": est["per_frame_mm"]}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seeds", type=int, default=8)
    p.add_argument("--seed", type=int, action="append", help="a seed to replay (repeatable)")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--device", default="auto")
    p.add_argument("--matrix", default="")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    seeds = a.seed or [int(s) % (1 << 30) for s in np.random.SeedSequence().generate_state(a.seeds)]
    os.makedirs(a.out, exist_ok=True)
    rows = []
    with concurrent.futures.ProcessPoolExecutor(a.jobs) as pool:
        for r in pool.map(one, seeds, [a.device] * len(seeds), [a.matrix] * len(seeds), [a.out] * len(seeds)):
            rows.append(r)
            if "error" in r:
                print(f"seed {r['seed']}: FAILED\n{r['error']}", flush=True)
                continue
            print(f"seed {r['seed']}: NRMSE " + " ".join(f"{m} {v:.4f}" for m, v in r["nrmse"].items()) +
                  f"; g/e {r['g/e']:.3f}, e/b {r['e/b']:.3f}, b/a {r['b/a']:.3f}; track {r['track_mean_mm']:.2f} / "
                  f"{r['track_max_mm']:.2f} mm (worst frame {r['worst_frame']})", flush=True)
    with open(os.path.join(a.out, "family.json"), "w") as f:
        json.dump(rows, f, indent=1)
    ok = [r for r in rows if "error" not in r]
    lines = ["| seed | (a) | (b) | (e) | (g) | g/e | track mean / max (mm) |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['seed']} | " + " | ".join(f"{r['nrmse'][m]:.4f}" for m in "abeg") +
              f" | {r['g/e']:.3f} | {r['track_mean_mm']:.2f} / {r['track_max_mm']:.2f} |" for r in ok]
    lines.append("")
    for k in ("b/a", "e/b", "g/e", "track_mean_mm", "track_max_mm") if ok else ():
        v = np.array([r[k] for r in ok])
        lines.append(f"- {k}: median {np.median(v):.3f}, range {v.min():.3f}-{v.max():.3f} over {len(v)} seeds")
    open(os.path.join(a.out, "family.md"), "w").write("\n".join(lines) + "\n")
    print("\n".join(lines[-5:]))
    return 0 if len(ok) == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
