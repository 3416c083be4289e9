"""CuPy arrays and PyTorch CUDA tensors (the GPU machine; skipped where no
CUDA device is): read and written in place on the GPU with no host transfer
(CUPTI's memcpy records, through torch.profiler), on the caller's stream,
equal to the numpy path, and from several threads on several GPUs (or
streams)."""

import threading

import numpy as np
import pytest

import petblur

torch = pytest.importorskip("torch")
if not torch.cuda.is_available() or not any(s.startswith("cuda") for s, _ in petblur.devices()):
    pytest.skip("no CUDA device", allow_module_level=True)

from petblur.torch import blur  # noqa: E402
from random_tracks import random_track  # noqa: E402

# AB HARDWARE reads a volume along x through layers from numpy (volumes) and
# through the 3-D texture from device memory: the texture unit's 8-bit
# weights blend them in another order (tests/testlib.h, PB_TEX_TRILINEAR_ERROR).
TEX = 2e-3


def _op(rng, shape=(64, 48, 40), device="cuda:0", **kw):
    m = petblur.Motion.from_axis_angle(translation=rng.uniform(-8, 8, 3), angle=rng.uniform(5, 20))
    return petblur.BlurOperator(shape, (2.0, 2.0, 2.5), m, device=device, **kw)


@pytest.mark.parametrize("order", ["C", "F"])
def test_torch_equals_numpy(rng, order):
    op = _op(rng)
    x = np.asarray(rng.random(op.in_shape, dtype=np.float32), order=order)
    xt = torch.from_numpy(x).cuda() if order == "C" else torch.from_numpy(x.T.copy()).cuda().permute(2, 1, 0)
    yt = op(xt)
    assert yt.device == xt.device and yt.dtype == torch.float32 and yt.shape == xt.shape
    assert yt.is_contiguous() == (order == "C")
    y = op(x)
    np.testing.assert_allclose(yt.cpu().numpy(), y, rtol=0, atol=TEX * y.max())
    bt = op.adjoint(yt)
    np.testing.assert_allclose(bt.cpu().numpy(), op.adjoint(yt.cpu().numpy()), rtol=0, atol=TEX * y.max())


def test_cupy_equals_numpy(rng):
    cupy = pytest.importorskip("cupy")
    op = _op(rng)
    x = rng.random(op.in_shape, dtype=np.float32)
    yc = op(cupy.asarray(x))
    assert isinstance(yc, cupy.ndarray) and yc.device.id == 0
    np.testing.assert_allclose(cupy.asnumpy(yc), op(x), rtol=0, atol=TEX * float(yc.max()))
    y64 = op.adjoint(cupy.asarray(x, dtype=cupy.float64))
    assert y64.dtype == cupy.float64
    y32 = op.adjoint(cupy.asarray(x))
    np.testing.assert_allclose(cupy.asnumpy(y64), cupy.asnumpy(y32), rtol=0, atol=1e-5 * float(y32.max()))
    # A stream the caller destroys after a call, then another: the context
    # holds no stream between calls.
    import gc
    xc = cupy.asarray(x)
    want = cupy.asnumpy(op(xc))
    s1 = cupy.cuda.Stream(non_blocking=True)
    with s1:
        op(xc)
    s1.synchronize()
    del s1
    gc.collect()
    s2 = cupy.cuda.Stream(non_blocking=True)
    with s2:
        y2 = op(xc)
    s2.synchronize()
    np.testing.assert_array_equal(cupy.asnumpy(y2), want)


def test_no_host_transfer(rng):
    """Device in, device out: no host-to-device or device-to-host copy in the
    call, only the copy into the texture and the kernel."""
    op = _op(rng)
    x = torch.rand(op.in_shape, device="cuda")
    op(x)
    torch.cuda.synchronize()
    from torch.profiler import ProfilerActivity, profile
    with profile(activities=[ProfilerActivity.CUDA]) as prof:
        y = op(x)
        z = op.adjoint(y)
        torch.cuda.synchronize()
    names = [e.name for e in prof.events()]
    assert not [n for n in names if "HtoD" in n or "DtoH" in n], names
    assert any("pb_" in n or "blur" in n.lower() for n in names), names  # the kernels were seen
    assert y.data_ptr() != x.data_ptr() and z.device.type == "cuda"


def test_callers_stream(rng):
    """Work queued on the caller's stream before the call is seen by it: a
    long sleep, then the input written, then the blur, all on a side stream
    (non-blocking: the library's own stream would not wait for it)."""
    op = _op(rng)
    x = torch.rand(op.in_shape, device="cuda")
    want = op(x).clone()
    torch.cuda.synchronize()
    s = torch.cuda.Stream()
    src = x.clone()
    x.zero_()
    torch.cuda.synchronize()
    with torch.cuda.stream(s):
        torch.cuda._sleep(200_000_000)  # about 0.1 s
        x.copy_(src)
        y = op(x)
        z = y * 1.0  # queued after the blur on the same stream
    s.synchronize()
    torch.testing.assert_close(z, want, rtol=0, atol=1e-6 * float(want.max()))


def test_autograd_cuda(rng):
    op = _op(rng)
    x = torch.rand(op.in_shape, device="cuda", requires_grad=True)
    w = torch.rand(op.out_shape, device="cuda")
    (blur(op, x) * w).sum().backward()
    g = op.adjoint(w)
    torch.testing.assert_close(x.grad, g, rtol=0, atol=1e-5 * float(g.abs().max()))  # the scatter's atomics


def test_gradcheck_host_double(rng):
    m = petblur.Motion.from_axis_angle(translation=rng.uniform(-3, 3, 3), angle=rng.uniform(5, 15))
    op = petblur.BlurOperator((6, 5, 4), (1.5, 1.5, 2.0), m, device="host")
    x = torch.tensor(rng.random(op.in_shape), dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda v: blur(op, v), (x,), eps=1e-2, atol=1e-5, rtol=1e-3)


def test_wrong_device_refused(rng):
    op_host = _op(rng, device="host")
    with pytest.raises(petblur.ArgumentError, match="CUDA operator"):
        op_host(torch.rand(op_host.in_shape, device="cuda"))
    if torch.cuda.device_count() > 1:
        op1 = _op(rng, device="cuda:1")
        with pytest.raises(petblur.ArgumentError, match="cuda:0"):
            op1(torch.rand(op1.in_shape, device="cuda:0"))


def test_threads(rng):
    """Two GPUs from two threads where there are two, else two streams of one
    GPU from two threads; each thread's results equal its operator's alone."""
    n = torch.cuda.device_count()
    devs = [f"cuda:{i}" for i in range(min(n, 2))] or ["cuda:0"]
    if len(devs) == 1:
        devs = devs * 2
    ops = [_op(rng, device=d) for d in devs]
    xs = [torch.rand(op.in_shape, device=op.device) for op in ops]
    want = [op(x).clone() for op, x in zip(ops, xs)]
    want_adjoint = [op.adjoint(w).clone() for op, w in zip(ops, want)]
    torch.cuda.synchronize()
    errors = []

    def work(i):
        try:
            dev = torch.device(devs[i])
            with torch.cuda.device(dev), torch.cuda.stream(torch.cuda.Stream(dev)):
                for _ in range(50):
                    y = ops[i](xs[i])
                    b = ops[i].adjoint(y)
                torch.cuda.current_stream(dev).synchronize()
                if not torch.equal(y, want[i]):
                    errors.append(f"thread {i}: forward differs by {float((y - want[i]).abs().max())}")
                scale = float(want_adjoint[i].abs().max())
                if not float((b - want_adjoint[i]).abs().max()) <= 1e-5 * scale:  # the scatter's atomics
                    errors.append(f"thread {i}: adjoint differs by {float((b - want_adjoint[i]).abs().max())}")
        except Exception as e:  # reported below
            errors.append(f"thread {i}: {e!r}")

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors


def test_cuda_is_the_current_device(rng):
    """device='cuda' names the process's current GPU (torch.cuda.set_device,
    as torchrun's ranks set it), 'cuda:N' the GPU N whatever is current."""
    last = torch.cuda.device_count() - 1
    with torch.cuda.device(last):
        op = _op(rng, device="cuda")
        assert op.device == f"cuda:{last}"
        x = torch.rand(op.in_shape, device=f"cuda:{last}")
        assert op(x).device == x.device and torch.cuda.current_device() == last
    assert _op(rng, device="cuda:0").device == "cuda:0"


def test_dask_two_workers_share_one_gpu(rng):
    """Two Dask worker processes planning on one GPU (device='cuda' in
    each) give what one process gives: the forward bit for bit (the same
    plans), the adjoint's sum to float rounding (another order, atomics)."""
    distributed = pytest.importorskip("distributed")
    import petblur.dask
    track = random_track(rng, 60, 30, 8, 4)
    F = petblur.FramesOperator((64, 56, 48), (2.0, 2.0, 2.5), track, np.sort(rng.uniform(0, 30, 6)), device="cuda")
    x = rng.random(F.in_shape, dtype=np.float32)
    y = rng.random(F.out_shape, dtype=np.float32)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        Y = client.compute(petblur.dask.forward(F, x, frames_per_task=2)).result()
        s = client.compute(petblur.dask.adjoint(F, y, frames_per_task=2)).result()
        devices = client.run(lambda: sorted({op.device for op in __import__("petblur.dask").dask._cache.values()}))
    assert sorted(devices.values()) == [["cuda:0"], ["cuda:0"]], devices
    np.testing.assert_array_equal(Y, F.apply(x))
    ref = F.adjoint(y)
    assert float(np.abs(s - ref).max()) <= 1e-5 * float(np.abs(ref).max())


def test_nvrtc_kernels_equal_nvcc(tmp_path, rng):
    """The CUDA kernels compiled at run time by NVRTC (found through the
    nvidia-cuda-nvrtc wheel where installed), cached under PETBLUR_CACHE_DIR,
    give nvcc's results; a second process reads the cache."""
    import json
    import os
    import subprocess
    import sys
    x = rng.random((40, 36, 30), dtype=np.float32)
    np.save(tmp_path / "x.npy", x)
    code = (f"import json, numpy as np, petblur, os; x = np.load({str(tmp_path / 'x.npy')!r}); "
            "m = petblur.Motion.from_axis_angle(translation=(6, -4, 3), angle=12); "
            "B = petblur.BlurOperator(x.shape, (2, 2, 2.5), m, device='cuda'); "
            f"np.save({str(tmp_path)!r} + '/y-' + os.environ['PETBLUR_CUDA_KERNELS'] + '.npy', B(x)); "
            f"np.save({str(tmp_path)!r} + '/z-' + os.environ['PETBLUR_CUDA_KERNELS'] + '.npy', B.adjoint(x)); "
            "print(json.dumps(os.environ.get('PETBLUR_NVRTC_LIBRARY')))")
    cache = tmp_path / "cache"
    for kernels in ("builtin", "nvrtc", "nvrtc"):
        env = dict(os.environ, PETBLUR_CUDA_KERNELS=kernels, PETBLUR_CACHE_DIR=str(cache))
        r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr[-3000:]
        print(kernels, json.loads(r.stdout.strip().splitlines()[-1]))
    assert len(list(cache.iterdir())) == 1
    y0, y1 = np.load(tmp_path / "y-builtin.npy"), np.load(tmp_path / "y-nvrtc.npy")
    z0, z1 = np.load(tmp_path / "z-builtin.npy"), np.load(tmp_path / "z-nvrtc.npy")
    assert float(np.abs(y1 - y0).max()) <= 1e-6 * float(y0.max())
    assert float(np.abs(z1 - z0).max()) <= 1e-5 * float(z0.max())


@pytest.mark.parametrize("order", ["C", "F"])
def test_frames_on_cuda_tensors_in_one_call(rng, order):
    """A FramesOperator on CUDA tensors runs its frames in one library call
    (the activity copied into the texture once; the adjoint's sum in one
    call): each frame equal to its own BlurOperator on the same tensor, the
    summed adjoint to the sum of theirs, per-frame inputs (one call a frame)
    alike."""
    track = random_track(rng, 40, 20, 6, 3)
    bounds = np.sort(rng.uniform(0, 20, 6))
    shape = (44, 38, 30)
    F = petblur.FramesOperator(shape, (2.0, 2.2, 2.5), track, bounds, device="cuda")
    x = torch.rand(shape, device="cuda")
    if order == "F":
        x = x.permute(2, 1, 0).contiguous().permute(2, 1, 0)
    y = F(x)
    assert y.shape == (5,) + shape
    s = F.adjoint(y)
    ref_s = torch.zeros(shape, device="cuda")
    for k in range(5):
        B = petblur.BlurOperator(shape, (2.0, 2.2, 2.5), track, frame=(bounds[k], bounds[k + 1]), device="cuda")
        yk = B(x)
        assert torch.equal(y[k], yk), k
        ref_s += B.adjoint(y[k].contiguous() if order == "C" else y[k])
    assert float((s - ref_s).abs().max()) <= 1e-5 * float(ref_s.abs().max())
    if order == "C":  # torch.stack gives C order, whose plan is the transposed grid's where x is F
        Fp = petblur.FramesOperator(shape, (2.0, 2.2, 2.5), track, bounds, per_frame=True, device="cuda")
        assert torch.equal(Fp(torch.stack([x] * 5)), y)
