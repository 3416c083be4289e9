# The local smoothing prototype: ORDER=1|2 HALF=20 python3 smooth_local_proto.py KIND SEED,SEED,...: each sample's
# lambda chosen in its window of +-HALF samples so that the window's smoothed variance keeps the log's less the
# drawn noise's, then one Whittaker solve with the lambdas varying along the track; planned at the default.
import sys, json, os, numpy as np
from scipy import sparse
from scipy.sparse.linalg import splu
from scipy.spatial.transform import Rotation
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import repo_scripts, petblur
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
kind = sys.argv[1]; seeds = [int(s) for s in sys.argv[2].split(",")]
ORDER = int(os.environ.get("ORDER", "2")); HALF = int(os.environ.get("HALF", "20"))
LAMS = 10.0 ** np.arange(-2, 12.01, 0.5)
def diffmat(t, order):
    n = len(t)
    if order == 1:
        h = np.diff(t)
        return sparse.diags([-1 / h, 1 / h], [0, 1], shape=(n - 1, n))
    h = np.diff(t); rows, cols, vals = [], [], []
    for j in range(1, n - 1):
        a, b = h[j - 1], h[j]; s = 2.0 / (a + b)
        rows += [j - 1] * 3; cols += [j - 1, j, j + 1]; vals += [s / a, -s * (1 / a + 1 / b), s / b]
    return sparse.csr_matrix((vals, (rows, cols)), shape=(n - 2, n))
def bank(t, Y):
    D = diffmat(t, ORDER); P = (D.T @ D).tocsc(); I = sparse.identity(len(t), format="csc")
    return np.stack([splu((I + lam * P).tocsc()).solve(Y) for lam in LAMS])  # [L, n, 6]
for seed in seeds:
    rng = np.random.default_rng(seed)
    case = pc.draw_case(kind, rng, small=True)
    true = pc.reference(case, "true", times=min(pc.reference_times(case, "true"), 1500))
    x = np.asfortranarray(case.x)
    t = case.log_times; dt = np.median(np.diff(t)); tn = t / dt
    Y = np.column_stack([case.log_translations, case.log_rotations.as_rotvec() * pc.HEAD_MM])
    sig2 = case.noise_mm ** 2
    n = len(t); lamj = np.empty(n); pick = []
    for j in range(n):
        lo, hi = max(0, j - HALF), min(n, j + HALF + 1)
        Bw = bank(tn[lo:hi], Y[lo:hi])
        vy = Y[lo:hi].var(0).sum(); vz = Bw.var(1).sum(-1)
        ok = np.flatnonzero(vz >= vy - 6 * sig2)
        k = ok.max() if ok.size else 0
        pick.append(k); lamj[j] = LAMS[k]
    D = diffmat(tn, ORDER)
    w = lamj[ORDER // 2: ORDER // 2 + D.shape[0]] if ORDER == 2 else np.minimum(lamj[:-1], lamj[1:])
    if ORDER == 2: w = np.minimum(np.minimum(lamj[:-2], lamj[1:-1]), lamj[2:])
    A = (sparse.identity(n, format="csc") + D.T @ sparse.diags(w) @ D).tocsc()
    Z = splu(A).solve(Y)
    q = Rotation.from_rotvec(Z[:, 3:] / pc.HEAD_MM).as_quat()
    sm = petblur.Motion(t, Z[:, :3], np.column_stack([q[:, 3], q[:, :3]]), center=case.center)
    out = {"seed": seed, "kind": kind, "lam_range": [float(np.log10(LAMS[min(pick)])), float(np.log10(LAMS[max(pick)]))]}
    for name, mot in (("logged", case.logged), ("smoothed", sm)):
        op = petblur.BlurOperator(case.shape, case.voxel, mot, frame=case.frame, method="ab", filter="exact",
                                  affine=case.affine, device="host")
        y = np.asarray(op(x)); e = pc.errors(true, y)
        out[name] = (round(e["rms_pct"], 3), round(e["max_pct"], 3), pc.path_segments(op))
    out["true_segs"] = pc.path_segments(op, case.true)
    print(json.dumps(out), flush=True)
