"""The README's MLEM update with the operator, deblurring a moved phantom
(the projector taken as the identity, as examples/mlem_deblur.c does): the
error against the truth must fall below the blurred data's, and every
iterate stay finite and non-negative."""

import numpy as np

import petblur


def test_readme_mlem_deblurs(device, rng):
    shape = (24, 20, 16)
    truth = np.zeros(shape, dtype=np.float32)
    for _ in range(6):  # hot and cold balls
        c = rng.uniform(4, np.array(shape) - 4)
        r = rng.uniform(2, 4)
        g = np.stack(np.meshgrid(*[np.arange(n) + 0.5 for n in shape], indexing="ij"), -1)
        truth[np.sum((g - c) ** 2, -1) < r * r] += rng.uniform(1, 4)
    truth += 0.1
    motion = petblur.Motion.from_axis_angle(translation=rng.uniform(-6, 6, 3), angle=rng.uniform(-15, 15))
    B = petblur.BlurOperator(shape, (2.0, 2.0, 2.0), motion, device=device)
    data = B(truth)
    sens = B.adjoint(np.ones(shape, np.float32))
    x = np.ones(shape, np.float32)
    err = [float(np.linalg.norm(x - truth) / np.linalg.norm(truth))]
    for _ in range(12):
        x *= B.adjoint(data / (B(x) + 1e-6)) / np.maximum(sens, 1e-6)
        assert np.all(np.isfinite(x)) and x.min() >= 0
        err.append(float(np.linalg.norm(x - truth) / np.linalg.norm(truth)))
    blurred = float(np.linalg.norm(data - truth) / np.linalg.norm(truth))

    # Past the first iteration's scaling, the error keeps falling, below the
    # blurred data's own.
    assert err[-1] < 0.7 * err[1] and err[-1] < 0.6 * blurred, (err, blurred)
    # The data is matched better than by the start.
    assert np.linalg.norm(B(x) - data) < 0.2 * np.linalg.norm(B(np.ones(shape, np.float32)) - data)
