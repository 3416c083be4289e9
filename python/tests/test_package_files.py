"""The wheel holds every module of the package: python/meson.build lists the
files that pip installs, one by one (meson does not glob), so a module added
to python/petblur and not listed there works from the source tree and is
missing from every installed copy (petblur.estimate was, and
Motion.from_frames failed with an ImportError once installed)."""

import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_every_module_is_installed():
    listed = set(re.findall(r"'petblur/([A-Za-z0-9_]+\.py)'", (ROOT / "python" / "meson.build").read_text()))
    present = {p.name for p in (ROOT / "python" / "petblur").glob("*.py")}
    assert present - listed == set(), f"modules missing from python/meson.build: {sorted(present - listed)}"
    assert listed - present == set(), f"python/meson.build lists modules that do not exist: {sorted(listed - present)}"
