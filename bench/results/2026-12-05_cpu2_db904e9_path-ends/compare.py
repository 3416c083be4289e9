"""Each draw with the step at a path's still end (the default) and with the ramp (PETBLUR_ESTIMATE_PATH_ENDS=ramp):
the draw's mean and worst-frame error, and every frame whose error changed by over 0.005 mm."""
import json
import os

here = os.path.dirname(os.path.abspath(__file__))
rows = [json.loads(line) for line in open(os.path.join(here, "family", "draws.jsonl"))]
print("| seed | kind | frames | moving frames | ramp mean / worst mm | step mean / worst mm | frames changed (ramp -> step mm) |")
print("|---|---|---|---|---|---|---|")
better = worse = 0
for r in rows:
    a, b = r["petblur"], r["variants"]["ramp"]
    changed = ["%d: %.3f -> %.3f" % (i, y, x) for i, (x, y) in enumerate(zip(a["per_frame_mm"], b["per_frame_mm"]))
               if abs(x - y) > 0.005]
    better += a["mean_mm"] < b["mean_mm"] - 0.005
    worse += a["mean_mm"] > b["mean_mm"] + 0.005
    print("| %d | %s | %d | %d | %.3f / %.3f | %.3f / %.3f | %s |" % (
        r["seed"], "injection" if r["from_injection"] else "late", r["frames"], sum(a["frames"]["moving"]),
        b["mean_mm"], b["max_mm"], a["mean_mm"], a["max_mm"], "; ".join(changed) or "-"))
print()
print("%d draws: %d better, %d worse by over 0.005 mm in their mean" % (len(rows), better, worse))
