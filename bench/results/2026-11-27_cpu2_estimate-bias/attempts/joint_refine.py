"""The joint rank-3 fit (joint_fit.py) as the estimator's last pass: from TRACK, each outer round moves every frame
but the reference by a rigid correction D_k (L-BFGS on the fit's residual with P and c held, which is each frame
registered to its own fitted reference), then refits P, c and o; the error is measured against the truth each round.

    python3 joint_refine.py DIR TRACK.csv      (R0: first fit's rounds, 12; R1: each refit's, 4; OUTER: 6)
"""
import os
import sys
import time
import numpy as np
import torch
from joint_fit import *  # noqa

est = hf.track_maps(*hf.read_matrix_csv(sys.argv[2]))
t, maps = hf.read_matrix_csv(sys.argv[2])
moving = sorted({int(np.searchsorted(bounds, x, side="right") - 1) for x in t
                 if not any(abs(x - 0.5 * (bounds[k] + bounds[k + 1])) < 1e-6 for k in range(K))} - {-1, 0, K})
ser = Series(est, moving)
P = init_P(est)
t0 = time.time()
P, C, sse = inner(ser, P, None, rounds=int(os.environ.get("R0", "12")))
print("start sse %.4f %.0f s" % (sse, time.time() - t0), flush=True)
xi = torch.zeros(K, 6)


def err_of(xi):
    D = [rodrigues(xi[k]).detach().numpy() for k in range(K)]

    def tr(tt):
        k = min(max(int(np.searchsorted(bounds, tt, side="right") - 1), 0), K - 1)
        return D[k] @ est(tt)
    e = hf.displacement_errors(tr, truth, bounds, pts)
    return e.mean(), e.max(), e


m, x, e = err_of(xi)
print("error before: mean %.3f max %.3f" % (m, x), " ".join("%.2f" % v for v in e[:6]), flush=True)
for outer in range(int(os.environ.get("OUTER", "6"))):
    var = xi[1:].clone().requires_grad_(True)
    opt = torch.optim.LBFGS([var], lr=1, max_iter=25, line_search_fn="strong_wolfe")

    def closure():
        opt.zero_grad()
        full = torch.cat([torch.zeros(1, 6), var], 0)
        mods = model(ser, P, C, full)
        loss = sum(((mo - f[k]) ** 2).sum() for k, mo in enumerate(mods))
        loss.backward()
        return loss
    opt.step(closure)
    xi = torch.cat([torch.zeros(1, 6), var.detach()], 0)
    P, C, sse = inner(ser, P, xi, rounds=int(os.environ.get("R1", "4")))
    m, x, e = err_of(xi)
    print("outer %d sse %.4f mean %.3f max %.3f %.0f s" % (outer, sse, m, x, time.time() - t0),
          " ".join("%.2f" % v for v in e[:6]), flush=True)
    np.save(os.path.join("/tmp", "xi_%s.npy") % os.path.basename(sys.argv[1]), xi.numpy())
