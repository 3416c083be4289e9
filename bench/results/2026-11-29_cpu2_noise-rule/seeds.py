"""The noisy kinds of bench/path_cases.py (--small) on fresh seeds, host, AB exact at the defaults: errors against
the dense references of the true motion and of the logged track, the logged track's own reference against the true
one's, and segments (logged track; true motion at 100 Hz). Run from the repository root:
  PYTHONPATH=python PETBLUR_LIBRARY=... python3 seeds.py SEED... > seeds.jsonl"""
import json
import sys

import numpy as np

sys.path.insert(0, "bench")
import path_cases as pc  # noqa: E402

import petblur  # noqa: E402

for seed in [int(a) for a in sys.argv[1:] if a.isdigit()]:
    for kind in (sys.argv[1].split(",") if not sys.argv[1].isdigit() else ("still", "drift-20hz", "nod", "seizure")):
        case = pc.draw_case(kind, np.random.default_rng([seed, pc.KINDS.index(kind)]), small=True)
        refs = {w: pc.reference(case, w, times=min(pc.reference_times(case, w), 1500)) for w in ("true", "logged")}
        op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab",
                                  filter="exact", affine=case.affine, device="host")
        y = np.asarray(op(np.asfortranarray(case.x)))
        row = dict(seed=seed, kind=kind, case=pc.describe(case), segments=pc.path_segments(op),
                   true_segments=pc.path_segments(op, case.true))
        for w in ("true", "logged"):
            e = pc.errors(refs[w], y)
            row[w] = [round(e["rms_pct"], 4), round(e["max_pct"], 4)]
        e = pc.errors(refs["true"], refs["logged"])
        row["logged_vs_true"] = [round(e["rms_pct"], 4), round(e["max_pct"], 4)]
        print(json.dumps(row), flush=True)
