"""The noise-free kinds of bench/path_cases.py over fresh seeds, as
python/tests/test_path_cases.py::test_default_bound_fitted draws them (the
rng of PETBLUR_TEST_SEED, one small case per kind): AB's and RM's relative
RMS / max % against the logged track's dense reference at the default bound,
and the logged track's segments. One JSON line per seed, kind and method.
Usage: PYTHONPATH=python PETBLUR_LIBRARY=... python3 seeds.py SEED..."""
import importlib.util
import json
import pathlib
import sys

import numpy as np

import petblur

ROOT = pathlib.Path(__file__).resolve().parents[3]
spec = importlib.util.spec_from_file_location("path_cases", ROOT / "bench/path_cases.py")
pc = importlib.util.module_from_spec(spec)
spec.loader.exec_module(pc)

for seed in map(int, sys.argv[1:]):
    for kind in ("drift-1hz", "rotation", "translation"):
        case = pc.draw_case(kind, np.random.default_rng(seed), True)
        ref = pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500))
        x = np.asfortranarray(case.x)
        for method in ("ab", "rm"):
            op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method=method,
                                      filter="exact", affine=case.affine, device="host")
            y = np.full(case.shape, np.nan, np.float32, order="F")
            y[...] = op(x)
            e = pc.errors(ref, y)
            print(json.dumps({"seed": seed, "kind": kind, "method": method, "rms_pct": round(e["rms_pct"], 4),
                              "max_pct": round(e["max_pct"], 4), "segments": pc.path_segments(op)}), flush=True)
