import json, sys, numpy as np
rows = [json.loads(l) for f in sys.argv[1:] for l in open(f)]
d = np.array([[r['petblur']['mean_mm'], r['variants']['raw']['mean_mm'], r['petblur']['max_mm'], r['variants']['raw']['max_mm'], r['from_injection'], r['petblur']['reference'] == r['variants']['raw']['reference']] for r in rows], float)
s, r, sw, rw, inj, same = d.T
print("draws", len(d), "injection", int(inj.sum()))
for name, m in (("all", np.ones(len(d), bool)), ("injection", inj == 1), ("late", inj == 0), ("same reference", same == 1), ("reference changed", same == 0)):
    diff = s[m] - r[m]
    print(f"{name:18s} n={m.sum():2d}  smoothed {np.median(s[m]):.3f} raw {np.median(r[m]):.3f} (median mean) | worst frame {np.median(sw[m]):.3f} vs {np.median(rw[m]):.3f} | smoothed better by >0.01: {(diff < -0.01).sum()}, worse by >0.01: {(diff > 0.01).sum()} | diff median {np.median(diff):+.3f} min {diff.min():+.3f} max {diff.max():+.3f}")
print("above 0.6 mm: smoothed", (s > 0.6).sum(), "raw", (r > 0.6).sum())
print("90th pct: smoothed %.3f raw %.3f; worst %.3f %.3f" % (np.percentile(s, 90), np.percentile(r, 90), s.max(), r.max()))
