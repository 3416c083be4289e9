"""Errors: every failure raises petblur.Error, of a subclass per status group
of the C library (include/petblur.h), carrying the library's message, which
says what went wrong and how to fix it."""

import reprlib


def shown(value):
    """A value as given, for a message: its repr, shortened (reprlib's
    limits), on one line."""
    return " ".join(reprlib.repr(value).split())


class Error(Exception):
    """A petblur failure. ``status`` is the C library's pb_status (negative),
    ``message`` its text."""

    def __init__(self, message, status=-1):
        super().__init__(message)
        self.message = message
        self.status = status


class ArgumentError(Error, ValueError):
    """Bad arguments or inputs: shapes, dtypes, motions, options (-1 .. -99)."""


class DeviceError(Error, RuntimeError):
    """No such backend or device, or a runtime call failed (-200 .. -299)."""


class BuildError(Error, RuntimeError):
    """The kernels did not compile for the device (-300 .. -399)."""


class LaunchError(Error, RuntimeError):
    """A kernel launch failed (-400 .. -499)."""


class OutOfMemoryError(Error, MemoryError):
    """Host or device memory ran out (-500 .. -599)."""


class FileError(Error, OSError):
    """A file could not be read, or its content is malformed (-600 .. -699)."""


class LibraryError(Error, ImportError):
    """The C library cannot serve the package: it does not load, it is not
    petblur's (PETBLUR_LIBRARY naming another library) or it lacks a call,
    or its structs differ from the package's. Raised by ``import petblur``."""


class FileContentError(FileError, ArgumentError):
    """A file that breaks a rule on its values: a zero quaternion, times that
    do not increase, a matrix that is no rotation, frames with a gap. A
    FileError, since the file is what to fix, and an ArgumentError, the group
    of its status (-1 .. -99), which ``status`` keeps."""


def error_class(status, reading_file=False):
    """The subclass for a pb_status. A call that reads a file (reading_file)
    raises a rule on values that the file breaks as FileContentError; its
    own arguments (PB_ERR_INVALID_ARGUMENT, -1) stay ArgumentError."""
    if reading_file and -99 <= status <= -2:
        return FileContentError
    if status >= -99:
        return ArgumentError
    if status >= -299:
        return DeviceError
    if status >= -399:
        return BuildError
    if status >= -499:
        return LaunchError
    if status >= -599:
        return OutOfMemoryError
    return FileError
