"""Moves by shears of trigonometric interpolation (energy kept), numpy: the prototype of
src/estimate/sinc_shears.c's idea for the link-choice probe."""
import numpy as np
from scipy.spatial.transform import Rotation


def _shear(v, axis, along, s, voxel, centre):
    """v(x) -> v(x - s * (j_mm) e_axis), j the coordinate along `along` (mm from centre), shift in voxels."""
    n = v.shape[axis]
    k = np.fft.fftfreq(n)
    j_mm = (np.arange(v.shape[along]) - centre[along]) * voxel[along]
    shift = s * j_mm / voxel[axis]  # voxels, per line
    shp = [1, 1, 1]; shp[axis] = n
    kk = k.reshape(shp)
    shp2 = [1, 1, 1]; shp2[along] = len(shift)
    ph = np.exp(-2j * np.pi * kk * shift.reshape(shp2))
    return np.real(np.fft.ifft(np.fft.fft(v, axis=axis) * ph, axis=axis))


def _rot2(v, i, j, theta, voxel, centre):
    """Rotate by theta in the (i, j) plane (mm), three shears."""
    t = np.tan(theta / 2)
    v = _shear(v, i, j, -t, voxel, centre)
    v = _shear(v, j, i, np.sin(theta), voxel, centre)
    return _shear(v, i, j, -t, voxel, centre)


def move(f, A, M, pad=12):
    """g(v) = f(A^-1 M A v) for world map M, A the voxel-to-world affine, by shears (energy kept)."""
    D = np.linalg.norm(A[:3, :3], axis=0)
    Q = A[:3, :3] / D
    # in mm-index coordinates y = D v: g(y) = f(Q^T (M (Q y + a)) - ...) ; the map y -> Q^T R Q y + b
    Rm = Q.T @ M[:3, :3] @ Q
    full = np.linalg.inv(A) @ M @ A  # voxel map v -> w
    fp = np.pad(f.astype(np.float64), pad)
    centre = (np.array(fp.shape) - 1) / 2.0
    # v -> w = Dinv Rm D (v - cv) + Dinv Rm D cv + full_t ; with padding, cv in padded coords
    cv = centre - pad  # the padded centre in the original grid's index
    wc = full[:3, :3] @ cv + full[:3, 3]  # where the centre maps
    # g(v) = f(w(v)): rotation about the centre, then a shift of (wc - cv) voxels
    # Sampling f at Rm (y - yc) + yc + d is f moved by the inverse: rotate f's content by Rm^-1 and shift by -d.
    d = wc - cv
    # shift first: h(v) = f(v + d)
    k = [np.fft.fftfreq(n) for n in fp.shape]
    ph = np.exp(2j * np.pi * (k[0][:, None, None] * d[0] + k[1][None, :, None] * d[1] + k[2][None, None, :] * d[2]))
    h = np.real(np.fft.ifftn(np.fft.fftn(fp) * ph))
    # then g(y) = h(Rm (y - c) + c): content rotated by Rm^-1
    a, b, c = Rotation.from_matrix(Rm.T).as_euler("xyz")  # Rm^T = Rx(a)... extrinsic xyz: Rz(c) Ry(b) Rx(a)
    voxel = D
    h = _rot2(h, 1, 2, a, voxel, centre)
    h = _rot2(h, 2, 0, b, voxel, centre)
    h = _rot2(h, 0, 1, c, voxel, centre)
    return h[pad:-pad, pad:-pad, pad:-pad]
