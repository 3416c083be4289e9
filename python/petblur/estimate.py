"""Motion from the frames: petblur.Motion.from_frames, through the C
library's pb_motion_estimate (the one the command line's `petblur motion
estimate` calls), so that both give the same track."""

import ctypes

import numpy as np

from . import _lib
from ._arrays import Array, _check_finite
from .errors import ArgumentError


class EstimateOptions(ctypes.Structure):
    _fields_ = [("reference", ctypes.c_size_t), ("levels", ctypes.c_uint), ("iterations", ctypes.c_uint),
                ("frame_poses_only", ctypes.c_int), ("fwhm_mm", ctypes.c_double)]


class EstimateReport(ctypes.Structure):
    _fields_ = [("seconds", ctypes.c_double), ("moving_frames", ctypes.c_size_t), ("warnings", _lib.Warnings)]


_lib.check_layout({"pb_estimate_options": EstimateOptions, "pb_estimate_report": EstimateReport}, {})
_P, _vp, _dbl = ctypes.POINTER, ctypes.c_void_p, ctypes.c_double
_lib.lib.pb_motion_estimate.restype = ctypes.c_int
_lib.lib.pb_motion_estimate.argtypes = [_vp, _P(_lib.Geometry), _P(_dbl), _vp, ctypes.c_size_t, _P(_dbl),
                                        _P(EstimateOptions), _P(_vp), _P(EstimateReport)]


_FLOAT32_MAX = float(np.finfo(np.float32).max)


def _computed(frames):
    """A Dask array as numpy: the estimate reads every frame at once, on the host."""
    if type(frames).__module__.split(".")[0] == "dask" and hasattr(frames, "compute"):
        return np.asarray(frames.compute())
    return frames


def _check_float32_range(x, k):
    """The estimate computes in float32: a finite value beyond its range would become an infinity."""
    big = np.abs(x) > _FLOAT32_MAX
    if big.any():
        where = tuple(int(i) for i in np.argwhere(big)[0])
        raise ArgumentError(f"frame {k} holds {x[where]!r} at {list(where)} (axes x, y, z), finite but beyond "
                            f"float32's range (magnitudes up to {_FLOAT32_MAX:.7g}), in which the estimate computes; "
                            "scale the frames down (the estimate fits each frame's own scale, so their unit does not "
                            "matter)", -4)


def _host_frames(frames):
    """[x, y, z, t] float32 on the host, x fastest then frame after frame."""
    frames = _computed(frames)
    with np.errstate(over="ignore"):  # values beyond float32 are refused below, by name
        a = Array(frames, "frames")
    x = a.original
    if a.kind in ("torch", "torch-cpu"):
        x = x.detach().cpu().numpy()
    elif a.kind == "cupy":
        x = x.get()
    x = np.asarray(x)
    if x.ndim != 4:
        raise ArgumentError(f"frames must be 4-D, [x, y, z, t], not of shape {x.shape}: a 3-D image or a single "
                            "frame has nothing to register")
    for k in range(x.shape[3]):
        _check_finite(x[..., k], f"frame {k}")
        _check_float32_range(x[..., k], k)
    return np.asfortranarray(x, dtype=np.float32)


def _voxel_sizes(a):
    """The lengths of the affine's columns, as numpy gives them; a column
    whose squares overflow or underflow (sizes beyond 1e150 or under 1e-150)
    is scaled first, so that its size is refused as given, not as inf or 0."""
    out = []
    for col in a[:3, :3].T:
        with np.errstate(over="ignore", under="ignore"):
            v = float(np.linalg.norm(col))
        top = float(np.max(np.abs(col)))
        if top > 0 and not 1e-150 < v < 1e150:
            v = top * float(np.linalg.norm(col / top))
        out.append(v)
    return tuple(out)


def _estimate_device(device):
    """'auto' as the library resolves it for the estimate (a GPU, else the
    host backend rather than an OpenCL CPU device); any other spec as given."""
    if device != "auto":
        return device
    backend, index = ctypes.c_int(), ctypes.c_int()
    _lib.check(_lib.lib.pb_device_auto_estimate(ctypes.byref(backend), ctypes.byref(index)))
    if backend.value == _lib.BACKEND_HOST:
        return "host"
    return f"{_lib.BACKEND_NAMES[backend.value]}:{index.value}"


def estimate(frames, affine, voxel_size, bounds, reference, device, frame_poses_only, levels, iterations, fwhm):
    """The motion's C track (matrix-csv: world maps about the world's origin; the caller frees it) and the
    report."""
    x = _host_frames(frames)
    nx, ny, nz, nt = x.shape
    if affine is None:
        # Without an affine the series lies in the grid frame the operators
        # take without one: voxel_size mm, the grid's corner at the origin.
        if voxel_size is None:
            raise ArgumentError("give affine= (the series' voxel-to-world 4x4, nibabel's img.affine) or voxel_size= "
                                "(mm): without either the motion's translations would be in voxels, not mm")
        d = np.asarray(voxel_size, dtype=np.float64).reshape(-1)
        if d.size == 1:  # one size for the three axes, as the operators take it
            d = np.repeat(d, 3)
        if d.size != 3 or not np.all(np.isfinite(d)) or not np.all(d > 0):
            raise ArgumentError(f"voxel_size {voxel_size!r}: give one or three positive, finite sizes in mm")
        affine = np.eye(4)
        affine[:3, :3] = np.diag(d)
        affine[:3, 3] = 0.5 * d
    elif voxel_size is not None:
        raise ArgumentError("give affine= or voxel_size=, not both: the affine holds the voxel size")
    a = np.asarray(affine, dtype=np.float64)
    if a.shape != (4, 4) or not np.all(np.isfinite(a)):
        raise ArgumentError(f"affine must be a finite 4x4 voxel-to-world matrix (nibabel's img.affine), not {a.shape}")
    geometry_voxel = _voxel_sizes(a)
    flat = (ctypes.c_double * 16)(*a.reshape(-1))
    b = np.asarray(bounds, dtype=np.float64).reshape(-1)
    if b.size != nt + 1:
        raise ArgumentError(f"the frames' times give {b.size - 1} frames but frames holds {nt} (its last axis); give "
                            "one start and duration per frame")
    for name, v, lo, hi in (("levels", levels, 0, 6), ("iterations", iterations, 0, 1000)):
        if not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
            raise ArgumentError(f"{name} {v!r}: give a whole number from {lo} (the default) to {hi}")
    if isinstance(reference, bool) or not isinstance(reference, (int, np.integer)) or not 0 <= reference < nt:
        raise ArgumentError(f"reference {reference!r}: the series has frames 0 to {nt - 1}")
    fwhm = float(fwhm)
    if not np.isfinite(fwhm) or not 0.0 <= fwhm <= 1000.0:
        raise ArgumentError(f"fwhm {fwhm}: give 0 (two voxels of each level) to 1000 mm")
    g = _lib.Geometry((ctypes.c_size_t * 3)(nx, ny, nz), (ctypes.c_double * 3)(*geometry_voxel))
    opts = EstimateOptions(int(reference), int(levels), int(iterations), int(bool(frame_poses_only)), fwhm)
    cb = (ctypes.c_double * b.size)(*b)
    track, report = ctypes.c_void_p(), EstimateReport()
    ctx = _lib.context(_estimate_device(device))
    with ctx.use():
        status = _lib.lib.pb_motion_estimate(ctx.handle, ctypes.byref(g), flat, x.ctypes.data, nt, cb,
                                             ctypes.byref(opts), ctypes.byref(track), ctypes.byref(report))
        _lib.check(status, ctx.handle)
    return track, report
