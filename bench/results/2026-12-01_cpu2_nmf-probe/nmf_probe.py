"""Does a non-negative factorization see a drift that follows the contrast, where the SVD's energy beyond does not?
Frames of a still head (drawmod.py SEED still|stillclean), shifted along an axis by a * (w_k - w_ref), w_k the
frame's s2/s1 on the frames' own SVD; the SVD's energy beyond r images and a KL-NMF's divergence at rank r, per a."""
import sys, json, numpy as np, nibabel as nib
from scipy import ndimage
d = sys.argv[1]; r = int(sys.argv[2]) if len(sys.argv) > 2 else 3
img = nib.load(d + "/f.nii.gz"); F = np.asarray(img.dataobj, np.float64)
side = json.load(open(d + "/f.json")); L = np.array(side["FrameDuration"])
nk = F.shape[-1]
C = F * L  # counts-like (frames are counts / s)
C = np.maximum(C, 0)
# coarse grid: block means 2x2x2 (as pass 4 compares on coarser voxels)
def coarse(v):
    s = [x // 2 * 2 for x in v.shape[:3]]
    v = v[:s[0], :s[1], :s[2]]
    return v.reshape(s[0] // 2, 2, s[1] // 2, 2, s[2] // 2, 2, *v.shape[3:]).sum(axis=(1, 3, 5))
X0 = C
M = X0.reshape(-1, nk)
G = M.T @ M
w_, v_ = np.linalg.eigh(G); o = np.argsort(w_)[::-1]; v_ = v_[:, o]
s1, s2 = v_[:, 0], v_[:, 1]
wts = s2 / s1; wts = (wts - wts[0]); wts /= np.abs(wts).max()
if len(sys.argv) > 3:  # the weights from another series (the same draw without noise)
    Fc = np.asarray(nib.load(sys.argv[3] + "/f.nii.gz").dataobj, np.float64) * L
    Mc = Fc.reshape(-1, nk); wc, vc = np.linalg.eigh(Mc.T @ Mc); vc = vc[:, np.argsort(wc)[::-1]]
    wts = vc[:, 1] / vc[:, 0]; wts = wts - wts[0]; wts /= np.abs(wts).max()
print("weights", np.round(wts, 2))
vox = np.sqrt((img.affine[:3, :3] ** 2).sum(0))
def nmf_kl(V, r, it=400, seed=0):
    """Frobenius NMF by HALS (each column of W and row of H in turn, exact), the residual's share of |V|^2."""
    rng = np.random.default_rng(seed)
    u, sv, vt = np.linalg.svd(V, full_matrices=False)
    W = np.abs(u[:, :r] * sv[:r]) + 1e-6; H = np.abs(vt[:r]) + 1e-6
    for _ in range(it):
        A, B = V.T @ W, W.T @ W
        for j in range(r):
            H[j] = np.maximum(H[j] + (A[:, j] - B[j] @ H) / max(B[j, j], 1e-12), 1e-12)
        A, B = V @ H.T, H @ H.T
        for j in range(r):
            W[:, j] = np.maximum(W[:, j] + (A[:, j] - W @ B[:, j]) / max(B[j, j], 1e-12), 0)
    return float(np.sum((V - W @ H) ** 2) / np.sum(V ** 2))


for axis in (2,):
    for a_mm in (-2.0, -1.0, 0.0, 1.0, 2.0):
        X = np.empty_like(X0)
        for k in range(nk):
            sh = [0.0, 0.0, 0.0]; sh[axis] = a_mm * wts[k] / vox[axis]
            # a Fourier shift keeps the noise's energy, as pass 4's resampler does
            X[..., k] = np.maximum(np.real(np.fft.ifftn(ndimage.fourier_shift(np.fft.fftn(X0[..., k]), sh))), 0)
        Xc = coarse(X).reshape(-1, nk)
        Xc = Xc[Xc.sum(1) > 0]
        G = Xc.T @ Xc
        ev = np.sort(np.linalg.eigvalsh(G))[::-1]
        beyond = ev[r:].sum() / ev.sum()
        kl = nmf_kl(Xc, r)
        print(f"axis {axis} a {a_mm:+.1f} mm: svd beyond {r}: {beyond:.8e}  nmf beyond {r}: {kl:.8e}", flush=True)
