# What bounds the default's error on noisy nods: python3 nod_bound.py FIRST_SEED END_SEED, from the repository root
# with PETBLUR_LIBRARY set. The draws of noise_tails.py (bench/path_cases.py's nod, small, AB exact on the host), one
# JSON line each; every error is RMS / max % from the true motion's dense blur:
#   default   the default on the log (noise_tails.py's rms)
#   follow    the log's own dense blur (following the noise)
#   clean     the default on the true motion logged at the same 20 Hz without noise (the planner's own error)
#   mean      the true motion moved by the noise's mean over the frame's samples, dense (what no track estimate
#             that keeps the log's mean over the frame removes)
#   var       the log smoothed with its lambda chosen so that the smoothed track keeps the log's variance less the
#             drawn noise's (smooth_proto.py, MODE=var), then the default
#   oracle    the same smoother at every lambda of a grid, the one nearest the true motion's blur (chosen knowing it)
import sys, json, numpy as np
from scipy import sparse
from scipy.sparse.linalg import spsolve
from scipy.spatial.transform import Rotation
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests"); sys.path.insert(0, "bench")
import repo_scripts, petblur
from accuracy_case import mean_resampled
pc = repo_scripts.load("bench/path_cases.py", "path_cases")
LAMBDAS = 10.0 ** np.arange(-1.0, 7.01, 0.5)


def second_differences(n):
    return sparse.diags([np.ones(n - 2), -2 * np.ones(n - 2), np.ones(n - 2)], [0, 1, 2], shape=(n - 2, n))


def whittaker(Y, lam):
    n = len(Y); D = second_differences(n)
    return spsolve((sparse.identity(n) + lam * (D.T @ D)).tocsc(), Y)


def track(case, t, Y):
    q = Rotation.from_rotvec(Y[:, 3:] / pc.HEAD_MM).as_quat()
    return petblur.Motion(t, Y[:, :3], np.column_stack([q[:, 3], q[:, :3]]), center=case.center)


def blur(case, motion):
    op = petblur.BlurOperator(case.shape, case.voxel, motion, frame=case.frame, method="ab", filter="exact",
                              affine=case.affine, device="host")
    return np.asarray(op(np.asfortranarray(case.x))), pc.path_segments(op)


def err(true, y):
    e = pc.errors(true, y)
    return [round(e["rms_pct"], 4), round(e["max_pct"], 4)]


for seed in range(int(sys.argv[1]), int(sys.argv[2])):
    case = pc.draw_case("nod", np.random.default_rng(seed), small=True)
    n_true = min(pc.reference_times(case, "true"), 1500)
    true = pc.reference(case, "true", times=n_true)
    out = {"seed": seed, "noise": round(case.noise_mm, 4), "obj": case.object, "vox": np.round(case.voxel, 3).tolist(),
           "period_s": round(case.params["period_s"], 3), "amplitude_deg": round(case.params["amplitude_deg"], 3)}
    y, out["segs"] = blur(case, case.logged)
    out["default"] = err(true, y)
    out["follow"] = err(true, pc.reference(case, "logged", times=min(pc.reference_times(case, "logged"), 1500)))
    t = case.log_times
    rot, tr = case.true_pose(t)
    y, out["clean_segs"] = blur(case, pc._motion(t, rot, tr, case.center))
    out["clean"] = err(true, y)
    # The noise's mean over the samples inside the frame, put on the true motion.
    inside = (t > case.frame[0]) & (t < case.frame[1])
    mean_tr = (case.log_translations - tr)[inside].mean(0)
    mean_rot = Rotation.from_rotvec((case.log_rotations * rot.inv()).as_rotvec()[inside].mean(0))
    ts = case.frame[0] + (np.arange(n_true) + 0.5) * (case.frame[1] - case.frame[0]) / n_true
    r, p = case.true_pose(ts)
    out["mean"] = err(true, mean_resampled(case.x, case.affine, case.center, mean_rot * r, p + mean_tr))
    # The smoother, on the translations and rotation vectors (x HEAD_MM), sample index units.
    Y = np.column_stack([case.log_translations, case.log_rotations.as_rotvec() * pc.HEAD_MM])
    lo, hi = -4.0, 12.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        Z = whittaker(Y, 10 ** mid)
        if Z.var(0).sum() < Y.var(0).sum() - 6 * case.noise_mm ** 2:
            hi = mid
        else:
            lo = mid
    y, segs = blur(case, track(case, t, whittaker(Y, 10 ** lo)))
    out["var"] = err(true, y) + [round(lo, 2), segs]
    best = None
    for lam in LAMBDAS:
        y, segs = blur(case, track(case, t, whittaker(Y, lam)))
        e = err(true, y)
        if best is None or e[0] < best[0]:
            best = e + [round(float(np.log10(lam)), 2), segs]
    out["oracle"] = best
    print(json.dumps(out), flush=True)
