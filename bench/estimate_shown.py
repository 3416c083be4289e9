#!/usr/bin/env python3
"""How much of a family draw's error lies in motion its frames do not show (issue 47).

For each frame of a draw of bench/estimate_family.py, rendered as the family renders it but without its counts'
noise, the share of the noisy frame's noise energy (on the head's voxels) that one pose's misfit leaves: the frame
fitted by least squares (a scale and an offset) with its view at the truth's mean pose over the frame. That share is
the most that any path inside the frame can take off its residual, so a frame under a path's bar (pass 3's lowest is
1 %) cannot show its motion, and its error is at best what the truth's mean poses leave there, through the monotone
cubic the estimate draws between still frames (the family's `frame_means_curved`), or held over the frame,
whichever is nearer the truth there.

    python3 bench/estimate_shown.py --draws bench/results/RUN/heads/draws.jsonl --jobs 2 --out /tmp/shown

Writes frames.jsonl (a line a frame: its share, the truth's mean pose's error there, petblur's) and shown.md: per
draw, petblur's mean error beside the part of the mean that frames under 1 % and under 3 % leave at best, and
petblur's error on the frames with no motion inside (their true mean pose, held, within 0.05 mm of the truth), and
the worst frame the same way: petblur's beside the worst that frames under each bar leave at best, which bounds what
any estimate from these frames can reach on issue 47's worst-frame target."""
from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import sys

import numpy as np
from scipy import ndimage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import estimate_family as ef  # noqa: E402
import head_frames as hf  # noqa: E402

BARS = (1.0, 3.0)  # percent of a frame's noise energy
STILL_MM = 0.05    # the truth's mean pose this near the truth over a frame: no motion inside it


def shares(seed: int) -> list:
    """Each frame's one-pose misfit without noise, percent of its noise energy on the head."""
    d = ef.draw(seed)
    truth, scene = ef.Truth(d), ef.Scene(d)
    rng = np.random.default_rng([seed, 1])
    frames, _, b, _ = ef.simulate(d, rng)
    points = hf.head_points(rng)  # the family's own, drawn after the frames' counts
    means = ef.frame_means(truth, b)[1][1:-1]
    held = hf.displacement_errors(lambda t: means[min(np.searchsorted(b, t, side="right") - 1, len(means) - 1)],
                                  truth, b, points)
    out = []
    for k in range(len(b) - 1):
        ts = ef.instants(truth, b[k], b[k + 1])
        maps = np.array([truth(t) for t in ts])

        def view(ms):
            acc = sum(scene.sample(m, t) for m, t in zip(ms, ts)) / len(ts)
            return ndimage.gaussian_filter(acc, scene.sigma, mode="constant")

        clean = view(maps)
        mask = clean > 0.05 * clean.max()
        scale = frames[..., k].sum() / clean.sum()
        y, yc = frames[..., k][mask].astype(np.float64), clean[mask] * scale
        one = view([ef.mean_map(maps)] * len(ts))[mask] * scale
        x = np.column_stack([one, np.ones(len(one))])
        c, *_ = np.linalg.lstsq(x, yc, rcond=None)
        misfit = float(((yc - x @ c) ** 2).sum())
        noise = float(((y - yc) ** 2).sum())
        out.append({"seed": seed, "frame": k, "t0": float(b[k]), "t1": float(b[k + 1]),
                    "shown_percent": 100.0 * misfit / noise, "held_mean_pose_mm": round(float(held[k]), 3)})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--draws", required=True, help="a family run's draws.jsonl (petblur's per-frame errors)")
    ap.add_argument("--seed", type=int, action="append", help="only these seeds")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    draws = [json.loads(line) for line in open(a.draws)]
    draws = [r for r in draws if not a.seed or r["seed"] in a.seed]
    os.makedirs(a.out, exist_ok=True)
    with multiprocessing.Pool(a.jobs) as pool:
        per_draw = pool.map(shares, [r["seed"] for r in draws], chunksize=1)
    rows, lines = [], []
    for r, fr in zip(draws, per_draw):
        pb, fm = r["petblur"]["per_frame_mm"], r["frame_means_curved"]["per_frame_mm"]
        moving = r["petblur"]["frames"]["moving"]
        for f in fr:
            k = f["frame"]
            f.update(curved_mean_poses_mm=fm[k], petblur_mm=pb[k], petblur_moving=bool(moving[k]))
            f["best_mean_poses_mm"] = min(fm[k], f["held_mean_pose_mm"])
            lines.append(f)
        n = len(fr)
        floors = [sum(f["best_mean_poses_mm"] for f in fr if f["shown_percent"] < bar) / n for bar in BARS]
        worst = [max([f["best_mean_poses_mm"] for f in fr if f["shown_percent"] < bar] or [0.0]) for bar in BARS]
        still = [f["frame"] for f in fr if f["held_mean_pose_mm"] < STILL_MM]
        rows.append((r["seed"], r["from_injection"], n, r["petblur"]["mean_mm"], *floors,
                     sum(pb[k] for k in still) / n, len(still),
                     float(np.mean([pb[k] for k in still])) if still else float("nan"), max(pb), *worst))
    with open(os.path.join(a.out, "frames.jsonl"), "w") as f:
        for line in lines:
            f.write(json.dumps(line) + "\n")
    head = ("| seed | from injection | frames | petblur mean mm | unshown motion's floor, 1 % bar | the same, 3 % | "
            "petblur on frames without motion inside: share of the mean mm | those frames | their mean mm | "
            "petblur's worst frame mm | the unshown motion's worst frame, 1 % bar | the same, 3 % |")
    md = [head, "|" + "---|" * 12]
    for s in sorted(rows, key=lambda s: -s[3]):
        md.append("| %d | %s | %d | %.3f | %.3f | %.3f | %.3f | %d | %.3f | %.3f | %.3f | %.3f |"
                  % (s[0], "yes" if s[1] else "no", *s[2:]))
    arr = np.array([s[3:7] for s in rows])
    med = np.median(arr, axis=0)
    worst = np.median(np.array([s[9:12] for s in rows]), axis=0)
    md += ["", "Medians over the %d draws: petblur %.3f mm, the unshown motion's floor %.3f (1 %% bar) and %.3f (3 %%), "
           "petblur's share of the mean on frames without motion inside %.3f." % (len(rows), *med),
           "", "The worst frame, median over the draws: petblur %.3f mm, what the frames under the bar leave at best "
           "%.3f (1 %%) and %.3f (3 %%)." % tuple(worst)]
    with open(os.path.join(a.out, "shown.md"), "w") as f:
        f.write("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
