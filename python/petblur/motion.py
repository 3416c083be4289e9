"""Motions: time-stamped rigid poses (seconds, mm, unit quaternions w,x,y,z),
made from arrays, from a tracker's log (every format the command line reads)
or from one pose. A pose maps object space to tomograph space,
p' = R(q) (p - c) + c + t, about the centre c.

Everything a motion means lives in the C library's motion layer
(include/petblur.h): the readers, the tracker conventions (calibration,
reference time, inversion), the placement in a grid's world, a frame's part
of a track, and the checks and warnings on a track and its frames. This file
holds the arrays and passes them through, so that a track means the same to
Python as to the command line.

Coordinates: without an affine the operators take a motion along the array's
axes, in mm from the grid's corner (the command line's --coords grid); with
affine= (voxel to world, 4x4, as nibabel's img.affine) in the scanner's world
mm, where tracker logs live (--coords world)."""

import ctypes
import errno
import numbers
import os
import secrets
import warnings

import numpy as np

from . import _lib
from .errors import ArgumentError, Error, shown


# The library's messages name the command line's options; these are their
# names here.
_WORDS = (("--quaternion-order xyzw", "quaternion_order='xyzw'"), ("--quaternion-order wxyz", "quaternion_order='wxyz'"),
          ("--time-unit ms", "time_unit='ms'"), ("--motion-format", "format"), ("--time-unit", "time_unit"),
          ("--quaternion-order", "quaternion_order"), ("--reference-time", "reference_time"),
          ("--motion-inverse", "inverse"), ("--calibration", "calibration"), ("--center", "center"),
          ("(see --coords)", "(see affine=)"), ("--frames", "bounds"))


def python_words(text):
    """A library message in this API's words."""
    for option, name in _WORDS:
        text = text.replace(option, name)
    return text


def _check(status, ctx=None):
    try:
        _lib.check(status, ctx)
    except Error as e:
        raise type(e)(python_words(e.message), e.status) from None


def _warn(w, stacklevel):
    for line in w.text.decode("utf-8", "replace").splitlines():
        warnings.warn(python_words(line), stacklevel=stacklevel + 1)


def _frames_warn(bounds):
    """Frame bounds where a public call is given them: the library's rules on
    bounds alone and its warning (a frame over 6 h: milliseconds), raised at
    that call's caller rather than when an operator is first made."""
    b = (ctypes.c_double * len(bounds))(*bounds)
    w = _lib.Warnings()
    _check(_lib.lib.pb_frames_check(b, len(bounds) - 1, ctypes.byref(w)))
    _warn(w, 3)


def _vector(name, value, n):
    try:
        v = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ArgumentError(f"{name} must be {n} numbers, not {value!r}") from None
    if v.size != n:
        raise ArgumentError(f"{name} must be {n} numbers, not {v.size}")
    if not np.all(np.isfinite(v)):
        raise ArgumentError(f"{name} holds NaN or infinity: {value.tolist() if hasattr(value, 'tolist') else value}")
    return v


def _finite(value):
    """value as a finite float, or None (not a number, NaN, infinite)."""
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        return None
    return v if np.isfinite(v) else None


def _numbers(name, value):
    try:
        return np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ArgumentError(f"{name} must be numbers, not {shown(value)}") from None


def _pose(translation, quaternion):
    return _lib.Pose((ctypes.c_double * 3)(*translation), (ctypes.c_double * 4)(*quaternion))


def _grid(dims, voxel_size):
    return _lib.Geometry((ctypes.c_size_t * 3)(*dims), (ctypes.c_double * 3)(*voxel_size))


class _Track:
    """The C track of a Motion, alive while the C motions made from it are
    (they point into its times)."""

    def __init__(self, motion):
        n = len(motion)
        times = (ctypes.c_double * n)(*motion.times)
        poses = (_lib.Pose * n)(*[_pose(t, q) for t, q in zip(motion.translations, motion.quaternions)])
        lines = None if motion._lines is None else (ctypes.c_size_t * n)(*motion._lines)
        missing = None if motion._missing is None else (ctypes.c_size_t * n)(*motion._missing)
        self.handle = ctypes.c_void_p()
        _check(_lib.lib.pb_track_create(motion._source.encode(), motion._format, times, poses, lines, missing, n,
                                        ctypes.byref(self.handle)))

    def __del__(self):
        if getattr(self, "handle", None):
            _lib.lib.pb_track_free(self.handle)


class Motion:
    """A pose track: ``times`` (N,) seconds, strictly increasing, N >= 2;
    ``translations`` (N, 3) mm; ``quaternions`` (N, 4) unit w,x,y,z; ``center``
    (3,) mm, the rotation centre (None: the grid's centre). Between samples the
    translation is interpolated linearly and the rotation spherically."""

    def __init__(self, times, translations, quaternions, center=None):
        self.times = _numbers("times", times).reshape(-1)
        self.translations = _numbers("translations", translations)
        self.quaternions = _numbers("quaternions", quaternions)
        n = self.times.size
        if self.translations.shape != (n, 3):
            raise ArgumentError(f"translations must have shape ({n}, 3), one row per time, not "
                                f"{self.translations.shape}")
        if self.quaternions.shape != (n, 4):
            raise ArgumentError(f"quaternions must have shape ({n}, 4), w,x,y,z per time, not "
                                f"{self.quaternions.shape}")
        for name, rows in (("translations", self.translations), ("quaternions", self.quaternions)):
            bad = np.flatnonzero(~np.isfinite(rows).all(axis=1))
            if bad.size:  # the library says "sample i holds NaN", not which array
                raise ArgumentError(f"{name}[{bad[0]}] is {rows[bad[0]].tolist()}, NaN or infinity; give finite "
                                    f"{'mm' if name == 'translations' else 'unit quaternions'}")
        self.center = None if center is None else _vector("center", center, 3)
        # What a file gives beyond the arrays: its format (csv poses turn about
        # a centre, tracker matrices about the world's origin), each sample's
        # line and the samples missing before it; and the conventions.
        self._format = _lib.TRACK_CSV
        self._lines = self._missing = None
        self._source = "the motion"
        self._calibration = None
        self._reference_time = None
        self._inverse = False
        # The coordinates the poses are in where they are known: "world" (a
        # tracker's log, an estimate placed by an affine: the operators need
        # affine=), "grid" (an estimate given voxel_size=), None (arrays,
        # csv: either, as the operator's affine= says).
        self._coords = None
        _Track(self)  # the library's checks (finite, increasing, unit quaternions), now

    def __len__(self):
        return self.times.size

    def __repr__(self):
        return f"petblur.Motion({len(self)} poses, {self.times[0]:g} to {self.times[-1]:g} s)"

    @property
    def about_origin(self):
        """True for tracker matrices (matrix-csv, Polaris): poses about the
        world's origin, which carry their own centre."""
        return self._format != _lib.TRACK_CSV

    @classmethod
    def from_axis_angle(cls, translation=(0.0, 0.0, 0.0), angle=0.0, axis=(0.0, 0.0, 1.0), center=None,
                        duration=1.0):
        """A frame [0, duration] from rest to one pose: ``translation`` mm and
        ``angle`` degrees (right-hand rule) about ``axis``, as the command
        line's --translate, --rotate and --axis. A turn beyond 90 degrees is
        tracked in pieces, so that the arc asked for is followed."""
        t = _vector("translation", translation, 3)
        a = _vector("axis", axis, 3)
        given = angle
        angle = _finite(angle)
        if angle is None or abs(angle) > 3600.0:
            raise ArgumentError(f"angle {shown(given)}: give at most ten turns within one frame, in degrees")
        if not np.any(a):
            raise ArgumentError("axis must not be zero; e.g. (0, 0, 1), the scanner axis")
        given = duration
        duration = _finite(duration)
        if duration is None or not duration > 0:
            raise ArgumentError(f"duration {shown(given)}: give a positive number of seconds")
        pieces = max(1, int(np.ceil(abs(angle) / 90.0 - 1e-12)))
        s = np.linspace(0.0, 1.0, pieces + 1)
        q = np.empty((pieces + 1, 4))
        for i, si in enumerate(s):
            qi = (ctypes.c_double * 4)()
            _check(_lib.lib.pb_quaternion_from_axis_angle((ctypes.c_double * 3)(*a), si * angle, qi))
            q[i] = qi[:]
        return cls(s * duration, s[:, None] * t[None, :], q, center)

    @classmethod
    def from_file(cls, path, format=None, time_unit="s", quaternion_order="wxyz", calibration=None,
                  reference_time=None, inverse=False, center=None, coords=None):
        """A tracker's log, read by the C library as the command line reads it:
        ``format`` 'csv' (t,tx,ty,tz,qw,qx,qy,qz), 'matrix-csv' (t and a 3x4
        rigid matrix; yrt-pet) or 'polaris' (NDI .mt and Toolviewer CSV); None
        tells it from the content. The options are the command line's:
        ``time_unit`` 's' or 'ms' (--time-unit), ``quaternion_order`` 'wxyz'
        or 'xyzw' (--quaternion-order), ``calibration`` a 4x4 tracker-to-scanner
        matrix or a text file of its 16 numbers (--calibration),
        ``reference_time`` s (--reference-time; a Polaris log's default is its
        first sample), ``inverse`` (--motion-inverse), ``center`` (--center; csv
        only: the other formats turn about the world's origin), ``coords``
        (--coords: 'world', the default for tracker matrices, or 'grid' for
        matrices in the grid frame, as an estimate given voxel_size= saves
        them). The poses become M(t) = C P(t) P(ref)^-1 C^-1."""
        format_value = _lib.TRACK_AUTO if format is None else _lib.parse_name("track_format", format)
        if time_unit not in ("s", "ms"):
            raise ArgumentError(f"time_unit {time_unit!r}: choose 's' or 'ms'")
        if quaternion_order not in ("wxyz", "xyzw"):
            raise ArgumentError(f"quaternion_order {quaternion_order!r}: choose 'wxyz' or 'xyzw'")
        opts = _lib.TrackReadOptions(format_value, 1000.0 if time_unit == "ms" else 1.0,
                                     int(quaternion_order == "xyzw"))
        handle = ctypes.c_void_p()
        _check(_lib.lib.pb_track_read(os.fsencode(path), ctypes.byref(opts), ctypes.byref(handle)))
        fmt, times, tr, q, lines, missing = track_arrays(handle)
        m = cls(times, tr, q)
        m._format, m._lines, m._missing, m._source = fmt, lines, missing, os.fsdecode(path)
        if coords not in _COORDS:
            raise ArgumentError(f"coords {coords!r}: choose 'world' or 'grid' (or None: as the format says)")
        if fmt != _lib.TRACK_CSV:  # tracker matrices: the scanner's world, unless told
            m._coords = coords or "world"
        elif coords is not None:
            m._coords = coords
        if center is not None:
            m.center = _vector("center", center, 3)
        if calibration is not None:
            if isinstance(calibration, (str, bytes, os.PathLike)):
                cal = (ctypes.c_double * 16)()
                _check(_lib.lib.pb_calibration_read(os.fsencode(calibration), cal))
                calibration = np.array(cal[:]).reshape(4, 4)
            c = np.array(calibration, dtype=np.float64)
            if c.shape != (4, 4):
                raise ArgumentError("calibration must be a 4x4 tracker-to-scanner matrix, or the path of its file")
            m._calibration = c
        if reference_time is not None:
            m._reference_time = _finite(reference_time)
            if m._reference_time is None:
                raise ArgumentError(f"reference_time {shown(reference_time)}: give finite seconds")
        m._inverse = bool(inverse)
        m._world(_grid((1, 1, 1), (1.0, 1.0, 1.0)), None, warn=False)  # the conventions' refusals, now
        return m

    @classmethod
    def from_frames(cls, frames, affine=None, starts=None, durations=None, reference="auto", device="auto",
                    bounds=None, frame_poses_only=False, levels=0, iterations=0, fwhm=0.0, voxel_size=None,
                    progress=None):
        """The head's rigid motion estimated from a dynamic series itself, as
        `petblur motion estimate` does (the C library's pb_motion_estimate):
        ``frames`` [x, y, z, t] (numpy, CuPy, torch or Dask, computed; read on the host),
        placed in the world by ``affine`` (voxel to world, nibabel's
        img.affine), or, without one, given ``voxel_size`` (mm) in the grid
        frame the operators take without an affine; frame k spanning ``starts[k]`` for
        ``durations[k]`` seconds (BIDS-PET's FrameTimesStart and
        FrameDuration; or ``bounds``, the n + 1 boundaries, as
        frames_from_sidecar gives them). The motion moves the object seen in
        frame ``reference`` (its pose is the identity; the motion's
        ``reference_frame``): by default ('auto') the frame held still whose
        pose the series determines best, so that the first seconds' frame of
        few counts, whose pose is off by its noise, does not move every
        other frame's; a frame holding a jerk
        gets the poses on both sides of it unless ``frame_poses_only``.
        ``levels``, ``iterations`` and ``fwhm`` (mm) are the command line's
        --levels, --iterations and --fwhm (0: the defaults). ``progress``,
        as the operators take it: a callable given the fraction done (0 to 1,
        1 at the end) as the estimate goes. The poses are rigid maps about
        the world's origin, as a matrix-csv track's: give the operators the
        same affine. The motion's ``frame_report`` says, a dict a frame
        (``frame``, ``start``, ``end``), how far to trust each: ``explained``,
        the share of the frame's variance its registration explains (a frame
        of few counts, or of a contrast unlike the others', less);
        ``structure`` False where the frame shows none above its noise and
        took a neighbour's pose; ``motion_inside`` (from, to) in seconds where
        the track moves inside the frame, else None; ``jumped_at_start`` True
        where the head jumped at the frame's start (the track steps there
        from the frame before's pose to this frame's); ``unfollowed`` above 0
        where the frame shows motion inside it that the track does not
        follow (the share of its one pose's residual a path inside it
        explains): its pose is a mean over that motion, to be trusted less."""
        from . import estimate
        if bounds is None:
            if starts is None or durations is None:
                raise ArgumentError("give the frames' times: starts= and durations= (BIDS-PET's FrameTimesStart and "
                                    "FrameDuration), or bounds=")
            s = _vector("starts", starts, np.size(starts))
            d = _vector("durations", durations, np.size(durations))
            if s.size != d.size:
                raise ArgumentError(f"starts has {s.size} frames and durations {d.size}; give one of each per frame")
            out = (ctypes.c_double * (s.size + 1))()
            _check(_lib.lib.pb_frames_from_starts((ctypes.c_double * s.size)(*s), (ctypes.c_double * d.size)(*d),
                                                  s.size, out))
            bounds = np.array(out[:])
        elif starts is not None or durations is not None:
            raise ArgumentError("give starts= and durations=, or bounds=, not both")
        else:
            bounds = _numbers("bounds", bounds).reshape(-1)
            if bounds.size < 2:
                raise ArgumentError(f"bounds must hold at least two times (one frame), not {bounds.size}")
        _frames_warn(bounds)
        try:
            handle, report, frames_report = estimate.estimate(frames, affine, voxel_size, bounds, reference,
                                                              device, frame_poses_only, levels, iterations, fwhm,
                                                              progress)
        except Error as e:
            raise type(e)(python_words(e.message), e.status) from None
        _warn(report.warnings, 2)
        fmt, times, tr, q, _, _ = track_arrays(handle)
        m = cls(times, tr, q)
        m._format, m._source = fmt, "the motion estimated from the frames"
        m._coords = "grid" if affine is None else "world"
        m.estimate_seconds, m.moving_frames = report.seconds, int(report.moving_frames)
        m.reference_frame = int(report.reference)
        m.frame_report = frames_report
        return m

    # ---- the library's motion layer ----

    def _conventions(self):
        c = _lib.TrackConventions()
        c.inverse = int(self._inverse)
        if self._reference_time is not None:
            c.has_reference_time, c.reference_time = 1, self._reference_time
        if self._calibration is not None:
            c.has_calibration = 1
            c.calibration[:] = [float(v) for v in self._calibration.reshape(-1)]
        if self.center is not None:
            c.has_center = 1
            c.center[:] = [float(v) for v in self.center]
        return c

    def _world(self, geometry, affine, warn=True, stacklevel=3):
        """The poses in the world with the conventions applied: (C motion,
        what it points into)."""
        track = _Track(self)
        n = len(self)
        poses = (_lib.Pose * n)()
        world, w = _lib.CMotion(), _lib.Warnings()
        flat = None if affine is None else (ctypes.c_double * 16)(*np.asarray(affine, dtype=np.float64).reshape(-1))
        _check(_lib.lib.pb_track_world(track.handle, ctypes.byref(self._conventions()),
                                       None if geometry is None else ctypes.byref(geometry), flat, poses,
                                       ctypes.byref(world), ctypes.byref(w)))
        if warn:
            _warn(w, stacklevel)
        return world, (track, poses)

    def _c_motion(self, dims, voxel_size, affine, bounds, warn=True, refuse=True):
        """The motion in the grid frame of a grid of dims and voxel_size placed
        by affine, with frames `bounds` checked as the command line checks
        them: the C struct, the geometry, and what they point into. With
        refuse False, a motion that takes the grid out of view for a whole
        frame is a warning, as in the program's summary (`petblur motion`),
        where a blur refuses it."""
        g = _grid(dims, voxel_size)
        track = _Track(self)
        n = len(self)
        grid, w = (_lib.Pose * n)(), _lib.Warnings()
        out = _lib.CMotion()
        flat = (ctypes.c_double * 16)(*np.asarray(affine, dtype=np.float64).reshape(-1))
        _check(_lib.lib.pb_track_place(track.handle, ctypes.byref(self._conventions()), ctypes.byref(g), flat, grid,
                                       ctypes.byref(out), ctypes.byref(w)))
        out.frame_start, out.frame_end = float(bounds[0]), float(bounds[-1])
        b = (ctypes.c_double * len(bounds))(*bounds)
        st = _lib.lib.pb_track_check_frames(track.handle, ctypes.byref(out), ctypes.byref(g), b, len(bounds) - 1,
                                            ctypes.byref(w))
        if st == _lib.ERR_OUT_OF_VIEW and not refuse:
            warnings.warn(python_words(_lib.message()), stacklevel=3)
        else:
            _check(st)
        if warn:
            _warn(w, 4)
        return g, out, (track, grid)

    def pose_at(self, t):
        """The pose at time t: (translation (3,), quaternion (4,) w,x,y,z),
        interpolated as the blur does, the conventions applied, about the
        motion's centre (the grid's, for a csv track without center: then
        tracker conventions need a center to be given)."""
        world, keep = self._world(None, None, warn=False)
        p = _lib.Pose()
        _check(_lib.lib.pb_motion_pose_at(ctypes.byref(world), float(t), ctypes.byref(p)))
        return np.array(p.translation[:]), np.array(p.rotation[:])

    def summary(self, bounds, shape, voxel_size, affine=None):
        """What the motion holds, as `petblur motion` reports it, for the grid
        of shape and voxel_size (mm) placed by affine (None: the grid's own
        frame) and the frames `bounds` (s, frames + 1): a dict of the track's
        samples, first and last time, median step (s), missing samples, gaps
        and the longest gap (s), and under "frames" one dict a frame: start,
        end, the tracked samples inside, the largest turn from the frame's
        first pose (max_turn_deg), the largest displacement of the grid's
        corners (max_corner_mm), the tracker's noise a blur measures there and
        does not follow as motion (noise_mm: the RMS of the corners' 3-D
        scatter; 0 where every sample is followed) and the segments the
        default path walks (segments); both None where that path cannot
        walk the frame (more segments than a blur takes). A motion that
        takes the grid out of view for a whole frame, which a blur refuses,
        is a warning here, as in the program's summary."""
        from .operator import _affine4, _grid_affine, _shape3, _voxel3
        shape, vox = _shape3(shape), _voxel3(voxel_size)
        a = _grid_affine(vox) if affine is None else _affine4(affine)
        b = _numbers("bounds", bounds)
        if b.ndim != 1 or b.size < 2:
            raise ArgumentError(f"bounds must list a frame's start and end at least, not {b.size} number(s)")
        g, placed, keep = self._c_motion(shape, vox, a, b, warn=False, refuse=False)
        t = _lib.TrackSummary()
        _check(_lib.lib.pb_track_summarize(keep[0].handle, ctypes.byref(t)))
        out = {name: getattr(t, name) for name, _ in _lib.TrackSummary._fields_}
        out["frames"] = []
        for t0, t1 in zip(b[:-1], b[1:]):
            f = _lib.FrameSummary()
            _check(_lib.lib.pb_motion_frame_summary(ctypes.byref(placed), ctypes.byref(g), float(t0), float(t1),
                                                    ctypes.byref(f)))
            frame = _lib.CMotion.from_buffer_copy(placed)
            frame.frame_start, frame.frame_end = float(t0), float(t1)
            noise, segments = ctypes.c_double(), ctypes.c_size_t()
            # None where the default path cannot walk the frame (more segments than a blur takes), as the
            # program's '-': a summary shows what a blur would refuse
            planned = _lib.lib.pb_path_noise(ctypes.byref(g), ctypes.byref(frame), None, ctypes.byref(noise),
                                             ctypes.byref(segments)) == 0
            out["frames"].append({"start": float(t0), "end": float(t1), "samples": f.samples,
                                  "max_turn_deg": f.max_turn_deg, "max_corner_mm": f.max_corner_mm,
                                  "noise_mm": noise.value if planned else None,
                                  "segments": segments.value if planned else None})
        return out

    def save(self, path, format=None):
        """Writes the motion as a track file that from_file and the program's
        --motion read back to the same motion: 'matrix-csv' (t and the 3x4
        map about the world's origin) for a motion about the origin (tracker
        matrices, estimates), 'csv' (t,tx,ty,tz,qw,qx,qy,qz about the
        motion's centre) for the others; ``format``, where given, must be
        that one: poses about another centre would agree at the samples but
        not between them (the blur interpolates about the motion's centre).
        The conventions (calibration, reference_time, inverse) are applied:
        the file holds the poses they give and reads back without them. A csv
        file holds no centre: read it back with the motion's center= (None:
        the grid's, as before); a motion in the grid frame reads back with
        coords='grid'. Written whole or not at all (a temporary beside the
        file, renamed over it), never over the file the motion was read
        from."""
        own = "matrix-csv" if self.about_origin else "csv"
        if format not in (None, "csv", "matrix-csv"):
            raise ArgumentError(f"format {format!r}: choose 'csv' or 'matrix-csv'")
        if format is not None and format != own:
            about, other = ("the world's origin", "a centre") if self.about_origin else ("a centre", "the origin")
            raise ArgumentError(f"this motion turns about {about}: saved as {format} it would turn about {other}, the "
                                f"same at the samples but not between them; save it as format='{own}' (the default)")
        world, keep = self._world(None, None, warn=False)
        rows, m = [], (ctypes.c_double * 16)()
        for i in range(len(self)):
            p = world.poses[i]
            if own == "matrix-csv":
                _check(_lib.lib.pb_pose_to_matrix(ctypes.byref(p), m))
                rows.append([world.times[i], *m[:12]])
            else:
                rows.append([world.times[i], *p.translation, *p.rotation])
        header = ("t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz" if own == "matrix-csv" else
                  "t,tx,ty,tz,qw,qx,qy,qz")
        path = os.fspath(path)
        source = self._source if self._lines is not None else None  # _lines: read from a file
        if source and os.path.exists(path) and os.path.exists(source) and os.path.samefile(path, source):
            raise ArgumentError(f"{path} is the file this motion was read from: save it under another name")
        folder = os.path.dirname(os.path.abspath(path))
        # named here: the temporary below would otherwise be the file an OSError names
        if os.path.isdir(path):
            raise IsADirectoryError(errno.EISDIR, "a folder: give the track file's name", path)
        if not os.path.isdir(folder):
            raise FileNotFoundError(errno.ENOENT, f"its folder {folder} does not exist; make it, or save elsewhere",
                                    path)
        # a fresh name beside the file, made with the modes a new file gets (mkstemp's are 0600)
        temp = os.path.join(folder, f".petblur-{os.getpid()}-{secrets.token_hex(6)}.csv")
        fd = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        try:
            with os.fdopen(fd, "w") as f:
                f.write(header + "\n")
                for r in rows:
                    f.write(",".join(repr(float(v)) for v in r) + "\n")
            os.replace(temp, path)
        except BaseException:
            os.unlink(temp)
            raise

    def mean_pose(self, t0, t1):
        """The time-weighted mean pose over the frame [t0, t1], as pose_at
        gives poses: the mean translation, and the normalised mean of the
        rotation's quaternions. What a model of one pose per frame takes."""
        frame = _numbers("the frame (t0, t1)", (t0, t1))
        _frames_warn(frame)
        world, keep = self._world(None, None, warn=False)
        world.frame_start, world.frame_end = frame
        p = _lib.Pose()
        _check(_lib.lib.pb_motion_mean_pose(ctypes.byref(world), ctypes.byref(p)))
        return np.array(p.translation[:]), np.array(p.rotation[:])

    # ---- copies, pickles ----

    # A motion is its arrays and conventions, all plain Python and numpy:
    # deepcopy and pickle copy them; a C track is made again from them per use.
    def __getstate__(self):
        return dict(self.__dict__)

    def __setstate__(self, state):
        """A loaded motion checked as a new one is: the constructor's checks
        on its arrays, then each field a file or an estimate adds, then the
        library's track and conventions, as from_file checks them."""
        try:
            self._load(state)
        except Error as e:
            raise type(e)(f"the pickled petblur.Motion is not one petblur made: {e.message}; pickle the Motion "
                          "again from its source", e.status) from None

    def _load(self, state):
        if not isinstance(state, dict):
            raise ArgumentError(f"its state is a {type(state).__name__}, not the dict of fields a Motion pickles")
        if "_coords" not in state:  # a Motion pickled before it recorded its coordinates: unknown, as arrays are
            state = dict(state, _coords=None)
        missing = [k for k in _STATE if k not in state]
        if missing:
            raise ArgumentError(f"its state lacks {', '.join(missing)}")
        extra = sorted(repr(k) for k in state if k not in _STATE and k not in _REPORT)
        if extra:
            raise ArgumentError(f"its state holds {', '.join(extra)}, which no Motion has")
        self.__init__(state["times"], state["translations"], state["quaternions"], state["center"])
        n = len(self)
        fmt = state["_format"]
        if not _whole(fmt) or fmt not in (_lib.TRACK_CSV, _lib.TRACK_MATRIX_CSV, _lib.TRACK_POLARIS):
            raise ArgumentError(f"_format is {shown(fmt)}; a track's format is {_lib.TRACK_CSV} (csv), "
                                f"{_lib.TRACK_MATRIX_CSV} (matrix-csv) or {_lib.TRACK_POLARIS} (polaris)")
        self._format = int(fmt)
        for name in ("_lines", "_missing"):
            v = state[name]
            if v is not None:
                a = np.asarray(v) if isinstance(v, (list, tuple, np.ndarray)) else None
                if a is None or a.dtype.kind not in "iu" or a.shape != (n,) or np.any(a < 0):
                    raise ArgumentError(f"{name} is {shown(v)}; give None or {n} whole numbers, one per "
                                        "sample, at least 0")
                v = a.astype(np.uint64)
            setattr(self, name, v)
        if not isinstance(state["_source"], str):
            raise ArgumentError(f"_source is {shown(state['_source'])}; give the track's name as text")
        self._source = state["_source"]
        cal = state["_calibration"]
        if cal is not None:
            c = _numbers("_calibration", cal)
            if c.shape != (4, 4) or not np.all(np.isfinite(c)):
                raise ArgumentError(f"_calibration is {shown(cal)}; give None or a finite 4x4 matrix")
            cal = c
        self._calibration = cal
        ref = state["_reference_time"]
        if ref is not None and (not isinstance(ref, numbers.Real) or isinstance(ref, bool) or
                                not np.isfinite(ref)):
            raise ArgumentError(f"_reference_time is {shown(ref)}; give None or finite seconds")
        self._reference_time = None if ref is None else float(ref)
        if not isinstance(state["_inverse"], (bool, np.bool_)):
            raise ArgumentError(f"_inverse is {shown(state['_inverse'])}; give True or False")
        self._inverse = bool(state["_inverse"])
        if not (state["_coords"] is None or isinstance(state["_coords"], str) and state["_coords"] in _COORDS):
            raise ArgumentError(f"_coords is {shown(state['_coords'])}; give None, 'world' or 'grid'")
        self._coords = state["_coords"]
        for name in _REPORT:
            if name == "frame_report" and name in state:
                self.frame_report = _frame_report(state[name])
                continue
            if name in state:
                v = state[name]
                good = (_whole(v) if name in _WHOLE else isinstance(v, numbers.Real) and
                        not isinstance(v, bool) and np.isfinite(v))
                if not good or v < 0:
                    raise ArgumentError(f"{name} is {shown(v)}; give a finite number, at least 0")
                setattr(self, name, int(v) if name in _WHOLE else float(v))
        _Track(self)
        self._world(_grid((1, 1, 1), (1.0, 1.0, 1.0)), None, warn=False)  # the conventions' refusals


# The state a Motion pickles: the constructor's arguments, what a file or an
# estimate adds to them (format, lines, missing samples, name, conventions,
# coordinates), and an estimate's report.
_STATE = ("times", "translations", "quaternions", "center", "_format", "_lines", "_missing", "_source",
          "_calibration", "_reference_time", "_inverse", "_coords")
_REPORT = ("estimate_seconds", "moving_frames", "reference_frame", "frame_report")
_WHOLE = ("moving_frames", "reference_frame")


def _frame_report(v):
    """A pickled estimate's frame_report, checked: a list of one dict a frame,
    as Motion.from_frames makes it."""
    def real(x):
        return isinstance(x, numbers.Real) and not isinstance(x, bool) and np.isfinite(x)
    if not isinstance(v, list):
        raise ArgumentError(f"frame_report is {shown(v)}; give a list of one dict a frame")
    out = []
    for k, f in enumerate(v):
        inside = f.get("motion_inside", 0) if isinstance(f, dict) else 0
        for name, before in (("jumped_at_start", False), ("unfollowed", 0.0)):
            if isinstance(f, dict) and name not in f:  # pickled before the report had it
                f = dict(f, **{name: before})
        if not (isinstance(f, dict) and set(f) == {"frame", "start", "end", "explained", "structure",
                                                   "motion_inside", "jumped_at_start", "unfollowed"} and
                isinstance(f["jumped_at_start"], bool) and real(f["unfollowed"]) and
                0.0 <= f["unfollowed"] <= 1.0 and _whole(f["frame"]) and f["frame"] == k and
                real(f["start"]) and real(f["end"]) and f["start"] < f["end"] and real(f["explained"]) and
                0.0 <= f["explained"] <= 1.0 and isinstance(f["structure"], bool) and
                (inside is None or isinstance(inside, tuple) and len(inside) == 2 and all(map(real, inside)) and
                 f["start"] <= inside[0] <= inside[1] <= f["end"])):
            raise ArgumentError(f"frame_report[{k}] is {shown(f)}; give the dict Motion.from_frames makes")
        out.append(dict(f))
    return out
_COORDS = (None, "world", "grid")


def _whole(v):
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool)


def track_arrays(handle):
    """A C track's format, times, translations, quaternions, lines and missing
    counts, copied out; the track is freed."""
    lib = _lib.lib
    try:
        n = lib.pb_track_count(handle)
        times = np.ctypeslib.as_array(lib.pb_track_times(handle), (n,)).copy()
        poses = (_lib.Pose * n).from_address(ctypes.addressof(lib.pb_track_poses(handle).contents))
        return (lib.pb_track_get_format(handle), times, np.array([p.translation[:] for p in poses]),
                np.array([p.rotation[:] for p in poses]),
                np.ctypeslib.as_array(lib.pb_track_lines(handle), (n,)).copy(),
                np.ctypeslib.as_array(lib.pb_track_missing(handle), (n,)).copy())
    finally:
        lib.pb_track_free(handle)


def frames_from_sidecar(path):
    """Frame bounds (n + 1 times, s) from a BIDS-PET sidecar's top-level
    FrameTimesStart and FrameDuration: the library's reader, the one the
    command line's --frames-from uses (strict JSON read as Python's json reads
    it, the frames' rules: positive durations, each frame starting where the
    one before ends)."""
    name = os.fsencode(path)
    frames = ctypes.c_size_t()
    _check(_lib.lib.pb_frames_read_sidecar(name, None, 0, ctypes.byref(frames)))
    bounds = (ctypes.c_double * (frames.value + 1))()
    _check(_lib.lib.pb_frames_read_sidecar(name, bounds, frames.value + 1, ctypes.byref(frames)))
    bounds = np.array(bounds[:])
    _frames_warn(bounds)
    return bounds
