"""The contrast (grey : white : blood : lesions) each way of building frame K's own reference gives it, on a draw's
series without motion (the whole series one window): as built (each other frame weighed by its energy beyond the
leading images), weighed by its noise alone (the finest Haar detail), so weighed with the noise's eigenvalue taken
off, and with each frame's noise fitted from the inner products themselves (a factor analysis). mix.py SEED K"""
import os
import sys

sys.path[:0] = [os.path.join(os.path.dirname(os.path.abspath(__file__)), "../.."),
                os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../../python")]
import numpy as np  # noqa: E402
from scipy import ndimage  # noqa: E402

import estimate_family as ef  # noqa: E402
from refcontrast import Held, coefficients, energy_scale, haar_noise, weights_of_variances  # noqa: E402

seed, k = int(sys.argv[1]), int(sys.argv[2])
d = ef.draw(seed)
n = len(d.bounds) - 1
scene = ef.Scene(d)
frames, affine, b, _ = ef.simulate(d, np.random.default_rng([seed, 1]), truth=Held(d, [np.eye(4)] * n))
tissues = []
for i in range(4):
    levels = np.zeros(4)
    levels[i] = 1
    tissues.append(ndimage.gaussian_filter(scene.sample(np.eye(4), 0.0, levels), scene.sigma, mode="constant"))
mask = sum(tissues) > 0.02 * sum(tissues).max()


def contrast(img):
    x = np.column_stack([t[mask] for t in tissues] + [np.ones(mask.sum())])
    c, *_ = np.linalg.lstsq(x, img[mask], rcond=None)
    return " : ".join("%.2f" % v for v in c[:4] / c[0])


def factor_analysis(gram, gk, rank, rounds=20):
    psi = 1 / energy_scale(gram, rank) ** 2
    for _ in range(rounds):
        w, v = np.linalg.eigh(gram - np.diag(psi))
        low = sum(w[j] * np.outer(v[:, j], v[:, j]) for j in np.argsort(w)[::-1][:rank])
        psi = np.maximum(np.diag(gram) - np.diag(low), 1e-3 * np.median(np.diag(gram)))
    return coefficients(gram - np.diag(psi), gk, rank, 1 / np.sqrt(psi), False)


g = frames.reshape(-1, n).T.astype(np.float64)
others = [i for i in range(n) if i != k]
gram, gk = g[others] @ g[others].T, g[others] @ g[k]
rank = max(1, min(3, n // 4))
noise = np.array([haar_noise(frames[..., i]) for i in range(n)]) ** 2
mid = 0.5 * (b[k] + b[k + 1])
print("truth           ", " : ".join("%.2f" % v for v in ef.uptake(d, mid) / ef.uptake(d, mid)[0]))
print("the frame itself", contrast(frames[..., k]))
for name, cf in (("as built", coefficients(gram, gk, rank, energy_scale(gram, rank), False)),
                 ("noise weights", coefficients(gram, gk, rank, weights_of_variances(noise[others]), False)),
                 ("noise weights, the noise's eigenvalue taken off",
                  coefficients(gram, gk, rank, weights_of_variances(noise[others]), True)),
                 ("factor analysis", factor_analysis(gram, gk, rank))):
    print("%-48s %s" % (name, contrast((cf @ g[others]).reshape(d.shape))))
