"""Motions: time-stamped rigid poses (seconds, mm, unit quaternions w,x,y,z),
made from arrays, from a tracker's log (every format the command line reads,
through the C library's reader) or from one pose. A pose maps object space to
tomograph space, p' = R(q) (p - c) + c + t, about the centre c.

Coordinates: without an affine the operators take a motion along the array's
axes, in mm from the grid's corner (the command line's --coords grid); with
affine= (voxel to world, 4x4, as nibabel's img.affine) in the scanner's world
mm, where tracker logs live (--coords world)."""

import ctypes
import os
import warnings

import numpy as np

from . import _lib
from .errors import ArgumentError, Error

_FORMATS = {None: 0, "auto": 0, "csv": 1, "matrix-csv": 2, "polaris": 3}
_FORMAT_NAMES = {1: "csv", 2: "matrix-csv", 3: "polaris"}


def _vector(name, value, n):
    try:
        v = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ArgumentError(f"{name} must be {n} numbers, not {value!r}") from None
    if v.size != n:
        raise ArgumentError(f"{name} must be {n} numbers, not {v.size}")
    if not np.all(np.isfinite(v)):
        raise ArgumentError(f"{name} holds NaN or infinity: {value!r}")
    return v


def _rigid_inverse(m):
    out = np.eye(4)
    out[:3, :3] = m[:3, :3].T
    out[:3, 3] = -m[:3, :3].T @ m[:3, 3]
    return out


def _pose_matrix(t, q, c):
    """The 4x4 map of pose (t, q) about c, as the command line composes them."""
    pose = _lib.Pose((ctypes.c_double * 3)(*t), (ctypes.c_double * 4)(*q))
    m = (ctypes.c_double * 16)()
    _lib.check(_lib.lib.pb_pose_to_matrix(ctypes.byref(pose), m))
    m = np.array(m[:]).reshape(4, 4)
    m[:3, 3] += c - m[:3, :3] @ c
    return m


def _matrix_pose(m, c):
    pose = _lib.Pose()
    flat = (ctypes.c_double * 16)(*m.reshape(-1))
    status = _lib.lib.pb_pose_from_matrix(flat, ctypes.byref(pose))
    if status != 0:
        raise ArgumentError(f"a composed pose is not rigid: {_lib.message()}", status)
    t = np.array(pose.translation[:]) - (c - m[:3, :3] @ c)
    return t, np.array(pose.rotation[:])


class Motion:
    """A pose track: ``times`` (N,) seconds, strictly increasing, N >= 2;
    ``translations`` (N, 3) mm; ``quaternions`` (N, 4) unit w,x,y,z; ``center``
    (3,) mm, the rotation centre (None: the grid's centre). Between samples the
    translation is interpolated linearly and the rotation spherically."""

    def __init__(self, times, translations, quaternions, center=None):
        self.times = np.array(times, dtype=np.float64).reshape(-1)
        self.translations = np.array(translations, dtype=np.float64)
        self.quaternions = np.array(quaternions, dtype=np.float64)
        n = self.times.size
        if n < 2:
            raise ArgumentError(f"a motion needs at least two poses (the frame's start and end), not {n}")
        if self.translations.shape != (n, 3):
            raise ArgumentError(f"translations must have shape ({n}, 3), one row per time, not "
                                f"{self.translations.shape}")
        if self.quaternions.shape != (n, 4):
            raise ArgumentError(f"quaternions must have shape ({n}, 4), w,x,y,z per time, not "
                                f"{self.quaternions.shape}")
        for name, a in (("times", self.times), ("translations", self.translations),
                        ("quaternions", self.quaternions)):
            if not np.all(np.isfinite(a)):
                raise ArgumentError(f"{name} hold NaN or infinity")
        if np.any(np.diff(self.times) <= 0):
            i = int(np.argmax(np.diff(self.times) <= 0))
            raise ArgumentError(f"times must increase strictly: {self.times[i + 1]!r} s follows {self.times[i]!r} s "
                                f"(rows {i} and {i + 1})")
        self.center = None if center is None else _vector("center", center, 3)
        # Tracker logs: 4x4 maps about the world's origin, and the conventions
        # (calibration, reference pose, inversion) applied once the grid is known.
        self.about_origin = False
        self._calibration = None
        self._reference_time = None
        self._inverse = False
        self._reference_default = False
        self._warned = False

    def __len__(self):
        return self.times.size

    def __repr__(self):
        return f"petblur.Motion({len(self)} poses, {self.times[0]:g} to {self.times[-1]:g} s)"

    @classmethod
    def from_axis_angle(cls, translation=(0.0, 0.0, 0.0), angle=0.0, axis=(0.0, 0.0, 1.0), center=None,
                        duration=1.0):
        """A frame [0, duration] from rest to one pose: ``translation`` mm and
        ``angle`` degrees (right-hand rule) about ``axis``, as the command
        line's --translate, --rotate and --axis. A turn beyond 90 degrees is
        tracked in pieces, so that the arc asked for is followed."""
        t = _vector("translation", translation, 3)
        a = _vector("axis", axis, 3)
        angle = float(angle)
        if not np.isfinite(angle) or abs(angle) > 3600.0:
            raise ArgumentError(f"angle {angle!r}: give at most ten turns within one frame, in degrees")
        if not np.any(a):
            raise ArgumentError("axis must not be zero; e.g. (0, 0, 1), the scanner axis")
        duration = float(duration)
        if not duration > 0 or not np.isfinite(duration):
            raise ArgumentError(f"duration {duration!r}: give a positive number of seconds")
        pieces = max(1, int(np.ceil(abs(angle) / 90.0 - 1e-12)))
        s = np.linspace(0.0, 1.0, pieces + 1)
        q = np.empty((pieces + 1, 4))
        for i, si in enumerate(s):
            qi = (ctypes.c_double * 4)()
            _lib.check(_lib.lib.pb_quaternion_from_axis_angle((ctypes.c_double * 3)(*a), si * angle, qi))
            q[i] = qi[:]
        return cls(s * duration, s[:, None] * t[None, :], q, center)

    @classmethod
    def from_file(cls, path, format=None, time_unit="s", quaternion_order="wxyz", calibration=None,
                  reference_time=None, inverse=False, center=None):
        """A tracker's log, read by the C library as the command line reads it:
        ``format`` 'csv' (t,tx,ty,tz,qw,qx,qy,qz), 'matrix-csv' (t and a 3x4
        rigid matrix; yrt-pet) or 'polaris' (NDI .mt and Toolviewer CSV); None
        tells it from the content. The options are the command line's:
        ``time_unit`` 's' or 'ms' (--time-unit), ``quaternion_order`` 'wxyz'
        or 'xyzw' (--quaternion-order), ``calibration`` a 4x4 tracker-to-scanner
        matrix or a text file of its 16 numbers (--calibration),
        ``reference_time`` s (--reference-time; a Polaris log's default is its
        first sample), ``inverse`` (--motion-inverse), ``center`` (--center; csv
        only: the other formats turn about the world's origin). The poses become
        M(t) = C P(t) P(ref)^-1 C^-1."""
        if format not in _FORMATS:
            raise ArgumentError(f"format {format!r}: choose 'csv', 'matrix-csv', 'polaris' or None (from the content)")
        if time_unit not in ("s", "ms"):
            raise ArgumentError(f"time_unit {time_unit!r}: choose 's' or 'ms'")
        if quaternion_order not in ("wxyz", "xyzw"):
            raise ArgumentError(f"quaternion_order {quaternion_order!r}: choose 'wxyz' or 'xyzw'")
        opts = _lib.TrackReadOptions(_FORMATS[format], 1000.0 if time_unit == "ms" else 1.0,
                                     int(quaternion_order == "xyzw"))
        handle = ctypes.c_void_p()
        try:
            _lib.check(_lib.lib.pb_track_read(os.fsencode(path), ctypes.byref(opts), ctypes.byref(handle)))
        except Error as e:  # the readers' words name the command line's options: these are their names here
            text = e.message
            for option, name in (("--motion-format", "format"), ("--time-unit", "time_unit"),
                                 ("--quaternion-order", "quaternion_order")):
                text = text.replace(option, name)
            raise type(e)(text, e.status) from None
        try:
            n = _lib.lib.pb_track_count(handle)
            fmt = _lib.lib.pb_track_get_format(handle)
            times = np.ctypeslib.as_array(_lib.lib.pb_track_times(handle), (n,)).copy()
            poses = (_lib.Pose * n).from_address(ctypes.addressof(_lib.lib.pb_track_poses(handle).contents))
            tr = np.array([p.translation[:] for p in poses])
            q = np.array([p.rotation[:] for p in poses])
        finally:
            _lib.lib.pb_track_free(handle)
        m = cls(times, tr, q)
        m.about_origin = fmt != 1
        if center is not None:
            if m.about_origin:
                raise ArgumentError(f"{os.fspath(path)}: a {_FORMAT_NAMES[fmt]} track's matrices turn about the "
                                    "world's origin; drop center")
            m.center = _vector("center", center, 3)
        if calibration is not None:
            if isinstance(calibration, (str, bytes, os.PathLike)):
                calibration = _read_calibration(calibration)
            c = np.array(calibration, dtype=np.float64)
            if c.shape != (4, 4) or not np.all(np.isfinite(c)):
                raise ArgumentError("calibration must be a finite 4x4 tracker-to-scanner matrix")
            _matrix_pose(c, np.zeros(3))  # rigid, or refused
            m._calibration = c
        if reference_time is not None:
            reference_time = float(reference_time)
            if not times[0] <= reference_time <= times[-1]:
                raise ArgumentError(f"reference_time {reference_time:.9g}: the track {os.fspath(path)} covers "
                                    f"{times[0]:.9g} to {times[-1]:.9g} s; give a time inside it")
            m._reference_time = reference_time
        elif fmt == 3:
            m._reference_time = float(times[0])
            m._reference_default = True
        m._inverse = bool(inverse)
        m._source = os.fspath(path)
        return m

    # ---- placement on a grid (the operators) ----

    def _world_poses(self, c):
        """The poses in the world, about c, with the conventions applied."""
        t, q = self.translations, self.quaternions
        if not (self._inverse or self._reference_time is not None or self._calibration is not None):
            return t, q
        mats = [_pose_matrix(t[i], q[i], c) for i in range(len(self))]
        if self._inverse:
            mats = [_rigid_inverse(m) for m in mats]
        ref = np.eye(4)
        if self._reference_time is not None:
            if self._reference_default and not self._warned:
                self._warned = True
                warnings.warn(f"{self._source}: no reference_time; the motion is taken relative to the first sample "
                              f"({self._reference_time:.9g} s)", stacklevel=3)
            rt, rq = _pose_matrix_track(self.times, mats, c, self._reference_time)
            ref = _rigid_inverse(_pose_matrix(rt, rq, c))
        cal = np.eye(4) if self._calibration is None else self._calibration
        cal_inv = _rigid_inverse(cal)
        out_t, out_q = np.empty_like(t), np.empty_like(q)
        for i, m in enumerate(mats):
            out_t[i], out_q[i] = _matrix_pose(cal @ (m @ ref) @ cal_inv, c)
        return out_t, out_q

    def _c_motion(self, dims, voxel_size, affine, frame):
        """The motion in the grid frame of a grid of dims and voxel_size placed
        by affine: the C struct and the arrays it points into."""
        g = _lib.Geometry((ctypes.c_size_t * 3)(*dims), (ctypes.c_double * 3)(*voxel_size))
        grid_center = affine[:3, :3] @ (0.5 * (np.array(dims, dtype=np.float64) - 1)) + affine[:3, 3]
        has_center = self.about_origin or self.center is not None
        c = np.zeros(3) if self.about_origin else (self.center if self.center is not None else grid_center)
        t, q = self._world_poses(c)
        n = len(self)
        times = (ctypes.c_double * n)(*self.times)
        world = (_lib.Pose * n)()
        for i in range(n):
            world[i] = _lib.Pose((ctypes.c_double * 3)(*t[i]), (ctypes.c_double * 4)(*q[i]))
        t0, t1 = frame
        wm = _lib.CMotion(times, world, n, t0, t1, int(has_center), (ctypes.c_double * 3)(*c))
        grid = (_lib.Pose * n)()
        out = _lib.CMotion()
        flat = (ctypes.c_double * 16)(*np.asarray(affine, dtype=np.float64).reshape(-1))
        _lib.check(_lib.lib.pb_motion_world_to_grid(ctypes.byref(g), flat, ctypes.byref(wm), grid, ctypes.byref(out)))
        if not has_center:  # the grid's centre, exactly
            out.has_center = 0
        return g, out, (times, world, grid)


def _pose_matrix_track(times, mats, c, when):
    """The pose at time `when` of a track of 4x4 maps about c (LERP and SLERP,
    by the C library)."""
    n = len(mats)
    poses = (_lib.Pose * n)()
    for i, m in enumerate(mats):
        t, q = _matrix_pose(m, c)
        poses[i] = _lib.Pose((ctypes.c_double * 3)(*t), (ctypes.c_double * 4)(*q))
    ct = (ctypes.c_double * n)(*times)
    whole = _lib.CMotion(ct, poses, n, times[0], times[-1], 0, (ctypes.c_double * 3)())
    p = _lib.Pose()
    _lib.check(_lib.lib.pb_motion_pose_at(ctypes.byref(whole), when, ctypes.byref(p)))
    return np.array(p.translation[:]), np.array(p.rotation[:])


def _read_calibration(path):
    try:
        with open(path, encoding="utf-8") as f:
            values = f.read().replace(",", " ").split()
    except OSError as e:
        raise ArgumentError(f"calibration {os.fspath(path)}: cannot open it ({e.strerror}); check the path") from None
    try:
        nums = [float(v) for v in values]
    except ValueError:
        raise ArgumentError(f"calibration {os.fspath(path)}: give the 4x4 tracker-to-scanner matrix as 16 numbers, "
                            "row by row") from None
    if len(nums) != 16:
        raise ArgumentError(f"calibration {os.fspath(path)}: {len(nums)} numbers; give the 4x4 tracker-to-scanner "
                            "matrix as 16 numbers, row by row")
    return np.array(nums).reshape(4, 4)
