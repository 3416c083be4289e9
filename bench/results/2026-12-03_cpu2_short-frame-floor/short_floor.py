"""One short frame of a noisy 20 Hz log (the draw of
python/tests/test_path_cases.py::test_short_frame_noise_measured_about_it):
the default's error from the true motion's dense blur beside the noise floor
(path_cases.noise_floor) and following the noise. Run from the repository
root with PETBLUR_LIBRARY the library: short_floor.py SEED KIND > one JSON line."""
import json
import sys

import numpy as np

sys.path.insert(0, "python/tests")
sys.path.insert(0, "python")
import petblur  # noqa: E402
import repo_scripts  # noqa: E402

pc = repo_scripts.load("bench/path_cases.py", "path_cases")
seed, kind = int(sys.argv[1]), sys.argv[2]
case = pc.draw_short_frame(kind, np.random.default_rng(seed))
true = pc.reference(case, "true", times=400)
follow = pc.errors(true, pc.reference(case, "logged", times=400))
floor = pc.errors(true, pc.noise_floor(case, times=400))
op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab", filter="exact",
                          affine=case.affine, device="host")
e = pc.errors(true, op(np.asfortranarray(case.x)))
print(json.dumps({"seed": seed, "kind": kind, "rms_pct": round(e["rms_pct"], 4), "floor_rms_pct": round(floor["rms_pct"], 4),
                  "max_pct": round(e["max_pct"], 4), "floor_max_pct": round(floor["max_pct"], 4),
                  "follow_rms_pct": round(follow["rms_pct"], 4)}))
