"""AB's own sampling error (issue 31, item 3) and what ab_sampling='sweep'
does about it, against a dense reference made without petblur: the mean of
2000 scipy map_coordinates resamplings (order 1: the same trilinear image
petblur blurs) at equally spaced times of an oblique translation, on a fresh
smooth random volume with anisotropic voxels.

The paper's AB reads each slice its path crosses at one point, so a path that
sweeps sideways across the slice is read as if it did not (A_R = 0 in the
paper's eq. 4). Measured while writing this test on short moves (24 draws on
the host, seeds 1-24, when AB walked every segment): the paper's AB 0.29-1.32 %
RMS and 0.76-3.51 % max, AB sweep 0.045-0.55 % and 0.10-1.44 %, at most 0.52
of AB's in either. Since issue 46 a segment of at most 5 voxels along its
major axis is read exactly, by AB (sweep or not) and by RM's default alike
(test_short_segments_are_exact); the walk, and so the sweep's gain, is
tested on moves of 6.5 voxels and more, where AB walks alone."""

import numpy as np
import pytest
from scipy import ndimage

import petblur
from petblur.errors import ArgumentError


def _errors(ref, y, inner):
    d, r = (y - ref)[inner], ref[inner]
    return 100 * np.linalg.norm(d) / np.linalg.norm(r), 100 * np.abs(d).max() / np.abs(r).max()


def _oblique(rng, shape, length):
    """A smooth random volume, its voxel sizes, and a move (voxels) whose main
    axis is drawn, `length` long, with sideways parts of 0.4 to 0.9 of it."""
    voxel = rng.uniform(1.5, 3.0, 3)
    x = ndimage.gaussian_filter(rng.random(shape), rng.uniform(0.6, 1.0))
    x = (x - x.min()).astype(np.float32)
    main = int(rng.integers(3))
    move = np.empty(3)
    move[main] = length * rng.choice([-1, 1])
    for i in range(3):
        if i != main:
            move[i] = abs(move[main]) * rng.uniform(0.4, 0.9) * rng.choice([-1, 1])
    return x, voxel, move


def _dense(x, move, times=2000):
    """The mean of x resampled (order 1, zero outside) at `times` equally
    spaced points of the move."""
    idx = np.stack(np.meshgrid(*[np.arange(n) for n in x.shape], indexing="ij"), 0).reshape(3, -1).astype(np.float64)
    ref = np.zeros(idx.shape[1])
    for t in (np.arange(times) + 0.5) / times:
        ref += ndimage.map_coordinates(x.astype(np.float64), idx - (t * move)[:, None], order=1,
                                       mode="grid-constant")
    return (ref / times).reshape(x.shape)


def test_short_segments_are_exact(rng, device):
    """A move of 0.2-5 voxels along its main axis: AB, AB sweep and RM at
    their defaults give the trilinear image's exact time average (what is
    left is float rounding and the reference's own midpoint rule, about
    1e-5 %), both ways."""
    shape = (20, 18, 16)
    for lo, hi in ((0.2, 3.0), (3.0, 5.0), (0.2, 5.0)):  # one draw near PB_AB_EXACT_TO (5), the longest read exactly
        x, voxel, move = _oblique(rng, shape, rng.uniform(lo, hi))
        ref = _dense(x, move)
        motion = petblur.Motion([0.0, 1.0], [[0.0, 0.0, 0.0], list(move * voxel)], [[1, 0, 0, 0], [1, 0, 0, 0]])
        inner = tuple(slice(4, n - 4) for n in shape)
        for name, kw in (("ab", {}), ("sweep", {"ab_sampling": "sweep"}), ("rm", {"method": "rm"})):
            op = petblur.BlurOperator(shape, voxel, motion, filter="exact", device=device, **kw)
            y = op(np.asfortranarray(x))
            rms, mx = _errors(ref, y, inner)
            assert rms < 1e-3 and mx < 5e-3, f"{name}, move {np.round(move, 3)}: {rms:.2g} % RMS, {mx:.2g} % max"
            z = rng.random(shape).astype(np.float32)
            lhs = np.vdot(y.astype(np.float64), z)
            rhs = np.vdot(x.astype(np.float64), op.adjoint(np.asfortranarray(z)))
            assert abs(lhs - rhs) <= 1e-5 * abs(lhs), (name, lhs, rhs)


def test_sweep_reads_what_the_slice_misses(rng, device):
    shape = (40, 36, 34)
    x, voxel, move = _oblique(rng, shape, rng.uniform(6.5, 9.0))
    ref = _dense(x, move, times=800)  # 0.011 voxels apart at most: the midpoint rule's error far below AB's
    motion = petblur.Motion([0.0, 1.0], [[0.0, 0.0, 0.0], list(move * voxel)], [[1, 0, 0, 0], [1, 0, 0, 0]])
    inner = tuple(slice(10, n - 10) for n in shape)  # what never leaves the grid
    got = {}
    for name, kw in (("ab", {}), ("sweep", {"ab_sampling": "sweep"}), ("rm", {"method": "rm"})):
        op = petblur.BlurOperator(shape, voxel, motion, filter="exact", device=device, **kw)
        y = op(np.asfortranarray(x))
        assert np.all(np.isfinite(y))
        got[name] = _errors(ref, y, inner)
        # the transpose of each, to float rounding: <B x, z> = <x, B^T z>
        z = rng.random(shape).astype(np.float32)
        lhs, rhs = np.vdot(y.astype(np.float64), z), np.vdot(x.astype(np.float64), op.adjoint(np.asfortranarray(z)))
        assert abs(lhs - rhs) <= 1e-5 * abs(lhs), (name, lhs, rhs)
    msg = f"move {np.round(move, 2)} voxels: " + ", ".join(f"{k} {v[0]:.3f} % RMS {v[1]:.3f} % max"
                                                            for k, v in got.items())
    print(msg)
    assert got["sweep"][0] < 0.65 * got["ab"][0] and got["sweep"][1] < 0.65 * got["ab"][1], msg


def test_sweep_is_abs_alone(device):
    m = petblur.Motion.from_axis_angle(translation=[2.0, 1.0, 0.5])
    with pytest.raises(ArgumentError, match="ab_sampling is set, but the method is RM"):
        petblur.BlurOperator((8, 8, 8), 1.0, m, method="rm", ab_sampling="sweep", device=device)
    with pytest.raises(ArgumentError, match="ab_sampling 'diagonal'"):
        petblur.BlurOperator((8, 8, 8), 1.0, m, ab_sampling="diagonal", device=device)
    with pytest.raises(ArgumentError, match="ab_sampling"):
        petblur.BlurOperator((8, 8, 8), 1.0, m, ab_sampling=["sweep"], device=device)
    # slice is the default's name, and the operator keeps its sampling through a
    # copy (a move long enough for AB to walk: shorter ones are read exactly)
    import copy
    import pickle
    m = petblur.Motion.from_axis_angle(translation=[7.0, 3.5, 1.5])
    a = petblur.BlurOperator((12, 12, 12), 1.0, m, device=device)
    b = petblur.BlurOperator((12, 12, 12), 1.0, m, ab_sampling="slice", device=device)
    s = petblur.BlurOperator((12, 12, 12), 1.0, m, ab_sampling="sweep", device=device)
    x = np.random.default_rng(0).random((12, 12, 12)).astype(np.float32)
    np.testing.assert_array_equal(a(x), b(x))
    assert not np.array_equal(a(x), s(x))
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(s))(x), s(x))
    np.testing.assert_array_equal(copy.deepcopy(s)(x), s(x))
