"""Series energy beyond the leading principal images, frames moved back by each track's poses:
energy.py SEED DIR (DIR holds link.csv/.txt and nolink.csv/.txt)"""
import os
import sys
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(HERE, "../../"), os.path.join(HERE, "../../../python")]
import numpy as np
from scipy import ndimage
import estimate_family as ef
import head_frames as hf

seed, dr = int(sys.argv[1]), sys.argv[2]
d = ef.draw(seed)
rng = np.random.default_rng([seed, 1])
frames, affine, bounds, truth = ef.simulate(d, rng)
inv = np.linalg.inv(affine)
n = frames.shape[-1]
mids = 0.5 * (bounds[:-1] + bounds[1:])
late = frames[..., -3:].mean(-1)
mask = ndimage.binary_dilation(ndimage.gaussian_filter(late, 1.0) > 0.1 * late.max(), iterations=2)

def noise(f):
    h = ((f[1:, :, :] - f[:-1, :, :])[::2])[mask[1:][::2]]
    return 1.4826 * np.median(np.abs(h - np.median(h))) / np.sqrt(2)

sig = np.array([noise(frames[..., k]) for k in range(n)])
ORDER = sys.argv[3] if len(sys.argv) > 3 else "u"

from unitary import move

means = ef.frame_means(truth, bounds)
refk = ef.reference_said(open(f"{dr}/link.txt").read())
def moved(csv):
    if csv == "truth":
        anchor = np.linalg.inv(means[1][1 + refk])
        track = lambda t: means[1][1 + int(np.searchsorted(bounds, t) - 1)] @ anchor
    else:
        times, maps = hf.read_matrix_csv(csv)
        track = hf.track_maps(times, maps)
    out = []
    for k in range(n):
        m = inv @ track(mids[k]) @ affine
        if ORDER == "u":
            g = move(frames[..., k], affine, track(mids[k]))
        else:
            g = ndimage.affine_transform(frames[..., k].astype(np.float64), m[:3, :3], m[:3, 3], order=int(ORDER), mode="constant")
        out.append(g[mask] / sig[k])
    return np.array(out)

def beyond(J, r):
    w = np.linalg.eigvalsh(J @ J.T)[::-1]
    return w[r:].sum()

Js = {v: moved(f"{dr}/{v}.csv") for v in ("link", "nolink")}
Js["truth"] = moved("truth")
for r in (1, 2, 3):
    print(seed, "rank", r, " ".join("%s %.6g" % (v, beyond(J, r)) for v, J in Js.items()),
          "diff(link-nolink) %.4g" % (beyond(Js['link'], r) - beyond(Js['nolink'], r)), "truth-nolink %.4g" % (beyond(Js['truth'], r) - beyond(Js['nolink'], r)))
# per frame: swap only frame k's pose into the nolink set
J = Js["nolink"]
for r in (2, 3, 4):
    base = beyond(J, r)
    out = []
    for k in range(n):
        vals = []
        for v in ("link", "truth"):
            J2 = J.copy(); J2[k] = Js[v][k]
            vals.append(beyond(J2, r) - base)
        out.append("%d:%+.0f/%+.0f" % (k, *vals))
    print("rank", r, "per frame link/truth minus nolink:", " ".join(out))
