"""BlurOperator and FramesOperator over numpy arrays, on the host reference
and on OpenCL: against an independent numpy integral, against the command
line, adjointness, memory orders, dtypes, shapes and refusals."""

import subprocess

import nibabel as nib
import numpy as np
import pytest

import petblur


def _turn(rng):
    return petblur.Motion.from_axis_angle(translation=rng.uniform(-4, 4, 3), angle=rng.uniform(8, 25),
                                          axis=(0.3, -0.2, 1.0))


def test_translation_equals_the_path_integral(device, rng):
    """A move of d whole voxels along an axis with float weights: each voxel
    is the average of the object along its path from v to v - d, which linear
    interpolation makes the trapezoid rule over d + 1 voxels."""
    shape, vox = (23, 17, 12), (1.5, 2.0, 2.5)
    for axis, d in ((0, int(rng.integers(3, 9))), (1, int(rng.integers(3, 9))), (2, int(rng.integers(2, 6)))):
        t = np.zeros(3)
        t[axis] = d * vox[axis]
        op = petblur.BlurOperator(shape, vox, petblur.Motion.from_axis_angle(translation=t), filter="exact",
                                  device=device)
        x = rng.random(shape, dtype=np.float32)
        pad = [(0, 0)] * 3
        pad[axis] = (d, 0)
        xp = np.pad(x.astype(np.float64), pad)  # zero outside the grid
        n = shape[axis]
        ref = np.zeros(shape)
        for k in range(d + 1):  # x at v - k, k = 0..d
            w = 0.5 if k in (0, d) else 1.0
            ref += w * np.take(xp, np.arange(d - k, d - k + n), axis=axis)
        ref /= d
        y = op(x)
        assert y.dtype == np.float32 and y.shape == shape
        np.testing.assert_allclose(y, ref, rtol=0, atol=2e-6 * ref.max())


@pytest.mark.parametrize("method", ["ab", "rm", "cl"])
def test_adjointness(device, rng, method):
    op = petblur.BlurOperator((19, 14, 11), (1.2, 1.5, 1.1), _turn(rng), method=method, device=device)
    assert op.adjointness_test(rtol=1e-4, seed=int(rng.integers(1 << 30))) <= 1e-4
    # The paper's polyline (one segment, no bound): its own operator, also transposed exactly.
    if method != "cl":
        turn = petblur.Motion.from_axis_angle(angle=80.0)  # the default bound cuts it, the paper does not
        paper, bounded = (petblur.BlurOperator(op.in_shape, op.voxel_size, turn, method=method, max_path_error=e,
                                               device=device) for e in ("paper", None))
        x = rng.random(op.in_shape, dtype=np.float32)
        assert np.abs(paper(x) - bounded(x)).max() > 1e-3
        assert paper.adjointness_test(seed=int(rng.integers(1 << 30))) <= 1e-4
    # And by hand, in C order and in Fortran order.
    for order in ("C", "F"):
        x = np.asarray(rng.random(op.in_shape, dtype=np.float32), order=order)
        y = np.asarray(rng.random(op.out_shape, dtype=np.float32), order=order)
        a, b = np.vdot(op(x).astype(np.float64), y), np.vdot(x, op.adjoint(y).astype(np.float64))
        assert abs(a - b) <= 1e-5 * abs(a)


def test_memory_orders_agree(device, rng):
    """C order (numpy's) runs on the transposed grid: the same operator.

    But for a voxel whose path has a segment with two largest extents tied
    within float rounding: AB walks along the major axis (ties: the lower
    one, another axis in the transposed grid), so on a float device the two
    orders may walk that segment along different axes (the host, in double,
    gives them bit for bit). Over 3000 draws on PoCL (seeds 500000-502999)
    9 had such a voxel, one each, off by 4e-5 to 1.66e-2 of the largest
    value, every other voxel within 1.8e-6 (median of the largest 1.2e-6,
    99th percentile 2.2e-6): 1e-5 on every voxel failed 1 run in 330. So at
    most two voxels may sit beyond 1e-5, within 5 % (a walk along another
    axis is still an average of the same inputs); a wrong transposition
    moves every voxel by tens of %."""
    op = petblur.BlurOperator((21, 14, 9), (1.2, 1.5, 1.9), _turn(rng), filter="exact", device=device)
    x = rng.random(op.in_shape, dtype=np.float32)
    yc, yf = op(np.ascontiguousarray(x)), op(np.asfortranarray(x))
    assert yc.flags.c_contiguous and yf.flags.f_contiguous
    off = np.abs(yc.astype(np.float64) - yf) / float(yc.max())
    worst = np.sort(off.ravel())[::-1]
    assert worst[2] <= 1e-5 and worst[0] <= 0.05, \
        f"C against Fortran order: largest differences {[repr(float(v)) for v in worst[:4]]} of the largest value"
    # Any other strides are copied: a view of every other voxel of a larger array.
    big = np.zeros((42, 14, 9), dtype=np.float32)
    big[::2] = x
    np.testing.assert_array_equal(op(big[::2]), yc)


def test_dtypes(device, rng):
    op = petblur.BlurOperator((10, 9, 8), 2.0, _turn(rng), device=device)
    x = rng.random(op.in_shape, dtype=np.float32)
    y32, y64 = op(x), op(x.astype(np.float64))
    assert y64.dtype == np.float64
    np.testing.assert_array_equal(y64, y32.astype(np.float64))
    for bad in (x.astype(np.int32), x.astype(np.float16), x.astype(np.complex64)):
        with pytest.raises(petblur.ArgumentError, match="float32"):
            op(bad)
    # NaN and infinity are refused, named by the array's own index, in either order.
    for order in ("C", "F"):
        for value in (np.nan, np.inf):
            bad = np.array(x, order=order)
            i, j, k = (int(rng.integers(n)) for n in bad.shape)
            bad[i, j, k] = value
            with pytest.raises(petblur.ArgumentError, match=rf"\[{i}, {j}, {k}\]") as e:
                op.adjoint(bad)
            assert e.value.status == -4


def test_shapes_and_refusals(device, rng):
    m = _turn(rng)
    op = petblur.BlurOperator((10, 9, 8), (2, 2, 2), m, device=device)
    assert op.in_shape == op.out_shape == (10, 9, 8)
    assert op.device.startswith(device)
    with pytest.raises(petblur.ArgumentError, match=r"\(8, 9, 10\)"):
        op(np.zeros((8, 9, 10), np.float32))
    with pytest.raises(petblur.ArgumentError, match="numpy"):
        op([[[1.0]]])
    for kwargs, pattern in [({"method": "xx"}, "method"), ({"filter": "linear"}, "filter"),
                            ({"max_path_error": -1}, "max_path_error"), ({"frame": (1, 0)}, "frame")]:
        with pytest.raises(petblur.ArgumentError, match=pattern):
            petblur.BlurOperator((10, 9, 8), 2.0, m, device=device, **kwargs)
    with pytest.raises(petblur.ArgumentError, match="shape"):
        petblur.BlurOperator((10, 0, 8), 2.0, m, device=device)
    for bad in ((2, -1, 2), 1e-300, (1, 1, np.inf)):
        with pytest.raises(petblur.ArgumentError, match="voxel_size"):
            petblur.BlurOperator((10, 9, 8), bad, m, device=device)
    for steps in (-1, 1 << 40):  # not wrapped into C's unsigned
        with pytest.raises(petblur.ArgumentError, match="steps"):
            petblur.BlurOperator((10, 9, 8), 2.0, m, device=device, steps=steps)
    with pytest.raises(petblur.ArgumentError, match="4x4"):
        petblur.BlurOperator((10, 9, 8), 2.0, m, device=device, affine=np.eye(3))
    with pytest.raises(petblur.Error) as e:  # the frame outside the track: the library's own check and words
        petblur.BlurOperator((10, 9, 8), 2.0, m, frame=(0.5, 3.0), device=device)
    assert e.value.status < 0 and "3" in e.value.message
    with pytest.raises(petblur.DeviceError):
        petblur.BlurOperator((10, 9, 8), 2.0, m, device="opencl:99")
    with pytest.raises(petblur.ArgumentError):
        petblur.BlurOperator((10, 9, 8), 2.0, m, device="gpu")


def test_motion_refusals():
    with pytest.raises(petblur.ArgumentError, match="at least two"):
        petblur.Motion([0.0], [[0, 0, 0]], [[1, 0, 0, 0]])
    with pytest.raises(petblur.ArgumentError, match=r"\(2, 4\)"):
        petblur.Motion([0, 1], np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(petblur.ArgumentError, match="increase"):
        petblur.Motion([1, 1], np.zeros((2, 3)), [[1, 0, 0, 0]] * 2)
    with pytest.raises(petblur.ArgumentError, match="NaN"):
        petblur.Motion([0, 1], [[0, 0, 0], [np.nan, 0, 0]], [[1, 0, 0, 0]] * 2)
    with pytest.raises(petblur.ArgumentError, match="the motion:2: the quaternion's norm is 2"):
        petblur.Motion([0, 1], np.zeros((2, 3)), [[1, 0, 0, 0], [2, 0, 0, 0]])  # refused by the library
    with pytest.raises(petblur.ArgumentError, match="axis"):
        petblur.Motion.from_axis_angle(angle=10, axis=(0, 0, 0))


def test_frames(device, rng):
    shape, vox = (13, 11, 9), (1.4, 1.2, 1.7)
    n = 9
    times = np.linspace(0, 8, n)
    q = np.array([[np.cos(a / 2), 0, 0, np.sin(a / 2)] for a in np.radians(rng.uniform(-6, 6, n))])
    track = petblur.Motion(times, rng.uniform(-3, 3, (n, 3)), q)
    bounds = [0.0, 2.5, 5.0, 8.0]
    F = petblur.FramesOperator(shape, vox, track, bounds, device=device)
    assert F.in_shape == shape and F.out_shape == (3,) + shape
    x = rng.random(shape, dtype=np.float32)
    y = F(x)
    singles = [petblur.BlurOperator(shape, vox, track, frame=(bounds[i], bounds[i + 1]), device=device)
               for i in range(3)]
    for i, B in enumerate(singles):
        np.testing.assert_allclose(y[i], B(x), rtol=0, atol=1e-6)
    # Per frame in, per frame out; the adjoint summed or not.
    xs = rng.random((3,) + shape, dtype=np.float32)
    ys = F(xs)
    for i, B in enumerate(singles):
        np.testing.assert_allclose(ys[i], B(xs[i]), rtol=0, atol=1e-6)
    r = rng.random((3,) + shape, dtype=np.float32)
    summed = F.adjoint(r)
    each = F.adjoint(r, sum=False)
    assert summed.shape == shape and each.shape == (3,) + shape
    np.testing.assert_allclose(summed, each.sum(axis=0), rtol=0, atol=1e-5)
    for i, B in enumerate(singles):
        np.testing.assert_allclose(each[i], B.adjoint(r[i]), rtol=0, atol=1e-5)
    assert F.adjointness_test(seed=int(rng.integers(1 << 30))) <= 1e-4
    Fp = petblur.FramesOperator(shape, vox, track, bounds, per_frame=True, device=device)
    assert Fp.in_shape == (3,) + shape and Fp.adjointness_test() <= 1e-4
    with pytest.raises(petblur.ArgumentError, match="frames"):
        F.adjoint(r[:2])


def _nifti(path, data, affine):
    nib.Nifti1Image(np.asarray(data, dtype=np.float32), affine).to_filename(str(path))


def test_equals_the_command_line(tmp_path, device, rng, cli):
    """The same blur through the program and through Python, in world
    coordinates of an oblique, reflected NIfTI placement."""
    shape, vox = (17, 13, 11), np.array([1.5, 1.7, 2.0])
    a = np.radians(rng.uniform(5, 30))
    R = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]) @ np.diag([-1, 1, 1])
    affine = np.eye(4)
    affine[:3, :3] = R * vox
    affine[:3, 3] = rng.uniform(-50, 50, 3)
    x = rng.random(shape, dtype=np.float32)
    _nifti(tmp_path / "x.nii", x, affine)
    # As stored (float32 in the header), as the program reads them: RM's
    # sample count per voxel is a whole number that a voxel size 3e-8 off can
    # change on paths that end near a slice boundary.
    img = nib.load(str(tmp_path / "x.nii"))
    affine, vox = img.affine, np.array(img.header.get_zooms()[:3], dtype=np.float64)
    t, deg, axis = rng.uniform(-6, 6, 3), rng.uniform(-20, 20), (0.2, 0.1, 1.0)
    for adjoint in (False, True):
        cmd = [cli, "blur", "-q", "-i", str(tmp_path / "x.nii"), "-o", str(tmp_path / "y.nii"), "--device", device,
               "--translate", ",".join(f"{v:.17g}" for v in t), "--rotate", f"{deg:.17g}",
               "--axis", ",".join(str(v) for v in axis), "--method", "rm"]
        subprocess.run(cmd + (["--adjoint"] if adjoint else []), check=True)
        want = nib.load(str(tmp_path / "y.nii")).get_fdata(dtype=np.float32)
        op = petblur.BlurOperator(shape, vox, petblur.Motion.from_axis_angle(t, deg, axis), method="rm",
                                  device=device, affine=affine)
        # x fastest, as the program holds volumes: the same plan, the same bits
        # but for the adjoint's atomics; in C order the transposed grid's plan.
        xf = np.asfortranarray(x)
        got = op.adjoint(xf) if adjoint else op(xf)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-6 * want.max())
        got = op.adjoint(x) if adjoint else op(x)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 * want.max())
