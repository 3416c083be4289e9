"""The default against the `energy` variant (the references as they were), per draw, from family runs'
draws.jsonl: pair.py DRAWS.jsonl..."""
import json
import sys

import numpy as np

rows = [json.loads(line) for f in sys.argv[1:] for line in open(f)]
d = np.array([[r["petblur"]["mean_mm"], r["variants"]["energy"]["mean_mm"], r["petblur"]["max_mm"],
               r["variants"]["energy"]["max_mm"], r["from_injection"]] for r in rows], float)
new, old, new_w, old_w, inj = d.T
print("draws", len(d), "from injection", int(inj.sum()))
for name, m in (("all", np.ones(len(d), bool)), ("from injection", inj == 1), ("late scans", inj == 0)):
    diff, dw = new[m] - old[m], new_w[m] - old_w[m]
    print(f"{name:15s} n={m.sum():2d}  mean, median over draws: now {np.median(new[m]):.3f} before {np.median(old[m]):.3f}"
          f" | worst frame, median: now {np.median(new_w[m]):.3f} before {np.median(old_w[m]):.3f}"
          f" | draws better / worse by > 0.01 mm: {(diff < -0.01).sum()} / {(diff > 0.01).sum()}"
          f" | worst frames better / worse by > 0.05 mm: {(dw < -0.05).sum()} / {(dw > 0.05).sum()}")
print("above 0.6 mm: now %d, before %d; 90th percentile now %.3f before %.3f; worst draw now %.3f before %.3f" % (
    (new > 0.6).sum(), (old > 0.6).sum(), np.percentile(new, 90), np.percentile(old, 90), new.max(), old.max()))
print()
print("| seed | from injection | mean now | before | worst frame now | before |")
print("|---|---|---|---|---|---|")
for r, (a, b, c, e, i) in sorted(zip(rows, d), key=lambda x: x[1][1] - x[1][0]):
    print("| %d | %s | %.3f | %.3f | %.3f | %.3f |" % (r["seed"], "yes" if i else "no", a, b, c, e))
