"""The C library through ctypes: its structs, its functions' signatures, and
the translation of a failed status into petblur.Error.

ctypes rather than a compiled extension: the wheel then builds with the C
compiler alone (no Python headers, no second build system), one shared library
serves C and Python (the same bits, so equal results), and a call costs a few
microseconds against kernels of a tenth of a millisecond and more
(docs/python.md, "Speed"). ctypes releases the GIL during every
call, so operators on several GPUs run from several threads at once."""

import contextlib
import ctypes
import os
import sys
import threading
import warnings

from .errors import LibraryError, error_class

_here = os.path.dirname(os.path.abspath(__file__))
# PETBLUR_LIBRARY: a build tree's library (development, the GPU machine).
_chosen = os.environ.get("PETBLUR_LIBRARY")
_path = _chosen or os.path.join(_here, "libpetblur.so")
_FIX = ("point PETBLUR_LIBRARY at libpetblur.so in a petblur build folder (build/src/libpetblur.so), or unset it "
        "to load the package's own library" if _chosen else
        "reinstall the package from one source tree with 'pip install .' at the repository root")


def _named():
    return f"{_path} (PETBLUR_LIBRARY)" if _chosen else _path


def _load():
    try:
        return ctypes.CDLL(_path)
    except OSError as e:
        raise LibraryError(f"petblur: cannot load its C library {_named()} ({e}); {_FIX}") from None


def bind(signatures):
    """Gives each of the library's functions {name: (restype, argtypes)} its
    signature. A library without one of them is not petblur's, or is of
    another version: refused by name here, at import, rather than as ctypes'
    AttributeError at the first call."""
    missing = [name for name in signatures if not hasattr(lib, name)]
    if missing:
        more = f" and {len(missing) - 1} other of its calls" if len(missing) > 1 else ""
        what = ("is not petblur's C library" if len(missing) == len(signatures) else
                "is a petblur library of another version")
        raise LibraryError(f"petblur: {_named()} {what}: it has no {missing[0]}{more}; {_FIX}")
    for name, (res, args) in signatures.items():
        f = getattr(lib, name)
        f.restype, f.argtypes = res, args


def _nvrtc_from_wheel():
    """NVRTC from the nvidia-cuda-nvrtc wheel (``pip install 'petblur[cuda]'``)
    for the library's run-time compile of the CUDA kernels, where none is
    named (PETBLUR_NVRTC_LIBRARY) and the library would otherwise search the
    loader's path and a toolkit's folder. The wheel's own folder first (CUDA
    13's, then 12's), found without loading anything; else NVIDIA's
    cuda-pathfinder, which looks further (conda, CUDA_HOME) but finds a
    library only by loading it, so it comes second. Asked before a CUDA
    context is first made (the library opens NVRTC there, where nvcc's
    kernels do not serve the GPU), not at import."""
    global _nvrtc_sought
    if _nvrtc_sought or os.environ.get("PETBLUR_NVRTC_LIBRARY"):
        return
    _nvrtc_sought = True
    import glob
    for site in sys.path:
        for pattern in ("nvidia/cu13/lib/libnvrtc.so.13", "nvidia/cuda_nvrtc/lib/libnvrtc.so.12"):
            found = glob.glob(os.path.join(site or ".", pattern))
            if found:
                os.environ["PETBLUR_NVRTC_LIBRARY"] = os.path.abspath(found[0])
                return
    try:
        from cuda.pathfinder import load_nvidia_dynamic_lib
        os.environ["PETBLUR_NVRTC_LIBRARY"] = load_nvidia_dynamic_lib("nvrtc").abs_path
    except Exception:  # not installed, or no NVRTC: the library searches itself
        pass


_nvrtc_sought = False
lib = _load()

c_size3 = ctypes.c_size_t * 3
c_double3 = ctypes.c_double * 3


class Geometry(ctypes.Structure):
    _fields_ = [("dims", c_size3), ("voxel_size", c_double3)]


class Pose(ctypes.Structure):
    _fields_ = [("translation", c_double3), ("rotation", ctypes.c_double * 4)]


class CMotion(ctypes.Structure):
    _fields_ = [("times", ctypes.POINTER(ctypes.c_double)), ("poses", ctypes.POINTER(Pose)),
                ("count", ctypes.c_size_t), ("frame_start", ctypes.c_double), ("frame_end", ctypes.c_double),
                ("has_center", ctypes.c_int), ("center", c_double3)]


class BlurOptions(ctypes.Structure):
    _fields_ = [("method", ctypes.c_int), ("filter", ctypes.c_int), ("steps", ctypes.c_uint),
                ("ref_points", ctypes.c_uint), ("ref_time_steps", ctypes.c_uint), ("seed", ctypes.c_uint32),
                ("path", ctypes.c_int), ("max_path_error", ctypes.c_double), ("ab_sampling", ctypes.c_int),
                ("jacobian", ctypes.c_int)]


class ContextOptions(ctypes.Structure):
    _fields_ = [("backend", ctypes.c_int), ("device_index", ctypes.c_int), ("build_options", ctypes.c_char_p)]


class DeviceInfo(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char * 256), ("platform", ctypes.c_char * 256), ("is_gpu", ctypes.c_int),
                ("image_support", ctypes.c_int), ("image3d_max", c_size3), ("max_alloc_bytes", ctypes.c_uint64),
                ("global_mem_bytes", ctypes.c_uint64), ("compute_units", ctypes.c_uint)]


class Native(ctypes.Structure):
    _fields_ = [("context", ctypes.c_void_p), ("queue", ctypes.c_void_p), ("device", ctypes.c_void_p),
                ("device_index", ctypes.c_int)]


class TrackReadOptions(ctypes.Structure):
    _fields_ = [("format", ctypes.c_int), ("time_divisor", ctypes.c_double), ("xyzw", ctypes.c_int)]


class TrackConventions(ctypes.Structure):
    _fields_ = [("inverse", ctypes.c_int), ("has_reference_time", ctypes.c_int), ("reference_time", ctypes.c_double),
                ("has_calibration", ctypes.c_int), ("calibration", ctypes.c_double * 16),
                ("has_center", ctypes.c_int), ("center", c_double3)]


class Warnings(ctypes.Structure):
    _fields_ = [("flags", ctypes.c_uint), ("text", ctypes.c_char * 4096)]


class FieldMotion(ctypes.Structure):
    _fields_ = [("times", ctypes.POINTER(ctypes.c_double)), ("displacements", ctypes.POINTER(ctypes.c_float)),
                ("count", ctypes.c_size_t), ("dims", c_size3), ("has_map", ctypes.c_int),
                ("field_from_grid", ctypes.c_double * 12), ("frame_start", ctypes.c_double),
                ("frame_end", ctypes.c_double), ("signal_times", ctypes.POINTER(ctypes.c_double)),
                ("signal", ctypes.POINTER(ctypes.c_double)), ("signal_count", ctypes.c_size_t)]


class FieldFolds(ctypes.Structure):
    _fields_ = [("voxels", ctypes.c_size_t), ("field", ctypes.c_long), ("voxel", ctypes.c_long),
                ("worst_determinant", ctypes.c_double)]


class FrameSummary(ctypes.Structure):
    _fields_ = [("samples", ctypes.c_size_t), ("max_turn_deg", ctypes.c_double), ("max_corner_mm", ctypes.c_double)]


class TrackSummary(ctypes.Structure):
    _fields_ = [("samples", ctypes.c_size_t), ("first", ctypes.c_double), ("last", ctypes.c_double),
                ("median_step", ctypes.c_double), ("missing", ctypes.c_size_t), ("gaps", ctypes.c_size_t),
                ("longest_gap", ctypes.c_double)]


ProgressFn = ctypes.CFUNCTYPE(None, ctypes.c_double, ctypes.c_void_p)


@contextlib.contextmanager
def progress_reported(handle, progress, hearing=None):
    """progress(fraction) called by the library during the block's calls on
    context handle (nothing where progress is None). Yields a list that holds
    the exception progress raised, if it did: ctypes would only print it, so
    it is kept (later reports are then not passed on) and raised when the
    block ends, after the caller has freed what a call made. hearing, where
    given, is an object whose .hearing is this thread's id while progress
    runs (the operators refuse calls from inside it)."""
    raised = []
    if progress is None:
        yield raised
        return

    def hear(fraction, user):
        if raised:
            return
        if hearing is not None:
            hearing.hearing = threading.get_ident()
        try:
            progress(float(fraction))
        except BaseException as e:  # noqa: B036 - re-raised below, whatever it is
            raised.append(e)
        finally:
            if hearing is not None:
                hearing.hearing = None
    fn = ProgressFn(hear)
    check(lib.pb_context_set_progress(handle, fn, None), handle)
    try:
        yield raised
    finally:
        lib.pb_context_set_progress(handle, ProgressFn(), None)
    if raised:
        raise raised[0]

# The structs above, as the library lays them out (checked at import by
# check_layout against pb_abi_layout) and the enums' values it reports.
STRUCTS = {"pb_geometry": Geometry, "pb_pose": Pose, "pb_motion": CMotion, "pb_blur_options": BlurOptions,
           "pb_context_options": ContextOptions, "pb_device_info": DeviceInfo, "pb_native": Native,
           "pb_track_read_options": TrackReadOptions, "pb_track_conventions": TrackConventions,
           "pb_warnings": Warnings, "pb_frame_summary": FrameSummary, "pb_track_summary": TrackSummary,
           "pb_field_motion": FieldMotion, "pb_field_folds": FieldFolds}


BACKEND_AUTO, BACKEND_HOST, BACKEND_OPENCL, BACKEND_CUDA = 0, 1, 2, 3
TRACK_AUTO, TRACK_CSV, TRACK_MATRIX_CSV, TRACK_POLARIS = 0, 1, 2, 3
PATH_DEFAULT, PATH_BOUNDED, PATH_TRACKED = 0, 1, 2
AB_SAMPLING_DEFAULT, AB_SAMPLING_SLICE, AB_SAMPLING_SWEEP, AB_SAMPLING_CHORD = 0, 1, 2, 3
ERR_OUT_OF_VIEW = -12
ENUMS = {"PB_BACKEND_AUTO": BACKEND_AUTO, "PB_BACKEND_HOST": BACKEND_HOST, "PB_BACKEND_OPENCL": BACKEND_OPENCL,
         "PB_BACKEND_CUDA": BACKEND_CUDA, "PB_TRACK_AUTO": TRACK_AUTO, "PB_TRACK_CSV": TRACK_CSV,
         "PB_TRACK_MATRIX_CSV": TRACK_MATRIX_CSV, "PB_TRACK_POLARIS": TRACK_POLARIS, "PB_METHOD_AB": 0,
         "PB_METHOD_RM": 1, "PB_METHOD_CL": 2, "PB_METHOD_REF": 3, "PB_FILTER_HARDWARE": 0, "PB_FILTER_EXACT": 1,
         "PB_PATH_DEFAULT": PATH_DEFAULT, "PB_PATH_BOUNDED": PATH_BOUNDED, "PB_PATH_TRACKED": PATH_TRACKED,
         "PB_AB_SAMPLING_DEFAULT": AB_SAMPLING_DEFAULT, "PB_AB_SAMPLING_SLICE": AB_SAMPLING_SLICE,
         "PB_AB_SAMPLING_SWEEP": AB_SAMPLING_SWEEP, "PB_AB_SAMPLING_CHORD": AB_SAMPLING_CHORD,
         "PB_ERR_OUT_OF_VIEW": ERR_OUT_OF_VIEW}
BACKEND_NAMES = {BACKEND_HOST: "host", BACKEND_OPENCL: "opencl", BACKEND_CUDA: "cuda"}

_vp, _sz, _int, _dbl = ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int, ctypes.c_double
_P = ctypes.POINTER
_signatures = {
    "pb_status_string": (ctypes.c_char_p, [_int]),
    "pb_last_error": (ctypes.c_char_p, [_vp]),
    "pb_context_notes": (ctypes.c_char_p, [_vp]),
    "pb_device_parse": (_int, [ctypes.c_char_p, _P(_int), _P(_int)]),
    "pb_device_auto_estimate": (_int, [_P(_int), _P(_int)]),
    "pb_backend_compiled": (_int, [_int]),
    "pb_device_count": (_int, [_int, _P(_int)]),
    "pb_device_get_info": (_int, [_int, _int, _P(DeviceInfo)]),
    "pb_context_create": (_int, [_P(ContextOptions), _P(_vp)]),
    "pb_context_destroy": (None, [_vp]),
    "pb_context_backend": (_int, [_vp]),
    "pb_context_device_info": (_int, [_vp, _P(DeviceInfo)]),
    "pb_context_native": (_int, [_vp, _P(Native)]),
    "pb_context_set_stream": (_int, [_vp, _vp]),
    "pb_context_last_kernel_ms": (_int, [_vp, _P(_dbl)]),
    "pb_context_last_input_ms": (_int, [_vp, _P(_dbl)]),
    "pb_volume_create": (_int, [_vp, _P(Geometry), _P(_vp)]),
    "pb_volume_destroy": (None, [_vp]),
    "pb_volume_upload": (_int, [_vp, _vp]),
    "pb_volume_download": (_int, [_vp, _vp]),
    "pb_motion_world_to_grid": (_int, [_P(Geometry), _P(_dbl), _P(CMotion), _P(Pose), _P(CMotion)]),
    "pb_motion_pose_at": (_int, [_P(CMotion), _dbl, _P(Pose)]),
    "pb_quaternion_from_axis_angle": (_int, [_P(_dbl), _dbl, _P(_dbl)]),
    "pb_pose_from_matrix": (_int, [_P(_dbl), _P(Pose)]),
    "pb_pose_to_matrix": (_int, [_P(Pose), _P(_dbl)]),
    "pb_path_segments": (_int, [_P(Geometry), _P(CMotion), _P(BlurOptions), _P(_sz)]),
    "pb_path_noise": (_int, [_P(Geometry), _P(CMotion), _P(BlurOptions), _P(_dbl), _P(_sz)]),
    "pb_plan_create": (_int, [_vp, _P(Geometry), _P(CMotion), _P(BlurOptions), _P(_vp)]),
    "pb_plan_create_frames": (_int, [_vp, _P(Geometry), _P(CMotion), _P(_dbl), _sz, _P(BlurOptions), _P(_vp)]),
    "pb_plan_create_gates": (_int, [_vp, _P(Geometry), _P(CMotion), _P(_dbl), _P(_sz), _sz, _P(BlurOptions),
                                    _P(_vp)]),
    "pb_plan_create_field_frames": (_int, [_vp, _P(Geometry), _P(FieldMotion), _P(_dbl), _sz, _P(BlurOptions),
                                           _P(_vp)]),
    "pb_plan_create_field_gates": (_int, [_vp, _P(Geometry), _P(FieldMotion), _P(_dbl), _P(_sz), _sz,
                                          _P(BlurOptions), _P(_vp)]),
    "pb_field_check_folds": (_int, [_P(Geometry), _P(FieldMotion), _P(FieldFolds)]),
    "pb_plan_destroy": (None, [_vp]),
    "pb_plan_forward": (_int, [_vp, _sz, _vp, _vp]),
    "pb_plan_adjoint": (_int, [_vp, _sz, _vp, _vp, _int]),
    "pb_plan_forward_device": (_int, [_vp, _sz, _vp, _vp]),
    "pb_plan_adjoint_device": (_int, [_vp, _sz, _vp, _vp, _int]),
    "pb_plan_forward_frames_device": (_int, [_vp, _sz, _sz, _vp, _P(_vp)]),
    "pb_plan_adjoint_frames_device": (_int, [_vp, _sz, _sz, _P(_vp), _vp, _int]),
    "pb_track_read": (_int, [ctypes.c_char_p, _P(TrackReadOptions), _P(_vp)]),
    "pb_track_free": (None, [_vp]),
    "pb_track_count": (_sz, [_vp]),
    "pb_track_get_format": (_int, [_vp]),
    "pb_track_times": (_P(_dbl), [_vp]),
    "pb_track_poses": (_P(Pose), [_vp]),
    "pb_track_lines": (_P(_sz), [_vp]),
    "pb_track_missing": (_P(_sz), [_vp]),
    "pb_track_create": (_int, [ctypes.c_char_p, _int, _P(_dbl), _P(Pose), _P(_sz), _P(_sz), _sz, _P(_vp)]),
    "pb_calibration_read": (_int, [ctypes.c_char_p, _P(_dbl)]),
    "pb_track_world": (_int, [_vp, _P(TrackConventions), _P(Geometry), _P(_dbl), _P(Pose), _P(CMotion),
                              _P(Warnings)]),
    "pb_track_place": (_int, [_vp, _P(TrackConventions), _P(Geometry), _P(_dbl), _P(Pose), _P(CMotion),
                              _P(Warnings)]),
    "pb_track_check_frames": (_int, [_vp, _P(CMotion), _P(Geometry), _P(_dbl), _sz, _P(Warnings)]),
    "pb_frames_check": (_int, [_P(_dbl), _sz, _P(Warnings)]),
    "pb_frames_from_starts": (_int, [_P(_dbl), _P(_dbl), _sz, _P(_dbl)]),
    "pb_frames_read_sidecar": (_int, [ctypes.c_char_p, _P(_dbl), _sz, _P(_sz)]),
    "pb_motion_mean_pose": (_int, [_P(CMotion), _P(Pose)]),
    "pb_options_check": (_int, [_P(BlurOptions)]),
    "pb_blur_pose_derivative": (_int, [_vp, _vp, _P(CMotion), _P(BlurOptions), _P(_vp)]),
    "pb_context_set_progress": (_int, [_vp, ProgressFn, _vp]),
    "pb_abi_layout": (ctypes.c_char_p, []),
    "pb_method_parse": (_int, [ctypes.c_char_p, _P(_int)]),
    "pb_filter_parse": (_int, [ctypes.c_char_p, _P(_int)]),
    "pb_ab_sampling_parse": (_int, [ctypes.c_char_p, _P(_int)]),
    "pb_track_format_parse": (_int, [ctypes.c_char_p, _P(_int)]),
    "pb_motion_frame_summary": (_int, [_P(CMotion), _P(Geometry), _dbl, _dbl, _P(FrameSummary)]),
    "pb_track_summarize": (_int, [_vp, _P(TrackSummary)]),
    "pb_pose_perturb": (_int, [_P(Pose), _P(_dbl), _P(Pose)]),
    "pb_pose_gradient_images": (_int, [_P(Geometry), _vp, _P(_dbl), _P(_vp)]),
}
bind(_signatures)


class FileStatus(int):
    """The status of a call that reads a file: check() raises a rule on values
    that the file breaks (a zero quaternion, times out of order) as
    FileContentError, a FileError, since the file is what to fix
    (errors.error_class)."""


def _file_status(status, func, args):
    return FileStatus(status)


# The readers: tracks, calibrations, BIDS sidecars.
for _name in ("pb_track_read", "pb_calibration_read", "pb_frames_read_sidecar"):
    getattr(lib, _name).errcheck = _file_status


def check_layout(structs=None, enums=None):
    """Raises ImportError where a ctypes struct above differs from the
    library's (size, a field's offset or size) or an enum value from its:
    a header changed without this file. structs: {name: ctypes class}
    (default STRUCTS), enums: {name: value} (default ENUMS)."""
    structs = STRUCTS if structs is None else structs
    enums = ENUMS if enums is None else enums
    seen, problems = set(), []
    for line in lib.pb_abi_layout().decode().splitlines():
        kind, name, *v = line.split()
        if kind == "struct" and name in structs:
            seen.add(name)
            if ctypes.sizeof(structs[name]) != int(v[0]):
                problems.append(f"{name} is {ctypes.sizeof(structs[name])} bytes here, {v[0]} in the library")
        elif kind == "field" and name.split(".")[0] in structs:
            cls, field = structs[name.split(".")[0]], name.split(".")[1]
            desc = getattr(cls, field, None)
            if desc is None or (desc.offset, desc.size) != (int(v[0]), int(v[1])):
                have = "missing" if desc is None else f"at {desc.offset}, {desc.size} bytes"
                problems.append(f"{name} is {have} here, at {v[0]}, {v[1]} bytes in the library")
        elif kind == "enum" and name in enums:
            seen.add(name)
            if enums[name] != int(v[0]):
                problems.append(f"{name} is {enums[name]} here, {v[0]} in the library")
    problems += [f"{n} is not described by the library" for n in list(structs) + list(enums) if n not in seen]
    if problems:
        raise LibraryError(f"petblur: the Python binding does not match its C library {_named()}: " +
                           "; ".join(problems) + f"; {_FIX}")


def message(ctx=None):
    return (lib.pb_last_error(ctx) or b"").decode("utf-8", "replace")


def check(status, ctx=None):
    """Raises the error of a failed call; the message is ctx's last error (or
    the calling thread's, for calls without a context)."""
    if status != 0:
        text = message(ctx) or lib.pb_status_string(status).decode()
        raise error_class(status, isinstance(status, FileStatus))(text, int(status))


check_layout()


def parse_name(kind, value):
    """The enum value of an option's name (kind: method, filter, ab_sampling,
    track_format), by the library's parser, which names every choice when it
    refuses one."""
    out = _int()
    parse = getattr(lib, f"pb_{kind}_parse")
    named = isinstance(value, str) and "\0" not in value
    if named and parse(value.encode("utf-8", "replace"), ctypes.byref(out)) == 0:
        return out.value
    if not named:
        parse(None, ctypes.byref(out))  # refused: the library's list of choices
    from .errors import ArgumentError
    raise ArgumentError(f"{kind.replace('track_', '')} {value!r}:{message().split(':', 1)[-1]}")

# Contexts shared by every operator on one device, each used by one thread at a
# time (the C library's rule: a context, its volumes and plans share its queue
# and timers). Operators on different devices run in parallel.
_contexts = {}
_contexts_lock = threading.Lock()


class Context:
    def __init__(self, backend, index):
        opts = ContextOptions(backend, index, None)
        handle = ctypes.c_void_p()
        check(lib.pb_context_create(ctypes.byref(opts), ctypes.byref(handle)))
        self.handle = handle
        self.backend = lib.pb_context_backend(handle)
        info = DeviceInfo()
        check(lib.pb_context_device_info(handle, ctypes.byref(info)), handle)
        self.name = info.name.decode("utf-8", "replace")
        notes = lib.pb_context_notes(handle).decode("utf-8", "replace")
        if notes:  # the library never prints: what works but could be better
            warnings.warn(f"petblur: {notes}", UserWarning, stacklevel=3)
        native = Native()
        check(lib.pb_context_native(handle, ctypes.byref(native)), handle)
        self.index = native.device_index if self.backend == BACKEND_CUDA else index
        # Reentrant: a plan made lazily inside a call, and a finaliser that
        # destroys one while the same thread holds the lock.
        self.lock = threading.RLock()

    @contextlib.contextmanager
    def use(self):
        """The context to this thread (its lock), and, on CUDA, the thread's
        current device given back afterwards: the library selects the
        context's device in every call, which would otherwise move PyTorch's
        and CuPy's current device under them."""
        with self.lock:
            if self.backend != BACKEND_CUDA:
                yield self
                return
            with _device_guard():
                yield self

    def set_stream(self, stream):
        """Under use(): queue on stream (a cudaStream_t as int), or with None
        on the context's own stream again; set back to None after every call,
        so that the context never holds a stream its caller may destroy."""
        check(lib.pb_context_set_stream(self.handle, stream), self.handle)

    def last_times(self):
        """(device ms, of it the input's copy ms) of the context's last call;
        after a call queued on a caller's stream, once it is done."""
        ms, inp = ctypes.c_double(), ctypes.c_double()
        with self.use():
            check(lib.pb_context_last_kernel_ms(self.handle, ctypes.byref(ms)), self.handle)
            check(lib.pb_context_last_input_ms(self.handle, ctypes.byref(inp)), self.handle)
        return ms.value, inp.value

    @property
    def device(self):
        name = BACKEND_NAMES[self.backend]
        return name if self.backend == BACKEND_HOST else f"{name}:{self.index}"


def _current_cuda_device():
    """What 'cuda' without an index names: the process's current GPU as
    PyTorch or CuPy set it (torch.cuda.set_device(LOCAL_RANK) under torchrun,
    cupy.cuda.Device(i).use()), else the first. Neither is imported for it,
    and PyTorch is not asked where it has not started CUDA (asking would)."""
    torch = sys.modules.get("torch")
    if torch is not None and torch.cuda.is_initialized():
        return int(torch.cuda.current_device())
    cupy = sys.modules.get("cupy")
    if cupy is not None:
        try:
            return int(cupy.cuda.runtime.getDevice())
        except Exception:  # no GPU or driver: the library says so itself
            return 0
    return 0


def _device_guard():
    """Gives the thread's current CUDA device back after the block, through
    the framework that cares about it (PyTorch's runtime and CuPy's read the
    driver's current context, which the library's cudaSetDevice moves)."""
    torch = sys.modules.get("torch")
    if torch is not None and torch.cuda.is_initialized():
        return torch.cuda.device(torch.cuda.current_device())
    cupy = sys.modules.get("cupy")
    if cupy is not None:
        return cupy.cuda.Device()
    return contextlib.nullcontext()


def context(device):
    """The shared context of a device spec: 'auto', 'host', 'opencl[:N]',
    'cuda[:N]' (the command line's --device)."""
    if not isinstance(device, str):
        device = str(device)  # a torch.device or a CuPy Device's id
    backend, index = ctypes.c_int(), ctypes.c_int()
    check(lib.pb_device_parse(device.encode(), ctypes.byref(backend), ctypes.byref(index)))
    if device == "cuda":
        index.value = _current_cuda_device()
    key = (backend.value, index.value)
    with _contexts_lock:
        ctx = _contexts.get(key)
        if ctx is None:
            if key[0] in (BACKEND_AUTO, BACKEND_CUDA):
                _nvrtc_from_wheel()
            # 'auto' and the device it picks share one context.
            with _device_guard():
                new = Context(*key)
            ctx = _contexts.setdefault((new.backend, new.index), new)
            if ctx is not new:
                lib.pb_context_destroy(new.handle)
            _contexts[key] = ctx
        return ctx


def backends():
    """Each backend of this build and whether it can run here: a list of
    (name, devices found, reason), the reason '' where it can run, else why
    not (not compiled in, its runtime library missing, no device) and how to
    fix it, as `petblur devices` prints it."""
    out = []
    for backend in (BACKEND_HOST, BACKEND_OPENCL, BACKEND_CUDA):
        name = BACKEND_NAMES[backend]
        if not lib.pb_backend_compiled(backend):
            out.append((name, 0, f"the {name} backend is not compiled into this build of petblur"))
            continue
        n = ctypes.c_int(0)
        if lib.pb_device_count(backend, ctypes.byref(n)) != 0:
            out.append((name, 0, message()))
        else:
            out.append((name, n.value, "" if n.value else f"no {name} device found"))
    return out


def devices():
    """Every device petblur can run on: a list of (spec, name)."""
    out = []
    for backend in (BACKEND_CUDA, BACKEND_OPENCL, BACKEND_HOST):
        if not lib.pb_backend_compiled(backend):
            continue
        n = ctypes.c_int(0)
        if lib.pb_device_count(backend, ctypes.byref(n)) != 0:
            continue
        for i in range(n.value):
            info = DeviceInfo()
            if lib.pb_device_get_info(backend, i, ctypes.byref(info)) == 0:
                spec = "host" if backend == BACKEND_HOST else f"{BACKEND_NAMES[backend]}:{i}"
                out.append((spec, info.name.decode("utf-8", "replace")))
    return out
