# The smoothing prototype: python3 smooth_proto.py KIND SEED,SEED,... [SHIFT], MODE=var or rss (the environment):
# a Whittaker smoother of the logged translations and rotation vectors (x 80 mm), its lambda chosen so that
# the smoothed track keeps the log's variance less the drawn noise's (var) or leaves residuals of the noise's
# mean square (rss, the discrepancy principle), SHIFT decades added; the smoothed track planned at the default.
import sys, json, numpy as np
from scipy import sparse
from scipy.sparse.linalg import spsolve
from scipy.spatial.transform import Rotation
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import repo_scripts, petblur
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
kind = sys.argv[1]; import os; MODE = os.environ.get('MODE', 'rss'); seeds = [int(s) for s in sys.argv[2].split(",")]
def whittaker(t, y, lam):
    n = len(t); h = np.diff(t)
    rows = []
    D = sparse.lil_matrix((n - 2, n))
    for j in range(1, n - 1):
        a, b = h[j - 1], h[j]; s = 2.0 / (a + b)
        D[j - 1, j - 1] = s / a; D[j - 1, j] = -s * (1 / a + 1 / b); D[j - 1, j + 1] = s / b
    A = (sparse.identity(n) + lam * (D.T @ D)).tocsc()
    return spsolve(A, y)
def corners(case):
    return pc._corners(case.shape, case.affine)
for seed in seeds:
    rng = np.random.default_rng(seed)
    case = pc.draw_case(kind, rng, small=True)
    true = pc.reference(case, "true", times=min(pc.reference_times(case, "true"), 1500))
    x = np.asfortranarray(case.x)
    t = case.log_times; tr = case.log_translations; rv = case.log_rotations.as_rotvec()
    # noise per axis known (drawn); corners RSS target: n * 3 * sigma^2 per corner roughly; use translation+rotation
    dt = np.median(np.diff(t)); tn = t / dt
    Y = np.column_stack([tr, rv * pc.HEAD_MM])
    sig = case.noise_mm
    lo, hi = -4.0, 12.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        Z = np.column_stack([whittaker(tn, Y[:, k], 10 ** mid) for k in range(6)])
        if MODE == "var":
            bad = Z.var(0).sum() < Y.var(0).sum() - 6 * sig ** 2
        else:
            bad = ((Y - Z) ** 2).mean() > sig ** 2
        if bad: hi = mid
        else: lo = mid
    lo += float(sys.argv[3]) if len(sys.argv) > 3 else 0.0
    Z = np.column_stack([whittaker(tn, Y[:, k], 10 ** lo) for k in range(6)])
    q = Rotation.from_rotvec(Z[:, 3:] / pc.HEAD_MM).as_quat()
    sm = petblur.Motion(t, Z[:, :3], np.column_stack([q[:, 3], q[:, :3]]), center=case.center)
    out = {"seed": seed, "lam": round(lo, 2)}
    for name, mot in (("logged", case.logged), ("smoothed", sm)):
        op = petblur.BlurOperator(case.shape, case.voxel, mot, frame=case.frame, method="ab", filter="exact",
                                  affine=case.affine, device="host")
        y = np.asarray(op(x)); e = pc.errors(true, y)
        out[name] = (round(e["rms_pct"], 3), round(e["max_pct"], 3), pc.path_segments(op))
    out["true_segs"] = pc.path_segments(op, case.true)
    print(json.dumps(out), flush=True)
