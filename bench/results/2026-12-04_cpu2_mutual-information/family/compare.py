"""The third set of bench/results/2026-12-04_H200_94a9dd7_curve, its 9 draws from injection: petblur (CUDA), SimpleITK
with correlation (that run's) and with Mattes mutual information (draws-mattes.jsonl, the host), each frame registered
to the reference frame petblur chose. Per draw: the mean error, and the mean over the still frames (the truth's mean
pose a frame within 0.05 mm of its track's: no motion inside them to model) before the reference frame, where the
early-to-late bias lies.

    cd bench && python3 results/2026-12-04_cpu2_mutual-information/family/compare.py
"""
import json
import os

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
curve = os.path.join(here, "..", "..", "2026-12-04_H200_94a9dd7_curve", "third")
gpu = {r["seed"]: r for r in map(json.loads, open(os.path.join(curve, "gpu", "draws.jsonl")))}
corr = {r["seed"]: r for r in map(json.loads, open(os.path.join(curve, "sitk", "draws.jsonl")))}
mi = {r["seed"]: r for r in map(json.loads, open(os.path.join(here, "draws-mattes.jsonl")))}
print("| draw | frames still before the reference | petblur, mean / still early | SimpleITK correlation | "
      "SimpleITK mutual information |")
print("|---|---|---|---|---|")
sums = np.zeros(6)
for seed, r in gpu.items():
    if seed not in mi:
        continue
    ref = r["petblur"]["reference"]
    fm = np.array(r["frame_means"]["per_frame_mm"])
    still = [k for k in range(ref) if fm[k] < 0.05]
    row = []
    for x in (r["petblur"], corr[seed]["sitk"], mi[seed]["sitk"]):
        e = np.array(x["per_frame_mm"])
        row += [x["mean_mm"], e[still].mean() if still else float("nan")]
    sums += np.array(row)
    print(f"| {seed} | {len(still)} of {ref} | " + " | ".join(f"{row[i]:.3f} / {row[i + 1]:.3f}" for i in (0, 2, 4))
          + " |")
n = len([s for s in gpu if s in mi])
print(f"| mean of {n} | | " + " | ".join(f"{sums[i] / n:.3f} / {sums[i + 1] / n:.3f}" for i in (0, 2, 4)) + " |")
