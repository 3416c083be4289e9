import sys, json, numpy as np
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import repo_scripts, petblur
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
kind = sys.argv[1]; lo, hi = int(sys.argv[2]), int(sys.argv[3])
for seed in range(lo, hi):
    rng = np.random.default_rng(seed)
    case = pc.draw_case(kind, rng, small=True)
    t0, t1 = case.frame
    length = rng.uniform(1.5, 3.0); start = rng.uniform(t0, t1 - length)
    case.frame = (start, start + length)
    ref = pc.reference(case, "true", times=400); lg = pc.errors(ref, pc.reference(case, "logged", times=400))
    x = np.asfortranarray(case.x)
    op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab", filter="exact",
                              affine=case.affine, device="host")
    e = pc.errors(ref, np.asarray(op(x)))
    f = case.logged.summary(list(case.frame), case.shape, case.voxel, affine=case.affine)["frames"][0]
    print(json.dumps({"seed": seed, "len_s": round(length, 2), "noise": round(case.noise_mm, 3), "segs": f["segments"], "noise_mm": round(f["noise_mm"], 3),
                      "rms": round(e["rms_pct"], 4), "max": round(e["max_pct"], 4), "follow_rms": round(lg["rms_pct"], 4), "follow_max": round(lg["max_pct"], 4), "true_segs": pc.path_segments(op, case.true)}), flush=True)
