"""Issue 46 idea: a frame's blur depends on where each voxel spends its time,
so replace its path by one (or a Lambda of two) uniform segments matching
the pose distribution's mean and leading covariance. Error against the dense
true reference, beside petblur's default AB exact."""
import sys, json, numpy as np
sys.path.insert(0, "python/tests"); sys.path.insert(0, "python")
import repo_scripts, petblur
from scipy.spatial.transform import Rotation
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
kind, seed = sys.argv[1], int(sys.argv[2])
rng = np.random.default_rng(seed)
case = pc.draw_case(kind, rng, small=True)
t0, t1 = case.frame
N = 2000
ts = t0 + (np.arange(N) + 0.5) * (t1 - t0) / N
rot, tr = case.poses("true", ts)
R = 0.5 * np.linalg.norm(np.array(case.shape) * np.array(case.voxel))  # radius: half the grid's diagonal
mrot = rot.mean()
rv = (mrot.inv() * rot).as_rotvec()  # relative to mean, body... small
P = np.hstack([tr, R * rv])
mu = P.mean(0)
C = np.cov((P - mu).T, bias=True)
w, V = np.linalg.eigh(C)
w, V = w[::-1], V[:, ::-1]
def poses_of(params):
    return mrot * Rotation.from_rotvec(params[:, 3:] / R), params[:, :3]
def seg(A, B, n):
    u = (np.arange(n) + 0.5) / n
    return A[None] + u[:, None] * (B - A)[None]
M = 400
a = np.sqrt(3 * max(w[0], 0)); b = np.sqrt(3 * max(w[1], 0))
one = seg(mu - a * V[:, 0], mu + a * V[:, 0], M)
lam = np.vstack([seg(mu - a * V[:, 0] - b * V[:, 1], mu + b * V[:, 1], M // 2),
                 seg(mu + b * V[:, 1], mu + a * V[:, 0] - b * V[:, 1], M // 2)])
true = pc.reference(case, "true", times=400)
out = {"kind": kind, "seed": seed, "obj": case.object, "size_vox": round(float(case.size_vox), 3),
       "sd_mm": [round(float(np.sqrt(max(x, 0))), 4) for x in w[:3]]}
for name, pts in (("mean", mu[None]), ("one", one), ("lambda", lam)):
    r, t = poses_of(pts)
    e = pc.errors(true, pc.mean_resampled(case.x, case.affine, case.center, r, t))
    out[name] = [round(e["rms_pct"], 3), round(e["max_pct"], 3)]
op = petblur.BlurOperator(case.shape, case.voxel, case.true, frame=case.frame, method="ab", filter="exact",
                          affine=case.affine, device="host")
e = pc.errors(true, op(np.asfortranarray(case.x)))
out["default"] = [round(e["rms_pct"], 3), round(e["max_pct"], 3)]
out["default_segments"] = pc.path_segments(op)
print(json.dumps(out))
