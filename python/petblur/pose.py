"""The blur as a function of its motion's samples: B(xi) x, where xi (K, 6)
moves each of the motion's K samples on the object's side, and its derivative
in xi, for gradient-based motion correction (petblur.torch.blur_posed feeds it
to autograd).

Definition. Sample k's pose T_k becomes T_k G(xi_k)^-1, with

    G(xi) p = R(w) (p - c) + c + v,      xi = (v, w) = (vx, vy, vz, wx, wy, wz)

v in mm, w a rotation vector in radians (angle |w| about w / |w|, right-hand
rule), c the motion's centre: the point the blur turns its poses about. xi is
in the motion's coordinates: the scanner's world mm for an operator made with
affine=, else the grid's mm along the array's axes. Between samples the moved
track is interpolated as every track is (LERP, SLERP). This is the C library's
pb_blur_pose_derivative perturbation, given to each sample alone.

The derivative d(B(xi) x)/d(xi_k) is the continuous model's (docs/python.md,
"Pose gradients"): B applied to the object's central-difference gradient
images dx/dp_j and ((p - c) x grad x)_j (pb_blur_pose_derivative's), over the
frame's time weighted by sample k's hat function (1 at t_k, 0 at its
neighbours, linear between). The hat's time integral is taken by blurs of
sub-windows of each tracked interval: with Gauss-Legendre nodes u_i of the
interval [a, b], the moment int (t - a) B_t g dt = int_a^b (int_u^b B_t g dt) du
is a quadrature over the windows [u_i, b], exact when B_t g is a polynomial
of degree 2 * nodes - 2 in t over the interval."""

import ctypes

import numpy as np

from . import _lib
from ._arrays import Array, _check_finite
from .errors import ArgumentError
from .motion import Motion
from .operator import BlurOperator, FramesOperator, _quiet


# ---- the chain rule's SO(3) Jacobian (the poses themselves move by pb_pose_perturb) ----

def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _left_jacobian(w):
    """J with exp(w + dw) = exp(J dw) exp(w) to first order in dw (SO(3))."""
    theta = float(np.linalg.norm(w))
    k = _skew(w)
    if theta < 1e-6:
        return np.eye(3) + 0.5 * k + k @ k / 6.0
    return (np.eye(3) + (1 - np.cos(theta)) / theta ** 2 * k + (theta - np.sin(theta)) / theta ** 3 * k @ k)


# ---- the motion in the grid frame, and xi there ----

class _Placed:
    """An operator's motion in its grid frame (mm from the grid's corner
    along the array's axes, as the plan takes it): times, translations,
    quaternions, the centre c, and the map of xi from the motion's
    coordinates to the grid's (xi_grid = M xi, M orthogonal: the affine's
    directions D, v_grid = D^T v, w_grid = det(D) D^T w)."""

    def __init__(self, op):
        if not isinstance(op, BlurOperator):
            raise ArgumentError(f"pose derivatives take a petblur.BlurOperator, not {type(op).__name__}")
        self.op = op
        shape, vox = op.in_shape, op.voxel_size
        g, cm, keep = op.motion._c_motion(shape, vox, op._affine, op._bounds, warn=False)
        n = cm.count
        self.times = np.array(cm.times[:n])
        self.translations = np.array([cm.poses[i].translation[:] for i in range(n)])
        self.quaternions = np.array([cm.poses[i].rotation[:] for i in range(n)])
        self.center = (np.array(cm.center[:]) if cm.has_center else 0.5 * np.array(shape, dtype=np.float64) * vox)
        del keep
        d = op._affine[:3, :3] / vox[None, :]  # the affine's directions: orthogonal (a shear is refused)
        self.m = np.zeros((6, 6))
        self.m[:3, :3] = d.T
        self.m[3:, 3:] = np.sign(np.linalg.det(d)) * d.T

    def __len__(self):
        return self.times.size

    def xi(self, xi):
        """xi (K, 6) in the motion's coordinates, checked, in the grid's."""
        if xi is None:
            return np.zeros((len(self), 6))
        try:
            a = np.array(xi, dtype=np.float64)
        except (TypeError, ValueError):
            raise ArgumentError(f"xi must be a ({len(self)}, 6) array of numbers") from None
        if a.shape != (len(self), 6):
            raise ArgumentError(f"xi has shape {a.shape}; give ({len(self)}, 6): one (vx, vy, vz, wx, wy, wz) per "
                                f"sample of the motion (mm, radians), {len(self)} samples")
        if not np.all(np.isfinite(a)):
            raise ArgumentError("xi holds NaN or infinity")
        return a @ self.m.T

    def moved(self, xi_grid):
        """The samples' poses T_k G(xi_k)^-1 (translations, quaternions), by
        the library's pb_pose_perturb."""
        t = self.translations.copy()
        q = self.quaternions.copy()
        out = _lib.Pose()
        for k, xi in enumerate(xi_grid):
            if not np.any(xi):
                continue
            p = _lib.Pose((ctypes.c_double * 3)(*t[k]), (ctypes.c_double * 4)(*q[k]))
            _lib.check(_lib.lib.pb_pose_perturb(ctypes.byref(p), (ctypes.c_double * 6)(*map(float, xi)),
                                                ctypes.byref(out)))
            t[k], q[k] = out.translation[:], out.rotation[:]
        return t, q

    def motion(self, xi_grid):
        """The moved track as a Motion in the grid frame, about the centre."""
        t, q = self.moved(xi_grid)
        return Motion(self.times, t, q, center=self.center)

    def operator(self, cls, **description):
        """An operator of the grid frame (no affine) with the original's
        options and device; the checks' warnings not raised again."""
        common = dict(self.op._common)
        common.update(affine=None, device=self.op.device)
        return _quiet(cls, dict(shape=self.op.in_shape, voxel_size=self.op.voxel_size, **common, **description),
                      None)

    def chain(self, xi_grid):
        """(K, 6, 6): A_k with grad_k = A_k d_k, grad the gradient in xi_k (the
        motion's coordinates) and d_k the derivative in a perturbation G(d)^-1
        composed on the right of the moved pose, T_k G(xi_k)^-1 G(d)^-1.
        G(xi + dxi) = G(d) G(xi) to first order gives d = J dxi with
        J = [[I, [v]x J_l(w)], [0, J_l(w)]] (in the grid frame), so
        A_k = M^T J^T."""
        out = np.empty((len(self), 6, 6))
        for k in range(len(self)):
            v, w = xi_grid[k, :3], xi_grid[k, 3:]
            jt = np.eye(6)
            if np.any(w) or np.any(v):
                jl = _left_jacobian(w)
                jt[3:, :3] = -jl.T @ _skew(v)
                jt[3:, 3:] = jl.T
            out[k] = self.m.T @ jt
        return out


def _pieces(times, t0, t1, nodes):
    """The frame [t0, t1] cut into the sub-windows the hat weights are
    integrated over: bounds (P + 1), and for each piece p the sample k[p]
    before it and the weights of its blur in the derivatives of samples k[p]
    and k[p] + 1 (each a share of the frame's time)."""
    if int(nodes) != nodes or not 1 <= nodes <= 8:
        raise ArgumentError(f"nodes {nodes!r}: give a whole number of quadrature nodes per interval, 1 to 8")
    gx, gw = np.polynomial.legendre.leggauss(int(nodes))
    length = t1 - t0
    bounds, k_of, w_lo, w_hi = [t0], [], [], []
    first = max(0, int(np.searchsorted(times, t0, side="right")) - 1)
    for k in range(first, times.size - 1):
        a, b = max(times[k], t0), min(times[k + 1], t1)
        if a >= t1:
            break
        if b - a <= 1e-6 * length:  # a sliver of an interval: its share is below the quadrature's error
            continue
        delta = times[k + 1] - times[k]
        s = np.concatenate([[a], 0.5 * (a + b) + 0.5 * (b - a) * gx, [b]])
        cum = np.concatenate([[0.0], np.cumsum(gw)])
        for p in range(int(nodes) + 1):
            piece = s[p + 1] - s[p]
            # int over [a, b] of (t - t_k) / delta B_t g dt = (M1 + (a - t_k) M0) / delta, M0 = sum of the pieces,
            # M1 = int_a^b F(u) du, F(u) the blur over [u, b] times its length: piece p counts in F at the nodes
            # at or before its start.
            hi = piece * (0.5 * (b - a) * cum[p] + (a - times[k])) / (delta * length)
            k_of.append(k)
            w_hi.append(hi)
            w_lo.append(piece / length - hi)
            bounds.append(s[p + 1])
    bounds[-1] = t1
    return np.array(bounds), np.array(k_of, dtype=np.intp), np.array(w_lo), np.array(w_hi)


# ---- the object's gradient images ----

def gradient_images(x, voxel_size, center):
    """The six images of pb_blur_pose_derivative for x indexed [x, y, z]
    (numpy or a torch tensor, on its device): dx/dp_j by central differences
    (zero outside the grid), then ((p - c) x grad x)_j, p a voxel's centre and
    c the centre, both in mm of the grid frame. float32, computed in double:
    numpy arrays by the library, torch tensors where they are."""
    torch = _torch_of(x)
    if torch is None:  # on the host: the library's (pb_pose_gradient_images), as its estimate takes them
        xf = np.asfortranarray(x, dtype=np.float32)
        out = [np.empty(xf.shape, dtype=np.float32, order="F") for _ in range(6)]
        g = _lib.Geometry((ctypes.c_size_t * 3)(*xf.shape), (ctypes.c_double * 3)(*map(float, voxel_size)))
        ptrs = (ctypes.c_void_p * 6)(*[o.ctypes.data for o in out])
        _lib.check(_lib.lib.pb_pose_gradient_images(ctypes.byref(g), xf.ctypes.data,
                                                    (ctypes.c_double * 3)(*map(float, center)), ptrs))
        return out
    xd = x.detach().to(torch.float64)
    zeros, arange = torch.zeros_like, (lambda n: torch.arange(n, dtype=torch.float64, device=x.device))
    grad, r = [], []
    for a in range(3):
        g = zeros(xd)
        n = xd.shape[a]

        def at(lo, hi, a=a):
            s = [slice(None)] * 3
            s[a] = slice(lo, hi)
            return tuple(s)
        if n > 1:
            g[at(1, n - 1)] = xd[at(2, n)] - xd[at(0, n - 2)]
            g[at(0, 1)] = xd[at(1, 2)]
            g[at(n - 1, n)] = -xd[at(n - 2, n - 1)]
        grad.append(g / (2.0 * float(voxel_size[a])))
        shape = [1, 1, 1]
        shape[a] = n
        r.append(((arange(n) + 0.5) * float(voxel_size[a]) - float(center[a])).reshape(shape))
    rot = [r[1] * grad[2] - r[2] * grad[1], r[2] * grad[0] - r[0] * grad[2], r[0] * grad[1] - r[1] * grad[0]]
    return [v.to(torch.float32) for v in grad + rot]


def _torch_of(x):
    import sys
    torch = sys.modules.get("torch")
    return torch if torch is not None and isinstance(x, torch.Tensor) else None


def _dot(a, b):
    torch = _torch_of(a)
    if torch is not None:
        return float(torch.sum(a.to(torch.float64) * b.to(torch.float64)))
    return float(np.dot(np.asarray(a, dtype=np.float64).ravel(), np.asarray(b, dtype=np.float64).ravel()))


# ---- the public functions ----

def posed_operator(op, xi):
    """The operator B(xi): op's blur with each sample k of its motion moved,
    T_k -> T_k G(xi_k)^-1 (xi (K, 6) in the motion's coordinates; module
    docstring). op itself when xi is None or zero."""
    placed = _Placed(op)
    xg = placed.xi(xi)
    if not np.any(xg):
        return op
    return placed.operator(BlurOperator, motion=placed.motion(xg), frame=op.frame)


def derivatives(op, x, xi=None, nodes=2):
    """d(B(xi) x)/d(xi_k): float32 numpy (K, 6, nx, ny, nz), row k the
    derivative in sample k's (vx, vy, vz, wx, wy, wz) (per mm, per radian),
    in the motion's coordinates; samples whose intervals miss the frame get
    zeros. From the C library's pb_blur_pose_derivative over the sub-windows
    (module docstring). x: numpy (or a torch CPU tensor) indexed [x, y, z].
    Memory K * 6 volumes: for a few samples (tests, small problems); vjp
    gives <y, d(B x)/d(xi_k)> for any number."""
    placed = _Placed(op)
    xg = placed.xi(xi)
    t0, t1 = op.frame
    bounds, k_of, w_lo, w_hi = _pieces(placed.times, t0, t1, nodes)
    arr = Array(x, "object (the activity)")
    if arr.on_gpu:
        raise ArgumentError("derivatives takes host arrays; vjp takes CUDA arrays too")
    if arr.shape != op.in_shape:
        raise ArgumentError(f"the object has shape {arr.shape}; the operator takes {op.in_shape}")
    _check_finite(arr.data, "object (the activity)", arr.wide)  # as the operators check what they read
    xf = np.asfortranarray(arr.data, dtype=np.float32)
    shape = op.in_shape
    out = np.zeros((len(placed), 6) + shape, dtype=np.float64)
    t, q = placed.moved(xg)
    count = len(placed)
    times = (ctypes.c_double * count)(*placed.times)
    poses = (_lib.Pose * count)(*[_lib.Pose((ctypes.c_double * 3)(*ti), (ctypes.c_double * 4)(*qi))
                                  for ti, qi in zip(t, q)])
    g = _lib.Geometry((ctypes.c_size_t * 3)(*shape), (ctypes.c_double * 3)(*op.voxel_size))
    lib, ctx = _lib.lib, op._ctx
    made = []
    image = np.empty(shape, dtype=np.float32, order="F")
    with ctx.use():
        try:
            vols = []
            for _ in range(7):
                v = ctypes.c_void_p()
                _lib.check(lib.pb_volume_create(ctx.handle, ctypes.byref(g), ctypes.byref(v)), ctx.handle)
                made.append(v)
                vols.append(v)
            _lib.check(lib.pb_volume_upload(vols[0], xf.ctypes.data), ctx.handle)
            ders = (ctypes.c_void_p * 6)(*vols[1:])
            for p in range(k_of.size):
                m = _lib.CMotion(times, poses, count, bounds[p], bounds[p + 1], 1,
                                 (ctypes.c_double * 3)(*placed.center))
                _lib.check(lib.pb_blur_pose_derivative(ctx.handle, vols[0], ctypes.byref(m),
                                                       ctypes.byref(op._options), ders), ctx.handle)
                k = k_of[p]
                for j in range(6):
                    _lib.check(lib.pb_volume_download(vols[1 + j], image.ctypes.data), ctx.handle)
                    out[k, j] += w_lo[p] * image
                    out[k + 1, j] += w_hi[p] * image
        finally:
            for v in made:
                lib.pb_volume_destroy(v)
    # Into the motion's coordinates, at xi.
    return np.einsum("kij,kj...->ki...", placed.chain(xg), out).astype(np.float32)


def vjp(op, x, y, xi=None, nodes=2):
    """<y, d(B(xi) x)/d(xi_k)> for every sample k: (K, 6) float64 numpy, in
    the motion's coordinates (per mm, per radian). x and y (in_shape,
    [x, y, z]) are numpy arrays or torch tensors (CPU or, on a CUDA operator,
    CUDA). One transpose per sub-window, B_p^T y, dotted with the object's
    six gradient images (<y, B_p g> = <B_p^T y, g>): (nodes + 1) transposes
    per tracked interval inside the frame."""
    placed = _Placed(op)
    xg = placed.xi(xi)
    t0, t1 = op.frame
    bounds, k_of, w_lo, w_hi = _pieces(placed.times, t0, t1, nodes)
    if tuple(x.shape) != op.in_shape:
        raise ArgumentError(f"the object has shape {tuple(x.shape)}; the operator takes {op.in_shape}")
    images = gradient_images(x, op.voxel_size, placed.center)
    fop = placed.operator(FramesOperator, track=placed.motion(xg), bounds=bounds, per_frame=True)
    arr = Array(y, "tomograph-space volume")
    if arr.shape != op.in_shape:
        raise ArgumentError(f"y has shape {arr.shape}; the operator gives {op.out_shape}")
    ((v, order),) = arr.volumes(op.in_shape)
    out = arr.empty(op.in_shape, order)
    grad = np.zeros((len(placed), 6))
    for p in range(k_of.size):
        fop._run(arr, [(p, v, out, 0, order)], True)
        d = np.array([_dot(out, images[j]) for j in range(6)])
        grad[k_of[p]] += w_lo[p] * d
        grad[k_of[p] + 1] += w_hi[p] * d
    return np.einsum("kij,kj->ki", placed.chain(xg), grad)
