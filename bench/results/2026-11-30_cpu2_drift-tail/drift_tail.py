import sys, json, numpy as np
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import repo_scripts, petblur
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
lo, hi = int(sys.argv[1]), int(sys.argv[2])
for seed in range(lo, hi):
    rng = np.random.default_rng(seed)
    case = pc.draw_case("drift-1hz", rng, small=True)
    ref = pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500))
    x = np.asfortranarray(case.x)
    r = {"seed": seed}
    for method in ("ab", "rm"):
        op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method=method,
                                  filter="exact", affine=case.affine, device="host")
        e = pc.errors(ref, np.asarray(op(x)))
        r[method] = [round(e["rms_pct"], 4), round(e["max_pct"], 4)]
    print(json.dumps(r), flush=True)
