import sys, os, json, numpy as np
sys.path.insert(0, __import__("os").path.dirname(__file__)); from segs import *
kind = sys.argv[1]; lo, hi = int(sys.argv[2]), int(sys.argv[3])
for seed in range(lo, hi):
    case = pc.draw_case(kind, np.random.default_rng(seed), small=True)
    which = "true" if case.noise_mm > 0 else "logged"
    ref = pc.reference(case, which, times=min(pc.reference_times(case, which), 1500))
    x = np.asfortranarray(case.x)
    n, op = segments(case, None)
    e = pc.errors(ref, np.asarray(op(x)))
    print(json.dumps({"seed": seed, "segs": n, "rms": round(e["rms_pct"], 4), "max": round(e["max_pct"], 4)}), flush=True)
