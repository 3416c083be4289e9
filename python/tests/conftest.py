"""Shared fixtures: the devices to test on (the host reference, and OpenCL
where a device is there: PoCL in CI), the command-line program to compare
with, and fresh random inputs (seeded per run, the seed printed on failure;
PETBLUR_TEST_SEED replays one)."""

import os
import pathlib
import shutil

import numpy as np
import pytest

import petblur

ROOT = pathlib.Path(__file__).resolve().parents[2]


def pytest_report_header(config):
    return [f"petblur {petblur.__version__} from {pathlib.Path(petblur.__file__).parent}",
            "devices: " + ", ".join(f"{s} ({n})" for s, n in petblur.devices())]


def _host_devices():
    specs = [s for s, _ in petblur.devices()]
    out = ["host"]
    if any(s.startswith("opencl") for s in specs):
        out.append("opencl")
    return out


@pytest.fixture(params=_host_devices())
def device(request):
    """'host' and, where OpenCL finds a device, 'opencl' (PoCL in CI)."""
    return request.param


@pytest.fixture
def rng(request):
    seed = int(os.environ.get("PETBLUR_TEST_SEED") or int.from_bytes(os.urandom(4), "little"))
    request.node.user_properties.append(("seed", seed))
    print(f"seed {seed}")
    return np.random.default_rng(seed)


@pytest.fixture(scope="session")
def cli():
    """The petblur program built by the README's test command (build-test),
    or another build, or PETBLUR_CLI."""
    env = os.environ.get("PETBLUR_CLI")
    candidates = [env] if env else [ROOT / d / "src/cli/petblur" for d in ("build-test", "build")]
    candidates.append(shutil.which("petblur"))
    for c in candidates:
        if c and os.access(c, os.X_OK):
            return str(c)
    pytest.fail("the petblur program is needed to compare with: build it (meson setup build && ninja -C build) "
                "or set PETBLUR_CLI")
