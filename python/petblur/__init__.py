"""petblur: 3-D motion blur of PET activity volumes, and its exact transpose,
on GPUs and CPUs, as linear operators over numpy, CuPy and PyTorch arrays.

    import petblur
    m = petblur.Motion.from_axis_angle(translation=(12, 10, -11), angle=10)
    B = petblur.BlurOperator(x.shape, (2, 2, 2), m)
    y = B(x)              # the blurred activity
    z = B.adjoint(y)      # its exact transpose

Volumes are indexed [x, y, z] (axis 0 is x, as nibabel holds them), float32.
docs/python.md has the whole API."""

from ._lib import backends, devices, lib as _c
from .errors import (ArgumentError, BuildError, DeviceError, Error, FileContentError, FileError, LaunchError,
                     LibraryError, OutOfMemoryError)
from .fields import FieldMotion, amplitude_gates
from .motion import Motion, frames_from_sidecar
from .operator import BlurOperator, FramesOperator

__version__ = "0.1.0"
__all__ = ["Motion", "FieldMotion", "amplitude_gates", "frames_from_sidecar", "BlurOperator", "FramesOperator", "backends", "devices", "Error", "ArgumentError", "DeviceError",
           "BuildError", "LaunchError", "OutOfMemoryError", "FileError", "FileContentError",
           "LibraryError"]
