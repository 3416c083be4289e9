# The default's error under variants of the path fit set by environment variables: python3 variants.py KIND
# FIRST_SEED END_SEED [--tails], from the repository root, with PETBLUR_LIBRARY a library that reads them and VARIANTS
# a list of NAME:VAR=VALUE,VAR=VALUE (NAME: for none; a variable no variant names stays unset). The libraries:
# variants.patch on 0314481 (PB_FIT_SHARE, the noisy run's mean-square share of E; PB_FIT_ZS and PB_FIT_ZL, the
# standard deviations of the noise's own mean square allowed below 64 samples and from 64), and
# ../2026-12-02_cpu2_measure-scatter/measure.patch on 94b6283 (PB_FIT_ZM=0, the old scatter; PB_FIT_AC=1, the lag-1
# test). The draws of noise_tails.py (bench/path_cases.py, small, AB exact on the host at the default bound); per
# variant: RMS %, max % from the true motion's dense blur, segments.
#   VARIANTS="base:PB_FIT_SHARE=1,PB_FIT_ZS=0,PB_FIT_ZL=3 a:PB_FIT_SHARE=0.35,PB_FIT_ZS=2,PB_FIT_ZL=3"
#   VARIANTS="old:PB_FIT_ZM=0 ac:PB_FIT_AC=1"
# --tails adds noise_tails.py's columns, for the test's bounds: own_rms, own_max (following the noise) and true_segs
# (the true motion's segments, planned without noise and so the same under every variant).
import sys, os, json, numpy as np
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import repo_scripts, petblur
pc = repo_scripts.load("bench/path_cases.py", "path_cases")


def variants():
    """[(name, {VAR: VALUE})] from VARIANTS, and every variable named, to unset between variants."""
    out = []
    for v in os.environ["VARIANTS"].split():
        name, _, sets = v.partition(":")
        out.append((name, dict(kv.split("=") for kv in sets.split(",") if kv)))
    return out, {k for _, sets in out for k in sets}


def use(sets, names):
    for k in names:
        os.environ.pop(k, None)
    os.environ.update(sets)


if __name__ == "__main__":
    VARIANTS, names = variants()
    kind, tails = sys.argv[1], "--tails" in sys.argv[4:]
    for seed in range(int(sys.argv[2]), int(sys.argv[3])):
        case = pc.draw_case(kind, np.random.default_rng(seed), small=True)
        true = pc.reference(case, "true", times=min(pc.reference_times(case, "true"), 1500))
        out = {"seed": seed, "kind": kind, "noise": round(case.noise_mm, 4), "obj": case.object}
        if tails:
            own = pc.errors(true, pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500)))
            out.update(own_rms=round(own["rms_pct"], 4), own_max=round(own["max_pct"], 4))
        for name, sets in VARIANTS:
            use(sets, names)
            op = petblur.BlurOperator(case.shape, case.voxel, case.logged, frame=case.frame, method="ab",
                                      filter="exact", affine=case.affine, device="host")
            y = np.asarray(op(np.asfortranarray(case.x))); e = pc.errors(true, y)
            out[name] = [round(e["rms_pct"], 4), round(e["max_pct"], 4), pc.path_segments(op)]
        if tails:
            out["true_segs"] = pc.path_segments(op, case.true)
        print(json.dumps(out), flush=True)
