"""Segments of bench/path_cases.py kinds (--small) on seeds A..B-1, planning only: the logged track against the true
motion (100 Hz, no noise); over-limit lists draws above test_tracker_noise_is_not_followed's 3x + 10. Run from the
repository root: PYTHONPATH=python PETBLUR_LIBRARY=... python3 segments.py KIND,... A B"""
import json, sys, time
import numpy as np
sys.path.insert(0, "bench")
import path_cases as pc
import petblur
kinds = sys.argv[1].split(",")
seeds = range(int(sys.argv[2]), int(sys.argv[3]))
for kind in kinds:
    rows = []
    t0 = time.time()
    for seed in seeds:
        case = pc.draw_case(kind, np.random.default_rng([seed, pc.KINDS.index(kind)]), small=True)
        op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab",
                                  filter="exact", affine=case.affine, device="host")
        s, ts = pc.path_segments(op), pc.path_segments(op, case.true)
        rows.append((seed, s, ts, case.params.get("noise_mm", 0) if hasattr(case, "params") else 0))
    r = np.array([(s, ts) for _, s, ts, _ in rows], float)
    ratio = r[:, 0] / np.maximum(r[:, 1], 1)
    bad = [(sd, s, ts) for sd, s, ts, _ in rows if s > 3 * ts + 10]
    print(f"{kind}: segs sum {r[:,0].sum():.0f} true {r[:,1].sum():.0f} ratio med {np.median(ratio):.2f} max {ratio.max():.2f} over-limit {bad} ({time.time()-t0:.0f}s)", flush=True)
