"""A frame of a family draw fitted, at the estimate's level-0 smoothing or without it, by the true images at one pose
and at the jerk's two ends, with the views blurred more than the frame or not: the gain a path could show.
refblur.py SEED FRAME"""
import os, sys
sys.path[:0] = [os.path.join(os.path.dirname(os.path.abspath(__file__)), "../..")]
import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation as R
import estimate_family as ef
seed, k = int(sys.argv[1]), int(sys.argv[2])
d = ef.draw(seed); T, sc = ef.Truth(d), ef.Scene(d)
F, A, b, _ = ef.simulate(d, np.random.default_rng([seed, 1]))
t0, t1 = b[k], b[k + 1]; ts = ef.instants(T, t0, t1)
def img(maps, extra=0.0):
    acc = sum(sc.sample(m, t) for m, t in zip(maps, ts)) / len(ts)
    s = np.sqrt(np.array(sc.sigma)**2 + extra**2)
    return ndimage.gaussian_filter(acc, s, mode="constant")
clean = img([T(t) for t in ts]); scale = F[..., k].sum() / clean.sum()
ms = np.array([T(t) for t in ts]); mean = np.eye(4)
mean[:3, :3] = R.from_matrix(ms[:, :3, :3]).mean().as_matrix(); mean[:3, 3] = ms[:, :3, 3].mean(0)
m = clean > 0.05 * clean.max(); y = F[..., k][m]
def fit(t, *xs):
    X = np.column_stack(list(xs) + [np.ones(len(t))]); c, *_ = np.linalg.lstsq(X, t, rcond=None); r = t - X @ c
    return r @ r
rng = np.random.default_rng(5)
for extra in (0.0, 0.3, 0.5, 0.7, 1.0):
    vf, vl, vm = [img([p] * len(ts), extra)[m] for p in (T(t0), T(t1), mean)]
    one, two = fit(y, vm), fit(y, vf, vl)
    # the reference's own noise: a view with noise of relative size of the frame's / sqrt(n)
    print(f"extra blur {extra} vox: one {one:.4g} two {two:.4g} gain {1-two/one:.4f}")
# a noisy reference: the views from a reference carrying noise (as moved-back frames would), the same noise in all views
for rel in ():
    noise = F[..., k] - clean * scale
    nz = ndimage.shift(noise, (0.3, 0.2, 0.1), order=1) * rel  # decorrelated-ish noise field
    vf, vl, vm = [(img([p] * len(ts)) * scale)[m] + nz[m] for p in (T(t0), T(t1), mean)]
    one, two = fit(y, vm), fit(y, vf, vl)
    print(f"reference noise x{rel}: one {one:.4g} two {two:.4g} gain {1-two/one:.4f}")
# the level-0 smoothing: FWHM twice the largest voxel, on the frame and on the views alike
fw = 2.0 * max(d.voxel); sig = fw / 2.3548 / np.array(d.voxel)
print("level-0 sigma (voxels)", np.round(sig, 2))
for frac in (0.0, 0.25, 0.5, 0.75, 1.0):
    s = sig * frac
    Fk = ndimage.gaussian_filter(F[..., k].astype(np.float64), s, mode="constant")
    vf, vl, vm = [ndimage.gaussian_filter(img([p] * len(ts)), s, mode="constant")[m] for p in (T(t0), T(t1), mean)]
    one, two = fit(Fk[m], vm), fit(Fk[m], vf, vl)
    print(f"smoothing x{frac}: one {one:.4g} two {two:.4g} gain {1-two/one:.4f}")
print("at the level-0 smoothing, the views blurred more than the frame:")
Fk = ndimage.gaussian_filter(F[..., k].astype(np.float64), sig, mode="constant")
for extra in (0.0, 0.2, 0.3, 0.41, 0.5):
    vf, vl, vm = [ndimage.gaussian_filter(img([p] * len(ts), extra), sig, mode="constant")[m] for p in (T(t0), T(t1), mean)]
    one, two = fit(Fk[m], vm), fit(Fk[m], vf, vl)
    print(f"extra {extra}: one {one:.4g} two {two:.4g} gain {1-two/one:.4f}")
v = ndimage.gaussian_filter(img([mean] * len(ts)), sig, mode="constant").ravel()
f = Fk.ravel()
X = np.column_stack([v, np.ones(len(v))]); c, *_ = np.linalg.lstsq(X, f, rcond=None); r = f - X @ c
print("ideal explained (one pose, whole grid, level 0): %.4f  (residual %.4g, variance %.4g)" % (1 - r @ r / (((f - f.mean())**2).sum()), r @ r, ((f - f.mean())**2).sum()))
nz = (Fk - ndimage.gaussian_filter(clean * scale, sig, mode="constant")).ravel()
print("noise alone share of variance: %.4f" % (nz @ nz / (((f - f.mean())**2).sum())))
