# The default's error under variants of the noisy-run rule: python3 variants.py KIND FIRST_SEED END_SEED [--tails],
# from the repository root, with PETBLUR_LIBRARY a library built with variants.patch (applied to 0314481) and VARIANTS
# a list of NAME:SHARE,ZS,ZL (the noisy run's mean-square share of E; the standard deviations of the noise's own mean
# square allowed below 64 samples, and from 64). The draws of noise_tails.py (bench/path_cases.py, small, AB exact on
# the host at the default bound); per variant: RMS %, max % from the true motion's dense blur, segments.
#   VARIANTS="base:1,0,3 a:0.35,2,3 e:0.35,3,3"        (0314481's rule: base; the rule adopted: a)
# --tails adds noise_tails.py's columns, for the test's bounds: own_rms, own_max (following the noise) and true_segs
# (the true motion's segments, planned without noise and so the same under every variant).
import sys, os, json, numpy as np
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import repo_scripts, petblur
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
VARIANTS = [(v.split(":")[0], *v.split(":")[1].split(",")) for v in os.environ["VARIANTS"].split()]
kind, tails = sys.argv[1], "--tails" in sys.argv[4:]
for seed in range(int(sys.argv[2]), int(sys.argv[3])):
    case = pc.draw_case(kind, np.random.default_rng(seed), small=True)
    true = pc.reference(case, "true", times=min(pc.reference_times(case, "true"), 1500))
    out = {"seed": seed, "kind": kind, "noise": round(case.noise_mm, 4), "obj": case.object}
    if tails:
        own = pc.errors(true, pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500)))
        out.update(own_rms=round(own["rms_pct"], 4), own_max=round(own["max_pct"], 4))
    for name, m, z, zl in VARIANTS:
        os.environ["PB_FIT_SHARE"] = m; os.environ["PB_FIT_ZS"] = z; os.environ["PB_FIT_ZL"] = zl
        op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab", filter="exact",
                                  affine=case.affine, device="host")
        y = np.asarray(op(np.asfortranarray(case.x))); e = pc.errors(true, y)
        out[name] = [round(e["rms_pct"], 4), round(e["max_pct"], 4), pc.path_segments(op)]
    if tails:
        out["true_segs"] = pc.path_segments(op, case.true)
    print(json.dumps(out), flush=True)
