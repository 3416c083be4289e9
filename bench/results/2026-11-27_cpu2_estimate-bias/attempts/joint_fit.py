"""The series' joint rank-3 fit in the data space at a track: min over P, c, o of sum_k |f_k - sum_j c_kj W_k(P_j) - o_k|^2.

W_k is frame k's view of the reference object along the track (the mean of trilinear warps, torch's grid_sample, at
2 instants of a still frame, 20 of a frame with a path), P three images on the frames' grid, fitted by conjugate
gradients on the normal equations (the adjoint by autograd), alternating with c and o by least squares. The data are
never resampled: the least-squares fit of the rank-3 model that the own references only approximate.

    LEVEL=1 python3 joint_fit.py DIR TRACK.csv       the fit's residual at TRACK and at the truth (joint_fit.log)

DIR is gen.py's folder; LEVEL halves the grid LEVEL times (2x2x2 means, as the estimator's pyramid)."""
import json
import os
import sys
import time

import nibabel as nib
import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", ".."))
import estimate_validation as ev  # noqa
import head_frames as hf  # noqa

torch.set_num_threads(2)
torch.set_default_dtype(torch.float64)

D = sys.argv[1]
img = nib.load(os.path.join(D, "frames.nii.gz"))
F = np.asarray(img.dataobj, dtype=np.float64)  # X Y Z T
A = img.affine
LEVEL = int(os.environ.get("LEVEL", "1"))
for _ in range(LEVEL):
    X, Y, Z, T = F.shape
    F = F.reshape(X // 2, 2, Y // 2, 2, Z // 2, 2, T).mean(axis=(1, 3, 5))
    A = A @ np.array([[2, 0, 0, 0.5], [0, 2, 0, 0.5], [0, 0, 2, 0.5], [0, 0, 0, 1.0]])
side = json.load(open(os.path.join(D, "frames.json")))
bounds = np.array(side["FrameTimesStart"] + [side["FrameTimesStart"][-1] + side["FrameDuration"][-1]])
K = F.shape[3]
shape = F.shape[:3]
meta = json.load(open(os.path.join(D, "meta.json")))
s = ev.SETUPS[meta["setup"]]
truth = hf.Truth(s)
pts = np.load(os.path.join(D, "points.npy"))

f = torch.tensor(np.moveaxis(F, 3, 0))  # K X Y Z
idx = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), -1).reshape(-1, 3)
W = torch.tensor(idx @ A[:3, :3].T + A[:3, 3])  # N 3
Ainv = torch.tensor(np.linalg.inv(A))
nvec = torch.tensor(np.array(shape, float) - 1)
CENTRE = torch.tensor([0.0, 0.0, 5.0])


def rodrigues(xi):
    """6-vector (rotation vector rad, translation mm) -> 4x4 about CENTRE."""
    w, t = xi[:3], xi[3:]
    th = torch.sqrt((w * w).sum() + 1e-30)
    k = w / th
    Kx = torch.zeros(3, 3)
    Kx = torch.stack([torch.stack([0 * th, -k[2], k[1]]), torch.stack([k[2], 0 * th, -k[0]]),
                      torch.stack([-k[1], k[0], 0 * th])])
    R = torch.eye(3) + torch.sin(th) * Kx + (1 - torch.cos(th)) * Kx @ Kx
    M = torch.eye(4)
    M = torch.cat([torch.cat([R, (CENTRE - R @ CENTRE + t)[:, None]], 1), torch.tensor([[0, 0, 0, 1.0]])], 0)
    return M


def samples_of(track_at, k, S):
    ts = bounds[k] + (np.arange(S) + 0.5) / S * (bounds[k + 1] - bounds[k])
    return [torch.tensor(track_at(t)) for t in ts]


def warp(P, M):
    """P (C X Y Z) in the object's grid; the frame's view under world map M (object -> tomograph)."""
    Minv = torch.linalg.inv(M)
    obj = W @ Minv[:3, :3].T + Minv[:3, 3]
    i = obj @ Ainv[:3, :3].T + Ainv[:3, 3]
    g = 2 * i / nvec - 1
    grid = g[:, [2, 1, 0]].reshape(1, *shape, 3)
    return torch.nn.functional.grid_sample(P[None], grid, mode="bilinear", padding_mode="zeros",
                                           align_corners=True)[0]


class Series:
    def __init__(self, track_at, moving_frames=(), S=2, Sm=20):
        self.base = [samples_of(track_at, k, Sm if k in moving_frames else S) for k in range(K)]

    def views(self, P, xi):
        out = []
        for k in range(K):
            Dk = rodrigues(xi[k]) if xi is not None else torch.eye(4)
            acc = 0
            for M in self.base[k]:
                acc = acc + warp(P, Dk @ M)
            out.append(acc / len(self.base[k]))
        return out


def fit_coeffs(views):
    C = torch.zeros(K, 4)
    sse = 0.0
    for k in range(K):
        X = torch.cat([views[k].reshape(views[k].shape[0], -1), torch.ones(1, views[k][0].numel())], 0)
        G = X @ X.T
        h = X @ f[k].reshape(-1)
        c = torch.linalg.solve(G + 1e-9 * torch.eye(4) * G.diagonal().mean(), h)
        C[k] = c
        r = f[k].reshape(-1) - c @ X
        sse += float(r @ r)
    return C, sse


def model(series, P, C, xi):
    v = series.views(P, xi)
    return [torch.einsum("j,jxyz->xyz", C[k, :3], v[k]) + C[k, 3] for k in range(K)]


def solve_P(series, P, C, xi, iters=10):
    """CG on the normal equations for P, C fixed."""
    def Aop(P):
        v = series.views(P, xi)
        return [torch.einsum("j,jxyz->xyz", C[k, :3], v[k]) for k in range(K)]

    def AT(rs):
        Q = torch.zeros_like(P, requires_grad=True)
        out = Aop(Q)
        s = sum((o * r).sum() for o, r in zip(out, rs))
        return torch.autograd.grad(s, Q)[0]

    b = AT([f[k] - C[k, 3] for k in range(K)])
    x = P.clone()
    r = b - AT(Aop(x))
    p = r.clone()
    rr = (r * r).sum()
    for _ in range(iters):
        Ap = AT(Aop(p))
        a = rr / (p * Ap).sum()
        x = x + a * p
        r = r - a * Ap
        rn = (r * r).sum()
        p = r + rn / rr * p
        rr = rn
    return x.detach()


def init_P(track_at):
    """PCA of the frames moved back at their mid-times."""
    moved = []
    for k in range(K):
        M = torch.tensor(track_at(0.5 * (bounds[k] + bounds[k + 1])))
        # the object's view: f_k(M x): sample frame at M applied to object points
        tom = W @ M[:3, :3].T + M[:3, 3]
        i = tom @ Ainv[:3, :3].T + Ainv[:3, 3]
        g = (2 * i / nvec - 1)[:, [2, 1, 0]].reshape(1, *shape, 3)
        moved.append(torch.nn.functional.grid_sample(f[k][None, None], g, align_corners=True)[0, 0])
    X = torch.stack([m.reshape(-1) for m in moved])
    U, Sv, Vt = torch.linalg.svd(X, full_matrices=False)
    return (Vt[:3] * Sv[:3, None]).reshape(3, *shape)


def inner(series, P, xi, rounds=4):
    for r in range(rounds):
        v = series.views(P, xi)
        C, sse = fit_coeffs(v)
        P = solve_P(series, P, C, xi)
    v = series.views(P, xi)
    C, sse = fit_coeffs(v)
    return P, C, sse


if __name__ == "__main__":
    est = hf.track_maps(*hf.read_matrix_csv(sys.argv[2]))
    t, maps = hf.read_matrix_csv(sys.argv[2])
    moving = sorted({int(np.searchsorted(bounds, x, side="right") - 1) for x in t
                     if not any(abs(x - 0.5 * (bounds[k] + bounds[k + 1])) < 1e-6 for k in range(K))} - {-1, 0, K})
    print("estimate's frames with paths", moving)
    for name, tr, mv in (("estimate", est, moving), ("truth", truth, [s.jerk_frame])):
        t0 = time.time()
        ser = Series(tr, mv)
        P = init_P(tr)
        for rounds in (6, 12, 18, 24):
            P, C, sse = inner(ser, P, None, rounds=6)
            print(name, "after", rounds, "rounds: sse %.6e" % sse, "%.0f s" % (time.time() - t0), flush=True)
