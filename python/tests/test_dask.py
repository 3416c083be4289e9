"""petblur.dask: a FramesOperator's frames as tasks on a Dask LocalCluster of
two worker processes (issue 34), against the same operator in this process,
on the host and PoCL. Fresh random volumes, tracks and frame bounds each run
(conftest's rng); frames split unevenly over the tasks. The forward reads the
same plans in either process, so it must agree bit for bit; the adjoint's
sum adds the frames in another order (and PoCL's scatter adds atomically),
so to float rounding. A worker plans each frame range once and keeps it for
later tasks (the iterations of a reconstruction)."""

import numpy as np
import pytest
from distributed import Client, LocalCluster

import petblur
import petblur.dask
from random_tracks import random_track


@pytest.fixture(scope="module")
def client():
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with Client(cluster) as c:
            yield c


def _frames_operator(rng, device, per_frame=False, frames=5):
    shape = tuple(int(n) for n in rng.integers(12, 20, 3))
    track = random_track(rng, 60, 30, 8, 4)
    bounds = np.sort(rng.uniform(0, 30, frames + 1))
    return petblur.FramesOperator(shape, rng.uniform(1.5, 2.5, 3), track, bounds, per_frame=per_frame, device=device)


def _close(a, b, rtol):
    return float(np.abs(a - b).max()) <= rtol * float(np.abs(b).max())


def test_forward_and_summed_adjoint_equal_one_process(client, device, rng):
    import dask.array as da
    op = _frames_operator(rng, device)
    x = rng.random(op.in_shape, dtype=np.float32)
    y = rng.random(op.out_shape, dtype=np.float32)
    Y = petblur.dask.forward(op, x, frames_per_task=2)
    assert Y.shape == op.out_shape and Y.numblocks[0] == 3
    fwd = client.compute(Y).result()
    np.testing.assert_array_equal(fwd, op.apply(x))
    s = client.compute(petblur.dask.adjoint(op, da.from_array(y, chunks=(2,) + op._shape), frames_per_task=2)).result()
    assert s.shape == op._shape and _close(s, op.adjoint(y), 1e-5)


def test_per_frame_inputs_and_unsummed_adjoint(client, device, rng):
    import dask.array as da
    op = _frames_operator(rng, device, per_frame=True, frames=4)
    x = rng.random(op.in_shape, dtype=np.float32)
    y = rng.random(op.out_shape, dtype=np.float64)
    fwd = client.compute(petblur.dask.forward(op, da.from_array(x, chunks=(1,) + op._shape), frames_per_task=3))
    np.testing.assert_array_equal(fwd.result(), op.apply(x))
    per = client.compute(petblur.dask.adjoint(op, y, frames_per_task=1)).result()
    ref = op.adjoint(y)
    assert per.dtype == np.float64 and per.shape == ref.shape and _close(per, ref, 1e-5), np.abs(per - ref).max()


def test_gates_of_a_field_motion_and_a_track(client, rng):
    """Gated FramesOperators of a surrogate-driven FieldMotion and of a rigid
    track the same belt moves: their gates split over the tasks as frames
    are, the same blur and summed transpose as in one process."""
    import dask.array as da
    shape = tuple(int(n) for n in rng.integers(8, 12, 3))
    t = np.linspace(0.0, 20.0, 401)
    s = 0.5 * (1 - np.cos(2 * np.pi * t / rng.uniform(3.5, 4.5))) * (1 + 0.2 * np.sin(t / 5.0))
    values = np.linspace(-0.1, 1.3, 4)
    fields = rng.normal(0.0, 1.5, (4,) + shape + (3,))
    fm = petblur.FieldMotion.from_surrogate(values, fields, t, s)
    gates = petblur.amplitude_gates(t, s, np.linspace(s.min(), s.max(), 4))
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # random fields fold
        op = petblur.FramesOperator(shape, 2.0, fm, gates, device="host")
    track = petblur.Motion(t, np.outer(s, rng.uniform(-4.0, 4.0, 3)), np.tile([1.0, 0.0, 0.0, 0.0], (t.size, 1)))
    for op in (op, petblur.FramesOperator(shape, 2.0, track, gates, device="host")):
        x = rng.random(op.in_shape, dtype=np.float32)
        fwd = client.compute(petblur.dask.forward(op, x, frames_per_task=2)).result()
        np.testing.assert_array_equal(fwd, op.apply(x))
        s_ = client.compute(petblur.dask.adjoint(op, da.from_array(fwd, chunks=(2,) + op._shape),
                                                 frames_per_task=2)).result()
        assert _close(s_, op.adjoint(fwd), 1e-5)


def test_each_worker_plans_a_frame_range_once(client, rng):
    op = _frames_operator(rng, "host", frames=5)
    first, second = sorted(client.scheduler_info()["workers"])
    plans = lambda: client.run(lambda: __import__("petblur.dask").dask._plans)  # noqa: E731
    before = plans()
    for worker, new in ((first, 3), (first, 0), (second, 3)):
        # a fresh activity each time: new tasks (Dask would reuse a result it still holds), the same frame ranges
        x = rng.random(op.in_shape, dtype=np.float32)
        Y = petblur.dask.forward(op, x, frames_per_task=2)  # three frame ranges
        expect = op.apply(x)
        np.testing.assert_array_equal(client.compute(Y, workers=[worker]).result(), expect)
        now = plans()
        assert now[worker] - before[worker] == new, (worker, before, now)
        before = now
    # the adjoint's tasks carry the same frame ranges: planned already
    client.compute(petblur.dask.adjoint(op, expect, frames_per_task=2), workers=[second]).result()
    assert plans()[second] == before[second]


def test_workers_plan_on_the_device_given(client, device, rng):
    # made on the host here, planned on `device` in the workers: the same frames as an operator made there
    op = _frames_operator(rng, "host", frames=3)
    there = petblur.FramesOperator(op._shape, op.voxel_size, op.motion, op.bounds, device=device)
    x = rng.random(op.in_shape, dtype=np.float32)
    got = client.compute(petblur.dask.forward(op, x, frames_per_task=2, device=device)).result()
    np.testing.assert_array_equal(got, there.apply(x))
    specs = client.run(lambda: sorted({o._description()["device"] for o in __import__("petblur.dask").dask._cache.values()}))
    assert any(device in v for v in specs.values()), specs


def test_refusals(rng):
    op = _frames_operator(rng, "host")
    x = np.zeros(op.in_shape, np.float32)
    for bad in (0, -1, 1.5, True, "2"):
        with pytest.raises(petblur.ArgumentError, match="frames_per_task"):
            petblur.dask.forward(op, x, frames_per_task=bad)
    with pytest.raises(petblur.ArgumentError, match="device"):
        petblur.dask.forward(op, x, device=0)
    with pytest.raises(petblur.ArgumentError, match="shape"):
        petblur.dask.forward(op, np.zeros((3, 3, 3), np.float32))
    with pytest.raises(petblur.ArgumentError, match="FramesOperator"):
        petblur.dask.forward(petblur.BlurOperator((8, 8, 8), 2.0, petblur.Motion.from_axis_angle((1, 0, 0)),
                                                  device="host"), np.zeros((8, 8, 8), np.float32))
    last = petblur.FramesOperator(op._shape, op.voxel_size, op.motion, op.bounds, frames_last=True, device="host")
    with pytest.raises(petblur.ArgumentError, match="frames_last=False"):
        petblur.dask.adjoint(last, np.zeros(last.out_shape, np.float32))
