# The default's error under variants set by environment variables: python3 variants.py KIND FIRST_SEED END_SEED,
# from the repository root, with PETBLUR_LIBRARY a library that reads them (measure.patch) and VARIANTS a list of
# NAME:VAR=VALUE,VAR=VALUE (NAME: for none). The draws of bench/path_cases.py (small, AB exact on the host at the
# default bound); per variant: RMS %, max % from the true motion's dense blur, segments. The noisy-share folder's
# variants.py with its three fixed variables made general.
#   VARIANTS="old:PB_FIT_ZM=0 new:"
import sys, os, json, numpy as np
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import repo_scripts, petblur
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
VARIANTS = []
for v in os.environ["VARIANTS"].split():
    name, _, sets = v.partition(":")
    VARIANTS.append((name, dict(kv.split("=") for kv in sets.split(",") if kv)))
names = {k for _, sets in VARIANTS for k in sets}
kind = sys.argv[1]
for seed in range(int(sys.argv[2]), int(sys.argv[3])):
    case = pc.draw_case(kind, np.random.default_rng(seed), small=True)
    true = pc.reference(case, "true", times=min(pc.reference_times(case, "true"), 1500))
    out = {"seed": seed, "kind": kind, "noise": round(case.noise_mm, 4), "obj": case.object}
    for name, sets in VARIANTS:
        for k in names:
            os.environ.pop(k, None)
        os.environ.update(sets)
        op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab", filter="exact",
                                  affine=case.affine, device="host")
        y = np.asarray(op(np.asfortranarray(case.x))); e = pc.errors(true, y)
        out[name] = [round(e["rms_pct"], 4), round(e["max_pct"], 4), pc.path_segments(op)]
    print(json.dumps(out), flush=True)
