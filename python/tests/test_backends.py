"""petblur.backends(): each backend and why it cannot run (issue 32, item 2).
The library opens the OpenCL ICD loader at run time: in a process whose
PETBLUR_OPENCL_LIBRARY names no loader, the package imports and runs on the
host, and OpenCL is unavailable with the reason and the fix, in backends(),
in devices() (absent) and in the error of an operator asked for it."""

import json
import subprocess
import sys

import petblur

PROBE = r"""
import json, numpy as np, petblur
out = {"backends": petblur.backends(), "devices": petblur.devices()}
m = petblur.Motion.from_axis_angle(translation=(1.5, -2, 0.5), angle=4)
try:
    petblur.BlurOperator((8, 9, 10), (2, 2, 2), m, device="opencl")
    out["opencl"] = "made"
except petblur.DeviceError as e:
    out["opencl"] = str(e)
try:
    petblur.BlurOperator((8, 9, 10), (2, 2, 2), m, device="auto")
    out["auto"] = "made"
except petblur.DeviceError as e:
    out["auto"] = str(e)
B = petblur.BlurOperator((8, 9, 10), (2, 2, 2), m, device="host")
x = np.random.default_rng(1).random((8, 9, 10), dtype=np.float32)
out["host_ok"] = bool(np.isfinite(B(x)).all() and B(x).sum() > 0)
print(json.dumps(out))
"""


def _probe(library):
    env = dict(__import__("os").environ, PETBLUR_OPENCL_LIBRARY=library, CUDA_VISIBLE_DEVICES="")
    r = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_backends_agree_with_devices():
    found = {name: n for name, n, _ in petblur.backends()}
    specs = [s for s, _ in petblur.devices()]
    assert found["host"] == 1 and "host" in specs
    for name in ("opencl", "cuda"):
        assert found[name] == sum(s.startswith(name + ":") for s in specs), (found, specs)
    for name, n, reason in petblur.backends():
        assert (reason == "") == (n > 0), (name, n, reason)


def test_missing_opencl_loader():
    out = _probe("/nonexistent/libOpenCL.so.1")
    opencl = next(b for b in out["backends"] if b[0] == "opencl")
    if "not compiled" in opencl[2]:
        return  # a build without OpenCL: nothing to open
    assert opencl[1] == 0 and "/nonexistent/libOpenCL.so.1" in opencl[2] and "ocl-icd-libopencl1" in opencl[2], opencl
    assert not any(s.startswith("opencl") for s, _ in out["devices"])
    assert "ICD loader" in out["opencl"] and "PETBLUR_OPENCL_LIBRARY" in out["opencl"], out["opencl"]
    # 'auto' (a GPU, else OpenCL) finds nothing here, and says why OpenCL could not serve
    assert "ICD loader" in out["auto"] and "host" in out["auto"], out["auto"]
    assert out["host_ok"], out


def test_a_library_that_is_not_an_opencl_loader():
    out = _probe("libm.so.6")
    opencl = next(b for b in out["backends"] if b[0] == "opencl")
    if "not compiled" in opencl[2]:
        return
    assert opencl[1] == 0 and "clBuildProgram" in opencl[2], opencl
    assert "clBuildProgram" in out["opencl"], out["opencl"]
