"""Issue 47: each frame's own reference (src/estimate/references.c) replicated in numpy on family draws, against the
frame's noise-free image: the projection as it was (the other frames weighed by their energy beyond the leading
images) and as it is (weighed by their noise measured alone, the noise's eigenvalue taken off each leading one).

    python3 refcontrast.py [--moved] SEED...

Each draw's series is rendered without head motion (`--moved`: each frame but the first at its own sub-voxel
translation, moved back by trilinear resampling as the estimate moves frames back), the whole series as one window.
Per frame: the reference's bias, the misfit left when the clean frame is fitted by the reference built from the
other frames' clean images (a scale and an offset, as the registration fits), and its noise, the same coefficients
on the other frames' noise; both as % RMS of the clean frame on the head."""
import argparse
import os
import sys

sys.path[:0] = [os.path.join(os.path.dirname(os.path.abspath(__file__)), "../.."),
                os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../../python")]
import numpy as np  # noqa: E402
from scipy import ndimage  # noqa: E402

import estimate_family as ef  # noqa: E402


class Held(ef.Truth):
    """The head held at one pose a frame (the identity, or a translation)."""

    def __init__(self, d, moves):
        super().__init__(d)
        self.moves, self.b = moves, np.array(d.bounds)

    def __call__(self, t):
        return self.moves[min(np.searchsorted(self.b, t, side="right") - 1, len(self.moves) - 1)]

    def changes(self, t0, t1):
        return False


def haar_noise(f):
    """contrast_poses.c's pbe_frame_noise: the median absolute finest Haar detail over the head's blocks."""
    d = f.shape
    g = f[:d[0] // 2 * 2, :d[1] // 2 * 2, :d[2] // 2 * 2].astype(np.float64)
    s, h = 0.0, 0.0
    for c in range(8):
        i, j, k = c & 1, c >> 1 & 1, c >> 2 & 1
        blk = g[i::2, j::2, k::2]
        s, h = s + blk, h + (-blk if i ^ j ^ k else blk)
    sel = s > 8.0 * f.mean()
    return float(np.median(np.abs(h[sel]))) if sel.any() else 0.0


def weights_of_variances(var):
    least = 0.01 * np.median(var)
    return 1.0 / np.sqrt(np.maximum(var, least)) if least > 0 else np.ones_like(var)


def coefficients(gram, gk, rank, scale, shift):
    """references.c's projection: a weight per other frame."""
    a = scale[:, None] * scale[None, :] * gram
    w, v = np.linalg.eigh(a)
    order = np.argsort(w)[::-1]
    tail = w[order[rank:]]
    tail = tail[tail > 1e-12 * w.max()]
    floor = float(np.median(tail)) if shift and len(tail) else 0.0
    coef = np.zeros(len(gk))
    for j in order[:rank]:
        coef += scale * v[:, j] * (v[:, j] * scale * gk).sum() / max(w[j] - floor, 0.5 * w[j])
    return coef


def energy_scale(gram, rank):
    w, v = np.linalg.eigh(gram)
    s = np.diag(gram).copy()
    for j in np.argsort(w)[::-1][:rank]:
        s -= w[j] * v[:, j] ** 2
    return weights_of_variances(s)


def draw(seed, moved):
    d = ef.draw(seed)
    n = len(d.bounds) - 1
    moves = [np.eye(4) for _ in range(n)]
    if moved:
        rng = np.random.default_rng([seed, 99])
        for m in moves[1:]:
            m[:3, 3] = rng.uniform(-0.75, 0.75, 3) * np.array(d.voxel)
    truth, scene = Held(d, moves), ef.Scene(d)
    frames, affine, b, _ = ef.simulate(d, np.random.default_rng([seed, 1]), truth=truth)
    lengths = np.diff(b)
    clean = np.zeros(frames.shape)
    for k in range(n):  # as simulate renders them, but for the counts
        ts = ef.instants(truth, b[k], b[k + 1])
        acc = ndimage.gaussian_filter(sum(scene.sample(truth(t), t) for t in ts) / len(ts), scene.sigma,
                                      mode="constant")
        expected = acc * (d.counts_per_voxel * scene.head * lengths[k] / lengths.mean() / acc.sum())
        clean[..., k] = ndimage.gaussian_filter(expected, 0.5 * scene.sigma, mode="constant") / lengths[k]
    noise = np.array([haar_noise(frames[..., k]) for k in range(n)]) ** 2  # on the frames as given
    if moved:
        inv = np.linalg.inv(affine)
        for k in range(n):
            m = inv @ moves[k] @ affine
            for x in (frames, clean):
                x[..., k] = ndimage.affine_transform(x[..., k], m[:3, :3], m[:3, 3], order=1, mode="constant")
    g, c = frames.reshape(-1, n).T.astype(np.float64), clean.reshape(-1, n).T
    mask = c.mean(0) > 0.05 * c.mean(0).max()
    rank = max(1, min(3, n // 4))
    out = {"before": [], "now": []}
    for k in range(n):
        others = [i for i in range(n) if i != k]
        gram, gk = g[others] @ g[others].T, g[others] @ g[k]
        coefs = {"before": coefficients(gram, gk, rank, energy_scale(gram, rank), False),
                 "now": coefficients(gram, gk, rank, weights_of_variances(noise[others]), True)}
        ck = c[k][mask]
        for name, cf in coefs.items():
            ref = (cf @ c[others])[mask]
            x = np.column_stack([ref, np.ones(len(ref))])
            fit, *_ = np.linalg.lstsq(x, ck, rcond=None)
            bias = np.sqrt(((x @ fit - ck) ** 2).mean() / (ck ** 2).mean())
            nz = np.sqrt((((cf @ (g - c)[others])[mask]) ** 2).mean() / (ck ** 2).mean())
            out[name].append((100 * bias, 100 * nz))
    own = np.median([np.sqrt((((g - c)[k][mask]) ** 2).mean() / (c[k][mask] ** 2).mean()) for k in range(n)])
    return d, n, own, {k: np.array(v) for k, v in out.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--moved", action="store_true")
    ap.add_argument("seeds", type=int, nargs="+")
    a = ap.parse_args()
    print("| seed | protocol | frames | the frames' noise | bias before: median / worst frame | now | "
          "the reference's noise before: median / worst | now |")
    print("|---|---|---|---|---|---|---|---|")
    for seed in a.seeds:
        d, n, own, r = draw(seed, a.moved)
        inj = d.start_s == 0.0
        print("| %d | %s | %d | %.1f %% | %.2f / %.2f %% | %.2f / %.2f %% | %.2f / %.2f %% | %.2f / %.2f %% |" % (
            seed, "from injection" if inj else "late", n, 100 * own,
            np.median(r["before"][:, 0]), r["before"][:, 0].max(), np.median(r["now"][:, 0]), r["now"][:, 0].max(),
            np.median(r["before"][:, 1]), r["before"][:, 1].max(), np.median(r["now"][:, 1]), r["now"][:, 1].max()),
            flush=True)


if __name__ == "__main__":
    main()
