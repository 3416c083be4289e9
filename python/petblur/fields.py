"""Non-rigid motion: a series of displacement fields, for breathing and the
heart. A FieldMotion goes wherever a Motion goes (BlurOperator,
FramesOperator, autograd, pickling, Dask); the C library plans and walks it
(include/petblur.h, pb_field_motion).

The convention is the resampling one, as registration tools write their
fields: a field is defined on the tomograph (image) grid and points into
object space, so the voxel centred at r sits at object point r + D(t)(r) at
time t. Between samples D is linear in time; where the field grid is not the
image grid, it is interpolated trilinearly in space."""

import os
import warnings

import numpy as np

from . import _lib
from .errors import ArgumentError, shown

# Axis order of a plan on the transposed grid (C-ordered volumes).
_REVERSE = np.array([[0, 0, 1], [0, 1, 0], [1, 0, 0]], dtype=np.float64)


def _host_array(a, what):
    """A numpy view of numpy, CuPy or torch data (fields are uploaded from
    the host by the library)."""
    if hasattr(a, "detach") and hasattr(a, "cpu"):  # torch
        a = a.detach().cpu().numpy()
    elif type(a).__module__.startswith("cupy"):
        a = a.get()
    try:
        return np.asarray(a)
    except (TypeError, ValueError) as e:
        raise ArgumentError(f"{what} is not an array of numbers ({e})") from None


def _affine4(a, what):
    try:
        m = np.array(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise ArgumentError(f"{what} must be a 4x4 voxel-to-world matrix, not {shown(a)}") from None
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise ArgumentError(f"{what} must be a finite 4x4 voxel-to-world matrix (nibabel's img.affine), not one "
                            f"of shape {m.shape}")
    if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
        raise ArgumentError(f"{what}'s last row is {m[3].tolist()}; a voxel-to-world affine's is 0 0 0 1 "
                            "(nibabel's img.affine)")
    if abs(np.linalg.det(m[:3, :3])) < 1e-12 * max(1.0, np.abs(m[:3, :3]).max()) ** 3:
        raise ArgumentError(f"{what} is singular: it collapses an axis of the grid; check the file's sform/qform")
    return m


class FieldMotion:
    """Motion as displacement fields: ``displacements[k]`` at ``times[k]``
    (seconds, increasing, at least two).

    ``displacements`` is (K, nx, ny, nz, 3) mm: numpy, CuPy or torch. With
    ``affine`` None the fields lie on the operator's image grid and their
    vectors run along the array's axes (x, y, z of the grid). With
    ``affine`` (the field grid's voxel-to-world 4x4, nibabel's img.affine)
    they are vectors in that world (mm, as NIfTI's RAS+), on a grid of their
    own that the operator's ``affine=`` places against the image; the field
    is then interpolated trilinearly in space. The same field twice is a
    still deformation (one gate's warp)."""

    def __init__(self, times, displacements, affine=None):
        try:
            t = np.array(times, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise ArgumentError(f"times must be the fields' times in seconds, not {shown(times)}") from None
        d = _host_array(displacements, "displacements")
        if d.ndim != 5 or d.shape[-1] != 3:
            raise ArgumentError(f"displacements has shape {d.shape}; give (K, nx, ny, nz, 3) mm, one field per "
                                "time, the vector last")
        if d.shape[0] != t.size:
            raise ArgumentError(f"{t.size} times (or values) for {d.shape[0]} fields; give one per field")
        if t.size < 2:
            raise ArgumentError(f"{t.size} field{'' if t.size == 1 else 's'}; give at least two, at or before a "
                                "frame's start and at or after its end (the same field twice for a still "
                                "deformation)")
        if not np.issubdtype(d.dtype, np.number) or np.iscomplexobj(d):
            raise ArgumentError(f"displacements are {d.dtype}; give real numbers (mm)")
        self.times = t
        self.shape = tuple(int(n) for n in d.shape[1:4])
        self.affine = None if affine is None else _affine4(affine, "affine")
        # The library's layout for the plan along the array's axes: the
        # vector fastest, then x, y, z; the transposed plan reads the C
        # order with the vector reversed (made when first asked).
        self._fields = {"F": np.ascontiguousarray(d.astype(np.float32, copy=False).transpose(0, 3, 2, 1, 4))}
        self.values = None  # a surrogate's values of the fields (from_surrogate)
        self._signal = None
        self._coords = "world" if affine is not None else "image"
        self._source = f"a FieldMotion of {t.size} fields of {self.shape[0]} x {self.shape[1]} x {self.shape[2]}"

    @classmethod
    def from_surrogate(cls, values, fields, signal_times, signal, affine=None):
        """Fields driven by a breathing surrogate (a respiratory belt, a
        data-driven signal): ``fields[k]`` (K, nx, ny, nz, 3) mm belongs to
        surrogate value ``values[k]`` (an amplitude, increasing: e.g. the
        gates' centres from end-exhale to end-inhale), and the motion at time
        t is the field at the signal's value s(t), linear between the
        fields' values; ``signal`` sampled at ``signal_times`` (s,
        increasing), linear between samples. A signal beyond the fields'
        values is refused where a frame reaches it. ``affine`` as for
        FieldMotion."""
        try:
            st = np.array(signal_times, dtype=np.float64).reshape(-1)
            sv = np.array(signal, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise ArgumentError("signal_times and signal must be numbers: the surrogate's sample times (s) and "
                                "values") from None
        if st.size != sv.size or st.size < 2:
            raise ArgumentError(f"{st.size} signal times for {sv.size} values; give one value per time, at least "
                                "two")
        m = cls(values, fields, affine)
        m.values, m.times = m.times, st
        m._signal = sv
        m._source = (f"a FieldMotion of {m.values.size} fields at surrogate values {m.values[0]:g} to "
                     f"{m.values[-1]:g}, driven by {st.size} signal samples")
        return m

    @classmethod
    def from_files(cls, paths, times=None, convention=None):
        """Fields from displacement-field files, as registration tools write
        them (NIfTI, read with nibabel): ``paths`` one file per time, with
        ``times`` in seconds; or, with ``times`` None, the path of a CSV whose
        header is ``time,path`` (paths relative to its folder), as the
        command line takes. ``convention`` None reads it from each file's
        header (intent 1006: 'nifti'; 1007 named NREG_TRANS: 'niftyreg') and
        refuses a vector field that does not say; 'nifti' (RAS
        displacements), 'niftyreg' (alias 'sirf': intent_p1 0 deformation,
        1 displacement) or 'itk' (aliases 'ants', 'simpleitk': LPS
        displacements) overrides. The files must share one grid; the result
        holds RAS displacements with that grid's affine, for operators given
        the image's ``affine=`` (docs/python.md, "Fields from files")."""
        from . import field_files
        if isinstance(paths, (str, bytes, os.PathLike)):
            if times is not None:
                raise ArgumentError(f"paths is one file ({os.fsdecode(paths)}) and times= is given: give a list of "
                                    "field files with one time each, or a CSV 'time,path' without times=")
            if not os.fsdecode(paths).lower().endswith(".csv"):
                raise ArgumentError(f"{os.fsdecode(paths)}: one file is one field; give a list of field files and "
                                    "times= (the same file twice is a still warp), or a CSV 'time,path'")
            times, paths = field_files.read_csv(paths)
        else:
            try:
                paths = [os.fspath(p) for p in paths]
            except TypeError:
                raise ArgumentError(f"paths must be field files or a CSV's path, not {shown(paths)}") from None
            if times is None:
                raise ArgumentError("times= is needed with a list of field files: one time in seconds per file "
                                    "(or give a CSV 'time,path' as paths)")
            try:
                times = np.array(times, dtype=np.float64).reshape(-1)
            except (TypeError, ValueError):
                raise ArgumentError(f"times must be seconds, one per file, not {shown(times)}") from None
            if times.size != len(paths):
                raise ArgumentError(f"{times.size} times for {len(paths)} field files; give one time per file")
            if len(paths) < 2 or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
                raise ArgumentError(f"times {shown(times.tolist())}: give two or more finite, increasing times, one "
                                    "per file (the same file twice is a still warp)")
        fields, affine = field_files.read_fields(paths, convention)
        return cls(times, fields, affine=affine)

    def __len__(self):
        return self.times.size

    def __repr__(self):
        return (f"FieldMotion({self.times.size} fields of {self.shape[0]}x{self.shape[1]}x{self.shape[2]}, "
                f"{self.times[0]:g} to {self.times[-1]:g} s{', world mm' if self.affine is not None else ''})")

    def __getstate__(self):
        return {"times": self.times, "fields": self._fields["F"], "affine": self.affine, "values": self.values,
                "signal": self._signal}

    def __setstate__(self, state):
        f = np.asarray(state["fields"]).transpose(0, 3, 2, 1, 4)
        if state.get("signal") is not None:
            m = FieldMotion.from_surrogate(state["values"], f, state["times"], state["signal"], state["affine"])
            self.__dict__.update(m.__dict__)
        else:
            FieldMotion.__init__(self, state["times"], f, state["affine"])

    def displacements(self):
        """The fields as given: (K, nx, ny, nz, 3) float32 mm (a view)."""
        return self._fields["F"].transpose(0, 3, 2, 1, 4)

    def _layout(self, order):
        data = self._fields.get(order)
        if data is None:  # 'C': the transposed grid's x fastest is the fields' z, the vector reversed
            data = np.ascontiguousarray(self.displacements()[..., ::-1])
            self._fields[order] = data
        return data

    def _c_field(self, shape, voxel_size, affine, order):
        """The C struct of the fields for a plan on the grid of ``shape``
        (nx, ny, nz) and ``voxel_size`` (the operator's, x first) placed by
        ``affine`` (4x4, None: no world), in memory order 'F' or 'C'; and what
        must stay alive while the library reads it."""
        shape, voxel_size = tuple(shape), np.asarray(voxel_size, dtype=np.float64)
        fields = self.displacements()
        if self.affine is None:
            if self.shape != shape:
                raise ArgumentError(
                    f"the fields are {self.shape[0]} x {self.shape[1]} x {self.shape[2]} and the image "
                    f"{shape[0]} x {shape[1]} x {shape[2]}; fields without affine= lie on the image grid: resample "
                    "them, or give FieldMotion(affine=) the field grid's voxel-to-world matrix and the operator "
                    "the image's affine=")
            has_map, m = 0, np.hstack([np.eye(3), np.zeros((3, 1))])
            vectors = None
        else:
            if affine is None:
                raise ArgumentError(
                    "the fields are placed in the world (FieldMotion(affine=)) and the operator has no affine= to "
                    "place the image there; give the operator the image's voxel-to-world 4x4 (nibabel's img.affine)")
            a = np.asarray(affine, dtype=np.float64)
            cols = a[:3, :3] / np.linalg.norm(a[:3, :3], axis=0)
            if np.abs(cols.T @ cols - np.eye(3)).max() > 1e-4:
                raise ArgumentError("the image's affine= shears its axes (its columns are not perpendicular); "
                                    "world vectors cannot be turned onto such a grid: resample the image onto a "
                                    "grid without shear")
            m4 = np.linalg.solve(self.affine, a)  # field voxel index from image voxel index
            has_map, m = 1, m4[:3, :]
            # World vectors into the image grid's frame: the image's unit
            # direction columns, transposed (include/petblur.h, pb_field_motion).
            d = a[:3, :3] / np.linalg.norm(a[:3, :3], axis=0)
            vectors = d.T
        if vectors is not None:
            fields = fields @ vectors.T.astype(np.float32)  # float32: fields of a clinical grid are gigabytes
            data = np.ascontiguousarray(fields.transpose(0, 3, 2, 1, 4)) if order == "F" else \
                np.ascontiguousarray(fields[..., ::-1])
        else:
            data = self._layout(order)
        dims = self.shape
        if order == "C":  # image and field grids both transposed
            dims = dims[::-1]
            m = np.hstack([_REVERSE @ m[:, :3] @ _REVERSE, (_REVERSE @ m[:, 3])[:, None]])
            if has_map == 0:
                m = np.hstack([np.eye(3), np.zeros((3, 1))])
        c = _lib.FieldMotion()
        c.displacements = data.ctypes.data_as(_lib.ctypes.POINTER(_lib.ctypes.c_float))
        own = self.values if self._signal is not None else self.times
        c.times = own.ctypes.data_as(_lib.ctypes.POINTER(_lib.ctypes.c_double))
        c.count = own.size
        if self._signal is not None:
            c.signal_times = self.times.ctypes.data_as(_lib.ctypes.POINTER(_lib.ctypes.c_double))
            c.signal = self._signal.ctypes.data_as(_lib.ctypes.POINTER(_lib.ctypes.c_double))
            c.signal_count = self.times.size
        c.dims = (_lib.ctypes.c_size_t * 3)(*dims)
        c.has_map = has_map
        c.field_from_grid = (_lib.ctypes.c_double * 12)(*m.reshape(-1))
        c.frame_start, c.frame_end = self.times[0], self.times[-1]
        return c, (data, self.times, self.values, self._signal)

    def folds(self, voxel_size, shape=None, affine=None):
        """Where the fields fold (a Jacobian determinant of r -> r + D(r) at
        most 0): (voxels, first field, first voxel (i, j, k) or None, the
        smallest determinant). voxel_size, shape and affine are the image's
        (shape: the fields' own grid when None)."""
        shape = tuple(shape) if shape is not None else self.shape
        c, keep = self._c_field(shape, voxel_size, affine, "F")
        g = _lib.Geometry((_lib.ctypes.c_size_t * 3)(*shape), (_lib.ctypes.c_double * 3)(*voxel_size))
        out = _lib.FieldFolds()
        _lib.check(_lib.lib.pb_field_check_folds(_lib.ctypes.byref(g), _lib.ctypes.byref(c), _lib.ctypes.byref(out)))
        del keep
        voxel = None
        if out.voxels:
            n = self.shape
            v = out.voxel
            voxel = (v % n[0], v // n[0] % n[1], v // (n[0] * n[1]))
        return int(out.voxels), (int(out.field) if out.voxels else None), voxel, float(out.worst_determinant)

    def _warn_folds(self, voxel_size, shape, affine, stacklevel):
        # Once per grid: every operator over the same fields would check them all again.
        key = (tuple(float(v) for v in voxel_size), tuple(shape), None if affine is None else
               np.asarray(affine, dtype=np.float64).tobytes())
        seen = self.__dict__.setdefault("_folds_seen", set())
        if key in seen:
            return
        seen.add(key)
        n, field, voxel, worst = self.folds(voxel_size, shape, affine)
        if n:
            warnings.warn(f"the fields fold at {n} voxel(s) of the field grid, first field {field} at voxel {voxel} "
                          f"(Jacobian determinant down to {worst:.3g}): the blur there reads one place for two; "
                          "check the registration (a smoother or diffeomorphic one does not fold)", UserWarning,
                          stacklevel=stacklevel)


_EPS = float(np.finfo(np.float64).eps)


def amplitude_gates(signal_times, signal, edges, span=None):
    """Amplitude gates of a breathing surrogate, as a gated reconstruction
    bins its counts: gate g is every visit of the signal (linear between its
    samples) to [edges[g], edges[g+1]) (the last bin closed) inside ``span`` (t0, t1; default the
    signal's), as a list of (start, end) intervals in seconds. The gates
    go to FramesOperator(bounds=gates) with a FieldMotion or a rigid Motion; a gate the breath
    never visits is an empty list, which the operator refuses."""
    t = np.asarray(signal_times, dtype=np.float64).reshape(-1)
    s = np.asarray(signal, dtype=np.float64).reshape(-1)
    e = np.asarray(edges, dtype=np.float64).reshape(-1)
    if t.size != s.size or t.size < 2 or not np.all(np.isfinite(t)) or not np.all(np.isfinite(s)) \
            or not np.all(np.diff(t) > 0):
        raise ArgumentError("signal_times and signal: one finite value per time, at least two, times increasing")
    if e.size < 2 or not np.all(np.isfinite(e)) or not np.all(np.diff(e) > 0):
        raise ArgumentError(f"edges {shown(edges)}: give at least two finite, increasing amplitudes")
    t0, t1 = (t[0], t[-1]) if span is None else (float(span[0]), float(span[1]))
    if not (t[0] <= t0 < t1 <= t[-1]):
        raise ArgumentError(f"span ({t0:g}, {t1:g}) s must lie inside the signal's [{t[0]:g}, {t[-1]:g}] s")
    # The signal's pieces cut at the span's ends.
    cut = np.unique(np.clip(np.concatenate([[t0, t1], t]), t0, t1))
    val = np.interp(cut, t, s)
    gates = []
    for g, (lo, hi) in enumerate(zip(e[:-1], e[1:])):
        last = g == e.size - 2  # the top bin is closed: a plateau at the top edge is in it
        out = []
        for a, b, sa, sb in zip(cut[:-1], cut[1:], val[:-1], val[1:]):
            if sa == sb:
                p, q = (a, b) if lo <= sa < hi or (last and sa == hi) else (a, a)
            else:  # the times where s crosses lo and hi, in the piece
                ta = a + (lo - sa) / (sb - sa) * (b - a)
                tb = a + (hi - sa) / (sb - sa) * (b - a)
                p, q = max(a, min(ta, tb)), min(b, max(ta, tb))
            if q > p:
                # joined where the two meet at a sample, up to the crossing's rounding (gates.c says why)
                if out and abs(out[-1][1] - p) <= 8 * _EPS * (abs(p) + (b - a)):
                    out[-1] = (out[-1][0], q)
                else:
                    out.append((p, q))
        gates.append(out)
    return gates
