"""The blur B of one frame and of many, as linear operators over numpy, CuPy
and PyTorch arrays, after parallelproj's LinearOperator: apply(x) (or
op(x)), adjoint(y), in_shape, out_shape, adjointness_test().

Each operator holds C plans (include/petblur.h): validated, planned and
uploaded once, applied many times. A CUDA array (CuPy, a PyTorch CUDA tensor)
is read and written in place on its GPU, on the caller's current stream, and
the call returns once queued, as the framework's own operations do; numpy
arrays go through the device's volumes (or, on the host backend, are read in
place).

Threads: operators are safe to use from several threads at once. Operators on
one device share its context and take turns on it (a lock held during each
call, with the GIL released inside the C library); operators on different
devices run in parallel.

Copies: copy.copy shares the C plans (freed with the last copy);
copy.deepcopy and pickle rebuild the operator from its description, on the
device its spec names where it is loaded (docs/python.md, "Copies, pickling
and Dask")."""

import copy
import ctypes
import inspect
import pickle
import threading
import weakref

import numpy as np

from . import _lib
from ._arrays import Array, pointer
from .errors import ArgumentError, Error, shown
from .fields import FieldMotion
from .motion import Motion

# Index (k, j, i) of a C-ordered array's memory, read x fastest, to (i, j, k).
_SWAP = np.array([[0, 0, 1, 0], [0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1]], dtype=np.float64)


def _shape3(shape):
    try:
        s = tuple(int(v) for v in shape)
    except (TypeError, ValueError):
        raise ArgumentError(f"shape must be three sizes (nx, ny, nz), not {shape!r}") from None
    if len(s) != 3 or min(s) < 1 or max(s) >= 1 << 40 or any(int(v) != v for v in shape):
        raise ArgumentError(f"shape must be three positive sizes (nx, ny, nz), not {shape!r}")
    return s


# Voxel sizes, mm: the library's PB_MIN_VOXEL_MM and PB_MAX_VOXEL_MM (the
# messages say 0.0001 and 10000), checked here first so that a size float32 or
# a squared norm would not survive is named as given.
VOXEL_MIN, VOXEL_MAX = 1e-4, 1e4


def _voxel3(voxel_size):
    try:
        v = np.array(voxel_size, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ArgumentError(f"voxel_size must be three positive sizes in mm (or one for cubes), not "
                            f"{shown(voxel_size)}") from None
    if v.size == 1:
        v = np.repeat(v, 3)
    if v.size != 3 or not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise ArgumentError(f"voxel_size must be three positive sizes in mm (or one for cubes), not "
                            f"{shown(voxel_size)}")
    if np.any(v < VOXEL_MIN) or np.any(v > VOXEL_MAX):
        raise ArgumentError(f"voxel_size {shown(voxel_size)}: give sizes in mm, between 0.0001 and 10000")
    return v


def _affine4(affine):
    """affine as a finite 4x4 float64 voxel-to-world matrix, or ArgumentError
    naming what was given."""
    try:
        a = np.array(affine, dtype=np.float64)
    except (TypeError, ValueError):
        a = None
    if a is None or a.shape != (4, 4) or not np.all(np.isfinite(a)):
        raise ArgumentError("affine must be a finite 4x4 voxel-to-world matrix (nibabel's img.affine), not " +
                            (shown(affine) if a is None or a.shape == (4, 4) else f"of shape {a.shape}"))
    if not np.array_equal(a[3], [0.0, 0.0, 0.0, 1.0]):
        raise ArgumentError(f"affine's last row is {a[3].tolist()}; a voxel-to-world affine's is 0 0 0 1 "
                            "(nibabel's img.affine)")
    return a


class _Handles:
    """An operator's C objects: its plans and volumes by memory order, on the
    shared context. Shallow copies of the operator hold this one object, so
    the C objects live until the last of them goes. weakref.finalize rather
    than __del__: it also runs at exit, before the modules are torn down."""

    def __init__(self, ctx):
        self.plans = {}  # order: (plan, geometry)
        self.volumes = {}  # order: [input, output]
        self._made = []  # (destroy, handle) of every C object, in the order made
        self.hearing = None  # the thread running the progress callable of a call on these objects
        weakref.finalize(self, _release, ctx, self._made)

    def made(self, destroy, handle):
        self._made.append((destroy, handle))


def _release(ctx, made):
    with ctx.use():
        for destroy, handle in reversed(made):
            destroy(handle)


class _Operator:
    def __init__(self, shape, voxel_size, motion, bounds, method, filter, max_path_error, device, affine, steps,
                 progress, ab_sampling, jacobian):
        self._shape = _shape3(shape)
        self.voxel_size = _voxel3(voxel_size)
        if not isinstance(motion, (Motion, FieldMotion)):
            raise ArgumentError(f"motion must be a petblur.Motion or petblur.FieldMotion, not "
                                f"{type(motion).__name__}")
        self.motion = motion
        method_value, filter_value = _lib.parse_name("method", method), _lib.parse_name("filter", filter)
        if max_path_error is None:
            path, bound = _lib.PATH_DEFAULT, 0.0
        elif isinstance(max_path_error, str) and max_path_error == "paper":
            path, bound = _lib.PATH_TRACKED, 0.0  # one segment per tracked interval, the paper's polyline
        else:
            try:
                path, bound = _lib.PATH_BOUNDED, float(max_path_error)
            except (TypeError, ValueError, OverflowError):
                raise ArgumentError(f"max_path_error {max_path_error!r}: give a bound in voxels, None for the "
                                    "default, or 'paper' for one segment per tracked interval") from None
        try:
            whole = int(steps)
        except (TypeError, ValueError, OverflowError):
            whole = None
        if whole is None or whole != steps:  # 2.7 is no count of steps, nor is NaN
            raise ArgumentError(f"steps {shown(steps)}: give a whole number") from None
        steps = whole
        if not 0 <= steps < 1 << 32:
            raise ArgumentError(f"steps {steps}: give 0 (the paper's choice) or a positive count")
        sampling_value = _lib.AB_SAMPLING_DEFAULT if ab_sampling is None else _lib.parse_name("ab_sampling",
                                                                                              ab_sampling)
        if progress is not None and not callable(progress):
            raise ArgumentError("progress must be a callable taking the fraction done, or None")
        self.method, self.filter = method, filter
        if not isinstance(jacobian, (bool, np.bool_)):
            raise ArgumentError(f"jacobian {shown(jacobian)}: give True (mass-preserving, for images of counts) or "
                                "False (concentrations)")
        if jacobian and not isinstance(motion, FieldMotion):
            raise ArgumentError("jacobian=True weighs a field's blur by its Jacobian determinant; a rigid motion's is 1 "
                                "everywhere: give a FieldMotion, or leave jacobian out")
        self._options = _lib.BlurOptions(method_value, filter_value, steps, 0, 0, 0, path, bound, sampling_value,
                                         int(jacobian))
        try:  # every range stated once, by the library
            _lib.check(_lib.lib.pb_options_check(ctypes.byref(self._options)))
        except ArgumentError as e:
            raise ArgumentError(e.message.replace("PB_PATH_BOUNDED", "a number"), e.status) from None
        self._progress = progress
        if affine is None:
            a = _grid_affine(self.voxel_size)
            if motion._coords == "world" and isinstance(motion, FieldMotion):
                raise ArgumentError(
                    "the fields are placed in the world (FieldMotion(affine=)) and the operator has no affine= to "
                    "place the image there; give the operator the image's voxel-to-world 4x4 (nibabel's img.affine)")
            if motion._coords == "world":
                raise _needs_affine(motion, a)
            self.affine = None
            self._affine = a
        else:
            a = _affine4(affine)
            grid = _grid_affine(self.voxel_size)
            if motion._coords == "grid" and not np.allclose(a, grid, rtol=1e-12, atol=1e-9 * self.voxel_size.max()):
                raise ArgumentError(
                    f"the motion ({motion._source}) was estimated in the grid's frame (from_frames given voxel_size=), "
                    "along the array's axes from the grid's corner, and affine= places the grid elsewhere in the "
                    "world, where its poses would turn about another point; give no affine=, or estimate the motion "
                    "with from_frames(affine=) the same affine")
            self.affine = self._affine = a
        self._bounds = np.array(bounds, dtype=np.float64)
        device = device if isinstance(device, str) else str(device)  # a torch.device, a CuPy Device's id
        # What deepcopy and pickle rebuild from, the device as named (its spec,
        # resolved again where it is loaded).
        self._common = dict(method=method, filter=filter,
                            max_path_error=bound if path == _lib.PATH_BOUNDED else max_path_error,
                            device=device, affine=self.affine, steps=steps, ab_sampling=ab_sampling,
                            jacobian=bool(jacobian))
        self._ctx = _lib.context(device)
        self._handles = _Handles(self._ctx)
        self._plan("F")  # every check now, not at the first call

    # ---- parallelproj's LinearOperator ----

    @property
    def device(self):
        """The device the operator runs on: 'host', 'opencl:N' or 'cuda:N'."""
        return self._ctx.device

    def __call__(self, x):
        return self.apply(x)

    def adjointness_test(self, rtol=1e-4, seed=None):
        """<B x, y> against <x, B^T y> for random x and y (numpy, float64
        sums): returns their relative difference, or raises AssertionError
        beyond rtol."""
        try:
            tol = float(rtol)
        except (TypeError, ValueError):
            tol = float("nan")
        if not (tol >= 0.0):  # NaN would fail every test with an AssertionError that is not about the operator
            raise ArgumentError(f"rtol {shown(rtol)}: give a relative tolerance of 0 or more, e.g. 1e-4")
        rng = np.random.default_rng(seed)
        x = rng.random(self.in_shape, dtype=np.float32)
        y = rng.random(self.out_shape, dtype=np.float32)
        bx = self.apply(x)
        bty = self.adjoint(y)
        a = float(np.dot(bx.ravel().astype(np.float64), y.ravel().astype(np.float64)))
        b = float(np.dot(x.ravel().astype(np.float64), bty.ravel().astype(np.float64)))
        rel = abs(a - b) / max(abs(a), abs(b), np.finfo(np.float64).tiny)
        if not rel <= tol:
            raise AssertionError(f"<Bx, y> = {a!r} but <x, B^T y> = {b!r}: relative difference {rel:.3g} > {tol:g}")
        return rel

    # ---- copies and pickles ----

    # Set on an operator rebuilt by deepcopy or pickle: the checks warned
    # when the original was made.
    _quiet = False

    def __copy__(self):
        """The same operator: its C plans shared, freed with the last copy."""
        new = type(self).__new__(type(self))
        new.__dict__.update(self.__dict__)
        return new

    def __deepcopy__(self, memo):
        """A new operator from a copy of the description, with C plans of its
        own. progress is shared: it reports to the caller, and a copy of, say,
        a progress bar would report to no one."""
        return _rebuild(type(self), copy.deepcopy(self._description(), memo), self._progress)

    def __reduce__(self):
        """The description, no C object nor volume: the loading process plans
        again, on the device the spec names there (for 'auto', its own)."""
        progress = self._progress
        if progress is not None:
            try:
                pickle.dumps(progress)
            except Exception as e:
                raise pickle.PicklingError(
                    f"cannot pickle this operator: its progress callable {progress!r} cannot be pickled ({e}); make "
                    "the operator with progress=None, or with a function defined at a module's top level") from None
        return _rebuild, (type(self), self._description(), progress)

    def last_device_ms(self):
        """(total, input) device milliseconds of the last call on this
        operator's device, from device events: the whole call, and of it the
        copy of the input into the texture. After a call queued on a CUDA
        stream it waits for that call."""
        return self._ctx.last_times()

    # ---- plans and calls ----

    def _plan(self, order):
        """The plan for volumes of memory order 'F' (x fastest) or 'C' (z
        fastest: the transposed grid, the motion's axes swapped with it)."""
        plans = self._handles.plans
        plan = plans.get(order)
        if plan is not None:  # every call after the first: no lock, no device guard
            return plan
        ctx = self._ctx
        with ctx.use():  # one plan per order, whichever thread (or copy) asks first
            plan = plans.get(order)
            if plan is not None:
                return plan
            f = order == "F"
            dims = self._shape if f else self._shape[::-1]
            vox = self.voxel_size if f else self.voxel_size[::-1]
            affine = self._affine if f else self._affine @ _SWAP
            handle = ctypes.c_void_p()
            if isinstance(self.motion, FieldMotion):
                if f and not self._quiet:
                    self.motion._warn_folds(self.voxel_size, self._shape, self.affine, stacklevel=5)
                cf, keep = self.motion._c_field(self._shape, self.voxel_size, self.affine, order)
                g = _lib.Geometry((ctypes.c_size_t * 3)(*dims), (ctypes.c_double * 3)(*vox))
                gates = self._c_gates()
                if gates is not None:
                    st = _lib.lib.pb_plan_create_field_gates(ctx.handle, ctypes.byref(g), ctypes.byref(cf), *gates,
                                                             ctypes.byref(self._options), ctypes.byref(handle))
                else:
                    b = (ctypes.c_double * len(self._bounds))(*self._bounds)
                    st = _lib.lib.pb_plan_create_field_frames(ctx.handle, ctypes.byref(g), ctypes.byref(cf), b,
                                                              len(self._bounds) - 1, ctypes.byref(self._options),
                                                              ctypes.byref(handle))
                _lib.check(st, ctx.handle)
                del keep
                self._handles.made(_lib.lib.pb_plan_destroy, handle)
                plans[order] = (handle, g)
                return plans[order]
            # The checks' warnings once, for the grid the caller named.
            g, cm, keep = self.motion._c_motion(dims, vox, affine, self._bounds, warn=f and not self._quiet)
            gates = self._c_gates()
            if gates is not None:
                st = _lib.lib.pb_plan_create_gates(ctx.handle, ctypes.byref(g), ctypes.byref(cm), *gates,
                                                   ctypes.byref(self._options), ctypes.byref(handle))
            elif len(self._bounds) == 2 and not isinstance(self, FramesOperator):
                st = _lib.lib.pb_plan_create(ctx.handle, ctypes.byref(g), ctypes.byref(cm),
                                             ctypes.byref(self._options), ctypes.byref(handle))
            else:
                b = (ctypes.c_double * len(self._bounds))(*self._bounds)
                st = _lib.lib.pb_plan_create_frames(ctx.handle, ctypes.byref(g), ctypes.byref(cm), b,
                                                    len(self._bounds) - 1, ctypes.byref(self._options),
                                                    ctypes.byref(handle))
            _lib.check(st, ctx.handle)
            del keep  # the C plan copied what it needs
            self._handles.made(_lib.lib.pb_plan_destroy, handle)
            plans[order] = (handle, g)
            return plans[order]

    def _c_gates(self):
        """A FramesOperator's gates as the C plans take them: the intervals
        (two numbers each, gate after gate), their counts, and how many
        gates; None for plain frames."""
        gates = getattr(self, "_gates", None)
        if gates is None:
            return None
        flat = [v for gate in gates for interval in gate for v in interval]
        counts = (ctypes.c_size_t * len(gates))(*[len(gate) for gate in gates])
        return (ctypes.c_double * len(flat))(*flat), counts, len(gates)

    def _volume_pair(self, order, g):
        """Under the context's lock: the plan's input and output volumes."""
        volumes = self._handles.volumes
        pair = volumes.get(order)
        if pair is None:
            ctx = self._ctx
            pair = []
            for _ in range(2):
                v = ctypes.c_void_p()
                _lib.check(_lib.lib.pb_volume_create(ctx.handle, ctypes.byref(g), ctypes.byref(v)), ctx.handle)
                self._handles.made(_lib.lib.pb_volume_destroy, v)
                pair.append(v)
            volumes[order] = pair
        return pair

    def _run(self, arr, jobs, adjoint):
        """jobs: (frame, input view, output view, accumulate), of one memory
        order each; runs them in order."""
        if self._handles.hearing == threading.get_ident():
            raise ArgumentError("the operator was called from its own progress callable, while its buffers hold the "
                                "call in progress; make a second operator for work inside progress")
        ctx = self._ctx
        if arr.on_gpu:
            if ctx.backend != _lib.BACKEND_CUDA:
                raise ArgumentError(f"a CUDA array needs a CUDA operator, and this one runs on {self.device}; make it "
                                    "with device='cuda' (or move the array to the host)")
            if arr.device != ctx.index:
                raise ArgumentError(f"the array is on cuda:{arr.device} and the operator on {self.device}; make the "
                                    f"operator with device='cuda:{arr.device}' or move the array")
            self._run_cuda(arr, jobs, adjoint)
        elif ctx.backend == _lib.BACKEND_HOST:
            with ctx.use(), self._reporting():
                for frame, x, y, acc, order in jobs:
                    plan = self._plan(order)[0]
                    self._call_device(plan, frame, pointer(x, "numpy"), pointer(y, "numpy"), acc, adjoint)
        else:
            self._run_volumes(jobs, adjoint)

    def _reporting(self):
        """progress(fraction) called during the block's calls (under the
        context's lock): each call's own fraction, 1 at its end. While
        progress runs, this operator's buffers are in use, and a call to it
        (or to a copy, which shares them) from there is refused rather than
        let overwrite them."""
        return _lib.progress_reported(self._ctx.handle, self._progress, self._handles)

    def _call_device(self, plan, frame, xp, yp, acc, adjoint):
        lib, ctx = _lib.lib, self._ctx
        st = (lib.pb_plan_adjoint_device(plan, frame, xp, yp, acc) if adjoint
              else lib.pb_plan_forward_device(plan, frame, xp, yp))
        _lib.check(st, ctx.handle)

    def _run_cuda(self, arr, jobs, adjoint):
        ctx = self._ctx
        if arr.kind == "torch":
            import torch
            stream = torch.cuda.current_stream(arr.device).cuda_stream
        else:
            import cupy
            with cupy.cuda.Device(arr.device):
                stream = cupy.cuda.get_current_stream().ptr
        # The frameworks report the legacy default stream as 0, which the C
        # library reads as "its own stream": cudaStreamLegacy is 0x1.
        stream = stream or 1
        plans = {order: self._plan(order)[0] for order in {j[4] for j in jobs}}
        with ctx.use():
            ctx.set_stream(stream)
            try:
                if not self._frames_in_one_call(plans, jobs, arr.kind, adjoint):
                    for frame, x, y, acc, order in jobs:
                        self._call_device(plans[order], frame, pointer(x, arr.kind), pointer(y, arr.kind), acc,
                                          adjoint)
            finally:
                ctx.set_stream(None)

    def _frames_in_one_call(self, plans, jobs, kind, adjoint):
        """A run of frames in one library call where the jobs are one: the
        forward of one activity into consecutive frames (copied into the
        texture once, not once a frame), or the adjoint of consecutive frames
        summed into one volume. False where they are not (left to the loop)."""
        if len(jobs) < 2 or len({j[4] for j in jobs}) != 1:
            return False
        frames = [j[0] for j in jobs]
        if frames != list(range(frames[0], frames[0] + len(frames))):
            return False
        lib, plan, n = _lib.lib, plans[jobs[0][4]], len(jobs)
        if not adjoint and all(j[1] is jobs[0][1] for j in jobs):
            outs = (ctypes.c_void_p * n)(*[pointer(j[2], kind) for j in jobs])
            st = lib.pb_plan_forward_frames_device(plan, frames[0], n, pointer(jobs[0][1], kind), outs)
        elif adjoint and all(j[2] is jobs[0][2] for j in jobs) and all(j[3] for j in jobs[1:]):
            ins = (ctypes.c_void_p * n)(*[pointer(j[1], kind) for j in jobs])
            st = lib.pb_plan_adjoint_frames_device(plan, frames[0], n, ins, pointer(jobs[0][2], kind), jobs[0][3])
        else:
            return False
        _lib.check(st, self._ctx.handle)
        return True

    def _run_volumes(self, jobs, adjoint):
        """numpy on a device: through the plan's volumes, uploaded and
        downloaded (an accumulated output once, at the end)."""
        lib, ctx = _lib.lib, self._ctx
        with ctx.use(), self._reporting():
            for i, (frame, x, y, acc, order) in enumerate(jobs):
                plan, g = self._plan(order)
                vin, vout = self._volume_pair(order, g)
                # One activity in every frame: uploaded once (and laid out once).
                if i == 0 or x is not jobs[i - 1][1]:
                    _lib.check(lib.pb_volume_upload(vin, pointer(x, "numpy")), ctx.handle)
                st = (lib.pb_plan_adjoint(plan, frame, vin, vout, acc) if adjoint
                      else lib.pb_plan_forward(plan, frame, vin, vout))
                _lib.check(st, ctx.handle)
                last = i + 1 == len(jobs) or jobs[i + 1][2] is not y
                if last:
                    _lib.check(lib.pb_volume_download(vout, pointer(y, "numpy")), ctx.handle)


def _grid_affine(voxel_size):
    """The grid frame's affine: mm along the array's axes, the grid's corner
    at the origin (index at voxel centres)."""
    a = np.eye(4)
    a[:3, :3] = np.diag(voxel_size)
    a[:3, 3] = 0.5 * voxel_size
    return a


def _needs_affine(motion, grid):
    """The refusal of a motion in the scanner's world given no affine: its
    poses would be taken along the array's axes about the grid's corner, a
    blur silently other than the one meant. The program never does this: it
    places such a track by the image's affine, and refuses --coords world
    where the image has none."""
    literal = "[" + ", ".join("[" + ", ".join(repr(float(v)) for v in row) + "]" for row in grid) + "]"
    return ArgumentError(
        f"the motion ({motion._source}) holds poses in the scanner's world mm, about the world's origin, and the "
        "operator has no affine= to place its grid in that world; give affine= the image's voxel-to-world 4x4 "
        "(nibabel's img.affine; for Motion.from_frames, the affine it was given), or, to take the poses along the "
        f"array's axes from the grid's corner (the program's --coords grid), affine={literal}")


def _check_shape(arr, shapes, what):
    if arr.shape not in shapes:
        want = " or ".join(str(s) for s in shapes)
        raise ArgumentError(f"the {what} has shape {arr.shape}; the operator takes {want} (axis 0 is x, as nibabel "
                            "holds volumes)")


def _one_order(vols):
    """Volumes all of one order (else all made C-contiguous)."""
    if len({o for _, o in vols}) > 1:
        vols = [(v if o == "C" else _c_copy(v), "C") for v, o in vols]
    return vols


def _c_copy(v):
    if hasattr(v, "contiguous"):
        return v.contiguous()
    if type(v).__module__.startswith("cupy"):
        import cupy
        return cupy.ascontiguousarray(v)
    return np.ascontiguousarray(v)


class BlurOperator(_Operator):
    """y = B x: the motion blur of one frame [t0, t1] of ``motion``, on a grid
    of ``shape`` (nx, ny, nz) voxels of ``voxel_size`` mm, and its exact
    transpose ``adjoint``. ``frame`` None takes the motion's whole track.
    ``method`` 'ab' (the paper's), 'rm', 'cl' or 'ref'; ``filter``
    'hardware' or 'exact'; ``max_path_error`` bounds a voxel's polyline
    against its true path, in voxels (None: the library's 0.1; 'paper': no
    bound, one segment per tracked interval, as --max-path-error paper); ``device``
    'auto', 'host', 'opencl[:N]' or 'cuda[:N]'; ``affine`` the grid's
    voxel-to-world 4x4 (the motion then in world mm). ``steps`` as the C
    library's options (0: the paper's). ``progress``: a callable given the
    fraction done of each call (REF on a CPU takes minutes), or None.
    ``ab_sampling``: how AB reads a slice its path crosses: None (the
    default, as 'slice'), 'slice' (one point, the paper's), 'sweep' (two
    points where the path sweeps sideways across the slice; docs/methods.md)
    or 'chord' (every segment read exactly, never walked: for segments of 6
    voxels and more, where the walk is up to several percent off on sharp
    objects; docs/methods.md, "Long segments").
    ``jacobian``: for a FieldMotion, True weighs each voxel's reading by the
    field's Jacobian determinant (mass-preserving: images of counts);
    False (the default) blurs concentrations, as PET images hold them.

    Making the operator checks the motion on its grid as the command line
    does: a motion that takes the grid out of view for the whole frame, or
    a gap in the track, is refused; a quaternion order slip, times in ms or
    a grid out of view at some poses raise warnings (UserWarning)."""

    def __init__(self, shape, voxel_size, motion, frame=None, method="ab", filter="hardware", max_path_error=None,
                 device="auto", affine=None, steps=0, progress=None, ab_sampling=None, jacobian=False):
        if frame is None:
            if not isinstance(motion, (Motion, FieldMotion)):
                raise ArgumentError(f"motion must be a petblur.Motion or petblur.FieldMotion, not "
                                    f"{type(motion).__name__}")
            frame = (motion.times[0], motion.times[-1])
        try:
            t0, t1 = (float(v) for v in frame)
        except (TypeError, ValueError):
            raise ArgumentError(f"frame must be (t0, t1) in seconds, not {frame!r}") from None
        super().__init__(shape, voxel_size, motion, (t0, t1), method, filter, max_path_error, device, affine, steps,
                         progress, ab_sampling, jacobian)
        self.frame = (t0, t1)

    def _description(self):
        return dict(shape=self._shape, voxel_size=self.voxel_size, motion=self.motion, frame=self.frame,
                    **self._common)

    @property
    def in_shape(self):
        return self._shape

    @property
    def out_shape(self):
        return self._shape

    def apply(self, x):
        """B x: the activity x (in_shape) blurred; the same array type, device
        and dtype back."""
        return self._direction(x, False, "object (the activity)")

    def adjoint(self, y):
        """B^T y: the transpose, for back projection."""
        return self._direction(y, True, "tomograph-space volume")

    def _direction(self, x, adjoint, what):
        arr = Array(x, what)
        _check_shape(arr, [self._shape], what)
        ((v, order),) = arr.volumes(self._shape)
        out = arr.empty(self._shape, order)
        self._run(arr, [(0, v, out, 0, order)], adjoint)
        return arr.result(out)


class FramesOperator(_Operator):
    """The blur of every frame [bounds[i], bounds[i+1]] of one ``track``: its
    forward takes one activity (shape) blurred into every frame, or a 4-D array
    of frames, each blurred by its own frame, and gives every frame's blur.
    Its adjoint takes the frames and gives the sum of their transposes in one
    volume when ``per_frame`` is False (the default: the transpose of one
    activity in every frame, a motion-compensated image from all frames), else
    each frame's transpose.

    ``bounds`` may instead be gates, one list of (start, end) intervals a
    frame (``amplitude_gates``' result), for a Motion and a FieldMotion alike:
    every visit of the breath to a bin. A gate's blur is the time-weighted
    mean of its intervals' blurs, the gaps between them skipped; its
    transpose is exact as for one interval.

    Frames are the first axis, (frames, nx, ny, nz), as torch and CuPy batch
    volumes (the batch leads); ``frames_last=True`` takes and gives
    (nx, ny, nz, frames), as nibabel holds a 4-D image, whose Fortran-ordered
    arrays are then read and written in place, frame by frame. The other
    arguments as BlurOperator's."""

    def __init__(self, shape, voxel_size, track, bounds, per_frame=False, method="ab", filter="hardware",
                 max_path_error=None, device="auto", affine=None, steps=0, progress=None, frames_last=False,
                 ab_sampling=None, jacobian=False):
        if not isinstance(track, (Motion, FieldMotion)):
            raise ArgumentError(f"track must be a petblur.Motion or petblur.FieldMotion, not {type(track).__name__}")
        gates = _gates(bounds)
        if gates is not None:
            # The span every gate lies in: the track's checks cover it.
            b = np.array([min(gate[0][0] for gate in gates), max(gate[-1][1] for gate in gates)])
        else:
            try:
                b = np.array(bounds, dtype=np.float64).reshape(-1)
            except (TypeError, ValueError):
                raise ArgumentError(f"bounds must be the frames' n + 1 times in seconds, or gates (a list of (start, "
                                    f"end) intervals per frame), not {shown(bounds)}") from None
            if b.size < 2:
                raise ArgumentError(f"bounds must hold at least two times (one frame), not {b.size}")
        self._gates = gates
        super().__init__(shape, voxel_size, track, b, method, filter, max_path_error, device, affine, steps,
                         progress, ab_sampling, jacobian)
        self.bounds = b if gates is None else gates
        self.frames = b.size - 1 if gates is None else len(gates)
        for name, flag in (("per_frame", per_frame), ("frames_last", frames_last)):
            if not isinstance(flag, (bool, np.bool_)):
                raise ArgumentError(f"{name} {shown(flag)}: give True or False")
        self.per_frame = bool(per_frame)
        self.frames_last = bool(frames_last)

    def _description(self):
        return dict(shape=self._shape, voxel_size=self.voxel_size, track=self.motion, bounds=self.bounds,
                    per_frame=self.per_frame, frames_last=self.frames_last, **self._common)

    def _frames_shape(self):
        return self._shape + (self.frames,) if self.frames_last else (self.frames,) + self._shape

    @property
    def in_shape(self):
        return self._frames_shape() if self.per_frame else self._shape

    @property
    def out_shape(self):
        return self._frames_shape()

    def _first(self, x):
        """A 4-D array's frames moved to the front (a view)."""
        return _move_axis(x, -1, 0) if self.frames_last and len(x.shape) == 4 else x

    def _last(self, y):
        return _move_axis(y, 0, -1) if self.frames_last and len(y.shape) == 4 else y

    def apply(self, x):
        """Every frame's blur of x: one activity (shape) or one per frame."""
        arr = Array(x, "activity")
        _check_shape(arr, [self._shape, self._frames_shape()], "activity")
        arr.move(self._first)
        vols = _one_order(arr.volumes(self._shape))
        order = vols[0][1]
        out = arr.empty((self.frames,) + self._shape, order)
        jobs = [(f, vols[f if len(vols) > 1 else 0][0], out[f], 0, order) for f in range(self.frames)]
        self._run(arr, jobs, False)
        return self._last(arr.result(out))

    def adjoint(self, y, sum=None):
        """The frames' transposes of y: summed into one volume (``sum`` True;
        the default unless per_frame), else one per frame."""
        if sum is None:
            sum = not self.per_frame
        if not isinstance(sum, (bool, np.bool_)):
            raise ArgumentError(f"sum {shown(sum)}: give True (the frames' transposes summed), False (one a frame) or "
                                "None (not per_frame)")
        arr = Array(y, "frames")
        _check_shape(arr, [self._frames_shape()], "frames")
        arr.move(self._first)
        vols = _one_order(arr.volumes(self._shape))
        order = vols[0][1]
        if sum:
            out = arr.empty(self._shape, order)
            jobs = [(f, vols[f][0], out, int(f > 0), order) for f in range(self.frames)]
        else:
            out = arr.empty((self.frames,) + self._shape, order)
            jobs = [(f, vols[f][0], out[f], 0, order) for f in range(self.frames)]
        self._run(arr, jobs, True)
        return self._last(arr.result(out))


def _gates(bounds):
    """Frames given as gates, a list of (start, end) intervals per frame
    (amplitude_gates' result), checked; None for plain bounds."""
    if isinstance(bounds, np.ndarray) and bounds.ndim >= 2:
        raise ArgumentError(f"bounds is a {bounds.ndim}-D array; give the frames' n + 1 times, or gates as a list "
                            "of lists of (start, end) intervals, one list a frame")
    if isinstance(bounds, np.ndarray) or not isinstance(bounds, (list, tuple)) or not bounds:
        return None
    if not all(isinstance(g, (list, tuple)) or (isinstance(g, np.ndarray) and g.ndim >= 1) for g in bounds):
        return None
    out = []
    for i, gate in enumerate(bounds):
        try:
            iv = np.array(gate, dtype=np.float64).reshape(-1, 2)
        except (TypeError, ValueError):
            raise ArgumentError(f"gate {i} is {shown(gate)}; give a list of (start, end) intervals in seconds") \
                from None
        if iv.shape[0] == 0:
            raise ArgumentError(f"gate {i} has no interval: the breath never visits it; leave it out, or widen the "
                                "bins")
        if not np.all(np.isfinite(iv)) or not np.all(iv[:, 1] > iv[:, 0]) or not np.all(iv[1:, 0] >= iv[:-1, 1]):
            raise ArgumentError(f"gate {i}'s intervals must be finite, each end after its start, in order and not "
                                "overlapping")
        out.append([tuple(map(float, r)) for r in iv])
    return out


def _rebuild(cls, description, progress):
    """An operator made again from its description (deepcopy, pickle.load),
    checked as a new one is: its fields are the constructor's arguments, and
    the constructor checks them."""
    if not (isinstance(cls, type) and issubclass(cls, _Operator) and cls is not _Operator):
        raise ArgumentError(f"the pickled operator's class is {shown(cls)}, not a petblur operator; pickle "
                            "the operator again")
    name = f"the pickled petblur.{cls.__name__}"
    try:
        if not isinstance(description, dict):
            raise ArgumentError(f"its description is a {type(description).__name__}, not the dict of arguments an "
                                "operator pickles")
        fields = [k for k in inspect.signature(cls.__init__).parameters if k not in ("self", "progress")]
        missing = [k for k in fields if k not in description]
        if missing:
            raise ArgumentError(f"its description lacks {', '.join(missing)}")
        extra = sorted(repr(k) for k in description if k not in fields)
        if extra:
            raise ArgumentError(f"its description holds {', '.join(extra)}, which {cls.__name__} does not take")
        return _quiet(cls, description, progress)
    except Error as e:
        raise type(e)(f"{name} is not one petblur made: {e.message}; pickle the operator again", e.status) from None


def _quiet(cls, arguments, progress):
    """An operator of cls made from arguments, without the checks' warnings
    (they were raised when the operator it derives from was made)."""
    op = cls.__new__(cls)
    op._quiet = True
    op.__init__(progress=progress, **arguments)
    return op


def _move_axis(x, src, dst):
    if hasattr(x, "movedim"):  # torch
        return x.movedim(src, dst)
    if type(x).__module__.startswith("cupy"):
        import cupy
        return cupy.moveaxis(x, src, dst)
    return np.moveaxis(x, src, dst)
