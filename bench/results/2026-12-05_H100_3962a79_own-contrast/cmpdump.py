"""One pose's view of a frame as the estimate dumped it (dump_view.raw, dump_frame.raw, dump_w.raw in DIR) against the
true images at the level-0 smoothing, under the estimate's own weights: the gain the true images give one pose and
the jerk's two ends, and the view's and the frame's mix of the four tissues. cmpdump.py SEED FRAME DIR"""
import os, sys
sys.path[:0] = [os.path.join(os.path.dirname(os.path.abspath(__file__)), "../..")]
import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation as R
import estimate_family as ef
seed, k, dd = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
d = ef.draw(seed); T, sc = ef.Truth(d), ef.Scene(d)
F, A, b, _ = ef.simulate(d, np.random.default_rng([seed, 1]))
sh = d.shape
ld = lambda n: np.fromfile(f"{dd}/dump_{n}.raw", np.float32).reshape(sh[::-1]).transpose(2, 1, 0).astype(np.float64)
fr, vw, w = ld("frame"), ld("view"), ld("w")
t0, t1 = b[k], b[k + 1]; ts = ef.instants(T, t0, t1)
sig = 2.0 * max(d.voxel) / 2.3548 / np.array(d.voxel)
def img(maps):
    acc = sum(sc.sample(m, t) for m, t in zip(maps, ts)) / len(ts)
    return ndimage.gaussian_filter(ndimage.gaussian_filter(acc, sc.sigma, mode="constant"), sig, mode="constant")
clean = img([T(t) for t in ts])
ms = np.array([T(t) for t in ts]); mean = np.eye(4)
mean[:3, :3] = R.from_matrix(ms[:, :3, :3]).mean().as_matrix(); mean[:3, 3] = ms[:, :3, 3].mean(0)
vm, vf, vl = img([mean] * len(ts)), img([T(t0)] * len(ts)), img([T(t1)] * len(ts))
Fk = ndimage.gaussian_filter(F[..., k].astype(np.float64), sig, mode="constant")
def wfit(y, *xs):
    X = np.column_stack([x.ravel() for x in xs] + [np.ones(y.size)]); sw = np.sqrt(w.ravel())
    c, *_ = np.linalg.lstsq(X * sw[:, None], y.ravel() * sw, rcond=None); r = (y.ravel() - X @ c)
    return (w.ravel() * r * r).sum(), c
s, c = wfit(fr, Fk); print("dumped frame vs my level-0 frame: scale %.4g offset %.4g, residual %.4g" % (c[0], c[1], s))
frs = (fr - c[1]) / c[0]  # the dumped frame in my units
print("weights: sum %.4g, >0 voxels %d of %d" % (w.sum(), (w > 0).sum(), w.size))
noise = wfit(frs, clean)[0]; print("noise alone (frame - exact clean, scaled): %.4g" % noise)
one_ideal = wfit(frs, vm)[0]; two_ideal = wfit(frs, vf, vl)[0]
print("ideal one pose %.4g, two poses %.4g, gain %.4f" % (one_ideal, two_ideal, 1 - two_ideal / one_ideal))
one_est, cc = wfit(frs, vw); print("estimator's view, refit scale/offset: %.4g (scale %.4g)" % (one_est, cc[0]))
# where the estimator's view differs from the exact clean view at the mean pose
v2 = vw * cc[0] + cc[1]
s2, c2 = wfit(v2, vm); diff = v2 - (vm * c2[0] + c2[1])
print("estimator view vs exact view at the mean pose: weighted misfit %.4g" % s2)
# the misfit's spatial character: smooth or edge-like
for sgm in (0.0, 1.0, 2.0, 4.0):
    dd2 = ndimage.gaussian_filter(diff, sgm) if sgm else diff
    print(" diff smoothed by %.0f vox: energy %.4g" % (sgm, (w * dd2 * dd2).sum()))
# the view vs an exact view at the estimator's contrast? try fitting with the 4 tissue images at the mean pose
lv = []
for i in range(4):
    levels = np.zeros(4); levels[i] = 1.0
    acc = sum(sc.sample(mean, t, levels) for t in ts) / len(ts)
    lv.append(ndimage.gaussian_filter(ndimage.gaussian_filter(acc, sc.sigma, mode="constant"), sig, mode="constant"))
print("estimator view by the four tissues at the mean pose: misfit %.4g" % wfit(v2, *lv)[0])
print("frame by the four tissues at the mean pose: misfit %.4g (the noise %.4g)" % (wfit(frs, *lv)[0], noise))
