"""Motion from the frames: petblur.Motion.from_frames, through the C
library's pb_motion_estimate (the one the command line's `petblur motion
estimate` calls), so that both give the same track."""

import ctypes

import numpy as np

from . import _lib
from ._arrays import Array, _check_finite
from .errors import ArgumentError, shown
from .motion import _finite
from .operator import VOXEL_MAX, VOXEL_MIN, _affine4, _voxel3


class EstimateFrame(ctypes.Structure):
    _fields_ = [("explained", ctypes.c_double), ("motion_from", ctypes.c_double), ("motion_to", ctypes.c_double),
                ("structure", ctypes.c_int), ("moving", ctypes.c_int), ("jumped_at_start", ctypes.c_int),
                ("unfollowed", ctypes.c_double)]


class EstimateOptions(ctypes.Structure):
    _fields_ = [("reference", ctypes.c_size_t), ("levels", ctypes.c_uint), ("iterations", ctypes.c_uint),
                ("frame_poses_only", ctypes.c_int), ("fwhm_mm", ctypes.c_double),
                ("frames", ctypes.POINTER(EstimateFrame))]


class EstimateReport(ctypes.Structure):
    _fields_ = [("seconds", ctypes.c_double), ("moving_frames", ctypes.c_size_t), ("warnings", _lib.Warnings),
                ("reference", ctypes.c_size_t)]


REFERENCE_AUTO = ctypes.c_size_t(-1).value  # PB_ESTIMATE_REFERENCE_AUTO


_lib.check_layout({"pb_estimate_options": EstimateOptions, "pb_estimate_report": EstimateReport,
                   "pb_estimate_frame": EstimateFrame}, {})
_P, _vp, _dbl = ctypes.POINTER, ctypes.c_void_p, ctypes.c_double
_lib.bind({"pb_motion_estimate": (ctypes.c_int, [_vp, _P(_lib.Geometry), _P(_dbl), _vp, ctypes.c_size_t, _P(_dbl),
                                                  _P(EstimateOptions), _P(_vp), _P(EstimateReport)])})



def _host_frames(frames):
    """[x, y, z, t] float32 on the host, x fastest then frame after frame.
    The frames are read on the host whatever holds them, so an array that
    numpy can read (a dask array, nibabel's img.dataobj) is read through
    numpy."""
    if not isinstance(frames, (list, tuple)) and hasattr(frames, "__array__") and \
            type(frames).__module__.split(".")[0] not in ("numpy", "cupy", "torch"):
        frames = np.asarray(frames)
    if isinstance(frames, np.ndarray) and frames.dtype.kind in "iub":  # counts, an unscaled NIfTI's dataobj
        frames = frames.astype(np.float32)
    a = Array(frames, "frames")
    if a.on_gpu and str(a.dtype).endswith("float64"):  # narrowed on the host, where a value lost is named
        a = Array(a.original.get() if a.kind == "cupy" else a.original.detach().cpu().numpy(), "frames")
    x = a.data
    if a.kind == "torch":
        x = x.cpu().numpy()
    elif a.kind == "cupy":
        x = x.get()
    x = np.asarray(x)
    if x.ndim != 4:
        raise ArgumentError(f"frames must be 4-D, [x, y, z, t], not of shape {x.shape}: a 3-D image or a single "
                            "frame has nothing to register")
    x = np.asfortranarray(x, dtype=np.float32)
    for k in range(x.shape[3]):
        _check_finite(x[..., k], f"frame {k}", None if a.wide is None else a.wide[..., k])
    return x


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


def estimate(frames, affine, voxel_size, bounds, reference, device, frame_poses_only, levels, iterations, fwhm,
             progress=None):
    """The motion's C track (matrix-csv: world maps about the world's origin; the caller frees it) and the
    report."""
    if progress is not None and not callable(progress):
        raise ArgumentError("progress must be a callable taking the fraction done, or None")
    x = _host_frames(frames)
    nx, ny, nz, nt = x.shape
    if affine is None:
        # Without an affine the series lies in the grid frame the operators
        # take without one: voxel_size mm, the grid's corner at the origin.
        if voxel_size is None:
            raise ArgumentError("give affine= (the series' voxel-to-world 4x4, nibabel's img.affine) or voxel_size= "
                                "(mm): without either the motion's translations would be in voxels, not mm")
        d = _voxel3(voxel_size)  # the operators' rule: the same grid frame
        affine = np.eye(4)
        affine[:3, :3] = np.diag(d)
        affine[:3, 3] = 0.5 * d
    elif voxel_size is not None:
        raise ArgumentError("give affine= or voxel_size=, not both: the affine holds the voxel size")
    a = _affine4(affine)
    # The columns' lengths, the voxel sizes, as the program computes them;
    # where squaring leaves float64 (1e300 to inf, 1e-300 to 0) scaled first,
    # to name the length as given. Held to the operators' range.
    with np.errstate(over="ignore", under="ignore"):
        lengths = np.linalg.norm(a[:3, :3], axis=0)
    scale = np.abs(a[:3, :3]).max(axis=0)
    lost = ~np.isfinite(lengths) | (lengths < 1e-150)
    lengths[lost] = (scale * np.linalg.norm(a[:3, :3] / np.where(scale > 0, scale, 1.0), axis=0))[lost]
    for i, v in enumerate(lengths):
        if not VOXEL_MIN <= v <= VOXEL_MAX:
            raise ArgumentError(f"affine's column {i} is {float(v)!r} mm long, the voxels' size along axis {i}; give "
                                "an affine of voxels between 0.0001 and 10000 mm (nibabel's img.affine, in mm)")
    geometry_voxel = tuple(float(v) for v in lengths)
    flat = (ctypes.c_double * 16)(*a.reshape(-1))
    b = np.asarray(bounds, dtype=np.float64).reshape(-1)
    if b.size != nt + 1:
        raise ArgumentError(f"the frames' times give {b.size - 1} frames but frames holds {nt} (its last axis); give "
                            "one start and duration per frame")
    for name, v, lo, hi in (("levels", levels, 0, 6), ("iterations", iterations, 0, 1000)):
        if not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
            raise ArgumentError(f"{name} {v!r}: give a whole number from {lo} (the default) to {hi}")
    if isinstance(reference, str) and reference == "auto":
        reference = REFERENCE_AUTO
    elif isinstance(reference, bool) or not isinstance(reference, (int, np.integer)) or not 0 <= reference < nt:
        raise ArgumentError(f"reference {reference!r}: the series has frames 0 to {nt - 1}, or give 'auto' (the "
                            "still frame whose pose the series determines best)")
    given = fwhm
    fwhm = _finite(fwhm)
    if fwhm is None or not 0.0 <= fwhm <= 1000.0:
        raise ArgumentError(f"fwhm {shown(given)}: give 0 (two voxels of each level) to 1000 mm")
    g = _lib.Geometry((ctypes.c_size_t * 3)(nx, ny, nz), (ctypes.c_double * 3)(*geometry_voxel))
    per_frame = (EstimateFrame * nt)()
    opts = EstimateOptions(int(reference), int(levels), int(iterations), int(bool(frame_poses_only)), fwhm,
                           ctypes.cast(per_frame, ctypes.POINTER(EstimateFrame)))
    cb = (ctypes.c_double * b.size)(*b)
    track, report = ctypes.c_void_p(), EstimateReport()
    ctx = _lib.context(_estimate_device(device))
    with ctx.use():
        with _lib.progress_reported(ctx.handle, progress) as raised:
            status = _lib.lib.pb_motion_estimate(ctx.handle, ctypes.byref(g), flat, x.ctypes.data, nt, cb,
                                                 ctypes.byref(opts), ctypes.byref(track), ctypes.byref(report))
            if raised and status == 0:  # progress raised: its exception, not the track
                _lib.lib.pb_track_free(track)
        _lib.check(status, ctx.handle)
    frames_report = [{"frame": k, "start": float(b[k]), "end": float(b[k + 1]),
                      "explained": float(per_frame[k].explained), "structure": bool(per_frame[k].structure),
                      "motion_inside": (float(per_frame[k].motion_from), float(per_frame[k].motion_to))
                      if per_frame[k].moving else None, "jumped_at_start": bool(per_frame[k].jumped_at_start),
                      "unfollowed": float(per_frame[k].unfollowed)}
                     for k in range(nt)]
    return track, report, frames_report
