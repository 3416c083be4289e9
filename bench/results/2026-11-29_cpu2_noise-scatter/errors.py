"""AB and RM (host, exact filter, defaults) against the true motion's dense reference (bench/path_cases.py, at most
1500 poses), seeds A..B-1, one JSON line a case. PYTHONPATH=python PETBLUR_LIBRARY=... python3 errors.py KIND,... A B"""
import json, sys, time
import numpy as np
sys.path.insert(0, "bench")
import path_cases as pc
import petblur
kinds = sys.argv[1].split(",")
for seed in range(int(sys.argv[2]), int(sys.argv[3])):
    for kind in kinds:
        case = pc.draw_case(kind, np.random.default_rng([seed, pc.KINDS.index(kind)]), small=True)
        ref = pc.reference(case, "true", times=min(pc.reference_times(case, "true"), 1500))
        out = {}
        for m in ("ab", "rm"):
            op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method=m,
                                  filter="exact", affine=case.affine, device="host")
            e = pc.errors(ref, np.asarray(op(np.asfortranarray(case.x))))
            out[m] = [round(e["rms_pct"], 3), round(e["max_pct"], 3)]
        print(json.dumps(dict(seed=seed, kind=kind, segs=pc.path_segments(op), true=pc.path_segments(op, case.true), **out)), flush=True)
