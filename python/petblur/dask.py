"""A FramesOperator's frames across Dask workers, one or more frames per task.

    import petblur, petblur.dask
    F = petblur.FramesOperator(shape, voxel_size, track, bounds, device="host")
    Y = petblur.dask.forward(F, x, frames_per_task=2, device="cuda")  # a dask array (frames, nx, ny, nz)
    s = petblur.dask.adjoint(F, Y, frames_per_task=2, device="cuda")  # a dask array (nx, ny, nz): the sum
    s.compute()                                                       # or client.compute(s)

Each task carries a pickle of the operator for its own frames: the track's
samples, the frames' bounds and the options, never a volume. A worker plans
that operator on its own device the first time (``device``, else the
operator's own: ``"cuda"`` is the worker's GPU, which dask-cuda's
LocalCUDACluster shows each worker one) and keeps the plan for later tasks,
the iterations of a reconstruction, in a cache of ``cache_size`` operators
per process (each holds its plans and device volumes). The adjoint's sum
over frames is a sum of each task's partial sum, which Dask reduces as a
tree. Frames are the first axis here; an operator made with
``frames_last=True`` is refused (a dask array's ``transpose`` is free).

Why a helper and not a recipe: the pieces every user would otherwise write,
and get wrong in ways that do not show on one machine, are the operator per
frame range, the per-process plan cache (without it every task plans again),
and which frames a chunk holds."""

import collections
import pickle
import threading

import numpy as np

from .errors import ArgumentError
from .operator import FramesOperator, _rebuild

__all__ = ["forward", "adjoint", "cache_size"]

# Operators a worker process keeps planned: enough for every frame range a
# worker meets in a reconstruction of a few dozen frames, forward and adjoint
# alike when both use one frames_per_task. Set it in the workers
# (client.run) to trade device memory for planning.
cache_size = 32
_cache = collections.OrderedDict()
_cache_lock = threading.Lock()
_plans = 0  # operators this process has planned (the tests read it)


def _operator(blob):
    """The operator a task's pickle describes, planned once per process."""
    with _cache_lock:
        op = _cache.get(blob)
        if op is not None:
            _cache.move_to_end(blob)
            return op
    global _plans
    cls, description = pickle.loads(blob)
    op = _rebuild(cls, description, None)
    with _cache_lock:
        _plans += 1
        op = _cache.setdefault(blob, op)
        while len(_cache) > max(int(cache_size), 1):
            _cache.popitem(last=False)
    return op


def _forward_task(blob, x):
    return _operator(blob).apply(x)


def _adjoint_task(blob, y, total):
    return _operator(blob).adjoint(y, sum=total)


def _parts(op, frames_per_task, device):
    """(first frame, end frame, pickle) for each task: op's frames in runs of
    frames_per_task, each run an operator of its own over its bounds, planned
    on device (None: op's own)."""
    if not isinstance(op, FramesOperator):
        raise ArgumentError(f"petblur.dask takes a petblur.FramesOperator, not {type(op).__name__}")
    if op.frames_last:
        raise ArgumentError("this operator takes frames last (frames_last=True); petblur.dask takes frames first: "
                            "make the operator with frames_last=False and give x.transpose(3, 0, 1, 2)")
    if device is not None and not isinstance(device, str):
        raise ArgumentError(f"device {device!r}: give a device spec such as 'cuda', 'opencl:0' or 'host'")
    if isinstance(frames_per_task, bool) or not isinstance(frames_per_task, (int, np.integer)) or frames_per_task < 1:
        raise ArgumentError(f"frames_per_task {frames_per_task!r}: give a whole number of frames, at least 1")
    d = dict(op._description())
    if device is not None:
        d["device"] = device
    out = []
    for start in range(0, op.frames, int(frames_per_task)):
        stop = min(start + int(frames_per_task), op.frames)
        # Bounds: n + 1 times; gates: one list of intervals a frame.
        d["bounds"] = op.bounds[start:stop] if op._gates is not None else op.bounds[start:stop + 1].copy()
        out.append((start, stop, pickle.dumps((type(op), d))))
    return out


def _dtype(x):
    return np.float64 if np.dtype(getattr(x, "dtype", np.float32)) == np.float64 else np.float32


def _check_shape(x, shape, what):
    if tuple(getattr(x, "shape", ())) != tuple(shape):
        raise ArgumentError(f"the {what} has shape {tuple(getattr(x, 'shape', ()))}; this operator takes "
                            f"{tuple(shape)}")


def forward(op, x, frames_per_task=1, device=None):
    """Every frame's blur of x as a dask array (frames, nx, ny, nz), one task
    per run of frames_per_task frames. x: one activity (nx, ny, nz), shared by
    every task, or with per_frame one per frame (frames, nx, ny, nz); numpy
    or dask. device: where the workers plan (None: as op was made)."""
    import dask
    import dask.array as da
    parts = _parts(op, frames_per_task, device)
    _check_shape(x, op.in_shape, "activity")
    dtype = _dtype(x)
    if not op.per_frame and not isinstance(x, da.Array):
        x = dask.delayed(x)  # one key in the graph, not a copy in every task
    blocks = []
    for start, stop, blob in parts:
        xi = x[start:stop] if op.per_frame else x
        task = dask.delayed(_forward_task, pure=True)(blob, xi)
        blocks.append(da.from_delayed(task, shape=(stop - start,) + op._shape, dtype=dtype))
    return da.concatenate(blocks, axis=0)


def adjoint(op, y, frames_per_task=1, sum=None, device=None):
    """The frames' transposes of y (frames, nx, ny, nz; numpy or dask) as a
    dask array: their sum (nx, ny, nz) when ``sum`` is True (the default
    unless op.per_frame), reduced over the tasks' partial sums; else one per
    frame. Give the forward's frames_per_task and device, so that both use
    the same planned operators."""
    import dask
    import dask.array as da
    parts = _parts(op, frames_per_task, device)
    _check_shape(y, op.out_shape, "frames")
    if sum is None:
        sum = not op.per_frame
    blocks = []
    for start, stop, blob in parts:
        task = dask.delayed(_adjoint_task, pure=True)(blob, y[start:stop], bool(sum))
        shape = op._shape if sum else (stop - start,) + op._shape
        blocks.append(da.from_delayed(task, shape=shape, dtype=_dtype(y)))
    if not sum:
        return da.concatenate(blocks, axis=0)
    return da.stack(blocks).sum(axis=0, dtype=_dtype(y))
