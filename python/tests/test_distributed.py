"""torch.distributed (issue 34): the motion study's MLEM with its frames
shared across 2 gloo processes (examples/motion_study/mlem_distributed.py,
started by torchrun) gives the image of 1 process, and both equal a serial
MLEM written here with scipy's sparse matrix and one petblur.BlurOperator per
frame on numpy arrays, from the same data. Host and PoCL; a fresh seed each
run (the data's noise and the number of frames and iterations)."""

import importlib.util
import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import petblur

torch = pytest.importorskip("torch")

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "motion_study" / "mlem_distributed.py"


def _example():
    sys.path.insert(0, str(EXAMPLE.parent))
    try:
        spec = importlib.util.spec_from_file_location("mlem_distributed", EXAMPLE)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    finally:
        sys.path.remove(str(EXAMPLE.parent))
    return mod


def _torchrun(ranks, args, out, cli, tmp):
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", f"--nproc-per-node={ranks}",
           str(EXAMPLE), "--out", str(out)] + args
    env = dict(__import__("os").environ, PETBLUR_CLI=cli, TMPDIR=str(tmp), OMP_NUM_THREADS="1")
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    with open(out / "results.json") as f:
        return np.load(out / "image.npy"), json.load(f)


def _serial_mlem(ex, p, matrix, cli, seed, device, tmp, monkeypatch):
    """The same MLEM in one process without torch: scipy's sparse matrix,
    each frame a BlurOperator of its own, sums in float64."""
    monkeypatch.setenv("PETBLUR_CLI", cli)
    s = ex.Setup(p, str(matrix), str(tmp))
    nx, ny, nz = s.truth.shape
    W = s.W.astype(np.float64)
    motion = s.motion_model()
    frames = [(s.bounds[k], s.bounds[k + 1]) for k in range(p["frames"])]
    B = [petblur.BlurOperator(s.truth.shape, s.voxel, motion, frame=f, device=device) for f in frames]
    y = [s.frame_data(k, seed).astype(np.float64) for k in range(p["frames"])]
    back = lambda q: (W.T @ q).reshape(nx, ny, nz).astype(np.float32)  # noqa: E731
    sens = sum(b.adjoint(s.scale * back(np.ones_like(y[0]))).astype(np.float64) for b in B)
    sens += 1e-6 * sens.max()
    x = np.ones((nx, ny, nz), np.float32)
    for _ in range(p["iterations"]):
        u = np.zeros((nx, ny, nz))
        for b, yk in zip(B, y):
            proj = W @ b.apply(x).reshape(nx * ny, nz).astype(np.float64)
            u += b.adjoint(s.scale * back(yk / (s.scale * proj + s.background)))
        x = (x * u / sens).astype(np.float32)
    return x, s


def test_two_ranks_equal_one_and_a_serial_mlem(tmp_path, cli, device, rng, monkeypatch):
    ex = _example()
    frames, iterations, seed = int(rng.integers(3, 6)), int(rng.integers(2, 4)), int(rng.integers(1 << 30))
    matrix = tmp_path / "matrix.npz"
    args = ["--device", device, "--frames", str(frames), "--iterations", str(iterations), "--seed", str(seed),
            "--matrix", str(matrix)]
    one, r1 = _torchrun(1, args, tmp_path / "one", cli, tmp_path)
    two, r2 = _torchrun(2, args, tmp_path / "two", cli, tmp_path)
    # the frames split as np.array_split does, each rank on the device asked for
    assert [r["frames"] for r in r2["ranks"]] == [[0, (frames + 1) // 2], [(frames + 1) // 2, frames]]
    assert r2["settings"]["backend"] == "gloo" and r2["settings"]["world"] == 2
    assert all(r["device"].split(":")[0] == device for r in r2["ranks"])
    assert np.all(np.isfinite(two)) and two.max() > 0
    # Sums over frames added in another order (per rank, then all_reduce): float rounding only.
    scale = float(np.abs(one).max())
    assert float(np.abs(two - one).max()) <= 2e-5 * scale, float(np.abs(two - one).max()) / scale
    p = dict(ex.PRESETS["small"], frames=frames, iterations=iterations)
    ref, s = _serial_mlem(ex, p, matrix, cli, seed, device, tmp_path, monkeypatch)
    err = np.abs(two - ref)
    assert float(err.max()) <= 1e-4 * float(np.abs(ref).max()), float(err.max()) / float(np.abs(ref).max())
    # MLEM from a flat start: closer to the truth at every iteration.
    h = [it["nrmse"] for it in r2["history"]]
    assert len(h) == iterations and all(b < a for a, b in zip(h, h[1:])), h
