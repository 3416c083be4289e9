"""The repository's scripts (bench/, examples/) as modules, for the tests
that reuse their cases and references: loaded from their files, as they are
not a package."""

import importlib.util
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[2]


def load(relative, name):
    """The script at ROOT / relative, executed as module `name`."""
    spec = importlib.util.spec_from_file_location(name, ROOT / relative)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
