"""Where a draw's mean error lies, frame by frame, in the sets of this run (first, second and third): frames that a
jerk spans across a boundary, frames that hold a jerk inside, frames where the head is still (the truth's mean pose a
frame within 0.05 mm), and the rest (nods, drift). Each class's share of a draw's mean (the sum of its frames' errors
over the draw's frame count), averaged over the draws; beside the first class, the truth's mean pose a frame there.

    cd bench && python3 results/2026-12-04_H200_94a9dd7_curve/budget.py
"""
import json
import os
import sys

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(here, "..", ".."))
import estimate_family as ef  # noqa: E402

for folder in ("first", "second", "third"):
    rows = [json.loads(line) for line in open(os.path.join(here, folder, "draws.jsonl"))]
    total = across = across_bound = inside = still = 0.0
    for r in rows:
        d = ef.draw(r["seed"])
        b = np.array(d.bounds)
        pf, fm = np.array(r["petblur"]["per_frame_mm"]), np.array(r["frame_means"]["per_frame_mm"])
        n = len(pf)
        cross, within = set(), set()
        for at, length, *_ in d.jerks:
            ks = [k for k in range(n) if b[k] < at + length and b[k + 1] > at]
            (cross if len(ks) > 1 else within).update(ks)
        quiet = [k for k in range(n) if fm[k] < 0.05 and k not in cross and k not in within]
        total += pf.mean()
        across += pf[list(cross)].sum() / n
        across_bound += fm[list(cross)].sum() / n
        inside += pf[list(within)].sum() / n
        still += pf[quiet].sum() / n
    m = len(rows)
    print(f"{folder}: {m} draws, mean of the draws' means {total / m:.3f} mm: across boundaries {across / m:.3f} "
          f"(one pose a frame there {across_bound / m:.3f}), jerks inside frames {inside / m:.3f}, still frames "
          f"{still / m:.3f}, the rest {(total - across - inside - still) / m:.3f}")
