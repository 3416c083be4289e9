"""petblur.pose: the derivative of a blur in each sample of its motion (what
petblur.torch.blur_posed gives autograd), on the host backend, without torch.

- against central finite differences of B(xi) x, each sample's pose moved
  alone (petblur.pose.posed_operator), on a fresh smooth object and a fresh
  four-sample track (CL, which follows the track's true path; AB and RM walk
  chords between key poses, whose derivative in one sample's rotation is not
  the path's: docs/python.md, "Pose gradients"); at xi = 0 and at a fresh
  xi far from it (the chain through G's Jacobian);
- vjp, one transpose per sub-window dotted with the gradient images computed
  here, against derivatives, the C library's pb_blur_pose_derivative;
- the samples' derivatives summing to the whole frame's, the hat weights'
  integrals, the motion's world coordinates (an affine that turns and
  mirrors), and the refusals."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import petblur
from petblur import pose

SHAPE = (26, 24, 22)
VOXEL = np.array([2.0, 2.2, 2.5])


def smooth_object(rng, shape=SHAPE):
    """Gaussian blobs 3 to 4.5 voxels wide near the middle, tapered to zero
    over the outer 30 % of each axis: the object is zero outside the grid, as
    the blur takes it, and smooth inside."""
    idx = np.meshgrid(*[np.arange(n, dtype=np.float64) for n in shape], indexing="ij")
    x = np.zeros(shape)
    for _ in range(10):
        c = rng.uniform(0.38, 0.62, 3) * np.array(shape)
        w = rng.uniform(3.0, 4.5)
        x += rng.uniform(0.5, 1.0) * np.exp(-0.5 * sum((idx[a] - c[a]) ** 2 for a in range(3)) / w ** 2)
    for a in range(3):
        u = (np.arange(shape[a]) + 0.5) / shape[a]
        t = np.clip((np.minimum(u, 1 - u) - 0.08) / 0.22, 0, 1)
        sh = [1, 1, 1]
        sh[a] = shape[a]
        x = x * (t * t * (3 - 2 * t)).reshape(sh)
    return x.astype(np.float32)


def random_motion(rng, k=4, shift=8.0, turn=6.0, shape=SHAPE, voxel=VOXEL):
    """k samples over [0, 1] s, each a translation up to `shift` mm per axis
    and a turn up to `turn` degrees about a fresh axis, about a fresh centre
    near the grid's."""
    times = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0.15, 0.85, k - 2)]))
    q = []
    for _ in range(k):
        axis = rng.normal(size=3)
        q.append(Rotation.from_rotvec(np.deg2rad(rng.uniform(-turn, turn)) * axis / np.linalg.norm(axis))
                 .as_quat()[[3, 0, 1, 2]])
    centre = rng.uniform(0.4, 0.6, 3) * np.array(shape) * voxel
    return petblur.Motion(times, rng.uniform(-shift, shift, (k, 3)), np.array(q), center=centre)


def rel_rms(a, b):
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def finite_difference(op, x, k, j, eps, xi0=None):
    xi = np.zeros((len(op.motion), 6)) if xi0 is None else np.array(xi0, dtype=np.float64)
    xi[k, j] += eps
    plus = pose.posed_operator(op, xi)(x).astype(np.float64)
    xi[k, j] -= 2 * eps
    minus = pose.posed_operator(op, xi)(x).astype(np.float64)
    return (plus - minus) / (2 * eps)


def fd_errors(op, x, d, xi0=None, samples=None):
    """d[k, j] against central differences, translations by half a voxel,
    rotations by 2 degrees: {(k, j): (squared error, squared norm)}. The
    differences see the trilinear fetches' slope, the derivative the central
    differences': the sampling is most of what is left, more where a sample's
    intervals inside the frame are short."""
    out = {}
    for k in range(len(op.motion)) if samples is None else samples:
        for j in range(6):
            eps = 0.5 * float(op.voxel_size.min()) if j < 3 else np.deg2rad(2.0)
            fd = finite_difference(op, x, k, j, eps, xi0)
            out[k, j] = (float(np.sum((d[k, j] - fd) ** 2)), float(np.sum(fd ** 2)))
    return out


# Relative RMS errors measured over 40 fresh draws of the test below (seeds
# 0-39): each component alone, translations 1.4-14 % (mean 4.8), rotations
# 3.5-32 % (mean 9.9; the worst for a sample with 0.07 s of the frame); all
# samples' translations together 3.0-6.3 %, rotations 6.1-12 %. Over 60 more
# draws (seeds 300000-300059): translations together median 4.0 %, largest
# 5.5 %; rotations together median 7.9 %, 99th percentile 17.5 %, largest
# 19.0 % (seed 300037, which failed the 18 % held before: its tail above the
# 90th percentile, 12.5 %, an exponential of mean 2.7 %, put 18 % at about 1
# failure in 100 runs; 40 % at 1 in 300,000, a bound from 6 tail points, so
# loose); each rotation component largest 31 %, each translation 14 %. A
# wrong sign, centre, hat or frame is 50 % and more.
BLOCK_TOL = {"v": 0.10, "w": 0.40}
COMPONENT_TOL = {"v": 0.25, "w": 0.5}


# One sample's blocks alone (test_world_coordinates), measured over 400 fresh
# draws of that test (seeds 0-399, the host backend): translations at most
# 7.6 %; rotations median 10.3 %, 99th percentile 18.4 %, largest 20.2 % (and
# 22.4 % once in CI). Again over 400 other draws (seeds 100000-100399):
# translations median 5.1 %, 99th percentile 7.0 %, largest 7.9 %; rotations
# median 10.4 %, 99th percentile 19.5 %, largest 21.7 %; CI's seed 4217072640
# replays at 26.1 % here. The rotations' tail above its 90th percentile
# (14.5 %) falls off as an exponential of mean 2.1 %: 32 % would fail about 1
# run in 40,000, 36 % 1 in 300,000. A wrong sign, centre or mirror is 50 % and
# more.
ONE_SAMPLE_BLOCK_TOL = {"v": 0.15, "w": 0.36}


def check(errors, request, block_tol=BLOCK_TOL):
    """Each component within COMPONENT_TOL, and each of the blocks (all the
    samples' translations together, their rotations) within block_tol."""
    for (k, j), (num, den) in sorted(errors.items()):
        request.node.user_properties.append((f"sample {k} {'vw'[j // 3]}{'xyz'[j % 3]}", float(np.sqrt(num / den))))
    print(" ".join(f"{k}{'vw'[j // 3]}{'xyz'[j % 3]} {100 * np.sqrt(n / d):.1f}%"
                   for (k, j), (n, d) in sorted(errors.items())))
    for block in "vw":
        part = [(n, d) for (k, j), (n, d) in errors.items() if "vw"[j // 3] == block]
        total = np.sqrt(sum(n for n, _ in part) / sum(d for _, d in part))
        print(f"{block}: {100 * total:.1f} % RMS")
        assert total < block_tol[block], f"{block}: {100 * total:.1f} % RMS from finite differences"
    for (k, j), (n, d) in errors.items():
        e = np.sqrt(n / d)
        assert e < COMPONENT_TOL["vw"[j // 3]], f"sample {k}, component {j}: {100 * e:.1f} % RMS"


def test_derivatives_match_finite_differences(rng, request):
    x = smooth_object(rng)
    m = random_motion(rng)
    op = petblur.BlurOperator(SHAPE, VOXEL, m, frame=(0.1, 0.9), method="cl", filter="exact", device="host")
    check(fd_errors(op, x, pose.derivatives(op, x)), request)


def test_derivatives_at_far_xi(rng, request):
    """At xi far from zero (4 mm, 5 degrees a sample): the derivative goes
    through G's Jacobian. Without it (the derivative at the moved poses in a
    perturbation composed on their right) the rotations' differ by 17-160 %
    (30 draws), with it as at xi = 0.

    It checks one sample, so against one sample's bounds: over 199 draws
    (seeds 200000-200198, host) its blocks' translations median 4.5 %,
    largest 8.3 %, rotations median 7.0 %, 99th percentile 14.7 %, largest
    15.6 %, whose tail (an exponential of mean 1.7 % above the 90th
    percentile, 10.7 %) put the four samples' 18 % at about 1 failure in 700
    runs, and puts 36 % below 1 in 10^7. The derivative without G's Jacobian
    differed by median 71 %, smallest 11.5 % (1st percentile 21 %); it must
    differ by 5 %: a derivative that skipped the Jacobian would be the naive
    one itself, 0 %."""
    x = smooth_object(rng)
    m = random_motion(rng, k=3)
    op = petblur.BlurOperator(SHAPE, VOXEL, m, frame=(0.0, 1.0), method="cl", filter="exact", device="host")
    xi0 = np.concatenate([rng.uniform(-4, 4, (3, 3)), np.deg2rad(rng.uniform(-5, 5, (3, 3)))], axis=1)
    d = pose.derivatives(op, x, xi0)
    check(fd_errors(op, x, d, xi0, samples=[1]), request, ONE_SAMPLE_BLOCK_TOL)
    placed = pose._Placed(op)
    moved = placed.operator(petblur.BlurOperator, motion=placed.motion(placed.xi(xi0)), frame=op.frame)
    naive = pose.derivatives(moved, x)
    assert max(rel_rms(naive[1, j], d[1, j]) for j in range(3, 6)) > 0.05


def test_vjp_equals_derivatives(rng):
    """<y, d(B x)/d xi_k> by transposes and gradient images made in Python,
    against the C library's derivative images: float rounding apart."""
    x = smooth_object(rng)
    m = random_motion(rng)
    op = petblur.BlurOperator(SHAPE, VOXEL, m, frame=(0.1, 0.9), device="host")  # AB, the default
    y = rng.random(SHAPE, dtype=np.float32)
    for xi in (None, 0.02 * rng.normal(size=(4, 6))):
        d = pose.derivatives(op, x, xi).astype(np.float64)
        want = np.einsum("kjabc,abc->kj", d, y.astype(np.float64))
        got = pose.vjp(op, x, y, xi)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 * np.abs(want).max())
    # C order and float64 take the same path.
    got64 = pose.vjp(op, np.ascontiguousarray(x, dtype=np.float64), np.asfortranarray(y), None)
    np.testing.assert_allclose(got64, pose.vjp(op, x, y), rtol=0, atol=1e-5 * np.abs(got64).max())


def test_gradient_images_are_the_library_s(rng):
    """gradient_images against pb_blur_pose_derivative of a motion at rest
    for a whole frame, which blurs them by the identity."""
    x = smooth_object(rng, (9, 8, 7)) + rng.random((9, 8, 7), dtype=np.float32)
    m = petblur.Motion([0.0, 1.0], np.zeros((2, 3)), [[1, 0, 0, 0]] * 2, center=rng.uniform(0, 20, 3))
    op = petblur.BlurOperator((9, 8, 7), VOXEL, m, method="cl", filter="exact", device="host")
    d = pose.derivatives(op, x)
    images = pose.gradient_images(x, VOXEL, m.center)
    for j in range(6):
        np.testing.assert_allclose(d[0, j] + d[1, j], images[j], rtol=0, atol=1e-5 * np.abs(images[j]).max())


def test_samples_sum_to_the_frame(rng):
    """The hat weights are a partition of unity: the samples' derivatives sum
    to the derivative of every pose moved together, the frame's blur of the
    gradient images, to the time sampling of the sub-windows' blurs (CL's 64
    steps a segment: measured 1.2e-5 to 6.2e-5 over 20 draws; 3.7e-3 with
    CL's default steps)."""
    shape = (12, 11, 10)
    x = smooth_object(rng, shape) + 0.2 * rng.random(shape, dtype=np.float32)
    m = random_motion(rng, shape=shape, shift=4.0)
    op = petblur.BlurOperator(shape, VOXEL, m, frame=(0.1, 0.9), method="cl", filter="exact", device="host", steps=64)
    d = pose.derivatives(op, x).sum(axis=0)
    images = pose.gradient_images(x, VOXEL, pose._Placed(op).center)
    for j in range(6):
        assert rel_rms(d[j], op(images[j])) < 3e-4


@pytest.mark.parametrize("nodes", [1, 2, 3])
def test_hat_weights(rng, nodes):
    """The pieces' weights integrate each sample's hat over the frame
    exactly (the quadrature is exact for a blur constant in time)."""
    times = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0.05, 0.95, 5)]))
    t0, t1 = rng.uniform(0.0, 0.3), rng.uniform(0.7, 1.0)
    bounds, k_of, w_lo, w_hi = pose._pieces(times, t0, t1, nodes)
    assert bounds[0] == t0 and bounds[-1] == t1 and np.all(np.diff(bounds) > 0)
    assert bounds.size == k_of.size + 1
    share = np.zeros(times.size)
    np.add.at(share, k_of, w_lo)
    np.add.at(share, k_of + 1, w_hi)
    # Each sample's hat, integrated over [t0, t1] by trapezoids between its breaks: exactly.
    t = np.unique(np.concatenate([[t0, t1], times[(times > t0) & (times < t1)]]))
    want = []
    for k in range(times.size):
        h = np.interp(t, times, np.eye(times.size)[k])
        want.append(float(np.sum(np.diff(t) * (h[1:] + h[:-1]) / 2)) / (t1 - t0))
    np.testing.assert_allclose(share, want, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.diff(bounds), (bounds[-1] - bounds[0]) * (w_lo + w_hi), rtol=1e-12)


def test_world_coordinates(rng, request):
    """With an affine that turns and mirrors the grid, xi is in world mm
    about the motion's world centre: posed_operator equals an operator of
    the world track whose samples are moved here, in world coordinates, and
    vjp in world coordinates is the grid's mapped (a turn and a mirror)."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q[:, 0] *= -np.sign(np.linalg.det(q))  # a mirror
    affine = np.eye(4)
    affine[:3, :3] = q * VOXEL[None, :]
    affine[:3, 3] = rng.uniform(-60, 60, 3)
    k = 3
    m = random_motion(rng, k=k, shift=3.0)
    world_centre = affine[:3, :3] @ (np.array(SHAPE) / 2 - 0.5) + affine[:3, 3] + rng.uniform(-5, 5, 3)
    m = petblur.Motion(m.times, m.translations, m.quaternions, center=world_centre)
    op = petblur.BlurOperator(SHAPE, VOXEL, m, affine=affine, method="cl", filter="exact", device="host")
    xi = np.concatenate([rng.uniform(-2, 2, (k, 3)), np.deg2rad(rng.uniform(-4, 4, (k, 3)))], axis=1)
    # T_k G(xi_k)^-1 in world coordinates, about the world centre, by SciPy: R_k R(w)^T, t_k - R_k R(w)^T v.
    t2, q2 = m.translations.copy(), m.quaternions.copy()
    for i in range(k):
        ri = Rotation.from_quat(m.quaternions[i][[1, 2, 3, 0]]) * Rotation.from_rotvec(xi[i, 3:]).inv()
        q2[i] = ri.as_quat()[[3, 0, 1, 2]]
        t2[i] = m.translations[i] - ri.apply(xi[i, :3])
    want_op = petblur.BlurOperator(SHAPE, VOXEL, petblur.Motion(m.times, t2, q2, center=world_centre),
                                   affine=affine, method="cl", filter="exact", device="host")
    x = smooth_object(rng)
    want = want_op(x)
    np.testing.assert_allclose(pose.posed_operator(op, xi)(x), want, rtol=0, atol=1e-4 * want.max())
    # One sample's derivative in world coordinates against finite differences of the world perturbation.
    check(fd_errors(op, x, pose.derivatives(op, x), samples=[1]), request, ONE_SAMPLE_BLOCK_TOL)


def test_refusals():
    m = petblur.Motion.from_axis_angle(translation=(2, 0, 0), angle=3)
    op = petblur.BlurOperator((8, 8, 8), 2.0, m, device="host")
    x = np.ones((8, 8, 8), dtype=np.float32)
    with pytest.raises(petblur.ArgumentError, match=r"give \(2, 6\)"):
        pose.vjp(op, x, x, np.zeros((3, 6)))
    with pytest.raises(petblur.ArgumentError, match="NaN"):
        pose.posed_operator(op, np.full((2, 6), np.nan))
    with pytest.raises(petblur.ArgumentError, match="nodes"):
        pose.vjp(op, x, x, None, nodes=0)
    frames = petblur.FramesOperator((8, 8, 8), 2.0, m, [0, 0.5, 1], device="host")
    with pytest.raises(petblur.ArgumentError, match="BlurOperator"):
        pose.derivatives(frames, x)
    assert pose.posed_operator(op, np.zeros((2, 6))) is op
