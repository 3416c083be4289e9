import sys, numpy as np
sys.path.insert(0, __import__('os').path.join(__import__('os').path.dirname(__import__('os').path.abspath(__file__)), '..', '..'))
import estimate_family as ef, head_frames as hf
from scipy.spatial.transform import Rotation

def vec(m):
    return np.concatenate([Rotation.from_matrix(m[:3,:3]).as_rotvec(), m[:3,3]])
def mat(v):
    m = np.eye(4); m[:3,:3] = Rotation.from_rotvec(v[:3]).as_matrix(); m[:3,3] = v[3:]; return m

def hat_avgs(knots, bounds, n=400):
    A = np.zeros((len(bounds)-1, len(knots)))
    for k in range(len(bounds)-1):
        t = bounds[k] + (np.arange(n)+0.5)/n*(bounds[k+1]-bounds[k])
        for j in range(len(knots)):
            e = np.zeros(len(knots)); e[j] = 1
            A[k, j] = np.interp(t, knots, e).mean()
    return A

def curvature(knots):
    n = len(knots); D = np.zeros((n-2, n))
    for i in range(1, n-1):
        h0, h1 = knots[i]-knots[i-1], knots[i+1]-knots[i]
        D[i-1, i-1], D[i-1, i], D[i-1, i+1] = 1/h0, -(1/h0+1/h1), 1/h1
        D[i-1] *= np.sqrt(2/(h0+h1))
    return D

def histo(knots, bounds, means):
    A = hat_avgs(knots, bounds); D = curvature(knots)
    n, m = len(knots), len(bounds)-1
    K = np.block([[2*D.T@D + 1e-9*np.eye(n), A.T], [A, np.zeros((m, m))]])
    rhs = np.concatenate([np.zeros((n, means.shape[1])), means])
    return np.linalg.solve(K, rhs)[:n]

def run(seed):
    d = ef.draw(seed); truth = ef.Truth(d); b = np.array(d.bounds)
    rng = np.random.default_rng([seed, 1]); points = hf.head_points(rng)
    times, maps = ef.frame_means(truth, b)
    a = hf.displacement_errors(hf.track_maps(times, maps), truth, b, points)
    means = np.array([vec(m) for m in maps[1:-1]])
    v = histo(times, b, means)
    h = hf.displacement_errors(hf.track_maps(times, np.array([mat(x) for x in v])), truth, b, points)
    return d, a, h

seeds = [int(s) for s in sys.argv[1:]]
for s in seeds:
    d, a, h = run(s)
    print(f"{s:11d} inj={int(d.start_s==0)} frames={len(d.bounds)-1:2d} mids {a.mean():.3f}/{a.max():.3f}  histo {h.mean():.3f}/{h.max():.3f}", flush=True)
