"""The estimate's own reference (references.c's weighted rank-3 projection) replicated in numpy on a draw's series
without motion: the contrast (grey : white : blood : lesions) it gives frame K from the raw frames' inner products
and from copies smoothed as level 0 is. proj.py SEED K"""
import os, sys
sys.path[:0] = [os.path.join(os.path.dirname(os.path.abspath(__file__)), "../..")]
import numpy as np
from scipy import ndimage
import estimate_family as ef
seed, k = int(sys.argv[1]), int(sys.argv[2])
d = ef.draw(seed)
class Still(ef.Truth):
    def __call__(self, t): return np.eye(4)
    def changes(self, t0, t1): return False
T = Still(d); sc = ef.Scene(d)
F, A, b, _ = ef.simulate(d, np.random.default_rng([seed, 1]), truth=T)
n = F.shape[-1]; sh = d.shape
sig = 2.0 * max(d.voxel) / 2.3548 / np.array(d.voxel)
tis = []
for i in range(4):
    lv = np.zeros(4); lv[i] = 1
    tis.append(ndimage.gaussian_filter(sc.sample(np.eye(4), 0.0, lv), sc.sigma, mode="constant"))
mask = sum(tis) > 0.02 * sum(tis).max()
def contrast(img):
    X = np.column_stack([t[mask] for t in tis] + [np.ones(mask.sum())]); c, *_ = np.linalg.lstsq(X, img[mask], rcond=None)
    return np.round(c[:4] / c[0], 3)
G = F.reshape(-1, n).T.astype(np.float64)  # frames as rows, raw
def reference(G, Gc, k, rank=3, weighted=True):
    others = [i for i in range(n) if i != k]
    gram = Gc[others] @ Gc[others].T
    if weighted:
        w, v = np.linalg.eigh(gram); lead = np.argsort(w)[::-1][:rank]
        scale = np.diag(gram).copy()
        for j in lead: scale -= w[j] * v[:, j] ** 2
        med = np.median(scale); scale = 1 / np.sqrt(np.maximum(scale, 0.01 * med))
    else:
        scale = np.ones(len(others))
    a = scale[:, None] * scale[None, :] * gram
    w, v = np.linalg.eigh(a); lead = np.argsort(w)[::-1][:rank]
    coef = np.zeros(len(others)); gk = Gc[others] @ Gc[k]
    for j in lead:
        dot = (v[:, j] * scale * gk).sum(); coef += scale * v[:, j] * dot / w[j]
    return coef @ G[others]
print("truth at frame", k, np.round(ef.uptake(d, 0.5 * (b[k] + b[k + 1])) / ef.uptake(d, 0.5 * (b[k] + b[k + 1]))[0], 3))
print("frame itself", contrast(F[..., k]))
for weighted in (True, False):
    for rank in (3, 4):
        print("weighted" if weighted else "unweighted", "rank", rank, "raw Gram:", contrast(reference(G, G, k, rank, weighted).reshape(sh)))
Gs = np.array([ndimage.gaussian_filter(F[..., i].astype(np.float64), sig, mode="constant").ravel() for i in range(n)])
for weighted in (True, False):
    print("weighted" if weighted else "unweighted", "rank 3, Gram of the level-0 smoothed frames:", contrast(reference(G, Gs, k, 3, weighted).reshape(sh)))
