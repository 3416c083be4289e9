# One line of JSON a draw: python3 noise_tails.py KIND FIRST_SEED END_SEED, from the repository root with
# PETBLUR_LIBRARY set (the draws of bench/path_cases.py, small; AB exact on the host at the default bound).
import sys, json, numpy as np
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import repo_scripts, petblur
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
kind = sys.argv[1]; lo, hi = int(sys.argv[2]), int(sys.argv[3])
for seed in range(lo, hi):
    rng = np.random.default_rng(seed)
    case = pc.draw_case(kind, rng, small=True)
    true = pc.reference(case, "true", times=min(pc.reference_times(case, "true"), 1500))
    logged = pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500))
    x = np.asfortranarray(case.x)
    op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab", filter="exact",
                              affine=case.affine, device="host")
    y = np.asarray(op(x))
    e = pc.errors(true, y); own = pc.errors(true, logged)
    print(json.dumps({"seed": seed, "kind": kind, "rms": e["rms_pct"], "max": e["max_pct"], "own_rms": own["rms_pct"],
                      "own_max": own["max_pct"], "segs": pc.path_segments(op), "true_segs": pc.path_segments(op, case.true),
                      "noise": case.noise_mm, "obj": case.object, "vox": case.voxel.tolist()}), flush=True)
