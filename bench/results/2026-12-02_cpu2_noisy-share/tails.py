# The test's bounds under two rules: python3 tails.py KIND FIRST_SEED END_SEED, from the repository root, with
# PETBLUR_LIBRARY and VARIANTS as variants.py's. noise_tails.py's draws and columns (own_rms, own_max: following the
# noise; true_segs: the true motion's segments, planned without noise and so the same under every variant), and per
# variant RMS %, max %, segments.
import sys, os, json, numpy as np
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import repo_scripts, petblur
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
VARIANTS = [(v.split(":")[0], *v.split(":")[1].split(",")) for v in os.environ["VARIANTS"].split()]
kind = sys.argv[1]
for seed in range(int(sys.argv[2]), int(sys.argv[3])):
    case = pc.draw_case(kind, np.random.default_rng(seed), small=True)
    true = pc.reference(case, "true", times=min(pc.reference_times(case, "true"), 1500))
    logged = pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500))
    own = pc.errors(true, logged)
    out = {"seed": seed, "kind": kind, "noise": round(case.noise_mm, 4), "obj": case.object,
           "own_rms": round(own["rms_pct"], 4), "own_max": round(own["max_pct"], 4)}
    for name, m, z, zl in VARIANTS:
        os.environ["PB_FIT_SHARE"] = m; os.environ["PB_FIT_ZS"] = z; os.environ["PB_FIT_ZL"] = zl
        op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab", filter="exact",
                                  affine=case.affine, device="host")
        y = np.asarray(op(np.asfortranarray(case.x))); e = pc.errors(true, y)
        out[name] = [round(e["rms_pct"], 4), round(e["max_pct"], 4), pc.path_segments(op)]
        out["true_segs"] = pc.path_segments(op, case.true)
    print(json.dumps(out), flush=True)
