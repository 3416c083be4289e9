"""Per draw: petblur with the link by mutual information (the default) against PETBLUR_ESTIMATE_LINK=0, mean / worst
frame error in mm, from family/draws.jsonl; SimpleITK (correlation, to petblur's reference frame) from
sitk/draws.jsonl where it is there. Usage: python3 compare.py (in this folder)."""
import json
import os

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
rows = [json.loads(line) for line in open(os.path.join(here, "family", "draws.jsonl"))]
sitk = {}
path = os.path.join(here, "sitk", "draws.jsonl")
if os.path.exists(path):
    sitk = {r["seed"]: r["sitk"]["mean_mm"] for r in map(json.loads, open(path))}
print("| seed | kind | link mean / worst mm | without mean / worst mm | SimpleITK mean mm | link |")
print("|---|---|---|---|---|---|")
for d in sorted(rows, key=lambda d: (not d["from_injection"], d["seed"])):
    a, b = d["petblur"], d["variants"]["nolink"]
    tag = "better" if a["mean_mm"] < b["mean_mm"] - 0.005 else "worse" if a["mean_mm"] > b["mean_mm"] + 0.005 else "same"
    print("| %d | %s | %.3f / %.3f | %.3f / %.3f | %.3f | %s |" % (
        d["seed"], "injection" if d["from_injection"] else "late", a["mean_mm"], a["max_mm"], b["mean_mm"], b["max_mm"],
        sitk.get(d["seed"], float("nan")), tag))
print()
for name, sel in (("from injection", True), ("late", False), ("all", None)):
    s = [d for d in rows if sel is None or d["from_injection"] == sel]
    link = np.array([d["petblur"]["mean_mm"] for d in s])
    without = np.array([d["variants"]["nolink"]["mean_mm"] for d in s])
    print("%s (%d): link median %.3f, mean %.3f, worst %.3f, above 0.6 mm %d; without median %.3f, mean %.3f, "
          "worst %.3f, above 0.6 mm %d; better %d, worse %d (by over 0.005 mm)" % (
              name, len(s), np.median(link), link.mean(), link.max(), (link > 0.6).sum(), np.median(without),
              without.mean(), without.max(), (without > 0.6).sum(), (link < without - 0.005).sum(),
              (link > without + 0.005).sum()))
    if sitk:
        st = np.array([sitk.get(d["seed"], np.nan) for d in s])
        print("  at or below SimpleITK's mean: link %d, without %d of %d" % (
            (link <= st).sum(), (without <= st).sum(), np.isfinite(st).sum()))
