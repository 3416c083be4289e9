"""petblur.torch on the host backend, in double: torch.autograd.gradcheck
against finite differences (the operator is linear, so a large step is exact
up to float32 rounding), and torch CPU tensors in and out."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")

import petblur  # noqa: E402
from petblur.torch import blur  # noqa: E402


def test_gradcheck_host_double(rng):
    m = petblur.Motion.from_axis_angle(translation=rng.uniform(-3, 3, 3), angle=rng.uniform(5, 15))
    op = petblur.BlurOperator((6, 5, 4), (1.5, 1.5, 2.0), m, device="host")
    x = torch.tensor(rng.random(op.in_shape), dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda v: blur(op, v), (x,), eps=1e-2, atol=1e-5, rtol=1e-3)
    frames = petblur.FramesOperator((6, 5, 4), 1.5, m, [0.0, 0.4, 1.0], device="host")
    assert torch.autograd.gradcheck(lambda v: blur(frames, v), (x,), eps=1e-2, atol=1e-5, rtol=1e-3)


def test_cpu_tensors(rng):
    m = petblur.Motion.from_axis_angle(translation=(4, 2, 0))
    op = petblur.BlurOperator((9, 8, 7), 2.0, m, device="host")
    x = rng.random(op.in_shape, dtype=np.float32)
    y = op(torch.from_numpy(x))
    assert isinstance(y, torch.Tensor) and y.dtype == torch.float32
    np.testing.assert_array_equal(y.numpy(), op(x))
