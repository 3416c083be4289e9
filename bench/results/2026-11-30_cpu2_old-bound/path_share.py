"""path_share.py FWHM SEED...: for accuracy_case.py's full-size case of each seed, AB's blur at the default
bound and at 0.25 voxels against AB's at 0.01 (the path's own share of the error), relative RMS and max in %,
and their ratios (bench/results/2026-11-30_cpu2_old-bound)."""
import sys, numpy as np, petblur
sys.path.insert(0, "bench")
import accuracy_case as ac
fwhm = float(sys.argv[1])
for seed in map(int, sys.argv[2:]):
    case = ac.Case(np.random.default_rng(seed), ac.FULL["shape"], ac.FULL["voxel"], fwhm_mm=fwhm)
    x = np.asfortranarray(case.x)
    y = {}
    segs = {}
    for bound in (None, 0.25, 0.01):
        op = petblur.BlurOperator(case.shape, case.voxel, case.motion(), method="ab", max_path_error=bound,
                                  affine=case.affine, device="opencl")
        y[bound] = op(x)
    fine = y[0.01]
    dn, do = ac.errors(fine, y[None]), ac.errors(fine, y[0.25])
    print(seed, fwhm, "default %.4f/%.4f  0.25 %.4f/%.4f  ratio rms %.2f max %.2f" % (dn["rms_pct"], dn["max_pct"], do["rms_pct"], do["max_pct"], do["rms_pct"]/max(dn["rms_pct"],1e-12), do["max_pct"]/max(dn["max_pct"],1e-12)), flush=True)
