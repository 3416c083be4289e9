"""How far a frame's motion shows above its noise: mixture_misfit.py SEED FRAME [FRAME ...]

Renders the frame of issue 47's family draw SEED without noise (as estimate_family.simulate does, the same instants
and scanner blur) and fits it, and the noisy frame, by least squares (a scale and an offset) with the view at the
truth's mean pose over the frame (one pose) and with the views at the frame's first and last poses mixed (two poses,
a jerk's model). Prints each fit's residual and the noise's energy on the head's voxels: the one pose's misfit
without noise over the noise's energy is how much of the frame's residual its motion can explain at best."""
import os
import sys

H = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [os.path.join(H, "../.."), os.path.join(H, "../../../python")]
import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation as R

import estimate_family as ef

seed = int(sys.argv[1])
d = ef.draw(seed)
T, sc = ef.Truth(d), ef.Scene(d)
F, A, b, _ = ef.simulate(d, np.random.default_rng([seed, 1]))
for k in map(int, sys.argv[2:]):
    t0, t1 = b[k], b[k + 1]
    ts = ef.instants(T, t0, t1)

    def img(maps):
        acc = sum(sc.sample(m, t) for m, t in zip(maps, ts)) / len(ts)
        return ndimage.gaussian_filter(acc, sc.sigma, mode="constant")

    clean = img([T(t) for t in ts])
    scale = F[..., k].sum() / clean.sum()
    ms = np.array([T(t) for t in ts])
    mean = np.eye(4)
    mean[:3, :3] = R.from_matrix(ms[:, :3, :3]).mean().as_matrix()
    mean[:3, 3] = ms[:, :3, 3].mean(0)
    m = clean > 0.05 * clean.max()
    y, yc = F[..., k][m], clean[m] * scale

    def fit(t, *xs):
        X = np.column_stack(list(xs) + [np.ones(len(t))])
        c, *_ = np.linalg.lstsq(X, t, rcond=None)
        r = t - X @ c
        return r @ r, np.round(c[:-1], 3)

    v_first, v_last, v_mean = [img([p] * len(ts))[m] * scale for p in (T(t0), T(t1), mean)]
    noise = ((y - yc) ** 2).sum()
    one_clean = fit(yc, v_mean)[0]
    print(f"seed {seed} frame {k} ({t0:.1f}-{t1:.1f} s): one pose's misfit without noise {one_clean:.4g}, "
          f"noise {noise:.4g}: {100 * one_clean / noise:.2f} % of it")
    for name, t in (("without noise", yc), ("noisy", y)):
        one, two = fit(t, v_mean), fit(t, v_first, v_last)
        print(f"  {name}: one pose {one[0]:.4g}, two poses {two[0]:.4g} (shares {two[1]}), "
              f"gain {1 - two[0] / one[0]:.3f}")
