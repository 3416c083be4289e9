import json, sys
import numpy as np
rows = [json.loads(l) for l in open(sys.argv[1])]
d = np.array([[r["petblur"]["mean_mm"], r["variants"]["unshifted"]["mean_mm"], r["variants"]["energy"]["mean_mm"],
               r["petblur"]["max_mm"], r["variants"]["unshifted"]["max_mm"], r["variants"]["energy"]["max_mm"], r["from_injection"]] for r in rows])
print("draws", len(d), "from injection", int(d[:, 6].sum()))
for i, name in enumerate(("noise", "unshifted", "energy")):
    print("%-10s median %.3f 90th %.3f worst %.3f | worst frame median %.3f" % (name, np.median(d[:, i]), np.percentile(d[:, i], 90), d[:, i].max(), np.median(d[:, 3 + i])))
for i, name in ((0, "noise"), (1, "unshifted")):
    diff = d[:, i] - d[:, 2]
    print("%s against energy: better %d worse %d (by > 0.01 mm)" % (name, (diff < -0.01).sum(), (diff > 0.01).sum()))
print("| seed | from injection | noise | unshifted | as built |")
print("|---|---|---|---|---|")
for r, x in zip(rows, d):
    print("| %d | %s | %.3f | %.3f | %.3f |" % (r["seed"], "yes" if x[6] else "no", x[0], x[1], x[2]))
