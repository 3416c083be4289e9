"""The arrays petblur takes: numpy, CuPy, and PyTorch tensors (CPU or CUDA).

Axes: a volume is indexed [x, y, z], as nibabel's img.get_fdata() holds it
(axis 0 is x). Memory: either order is read in place, Fortran order (x
fastest: nibabel's, the C library's own) and C order (z fastest: numpy's,
CuPy's and PyTorch's default), the latter through a plan of the transposed
grid. Other strides are copied into C order first, on the array's own device.
dtype: float32; float64 is computed in float32 and returned as float64; any
other dtype is refused. Values: NaN and infinity in host arrays are refused,
and so are numpy masked arrays (the library would read under the mask)."""

import sys

import numpy as np

from .errors import ArgumentError


def _torch():
    return sys.modules.get("torch")


def _cupy():
    return sys.modules.get("cupy")


class Array:
    """What the operator needs of an array: its kind ('numpy', 'cupy',
    'torch'), the float32 data in a usable order, the order ('F' or 'C'),
    the CUDA device (-1 on the host) and a way to allocate the output."""

    def __init__(self, x, what):
        torch, cupy = _torch(), _cupy()
        self.original = x
        # A float64 host array as given, beside its float32 copy: a value that
        # does not survive the narrowing is named as it was given.
        self.wide = None
        if torch is not None and isinstance(x, torch.Tensor):
            self.kind = "torch"
            x = x.detach()
            self.device = x.device.index if x.device.type == "cuda" else -1
            if x.device.type not in ("cuda", "cpu"):
                raise ArgumentError(f"the {what} is a torch tensor on {x.device}; petblur takes CPU and CUDA tensors")
            if x.dtype not in (torch.float32, torch.float64):
                raise ArgumentError(f"the {what} is a {x.dtype} tensor; give float32 (or float64, computed in "
                                    "float32): x.float()")
            self.dtype = x.dtype
            if x.device.type == "cpu":  # the numpy path, on the tensor's own memory
                self.kind = "torch-cpu"
                x = x.numpy()
                if x.dtype == np.float64:
                    self.wide = x
                    x = _narrow(x)
            elif x.dtype == torch.float64:
                x = x.float()
        elif isinstance(x, np.ma.MaskedArray):
            # The library reads every voxel, masked or not: a NaN under the
            # mask would be blurred into its neighbours.
            raise ArgumentError(f"the {what} is a numpy masked array, whose mask petblur cannot honour; give "
                                "x.filled(0) (masked voxels as 0) or np.ma.getdata(x) (the values under the mask)")
        elif isinstance(x, np.ndarray) or (cupy is not None and isinstance(x, cupy.ndarray)):
            gpu = not isinstance(x, np.ndarray)
            self.kind = "cupy" if gpu else "numpy"
            self.device = x.device.id if gpu else -1
            self.dtype = x.dtype
            if x.dtype not in (np.float32, np.float64):
                module = "cupy" if gpu else "numpy"
                raise ArgumentError(f"the {what} is a {x.dtype} {'CuPy ' if gpu else ''}array; give float32 (or "
                                    f"float64, computed in float32): x.astype({module}.float32)")
            if x.dtype == np.float64:
                self.wide = None if gpu else x
                x = x.astype(np.float32, order="K") if gpu else _narrow(x)
        else:
            kind = type(x).__name__ if type(x).__module__ == "builtins" else f"{type(x).__module__}.{type(x).__name__}"
            hint = ("; petblur.dask spreads an operator's frames over a dask array's chunks, or give x.compute()"
                    if type(x).__module__.startswith("dask") else "")
            raise ArgumentError(f"the {what} is a {kind}; give a numpy or CuPy array or a torch tensor{hint}")
        self.data = x
        self.shape = tuple(x.shape)
        self.what = what

    def move(self, fn):
        """The data (and the float64 array it came from) through fn, a view
        that moves axes, so that a voxel is named in the moved axes."""
        self.data = fn(self.data)
        if self.wide is not None:
            self.wide = fn(self.wide)

    @property
    def on_gpu(self):
        return self.device >= 0

    def volumes(self, shape):
        """The array as volumes of shape: a list of (view, order) for a 3-D
        array, one per frame for a 4-D one; views in neither order are copied
        (C order)."""
        x = self.data
        if not self.on_gpu:
            _check_finite(x, self.what, self.wide, largest=LARGEST)
        parts = [x] if x.ndim == 3 else [x[f] for f in range(x.shape[0])]
        out = []
        for v in parts:
            order = _order(v, self.kind)
            if order is None:
                v = _contiguous(v, self.kind)
                order = "C"
            out.append((v, order))
        return out

    def empty(self, shape, order):
        """float32 output of shape on the array's device; order 'F' or 'C' is
        that of every 3-D volume in it (frames first)."""
        nd = len(shape)
        if order == "F":  # each volume x fastest, frames outermost
            rev = tuple(reversed(shape[nd - 3:]))
            full = tuple(shape[:nd - 3]) + rev
            perm = tuple(range(nd - 3)) + tuple(range(nd - 1, nd - 4, -1))
        else:
            full, perm = tuple(shape), tuple(range(nd))
        if self.kind == "torch":
            torch = _torch()
            return torch.empty(full, dtype=torch.float32, device=self.original.device).permute(perm)
        if self.kind == "cupy":
            cupy = _cupy()
            with cupy.cuda.Device(self.device):
                return cupy.empty(full, dtype=np.float32).transpose(perm)
        return np.empty(full, dtype=np.float32).transpose(perm)

    def result(self, out):
        """out (float32, of this kind) as the caller's type and dtype."""
        if self.kind == "torch-cpu":
            torch = _torch()
            out = torch.from_numpy(out)
            return out.double() if self.dtype == torch.float64 else out
        if self.kind == "torch":
            torch = _torch()
            return out.double() if self.dtype == torch.float64 else out
        return out.astype(np.float64) if self.dtype == np.float64 else out


def _narrow(x):
    """A float64 host array in float32, the precision petblur computes in;
    values beyond float32's range become infinite here and are refused, by
    their float64 value, when the array is read (_check_finite)."""
    with np.errstate(over="ignore"):
        return x.astype(np.float32, order="K")


# The largest magnitude an operator reads. A blur is a mean of the values,
# but its transpose adds each voxel's weights (more than 1 where the motion
# compresses), REF and CL sum their samples before dividing, and a frames'
# adjoint sums the frames: near float32's top (3.4e38) those leave its range
# and return infinities. No activity, count or ratio comes near 1e30.
LARGEST = 1e30


def _check_finite(x, what, wide=None, largest=None):
    """Host arrays: one NaN would spread through every blur that reads it;
    refused here, where the voxel can be named in the array's own axes. wide:
    the float64 array x was narrowed from, whose finite values beyond
    float32's range x holds as infinite. largest: a bound on the magnitudes
    besides (the operators', LARGEST). (CUDA arrays are not read on the host
    for this, as the C library's device-memory calls do not check them.)"""
    if largest is None:
        finite = np.isfinite(x)
        ok = finite.all()
    else:  # two reductions, no array as large as x (a NaN fails both)
        ok = x.size == 0 or (float(x.max()) <= largest and float(x.min()) >= -largest)
        if not ok:
            with np.errstate(invalid="ignore"):
                finite = np.abs(x) <= largest
    if not ok:
        where = tuple(int(i) for i in np.argwhere(~finite)[0])
        axes = f"(axes {'frame, ' if x.ndim == 4 else ''}x, y, z)"
        given = x[where] if wide is None else wide[where]
        if np.isfinite(given) and np.isfinite(x[where]):
            raise ArgumentError(f"the {what} is {float(given)!r} at {list(where)} {axes}, beyond {largest:g}, where "
                                "an adjoint's or a reference's sums leave float32's range; scale the values first, "
                                "e.g. x / abs(x).max()", -4)
        if np.isfinite(given):
            raise ArgumentError(f"the {what} is {float(given)!r} at {list(where)} {axes}, beyond float32's range "
                                f"(magnitudes up to {float(np.finfo(np.float32).max):.4g}), in which petblur "
                                "computes; scale the values into it first, e.g. x / abs(x).max()", -4)
        raise ArgumentError(f"the {what} is {given} at {list(where)} {axes}; replace NaN and infinite values first, "
                            "for example with numpy.nan_to_num", -4)


def pointer(v, kind):
    if kind == "torch":
        return v.data_ptr()
    if kind == "cupy":
        return v.data.ptr
    return v.ctypes.data


def _order(v, kind):
    """'C' or 'F' for a dense volume (a volume dense both ways is taken as C),
    None otherwise."""
    if kind == "torch":
        if v.is_contiguous():
            return "C"
        return "F" if v.permute(2, 1, 0).is_contiguous() else None
    if v.flags.c_contiguous:
        return "C"
    return "F" if v.flags.f_contiguous else None


def _contiguous(v, kind):
    if kind == "torch":
        return v.contiguous()
    if kind == "cupy":
        return _cupy().ascontiguousarray(v)
    return np.ascontiguousarray(v)
