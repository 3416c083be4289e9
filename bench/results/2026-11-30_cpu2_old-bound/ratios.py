import os, sys, importlib.util, numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "python"))
import petblur
spec = importlib.util.spec_from_file_location("ac", os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "accuracy_case.py")); ac = importlib.util.module_from_spec(spec); spec.loader.exec_module(ac)
for seed in map(int, sys.argv[2:]):
    case = ac.Case(np.random.default_rng(seed), ac.FULL["shape"], ac.FULL["voxel"], fwhm_mm=float(sys.argv[1]))
    ref = ac.reference(case, times=1500)
    x = np.asfortranarray(case.x); out = {}
    for bound in (None, 0.25):
        op = petblur.BlurOperator(case.shape, case.voxel, case.motion(), method="ab", max_path_error=bound, affine=case.affine, device="opencl")
        out[bound] = ac.errors(ref, op(x))
    n, o = out[None], out[0.25]
    print(seed, "new %.4f/%.4f old %.4f/%.4f ratio rms %.2f max %.2f" % (n["rms_pct"], n["max_pct"], o["rms_pct"], o["max_pct"], o["rms_pct"]/n["rms_pct"], o["max_pct"]/n["max_pct"]), flush=True)
