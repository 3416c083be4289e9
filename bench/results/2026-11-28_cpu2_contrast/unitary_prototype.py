"""The collective correction with frames moved back by a unitary resampler (Fourier shears).

    python3 unitary.py DIR TRACK.csv [test]

A pose applied by shears (each a shift of lines by the FFT's phase) keeps every frame's energy, its noise's included,
so the energy beyond the moved-back frames' leading principal images changes with the poses only through how well
the frames agree: the trilinear resampler's smoothing of the noise, which moves with the pose, is gone."""
import json
import os
import sys
import time

import nibabel as nib
import numpy as np
from scipy import ndimage, optimize
from scipy.spatial.transform import Rotation

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", ".."))
sys.path.insert(0, "/work/main/bench")
import estimate_validation as ev  # noqa: E402
import head_frames as hf  # noqa: E402


def shear(h, u, v, p, cu):
    """g(y) = h(y + p (y_v - c_v) e_u): lines along axis u shifted by p times their v offset."""
    n = h.shape[u]
    H = np.fft.rfft(h, axis=u)
    xi = np.fft.rfftfreq(n)
    shape = [1] * h.ndim
    shape[u] = len(xi)
    vv = np.arange(h.shape[v]) - cu[v]
    vshape = [1] * h.ndim
    vshape[v] = h.shape[v]
    phase = np.exp(2j * np.pi * xi.reshape(shape) * (p * vv).reshape(vshape))
    return np.fft.irfft(H * phase, n=n, axis=u)


def shift(h, d):
    """g(y) = h(y + d)."""
    H = np.fft.rfftn(h)
    ph = 1.0
    for a in range(3):
        xi = np.fft.rfftfreq(h.shape[a]) if a == 2 else np.fft.fftfreq(h.shape[a])
        s = [1, 1, 1]
        s[a] = len(xi)
        ph = ph * np.exp(2j * np.pi * xi.reshape(s) * d[a])
    return np.fft.irfftn(H * ph, s=h.shape, axes=(0, 1, 2))


def plane_rotate(h, u, v, theta, c):
    """g(y) = h(R y) with R turning the (u, v) plane by theta about c."""
    p, q = -np.tan(theta / 2), np.sin(theta)
    g = shear(h, u, v, p, c)       # h(S_u y)
    g = shear(g, v, u, q, c)       # then S_v: h(S_u S_v y)
    return shear(g, u, v, p, c)    # h(S_u S_v S_u y)


def compose(f, R, t, c):
    """g(i) = f(R i + t) on the (odd) grid, index coordinates, by one shift and nine shears."""
    d = R @ c + t - c
    h = shift(f, d)
    a, b, g = Rotation.from_matrix(R).as_euler("XYZ")
    h = plane_rotate(h, 1, 2, a, c)
    h = plane_rotate(h, 2, 0, b, c)
    return plane_rotate(h, 0, 1, g, c)


def test():
    n = (41, 39, 37)
    c = (np.array(n) - 1) / 2
    idx = np.stack(np.meshgrid(*[np.arange(k) for k in n], indexing="ij"), -1)
    f = np.exp(-np.sum(((idx - c - [2, -1, 1.5]) / [4, 3, 5]) ** 2, -1))
    R = Rotation.from_rotvec([0.1, -0.15, 0.2]).as_matrix()
    t = np.array([1.3, -0.7, 2.1])
    g = compose(f, R, t, c)
    ref = ndimage.affine_transform(f, R, offset=t, order=5, mode="constant")
    print("unitary vs scipy order 5: max err %.2e of 1; energy %.6f vs %.6f" % (np.abs(g - ref).max(),
                                                                             (g * g).sum(), (f * f).sum()))
    noise = np.random.default_rng(0).normal(size=n)
    print("noise energy kept: %.6f" % ((compose(noise, R, t, c) ** 2).sum() / (noise ** 2).sum()))


if len(sys.argv) > 3 and sys.argv[3] == "test":
    test()
    sys.exit(0)

D = sys.argv[1]
img = nib.load(os.path.join(D, "frames.nii.gz"))
F = np.asarray(img.dataobj, dtype=np.float64)
A = img.affine
LEVEL = int(os.environ.get("LEVEL", "1"))
for _ in range(LEVEL):
    X, Y, Z, T = F.shape
    F = F.reshape(X // 2, 2, Y // 2, 2, Z // 2, 2, T).mean(axis=(1, 3, 5))
    A = A @ np.array([[2, 0, 0, 0.5], [0, 2, 0, 0.5], [0, 0, 2, 0.5], [0, 0, 0, 1.0]])
K = F.shape[3]
side = json.load(open(os.path.join(D, "frames.json")))
bounds = np.array(side["FrameTimesStart"] + [side["FrameTimesStart"][-1] + side["FrameDuration"][-1]])
mids = 0.5 * (bounds[1:] + bounds[:-1])
meta = json.load(open(os.path.join(D, "meta.json")))
s = ev.SETUPS[meta["setup"]]
truth = hf.Truth(s)
pts = np.load(os.path.join(D, "points.npy"))
# padded to odd sizes about twice the grid, the frame in the middle
pad = [2 * n + 1 for n in F.shape[:3]]
lo = [(p - n) // 2 for p, n in zip(pad, F.shape[:3])]
C = (np.array(pad) - 1) / 2.0
Apad = A @ np.array([[1, 0, 0, -lo[0]], [0, 1, 0, -lo[1]], [0, 0, 1, -lo[2]], [0, 0, 0, 1.0]])
Ainv = np.linalg.inv(Apad)
framesp = []
for k in range(K):
    g = np.zeros(pad)
    g[lo[0]:lo[0] + F.shape[0], lo[1]:lo[1] + F.shape[1], lo[2]:lo[2] + F.shape[2]] = F[..., k]
    framesp.append(g)

times, maps = hf.read_matrix_csv(sys.argv[2])
track = hf.track_maps(times, maps)
key_frame = np.clip(np.searchsorted(bounds, times, side="right") - 1, 0, K - 1)
path_frames = sorted({int(key_frame[i]) for i, t in enumerate(times)
                      if t > bounds[0] and t < bounds[-1] and not np.isclose(t, mids[key_frame[i]])})
use = [k for k in range(K) if k not in path_frames]
print("frames with paths (left out of the objective, corrected with the rest):", path_frames)
CENTRE = np.array([0.0, 0.0, 5.0])


def rigid(p):
    m = np.eye(4)
    R = Rotation.from_rotvec(p[:3]).as_matrix()
    m[:3, :3] = R
    m[:3, 3] = CENTRE - R @ CENTRE + p[3:]
    return m


def moved_back(k, M):
    """The object's view of frame k under world map M (object -> tomograph): f(M x)."""
    Mv = Ainv @ M @ Apad
    return compose(framesp[k], Mv[:3, :3], Mv[:3, 3], C)


def top_energy(moved, r=3):
    X = np.stack([m.ravel() for m in moved])
    G = X @ X.T
    w = np.linalg.eigvalsh(G)
    return G.trace() - w[-r:].sum(), X


base = [track(mids[k]) for k in range(K)]
t0 = time.time()
moved0 = [moved_back(k, base[k]) for k in use]
obj0, X = top_energy(moved0)
print("one objective: %.1f s" % (time.time() - t0), flush=True)
U, S, Vt = np.linalg.svd(X, full_matrices=False)
r = U[:, 1] * S[1] / (U[:, 0] * S[0])
ratio = np.zeros(K)
ratio[use] = r
# frames left out: the ratio of their nearest used neighbour
for k in path_frames:
    j = min(use, key=lambda u: abs(u - k))
    ratio[k] = ratio[j]
w = ratio - ratio[0]
w /= w[np.argmax(np.abs(w))]
print("contrast weights:", " ".join("%.2f" % x for x in w))


def objective(p):
    moved = [moved_back(k, rigid(w[k] * p) @ base[k]) for k in use]
    return top_energy(moved)[0]


def corrected_error(p):
    def tr(t):
        k = min(max(int(np.searchsorted(bounds, t, side="right") - 1), 0), K - 1)
        return rigid(w[k] * p) @ track(t)
    e = hf.displacement_errors(tr, truth, bounds, pts)
    return e.mean(), e.max()


print("before: objective %.6e error mean %.3f max %.3f" % ((obj0,) + corrected_error(np.zeros(6))), flush=True)
scale = np.array([0.005, 0.005, 0.005, 0.5, 0.5, 0.5])  # rad, mm: the search's units
res = optimize.minimize(lambda q: objective(q * scale) / obj0, np.zeros(6), method="Powell",
                        options={"xtol": 1e-2, "ftol": 1e-7, "maxfev": int(os.environ.get("MAXFEV", "300"))})
p = res.x * scale
print("after %d evaluations (%.0f s): p = rot %s deg, move %s mm" % (res.nfev, time.time() - t0,
      np.round(np.rad2deg(p[:3]), 3), np.round(p[3:], 3)))
print("after: objective %.6e error mean %.3f max %.3f" % ((res.fun * obj0,) + corrected_error(p)), flush=True)
