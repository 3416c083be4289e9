"""The views pass 3 fitted to a frame (dumped by a temporary fwrite in estimate.c: the dwell's nine views of the
path between, one pose's view, the level-0 frame and its weights, as float32 in DIR) against the true images:
where each view lies along the jerk, and the contrast of the frame's own reference. cmpviews.py SEED FRAME DIR"""
import os, sys
sys.path[:0] = [os.path.join(os.path.dirname(os.path.abspath(__file__)), "../..")]
import numpy as np
from scipy import ndimage
import estimate_family as ef
seed, k, dd, m = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3], 9
d = ef.draw(seed); T, sc = ef.Truth(d), ef.Scene(d)
F, A, b, _ = ef.simulate(d, np.random.default_rng([seed, 1]))
sh = d.shape; n = np.prod(sh)
ld = lambda a: a.reshape(sh[::-1]).transpose(2, 1, 0).astype(np.float64)
views = np.fromfile(f"{dd}/dump_views.raw", np.float32).reshape(m, -1)
views = [ld(v) for v in views]
w = ld(np.fromfile(f"{dd}/dump_w.raw", np.float32)); fr = ld(np.fromfile(f"{dd}/dump_frame.raw", np.float32))
t0, t1 = b[k], b[k + 1]; ts = ef.instants(T, t0, t1)
sig = 2.0 * max(d.voxel) / 2.3548 / np.array(d.voxel)
def img(mp):
    acc = sum(sc.sample(mp, t) for t in ts) / len(ts)
    return ndimage.gaussian_filter(ndimage.gaussian_filter(acc, sc.sigma, mode="constant"), sig, mode="constant")
jerk = ([j for j in d.jerks if t0 < j[0] < t1] or [(t0 + 1, 1.0)])[0]
jt = jerk[0] + np.linspace(-0.01, jerk[1] + 0.01, 11)
exact = [img(T(t)) for t in jt]
sw = np.sqrt(w.ravel())
def res(y, *xs):
    X = np.column_stack([x.ravel() * sw for x in xs] + [sw]); c, *_ = np.linalg.lstsq(X, y.ravel() * sw, rcond=None)
    r = y.ravel() * sw - X @ c; return r @ r
print("each dumped view against the exact views along the jerk (residual; columns = 11 points from A to B):")
for i, v in enumerate(views):
    rr = [res(v, e) for e in exact]
    print(i, " ".join("%7.1f" % x for x in rr), " best", int(np.argmin(rr)))
print("frame against: A and B exact: %.2f; dumped views 0 and 8: %.2f; one exact at mid: %.2f" % (
    res(fr, exact[0], exact[-1]), res(fr, views[0], views[-1]), res(fr, exact[5])))
print("frame against all 9 dumped views (unconstrained): %.2f" % res(fr, *views))
print("frame against all 11 exact (unconstrained): %.2f" % res(fr, *exact))
from scipy.spatial.transform import Rotation as R
ms = np.array([T(t) for t in ts]); mean = np.eye(4)
mean[:3, :3] = R.from_matrix(ms[:, :3, :3]).mean().as_matrix(); mean[:3, 3] = ms[:, :3, 3].mean(0)
lv = []
for i in range(4):
    levels = np.zeros(4); levels[i] = 1.0
    acc = sum(sc.sample(mean, t, levels) for t in ts) / len(ts)
    lv.append(ndimage.gaussian_filter(ndimage.gaussian_filter(acc, sc.sigma, mode="constant"), sig, mode="constant"))
vw = ld(np.fromfile(f"{dd}/dump_view.raw", np.float32))
for name, y in (("estimator's one-pose view", vw), ("the frame", fr)):
    X = np.column_stack([x.ravel() * sw for x in lv] + [sw]); c, *_ = np.linalg.lstsq(X, y.ravel() * sw, rcond=None)
    print(name, "as tissues (grey, white, blood, lesions, offset):", np.round(c / c[0], 3), "resid %.2f" % ((y.ravel()*sw - X@c)**2).sum())
print("true uptake at frame", k, np.round(ef.uptake(d, 0.5 * (t0 + t1)) / ef.uptake(d, 0.5 * (t0 + t1))[0], 3))
