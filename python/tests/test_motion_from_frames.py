"""petblur.Motion.from_frames: motion estimated from a dynamic series in
Python, against the program (`petblur motion estimate` on the same series
written as NIfTI and a BIDS sidecar, its track read here with numpy), against
a known motion (a series simulated here with numpy and SciPy, without
petblur), and on bad inputs (refused with the library's error classes and a
message naming the problem, the caller's array left as it was).

The simulated series: a smooth phantom (a sum of anisotropic Gaussians, fresh
each run), on a grid stored LAS and turned obliquely in the world, moved by a
known rigid map per frame, the tracer's uptake drifting from frame to frame,
Poisson counts; one frame holds a jerk: its first part shows the pose of the
frame before, the rest that of the frame after, 8 mm and 8 degrees on."""

import ast
import json
import os
import pickle
import re
import subprocess
import time

import nibabel as nib
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import petblur
from petblur.errors import ArgumentError

# ---- a series made without petblur ----------------------------------------


def _rigid(rng, deg, mm):
    """A 4x4 world map about the world's origin: a turn of deg degrees about a
    random axis and a shift of up to mm per axis."""
    axis = rng.normal(size=3)
    m = np.eye(4)
    m[:3, :3] = Rotation.from_rotvec(np.radians(deg) * axis / np.linalg.norm(axis)).as_matrix()
    m[:3, 3] = rng.uniform(-mm, mm, 3)
    return m


def _affine(rng, shape, voxel):
    """Voxel index to world mm: x flipped (LAS, as many scanners store), the
    grid turned 8 to 20 degrees about an oblique axis, its centre near the
    world's origin. Exact in float32, so that the program reads from the
    NIfTI header the very numbers given to from_frames: the rotation is
    Euler-Rodrigues' of an integer quaternion (integer entries over its norm
    n), the voxel sizes are n times a dyadic number near the size asked for,
    the offsets dyadic; the columns' lengths are exactly the header's voxel
    sizes (pixdim), which the program takes as the grid's while from_frames
    takes the columns' lengths. (The estimate is a chain of float32 images,
    iterations that stop at a tolerance and non-negative least squares: a
    last-bit change of a voxel size moves its track by up to 1e-5 mm on the
    host and 0.03 mm with OpenCL, as measured while writing this test.)"""
    a, b, c, d = int(rng.integers(10, 15)), *(int(v) for v in rng.integers(-1, 2, 3))
    if b == c == d == 0:
        b = 1
    n = a * a + b * b + c * c + d * d
    m = np.array([[a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)],
                  [2 * (b * c + a * d), a * a - b * b + c * c - d * d, 2 * (c * d - a * b)],
                  [2 * (b * d - a * c), 2 * (c * d + a * b), a * a - b * b - c * c + d * d]], dtype=np.float64)
    scale = np.round(np.asarray(voxel, dtype=np.float64) / n * 4096.0) / 4096.0
    out = np.eye(4)
    out[:3, :3] = m * scale
    out[:3, 0] = -out[:3, 0]
    centre = out[:3, :3] @ ((np.array(shape) - 1) / 2.0)
    out[:3, 3] = np.round((rng.uniform(-5.0, 5.0, 3) - centre) * 64.0) / 64.0
    assert np.array_equal(out.astype(np.float32), out)
    assert np.array_equal(np.linalg.norm(out[:3, :3], axis=0), n * scale)
    return out


class Phantom:
    """Activity in world mm: six anisotropic Gaussians (sigma 5 to 14 mm) whose
    weights drift by up to 10 % over the series (uptake changing)."""

    def __init__(self, rng, n=6):
        self.centres = rng.uniform(-22.0, 22.0, (n, 3))
        self.inverse_covariances = []
        for _ in range(n):
            q = _rigid(rng, rng.uniform(0.0, 180.0), 0.0)[:3, :3]
            self.inverse_covariances.append(q @ np.diag(rng.uniform(5.0, 14.0, 3) ** -2.0) @ q.T)
        self.weights = rng.uniform(0.5, 1.5, n)
        self.drift = 1.0 + 0.1 * rng.uniform(-1.0, 1.0, n)

    def __call__(self, points, u=0.0):
        """Activity at points [N, 3] at u, the fraction of the series gone."""
        out = np.zeros(len(points))
        for c, ic, w, d in zip(self.centres, self.inverse_covariances, self.weights, self.drift):
            p = points - c
            out += w * d ** u * np.exp(-0.5 * np.einsum("ni,ij,nj->n", p, ic, p))
        return out

    def inside(self, rng, n=2000):
        """n points where the activity is above a quarter of its highest at a
        blob's centre."""
        peak = self(self.centres).max()
        keep = []
        while sum(len(k) for k in keep) < n:
            p = rng.uniform(-40.0, 40.0, (20 * n, 3))
            keep.append(p[self(p) > 0.25 * peak])
        return np.concatenate(keep)[:n]


class Series:
    """Frames [x, y, z, t] float32 of a moving phantom, with the truth: maps[k]
    is frame k's world map (None for the jerk frame), truth(t) the map at t."""

    def __init__(self, rng, shape, voxel, frames, jerk, seconds=10.0, counts=1e6, at=0.4, frame_counts=None):
        self.affine = _affine(rng, shape, voxel)
        self.phantom = Phantom(rng)
        self.starts = np.arange(frames) * seconds
        self.durations = np.full(frames, seconds)
        self.jerk, self.jerk_time = jerk, (jerk + at) * seconds
        maps = [np.eye(4)] + [_rigid(rng, 4.0, 4.0) for _ in range(frames - 1)]
        step = _rigid(rng, 8.0, 0.0)
        v = rng.normal(size=3)
        step[:3, 3] = 8.0 * v / np.linalg.norm(v)
        # the jerk from the frame before's pose to the frame after's; in the
        # series' first or last frame, from or to a pose no other frame holds
        if jerk > 0:
            self.before = maps[jerk - 1]
            self.after = step @ self.before
            if jerk + 1 < frames:
                maps[jerk + 1] = self.after
        else:
            self.after = maps[1]
            self.before = np.linalg.inv(step) @ self.after
        maps[jerk] = None
        self.maps = maps
        idx = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), axis=-1).reshape(-1, 3)
        world = idx @ self.affine[:3, :3].T + self.affine[:3, 3]

        def view(m, k):
            # the tomograph's point w shows the object's point m^-1 w
            inv = np.linalg.inv(m)
            return self.phantom(world @ inv[:3, :3].T + inv[:3, 3], k / (frames - 1)).reshape(shape)

        self.frames = np.zeros(tuple(shape) + (frames,), np.float32)
        for k, m in enumerate(maps):
            v = view(m, k) if m is not None else at * view(self.before, k) + (1 - at) * view(self.after, k)
            self.frames[..., k] = rng.poisson(v * ((counts if frame_counts is None else frame_counts[k]) / v.sum()))

    def truth(self, t):
        k = min(int(t // self.durations[0]), len(self.maps) - 1)
        if k == self.jerk:
            return self.before if t < self.jerk_time else self.after
        return self.maps[k]

    def write(self, path):
        """The series as a 4-D NIfTI and its BIDS sidecar; the affine and
        frames as the program reads them back."""
        nib.save(nib.Nifti1Image(self.frames, self.affine), str(path) + ".nii")
        with open(str(path) + ".json", "w") as f:
            json.dump({"FrameTimesStart": self.starts.tolist(), "FrameDuration": self.durations.tolist(),
                       "TracerName": "FDG"}, f)
        img = nib.load(str(path) + ".nii")
        return str(path) + ".nii", str(path) + ".json", img.get_fdata(dtype=np.float32), img.affine


def _map(motion, t):
    """The motion's 4x4 world map at t (pose_at about the world's origin;
    quaternions w,x,y,z turned into a matrix by SciPy)."""
    tr, q = motion.pose_at(t)
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()
    m[:3, 3] = tr
    return m


def _displacement(a, b, points):
    """Mean |a p - b p| over points, mm."""
    return np.linalg.norm(points @ (a[:3, :3] - b[:3, :3]).T + (a[:3, 3] - b[:3, 3]), axis=1).mean()


def _ball(rng, n=2000, radius=25.0):
    """n points uniform in a ball of radius mm about the origin: the phantom's region, by which a move is sized."""
    ball = rng.normal(size=(n, 3))
    return ball * radius * rng.uniform(0, 1, (n, 1)) ** (1 / 3) / np.linalg.norm(ball, axis=1, keepdims=True)


def _read_matrix_csv(path):
    """The program's matrix-csv track (t, r00, r01, r02, tx, r10, ...), read
    with numpy: times and 4x4 maps."""
    rows = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    with open(path) as f:
        assert f.readline().strip() == "t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz"
    maps = np.tile(np.eye(4), (len(rows), 1, 1))
    maps[:, :3, :] = rows[:, 1:13].reshape(-1, 3, 4)
    return rows[:, 0], maps


# ---- the same motion as the program's -----------------------------------

# The options as from_frames takes them and as the program's arguments.
OPTIONS = {
    "defaults": ({}, []),
    "options": (dict(reference=3, frame_poses_only=True, levels=2, iterations=6, fwhm=9.0),
                ["--reference", "3", "--frame-poses-only", "--levels", "2", "--iterations", "6", "--fwhm", "9"]),
}


@pytest.mark.parametrize("options", OPTIONS)
def test_matches_program(tmp_path, rng, cli, device, options):
    kw, args = OPTIONS[options]
    s = Series(rng, (24, 24, 24), (4.0, 4.0, 4.0), 5, jerk=2)
    nii, sidecar, frames, affine = s.write(tmp_path / "sub-01_pet")
    track = tmp_path / "track.csv"
    said = subprocess.run([cli, "motion", "estimate", nii, "--frames-from", sidecar, "--device", device, "--format",
                           "matrix-csv", "-o", str(track)] + args, check=True, capture_output=True, text=True).stdout
    t, want = _read_matrix_csv(track)

    frames = np.asfortranarray(frames)  # read in place: it must come back as it was
    before = frames.copy()
    if options == "defaults":
        m = petblur.Motion.from_frames(frames, affine, s.starts.tolist(), s.durations.tolist(), device=device)
    else:  # the bounds as the library's sidecar reader gives them
        m = petblur.Motion.from_frames(frames, affine, bounds=petblur.frames_from_sidecar(sidecar), device=device,
                                       **kw)
    assert np.array_equal(frames, before)

    assert m.about_origin and m.center is None
    got = np.array([_map(m, ti) for ti in t])
    print(f"times {np.abs(m.times - t).max():.3g} s, rotations {np.abs(got - want)[:, :3, :3].max():.3g}, "
          f"translations {np.abs(got - want)[:, :3, 3].max():.3g} mm")
    # The same numbers in (frames, affine, voxel sizes and bounds, bit for bit), the same track out, to the csv's
    # 12 digits.
    tol = 1e-6
    np.testing.assert_allclose(m.times, t, rtol=0, atol=tol)  # s
    np.testing.assert_allclose(got[:, :3, :3], want[:, :3, :3], rtol=0, atol=tol)  # rad
    np.testing.assert_allclose(got[:, :3, 3], want[:, :3, 3], rtol=0, atol=tol)  # mm
    # not a vacuous agreement: the series moves by millimetres
    assert np.abs(want[:, :3, 3]).max() > 1.0
    # the poses: one at each bound and frame mid-time, and more inside the jerk's frame unless told not to
    mids = s.starts + s.durations / 2
    assert np.all(np.isin(np.delete(mids, s.jerk), t))
    assert t[0] == s.starts[0] and t[-1] == s.starts[-1] + s.durations[-1]
    if kw.get("frame_poses_only"):  # and the curve's seven between middles
        assert m.moving_frames == 0 and len(t) == len(mids) + 2 + 7 * (len(mids) - 1)
    else:
        assert m.moving_frames >= 1 and len(t) > len(mids) + 2
        inside = t[(t > s.starts[s.jerk]) & (t < s.starts[s.jerk] + s.durations[s.jerk])]
        assert len(inside) > 1, t
    # the reference frame's pose is the identity: the one asked for, or the one chosen, which the program names
    ref = kw.get("reference", m.reference_frame)
    assert m.reference_frame == ref
    chosen = " (chosen: the still frame whose pose the frames determine best)" if "reference" not in kw else ""
    assert f"relative to frame {ref}{chosen}\n" in said, said
    np.testing.assert_allclose(_map(m, mids[ref]), np.eye(4), rtol=0, atol=1e-9)


def test_the_reference_frame_chosen(rng, device):
    """By default the track is relative to the frame held still whose pose
    the frames determine best, not to the first frame: a first frame of the
    tracer's first seconds has few counts, its pose is off by their noise,
    and relative to it every other frame would be off by as much. The passes
    run against frame 0 either way, so the chosen track is the frame-0 track
    re-expressed, and the identity at the chosen frame's middle."""
    nf = 7
    counts = np.full(nf, 1e6)
    counts[0] = rng.uniform(1e4, 3e4)  # 1-3 % of the others' counts, as a first frame of a few seconds
    s = Series(rng, (32, 32, 32), (4.0, 3.5, 4.0), nf, jerk=int(rng.integers(2, nf - 1)), frame_counts=counts)
    m = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, device=device)
    zero = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, reference=0, device=device)
    r, j = m.reference_frame, s.jerk
    assert zero.reference_frame == 0
    rep = m.frame_report[r]
    assert r not in (0, j) and rep["structure"] and rep["motion_inside"] is None and rep["unfollowed"] == 0, (r, rep)
    mids = s.starts + s.durations / 2
    np.testing.assert_allclose(_map(m, mids[r]), np.eye(4), rtol=0, atol=1e-9)
    np.testing.assert_array_equal(m.times, zero.times)
    back = np.linalg.inv(_map(zero, mids[r]))
    for t in m.times:
        np.testing.assert_allclose(_map(m, t), _map(zero, t) @ back, rtol=0, atol=1e-9)
    # each track against the truth relative to its own reference frame, over the frames held still
    still = [k for k in range(nf) if k != j]
    inside = s.phantom.inside(rng)

    def errors(motion, ref):
        to_ref, points = np.linalg.inv(s.maps[ref]), inside @ s.maps[ref][:3, :3].T + s.maps[ref][:3, 3]
        return np.array([_displacement(_map(motion, mids[k]), s.maps[k] @ to_ref, points) for k in still])

    e_auto, e_zero = errors(m, r), errors(zero, 0)
    msg = f"reference {r}: {np.round(e_auto, 3)} mm; relative to frame 0: {np.round(e_zero, 3)} mm"
    print(msg)
    # Measured while writing this test, 12 fresh series on the host: mean 0.09-0.25 mm against 0.13-0.37 relative to
    # frame 0, lower on 11; on the twelfth frame 0 came out near its truth (0.154 against 0.120). Which reference
    # serves users better is a question of distributions (issue 47's family, docs/motion.md); here, that the choice
    # is never much worse than frame 0's.
    assert e_auto.mean() < 0.6 and e_auto.mean() < e_zero.mean() + 0.1, msg
    # pickled with the motion
    assert pickle.loads(pickle.dumps(m)).reference_frame == r


def test_orders_and_dtypes_agree(rng):
    """C order and float64 (converted on the host) give the very track that
    Fortran-ordered float32 gives, and neither array is changed."""
    s = Series(rng, (16, 16, 16), (4.0, 4.0, 4.0), 4, jerk=2)
    f32 = np.asfortranarray(s.frames)
    f64 = np.ascontiguousarray(s.frames, dtype=np.float64)
    keep32, keep64 = f32.copy(), f64.copy()
    a = petblur.Motion.from_frames(f32, s.affine, s.starts, s.durations, device="host", levels=1)
    b = petblur.Motion.from_frames(f64, s.affine, s.starts, s.durations, device="host", levels=1)
    assert np.array_equal(f32, keep32) and np.array_equal(f64, keep64)
    np.testing.assert_array_equal(a.times, b.times)
    np.testing.assert_allclose(a.translations, b.translations, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.quaternions, b.quaternions, rtol=0, atol=1e-12)


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one core here: nothing to narrow the threads to")
def test_the_same_track_on_one_core_and_many(rng):
    """The estimate's host loops and the host backend's forward run on the
    cores the process may run on, with sums taken in chunks of fixed size: the
    track is the same bits with the affinity narrowed to one CPU. The grid
    holds three chunks of voxels, so that the sums are split."""
    s = Series(rng, (40, 40, 24), (4.0, 4.0, 4.0), 5, jerk=2)
    many = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, device="host")
    cores = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cores)})
    try:
        one = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, device="host")
    finally:
        os.sched_setaffinity(0, cores)
    assert len(many.times) >= 6
    np.testing.assert_array_equal(many.times, one.times)
    np.testing.assert_array_equal(many.translations, one.translations)
    np.testing.assert_array_equal(many.quaternions, one.quaternions)


def test_voxel_size_is_the_grid_frame(rng):
    """Without an affine, voxel_size= places the series in the grid frame
    the operators take without one (voxel_size mm, the grid's corner at the
    origin): the very track that frame's affine, written out, gives; in mm,
    so twice the voxel size doubles the translations."""
    s = Series(rng, (16, 16, 16), (4.0, 4.0, 4.0), 4, jerk=2)
    d = np.array([3.0, 2.5, 3.5])
    grid = np.diag([*d, 1.0])
    grid[:3, 3] = 0.5 * d
    a = petblur.Motion.from_frames(s.frames, None, s.starts, s.durations, device="host", levels=1, voxel_size=d)
    b = petblur.Motion.from_frames(s.frames, grid, s.starts, s.durations, device="host", levels=1)
    np.testing.assert_array_equal(a.times, b.times)
    np.testing.assert_allclose(a.translations, b.translations, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.quaternions, b.quaternions, rtol=0, atol=1e-12)
    c = petblur.Motion.from_frames(s.frames, None, s.starts, s.durations, device="host", levels=1, voxel_size=2 * d)
    moved = np.abs(a.translations).max()
    assert moved > 0.05, a.translations
    # About the world's origin a rotation's translation scales with the grid too.
    np.testing.assert_allclose(c.translations, 2 * a.translations, rtol=0, atol=1e-3 * moved)


def test_world_motion_needs_the_affine(tmp_path, rng):
    """A motion about the world's origin, an estimate placed by the frames'
    affine or a tracker's matrix-csv log, given to an operator without
    affine= is refused, naming affine= and what to give it (the program places
    such a track by the image's affine, and refuses --coords world without
    one); with the affine it blurs, and so it does with the grid's own affine
    the message spells out. An estimate given voxel_size= is in the grid frame
    the operators take without an affine, and is taken so."""
    vox = rng.uniform(2.5, 4.0, 3)
    s = Series(rng, (16, 16, 16), tuple(vox), 4, jerk=2)
    shape, vox = s.frames.shape[:3], np.linalg.norm(s.affine[:3, :3], axis=0)
    estimated = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, device="host", levels=1)
    bounds = np.append(s.starts, s.starts[-1] + s.durations[-1])
    n = int(rng.integers(2, 9))
    times = np.concatenate([[bounds[0]], np.sort(rng.uniform(bounds[0], bounds[-1], n - 2)), [bounds[-1]]])
    rows = ["t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz"]
    rows += [",".join(f"{v:.17g}" for v in [t, *_rigid(rng, 3.0, 3.0)[:3].reshape(-1)]) for t in times]
    path = tmp_path / f"log{int(rng.integers(1 << 30))}.csv"
    path.write_text("\n".join(rows) + "\n")
    logged = petblur.Motion.from_file(path, format="matrix-csv")
    x = np.asfortranarray(s.frames[..., int(rng.integers(4))])
    k = int(rng.integers(4))
    for m in (estimated, logged):
        makers = (lambda **kw: petblur.BlurOperator(shape, vox, m, frame=bounds[k:k + 2], device="host", **kw),
                  lambda **kw: petblur.FramesOperator(shape, vox, m, bounds, device="host", **kw))
        for make in makers:
            with pytest.raises(petblur.ArgumentError) as e:
                make()
            text = str(e.value)
            assert f"the motion ({m._source}) holds poses in the scanner's world mm" in text, text
            assert "give affine= the image's voxel-to-world 4x4 (nibabel's img.affine" in text, text
            grid = np.array(ast.literal_eval(re.search(r"--coords grid\), affine=(\[\[.*\]\])$", text).group(1)))
            want = np.diag([*vox, 1.0])
            want[:3, 3] = 0.5 * vox
            np.testing.assert_array_equal(grid, want)
            y = make(affine=s.affine)(x)
            assert np.isfinite(y).all() and np.abs(y).max() > 0
            if m is logged:  # small moves: in view about the grid's corner too
                assert np.isfinite(make(affine=grid)(x)).all()
    in_grid = petblur.Motion.from_frames(s.frames, None, s.starts, s.durations, device="host", levels=1,
                                         voxel_size=vox)
    y = petblur.FramesOperator(shape, vox, in_grid, bounds, device="host")(x)
    assert np.isfinite(y).all()
    np.testing.assert_array_equal(petblur.FramesOperator(shape, vox, in_grid, bounds, device="host", affine=want)(x), y)
    # ... and refused with an affine that places the grid elsewhere.
    with pytest.raises(petblur.ArgumentError, match=r"estimated in the grid's frame \(from_frames given voxel_size=\)"
                       r".*give no affine=, or estimate the motion with from_frames\(affine=\)"):
        petblur.FramesOperator(shape, vox, in_grid, bounds, device="host", affine=s.affine)


def test_frames_numpy_can_read(tmp_path, rng):
    """The frames are read on the host, so what numpy reads is taken: a dask
    array in chunks of frames, nibabel's img.dataobj; the same track as
    the numpy array's. An operator, which reads its input in place, names a
    dask array's type and the way to give it."""
    import dask.array as da
    s = Series(rng, (16, 16, 16), (4.0, 4.0, 4.0), 4, jerk=2)
    want = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, device="host", levels=1)
    nib.save(nib.Nifti1Image(s.frames, s.affine), str(tmp_path / "f.nii"))
    chunks = (16, 16, 16, int(rng.integers(1, 4)))
    for frames in (da.from_array(s.frames, chunks=chunks), nib.load(str(tmp_path / "f.nii")).dataobj):
        got = petblur.Motion.from_frames(frames, s.affine, s.starts, s.durations, device="host", levels=1)
        np.testing.assert_array_equal(got.times, want.times)
        np.testing.assert_array_equal(got.translations, want.translations)
        np.testing.assert_array_equal(got.quaternions, want.quaternions)
    op = petblur.BlurOperator(s.frames.shape[:3], (4.0, 4.0, 4.0), petblur.Motion.from_axis_angle(angle=3),
                              device="host")
    with pytest.raises(petblur.ArgumentError, match=r"the object \(the activity\) is a dask\.array\.core\.Array; give "
                       r"a numpy or CuPy array or a torch tensor; petblur\.dask .* or give x\.compute\(\)"):
        op(da.from_array(s.frames[..., 0]))


# ---- a known motion -------------------------------------------------------


def test_recovers_known_motion(rng, device):
    s = Series(rng, (32, 32, 32), (4.0, 3.5, 4.0), 7, jerk=4)
    nf, j = len(s.maps), s.jerk
    ref = int(rng.choice([k for k in range(nf) if abs(k - j) > 1]))  # a still frame away from the jerk
    # the truth relative to the reference frame's object, and points inside that object
    to_ref = np.linalg.inv(s.maps[ref])
    points = s.phantom.inside(rng) @ s.maps[ref][:3, :3].T + s.maps[ref][:3, 3]

    def truth(t):
        return s.truth(t) @ to_ref

    frames = s.frames.copy()
    t0 = time.perf_counter()
    m = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, reference=ref, device=device)
    wall = time.perf_counter() - t0
    one = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, reference=ref, device=device,
                                     frame_poses_only=True)
    assert np.array_equal(s.frames, frames)

    mids = s.starts + s.durations / 2
    still = [k for k in range(nf) if k not in (j, ref)]
    err = np.array([_displacement(_map(m, mids[k]), truth(mids[k]), points) for k in still])
    none = np.array([_displacement(np.eye(4), truth(mids[k]), points) for k in still])
    # the jerk's frame: mean over its time
    tj = s.starts[j] + (np.arange(40) + 0.5) / 40 * s.durations[j]
    e_jerk = np.mean([_displacement(_map(m, t), truth(t), points) for t in tj])
    e_jerk_one = np.mean([_displacement(_map(one, t), truth(t), points) for t in tj])
    msg = (f"frames {still}: error {np.round(err, 3)} mm, uncorrected {np.round(none, 2)} mm; jerk frame {e_jerk:.3f} "
           f"mm, one pose per frame {e_jerk_one:.3f} mm; {m.moving_frames} moving; {m.estimate_seconds:.1f} s")
    print(msg)
    # Measured while writing this test, 24 fresh series (12 on the host, 12 with PoCL; 32^3 voxels of about 4 mm,
    # 7 frames, 1e6 counts a frame): frames held still 0.08-0.33 mm mean over the frames (worst frame 0.62 mm)
    # against 3.2-7.4 mm uncorrected, a ratio of at most 0.07; the jerk's frame 0.68-1.53 mm against 2.49-3.22 mm
    # with one pose per frame, a ratio of at most 0.53; one moving frame every time. With the dwell's views sharpened
    # by what their sampling smoothed them (docs/estimate-log.md, "The reference frame's sharp view"), the jerk's
    # frame 0.29-0.94 mm on 50 fresh series on the host, against 0.54-1.45 mm as sampled (7 of them above 1.3 mm).
    assert err.mean() < 0.6 and err.mean() < 0.15 * none.mean(), msg
    assert err.max() < 1.2, msg
    assert e_jerk < 1.3 and e_jerk < 0.5 * e_jerk_one, msg
    # the reference frame's pose is the identity; the jerk's frame, alone, gets motion inside
    np.testing.assert_allclose(_map(m, mids[ref]), np.eye(4), rtol=0, atol=1e-9)
    np.testing.assert_allclose(_map(one, mids[ref]), np.eye(4), rtol=0, atol=1e-9)
    assert m.moving_frames == 1 and one.moving_frames == 0, msg
    inside = m.times[(m.times > s.starts[j]) & (m.times < s.starts[j] + s.durations[j])]
    assert len(inside) > 1 and np.all(np.isin(np.delete(mids, j), m.times)), m.times
    # one pose a frame: a key at each middle and at the series' ends, and the curve's seven between middles
    assert np.all(np.isin(np.concatenate([[s.starts[0]], mids, [s.starts[-1] + 10.0]]), one.times)), one.times
    between = [np.count_nonzero((one.times > a) & (one.times < b)) for a, b in zip(mids[:-1], mids[1:])]
    assert between == [7] * (nf - 1) and len(one.times) == nf + 2 + 7 * (nf - 1), (between, one.times)
    # the time the library reports is this call's
    assert 0.0 < m.estimate_seconds <= wall + 0.05, (m.estimate_seconds, wall)
    # the report a frame: times, fit, structure; the jerk's frame alone with motion inside, about the jerk's time
    rep = m.frame_report
    assert [f["frame"] for f in rep] == list(range(nf)), rep
    np.testing.assert_allclose([[f["start"], f["end"]] for f in rep], np.stack([s.starts, s.starts + s.durations], 1))
    assert all(0.0 < f["explained"] <= 1.0 and f["structure"] for f in rep), rep
    assert [f["frame"] for f in rep if f["motion_inside"]] == [j], rep
    # the jerk followed, no frame is reported as holding motion the track does not follow
    assert all(f["unfollowed"] == 0.0 for f in rep), rep
    a, b = rep[j]["motion_inside"]
    assert s.starts[j] <= a <= b <= s.starts[j] + s.durations[j], rep[j]
    # the span reported held the jerk on every series tried (its start at 0.15, 0.4, 0.5 and 0.8 of the frame)
    assert a - 0.1 * s.durations[j] <= s.jerk_time <= b + 0.1 * s.durations[j], (s.jerk_time, rep[j])
    assert all(f["motion_inside"] is None for f in one.frame_report), one.frame_report
    # it travels with the motion through pickle, checked on the way back
    back = pickle.loads(pickle.dumps(m))
    assert back.frame_report == rep and back.moving_frames == m.moving_frames
    bad = m.__getstate__()
    bad["frame_report"] = rep[:1] + [dict(rep[1], explained=float("nan"))]
    with pytest.raises(petblur.ArgumentError, match=r"frame_report\[1\]"):
        petblur.Motion.__new__(petblur.Motion).__setstate__(bad)
    # a motion pickled before the report said where the head jumped at a boundary, or which frames hold motion the
    # track does not follow, reads them as nowhere and none
    older = m.__getstate__()
    older["frame_report"] = [{k: v for k, v in f.items() if k not in ("jumped_at_start", "unfollowed")} for f in rep]
    back = petblur.Motion.__new__(petblur.Motion)
    back.__setstate__(older)
    assert back.frame_report == [dict(f, jumped_at_start=False, unfollowed=0.0) for f in rep]
    bad["frame_report"] = rep[:1] + [dict(rep[1], unfollowed=1.5)]
    with pytest.raises(petblur.ArgumentError, match=r"frame_report\[1\]"):
        petblur.Motion.__new__(petblur.Motion).__setstate__(bad)


def test_frames_held_still_take_no_path_in_a_longer_series(rng, monkeypatch):
    """A series of 9 to 14 frames, each held still at a pose of its own (a
    head moved between frames, never inside one), at 2e5 to 2e6 counts a
    frame. From 8 frames on the gain a path must show to be taken is set by
    the series' own frames (8 times the upper quartile of their best gains,
    at least 1 %, where it was 5 % for every series; docs/estimate-log.md): it must
    give no frame held still a path that 5 % for every series
    (PETBLUR_ESTIMATE_DWELL=fixed) does not."""
    nf = int(rng.integers(9, 15))
    maps = [np.eye(4)] + [_rigid(rng, 3.0, 3.0) for _ in range(nf - 1)]
    frames, affine, starts, durations, phantom = _moving_series(rng, nf, lambda t: maps[int(t // 10.0)],
                                                                shape=(24, 24, 24), steps=1, counts=(2e5, 2e6))
    m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0)
    monkeypatch.setenv("PETBLUR_ESTIMATE_DWELL", "fixed")
    fixed = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0)
    points = phantom.inside(rng)
    err = np.array([_displacement(_map(m, s + 5.0), maps[k], points) for k, s in enumerate(starts)])
    none = np.array([_displacement(np.eye(4), maps[k], points) for k in range(nf)])
    moving = [f["frame"] for f in m.frame_report if f["motion_inside"] is not None]
    moving_fixed = [f["frame"] for f in fixed.frame_report if f["motion_inside"] is not None]
    msg = (f"{nf} frames, {frames[..., 0].sum():.3g} counts a frame: moving {moving} (5 %: {moving_fixed}), errors "
           f"{np.round(err, 3)} mm, uncorrected {np.round(none, 2)} mm")
    print(msg)
    assert set(moving) <= set(moving_fixed), msg
    # Measured while writing this test: the mean error at most 0.15 of the uncorrected (30 seeds), the worst frame
    # at most 0.70 mm (70 seeds; the error grows along the series with the phantom's uptake, as
    # docs/estimate-log.md's bias from injection). The series' bar gave a frame held still a path on 1 seed of 70,
    # and 5 % for every series the same path (981255980: frames 1 and 2, beside the reference frame, each gained
    # 6-7 % on a path into the other): docs/estimate-log.md, "Not yet". CI's seed 2095620605 (14 frames, the blobs
    # reaching the 24^3 grid's faces) stood at 1.45 mm, 1.09 mm without noise or uptake change, until the
    # registration weighed each voxel by whether its view reads the reference inside its support: 0.92 mm
    # (docs/estimate-log.md, "How, in full").
    assert err.mean() < 0.25 * none.mean() and err.max() < 1.2, msg


def test_a_frame_given_twice_and_a_series_without_noise(rng):
    """A series of 12 to 14 frames, each held still at a pose of its own
    (from 12 frames on, pass 2's references and pass 4 take three principal
    images), estimated three ways: as drawn; with one frame given twice, as
    the two halves of its time, the same image in each (a reframing tool that
    copies); and without noise (the expected counts). Each frame counts by its
    energy beyond the leading images (references.c, contrast_poses.c), which
    a frame given twice or a series without noise may hold only as rounding
    (pbe_noise_scales floors it). Every pose must be finite, every track near
    the truth, and the frame given twice must not move the track off the
    series as drawn. Measured on 54 seeds while writing this (the bounds
    1.3 to 2 times the worst): every track's mean at most 0.22 of
    uncorrected and its worst frame at most 1.87 mm (971746322, as drawn);
    the frame given twice at most 0.125 mm worse than as drawn (mean) and
    0.57 mm (worst frame), both on 193938399, whose frame 1, beside the
    reference frame, was given twice (the next worst 0.071 and 0.25 mm);
    without noise worse than with it on most seeds (the uptake's bias,
    docs/estimate-log.md)."""
    nf = int(rng.integers(12, 15))
    maps = [np.eye(4)] + [_rigid(rng, 3.0, 3.0) for _ in range(nf - 1)]
    seed = int(rng.integers(2**31))
    series = {}
    for noise in (True, False):
        frames, affine, starts, durations, phantom = _moving_series(
            np.random.default_rng(seed), nf, lambda t: maps[int(t // 10.0)], shape=(24, 24, 24), steps=1,
            counts=(2e5, 2e6), noise=noise)
        series["as drawn" if noise else "without noise"] = (frames, starts, durations, list(range(nf)))
    frames, starts, durations, _ = series["as drawn"]
    j = int(rng.integers(1, nf - 1))
    series["frame %d twice" % j] = (
        np.concatenate([frames[..., :j + 1], frames[..., j:]], axis=-1),
        np.concatenate([starts[:j], [starts[j], starts[j] + 5.0], starts[j + 1:]]),
        np.concatenate([durations[:j], [5.0, 5.0], durations[j + 1:]]),
        list(range(j + 1)) + list(range(j, nf)))
    points = phantom.inside(rng)
    none = np.mean([_displacement(np.eye(4), m, points) for m in maps])
    err = {}
    for name, (f, s, d, which) in series.items():
        m = petblur.Motion.from_frames(f, affine, s, d, reference=0, device="host")
        assert np.all(np.isfinite(m.translations)) and np.all(np.isfinite(m.quaternions)), f"{name}: a pose not finite"
        err[name] = np.array([_displacement(_map(m, s[k] + 0.5 * d[k]), maps[which[k]], points)
                              for k in range(len(s))])
    msg = f"{nf} frames, uncorrected {none:.2f} mm: " + "; ".join(
        f"{n} {e.mean():.3f} / {e.max():.3f} mm" for n, e in err.items())
    print(msg)
    for e in err.values():
        assert e.mean() < 0.35 * none and e.max() < 2.5, msg
    twice, drawn = err["frame %d twice" % j], err["as drawn"]
    assert twice.mean() < drawn.mean() + 0.25 and twice.max() < drawn.max() + 1.0, msg


def test_a_grid_that_cuts_the_object(rng):
    """A series of 8 to 12 frames, each held still at a pose of its own, on a
    20^3 grid of 4 mm that cuts the phantom (blobs to 50 mm from its centre,
    the grid's faces 40 mm): each pose moves activity in across the faces
    that the reference frame's grid never held. The registration weighs each
    voxel by whether its view reads the reference inside its support, where
    it read zeros beyond the grid as the object's and pulled the poses. On 20
    such series (bench/results/2026-11-30_cpu2_grid-support) the worst frame
    stood at 0.15-3.03 mm and the mean at 0.10-1.36 mm, two series above the
    bounds below; weighed, 0.14-0.90 and 0.09-0.54 (the error grows along the
    series with the phantom's uptake, as in the longer series above)."""
    nf = int(rng.integers(8, 13))
    maps = [np.eye(4)] + [_rigid(rng, 3.0, 3.0) for _ in range(nf - 1)]
    frames, affine, starts, durations, phantom = _moving_series(rng, nf, lambda t: maps[int(t // 10.0)],
                                                                shape=(20, 20, 20), steps=1, counts=(2e5, 2e6))
    m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
    points = phantom.inside(rng)
    err = np.array([_displacement(_map(m, s + 5.0), maps[k], points) for k, s in enumerate(starts)])
    none = np.array([_displacement(np.eye(4), maps[k], points) for k in range(nf)])
    msg = f"{nf} frames: errors {np.round(err, 3)} mm, uncorrected {np.round(none, 2)} mm"
    print(msg)
    assert err.mean() < 0.75 and err.max() < 1.5, msg


def test_jerk_in_the_series_first_or_last_frame(rng):
    """A jerk inside the series' first frame, and one inside the last (two
    series), each of which has one neighbour: such a frame may get motion
    inside, and then it alone does, and its error over its time is well below
    one pose's; where it gets none it keeps one pose and no other frame moves
    in its stead. Before, pass 3 gave paths only to frames between two
    neighbours (issue 47's fresh draw 1709400551: its last frame, holding a
    0.8 s jerk of 8 degrees and 7 mm, 5.57 mm off). The path's far end is the
    frame's own pose taken as far again from the neighbour's, not a pose a
    neighbour holds, so it is found less surely than between two neighbours.
    Measured, 168 fresh draws (84 an edge, the jerk at 0.25-0.75 of the frame;
    bench/results/2026-11-29_cpu2_edge-frames): 165 got the path, at 0.14-0.79
    of one pose's error, the more the less of the frame the pose no neighbour
    holds takes (between two neighbours, test_recovers_known_motion, at most
    0.53); three kept one pose (their paths gained under 15 %: a last frame
    whose jerk came at 0.68 of it, first frames' at 0.26 and 0.73, the last
    seed 793209620). So each series may miss, and the two together are
    asserted to find one (both missing: about one run in 3000). A path found
    is at most a tenth worse than one pose, and at least one of the two well
    below it: over 157 more series (two runs of 40, bench/results/2026-11-30_cpu2_edge-reruns;
    155 with a path) the paths found stood at a median of 0.44-0.49 of one
    pose's error and up to 0.84, but for one at 0.96 (seed 4287562895), and
    1704808628, met in a run of its own, at 0.97 (both the first frame's: the far end, taken through
    the one pose of a frame that shows two, lay 2 mm off the pose the head
    held, and a mixture of points along that line explained the frame better
    than any two of them near the true poses; a fit of the far pose itself is
    not built). A path can be a little worse than one pose: CI's seed
    1171309239 (the first frame, its jerk at 0.71 of it) stood at 1.03 of one
    pose's error, the path's motion spread over 0.23-0.94 of the frame where
    the head jumped at 0.71 from a pose no other frame holds, and 547465323's
    last frame at 1.03 too (both fail alike at 2121623, before the
    registration was weighed by the reference's support); on 164 fresh series
    (bench/results/2026-12-01_cpu2_edge-ratio) the median was 0.46, five stood
    at 0.84-0.92 and that one at 1.03. The span reported missed the jerk by
    more than a tenth of the frame in 8 of 24, and the pose at the series'
    end beside the jerk was up to 2.3 mm off: neither is asserted. Frames held still stood 0.9-1.1 mm off
    on 2 of 40 runs while the poses' smoothing could scale the fits' spread
    by up to 1000 (this series' frames each at a pose of their own: to a
    random walk, noise); bounded at 20, those two seeds' stood at 0.06-0.36
    mm, and 40 fresh runs' at most 0.30 mm on average and 0.52 at worst."""
    nf, found = 7, []
    for j in (0, nf - 1):
        s = Series(rng, (32, 32, 32), (4.0, 3.5, 4.0), nf, jerk=j, at=float(rng.uniform(0.25, 0.75)))
        ref = int(rng.choice([k for k in range(nf) if abs(k - j) > 1]))
        to_ref = np.linalg.inv(s.maps[ref])
        points = s.phantom.inside(rng) @ s.maps[ref][:3, :3].T + s.maps[ref][:3, 3]

        def truth(t):
            return s.truth(t) @ to_ref

        m = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, reference=ref, device="host")
        one = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, reference=ref, device="host",
                                         frame_poses_only=True)
        mids = s.starts + s.durations / 2
        still = [k for k in range(nf) if k not in (j, ref)]
        err = np.array([_displacement(_map(m, mids[k]), truth(mids[k]), points) for k in still])
        tj = s.starts[j] + (np.arange(40) + 0.5) / 40 * s.durations[j]
        e_jerk = np.mean([_displacement(_map(m, t), truth(t), points) for t in tj])
        e_jerk_one = np.mean([_displacement(_map(one, t), truth(t), points) for t in tj])
        rep = m.frame_report
        moving = [f["frame"] for f in rep if f["motion_inside"]]
        msg = (f"frame {j}, jerk at {s.jerk_time:.2f} s: {e_jerk:.3f} mm, one pose {e_jerk_one:.3f} mm; frames "
               f"{still}: {np.round(err, 3)} mm; moving {moving}, {rep[j]['motion_inside']}")
        print(msg)
        assert err.mean() < 0.6 and err.max() < 1.2, msg
        if moving:
            assert e_jerk < 1.1 * e_jerk_one, msg
            assert m.moving_frames == 1 and moving == [j], msg
            a, b = rep[j]["motion_inside"]
            assert s.starts[j] <= a <= b <= s.starts[j] + s.durations[j], msg
            found.append(e_jerk / e_jerk_one)
        else:
            assert m.moving_frames == 0 and e_jerk <= 1.01 * e_jerk_one, msg
    assert found, "neither the first frame's jerk nor the last's got a path"
    assert min(found) < 0.85, f"the paths found stand at {np.round(found, 3)} of one pose's error"


def test_motion_held_across_a_frame_boundary(rng):
    """A nod that goes down in the middle of frame k, is held across the
    boundary, and comes back in the middle of frame k + 1: each of the two
    frames holds half of each pose. Both get a path inside them (one running on
    into the next frame, one coming from the frame before), so each frame's
    error is well below the best single pose's (about half the nod; measured
    on five draws: 0.20 to 0.44 of it)."""
    shape, voxel, n, k, seconds = (28, 28, 28), (4.0, 4.0, 4.0), 7, 3, 10.0
    affine = _affine(rng, shape, voxel)
    phantom = Phantom(rng)
    nod = _rigid(rng, 8.0, 0.0)
    v = rng.normal(size=3)
    nod[:3, 3] = 6.0 * v / np.linalg.norm(v)
    idx = np.stack(np.meshgrid(*[np.arange(m) for m in shape], indexing="ij"), axis=-1).reshape(-1, 3)
    world = idx @ affine[:3, :3].T + affine[:3, 3]

    def view(m):
        inv = np.linalg.inv(m)
        return phantom(world @ inv[:3, :3].T + inv[:3, 3]).reshape(shape)

    rest, down = view(np.eye(4)), view(nod)
    frames = np.zeros(shape + (n,), np.float32)
    for f in range(n):
        x = 0.5 * (rest + down) if f in (k, k + 1) else rest
        frames[..., f] = rng.poisson(x * (1e6 / x.sum()))
    starts, durations = np.arange(n) * seconds, np.full(n, seconds)

    def truth(t):
        return nod if (k + 0.5) * seconds <= t < (k + 1.5) * seconds else np.eye(4)

    points = phantom.inside(rng)
    m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
    one = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host",
                                     frame_poses_only=True)

    def error(motion, f):
        times = (f + (np.arange(40) + 0.5) / 40) * seconds
        return np.mean([_displacement(_map(motion, t), truth(t), points) for t in times])

    got = [error(m, f) for f in (k, k + 1)]
    single = [error(one, f) for f in (k, k + 1)]
    print(got, single, m.moving_frames)
    assert m.moving_frames >= 2, m.moving_frames
    for g, s1 in zip(got, single):
        assert g < 0.7 * s1, (got, single)


def _moving_series(rng, nf, pose_at, seconds=10.0, shape=(28, 28, 28), voxel=(4.0, 4.0, 4.0), steps=12,
                   counts=(3e5, 2e6), noise=True):
    """Frames of the phantom whose world map at t is pose_at(t), each the mean
    of its views at `steps` times through it, Poisson counts a frame drawn
    log-uniformly in `counts` (their expected values without noise):
    frames, affine, starts, durations, phantom."""
    affine = _affine(rng, shape, voxel)
    phantom = Phantom(rng)
    idx = np.stack(np.meshgrid(*[np.arange(m) for m in shape], indexing="ij"), axis=-1).reshape(-1, 3)
    world = idx @ affine[:3, :3].T + affine[:3, 3]
    counts = float(np.exp(rng.uniform(np.log(counts[0]), np.log(counts[1]))))
    frames = np.zeros(shape + (nf,), np.float32)
    for k in range(nf):
        v = np.zeros(shape)
        for t in (k + (np.arange(steps) + 0.5) / steps) * seconds:
            inv = np.linalg.inv(pose_at(t))
            v += phantom(world @ inv[:3, :3].T + inv[:3, 3], k / (nf - 1)).reshape(shape)
        expected = v * (counts / v.sum())
        frames[..., k] = rng.poisson(expected) if noise else expected
    return frames, affine, np.arange(nf) * seconds, np.full(nf, seconds), phantom


def test_a_nod_that_turns_back_inside_a_frame(rng, monkeypatch):
    """A head held still but for a nod of 6-10 degrees and 4-8 mm inside one
    frame, out and back, so that both neighbours hold one pose. No path
    between poses the frames hold follows it, and a path on through the
    frame's own pose would carry the nod into a neighbour; the frame's path
    goes out and comes back (PATH_BACK: a dwell along two legs, from the
    frame before's pose out and on to the frame after's, a point and its
    twin on the other leg, within a voxel of each other, held alike). Its
    error over the frame must be well below one pose's, and no frame is
    reported as holding motion the track does not follow. Without it
    (PETBLUR_ESTIMATE_BACK=0, and PATH_TWO off: PETBLUR_ESTIMATE_TWO=0) the
    frame keeps one pose, the mean of poses it held, and the report must say
    so for that frame (`unfollowed`, the share of one pose's residual a path
    inside it explains) and no other. With PATH_TWO on, that run fitted the
    unfollowed nod as two poses at seed 4087869242 (a CI rehearsal,
    2026-12-06), 4.8-5.2 mm where one pose stood at 3.49: two poses held in
    turn are not a nod, and with PATH_BACK on (the default) the nod takes
    its path, which PATH_TWO does not replace.
    Measured while writing this test, 19 fresh series with one leg laid out
    and back: every nod got the path, the frame's error 0.16-0.63 of one
    pose's (median 0.32; 0.60 and 0.63 where the path gained 5-7 %, a short
    nod), the series' mean error at most 0.68 of it; without the path each
    nod's frame was the worst and the only one reported (its path's gain
    0.05-0.94). A first bar of 15 % left a nod of 3.4 s (seed 1213781347,
    6.8 %) at one pose, 1.43 mm off where the path takes it to 0.85. With
    the two legs, 14 fresh series: 0.22-0.58 (twins within a tenth of a
    voxel held alike instead of within one: up to 1.05, the dwell at the
    neighbours' poses put at the frame's start or end by the noise)."""
    nf, seconds = 7, 10.0
    k = int(rng.integers(2, nf - 1))
    nod = _rigid(rng, float(rng.uniform(6.0, 10.0)), 0.0)
    v = rng.normal(size=3)
    nod[:3, 3] = rng.uniform(4.0, 8.0) * v / np.linalg.norm(v)
    out, back = (k + rng.uniform(0.2, 0.35)) * seconds, (k + rng.uniform(0.65, 0.8)) * seconds

    def truth(t):
        return nod if out <= t < back else np.eye(4)

    frames, affine, starts, durations, phantom = _moving_series(rng, nf, truth, seconds=seconds, steps=40)
    points = phantom.inside(rng)
    runs = {}
    for name in ("back", "off"):
        monkeypatch.setenv("PETBLUR_ESTIMATE_BACK", "1" if name == "back" else "0")
        monkeypatch.setenv("PETBLUR_ESTIMATE_TWO", "2" if name == "back" else "0")
        m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
        rep = m.frame_report
        runs[name] = (_frame_errors(m, truth, points, starts, durations),
                      [f["frame"] for f in rep if f["motion_inside"]],
                      [(f["frame"], round(f["unfollowed"], 3)) for f in rep if f["unfollowed"] > 0], rep)
    msg = (f"the nod in frame {k} from {out:.2f} to {back:.2f} s; " + "; ".join(
        f"{n}: errors {np.round(e, 3)} mm, moving {mv}, reported not followed {nf_}"
        for n, (e, mv, nf_, _) in runs.items()))
    print(msg)
    err, moving, shown, rep = runs["back"]
    off, moving_off, shown_off, rep_off = runs["off"]
    assert moving == [k] and shown == [], msg
    a, b = rep[k]["motion_inside"]
    assert starts[k] <= a < b <= starts[k] + durations[k], msg
    assert err[k] < 0.75 * off[k] and err.mean() < off.mean(), msg
    assert moving_off == [] and [f for f, _ in shown_off] == [k], msg
    assert all(0.0 <= f["unfollowed"] <= 1.0 for f in rep_off), msg
    # the report points at the frame that is off: its error above every other frame's
    assert off[k] > np.delete(off, k).max(), msg
    one = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host",
                                     frame_poses_only=True)
    assert all(f["unfollowed"] == 0.0 for f in one.frame_report), one.frame_report


def _frame_errors(motion, truth, points, starts, durations):
    """Per frame: the mean over its time of the displacement error, mm."""
    return np.array([np.mean([_displacement(_map(motion, t), truth(t), points)
                              for t in s + (np.arange(40) + 0.5) / 40 * d]) for s, d in zip(starts, durations)])


def test_jump_at_a_frame_boundary_is_held_as_a_step(rng, monkeypatch):
    """A head held still that jumps (6-10 degrees and 5-8 mm) at a frame
    boundary: each frame beside it shows one pose, so the track holds each
    to the boundary and steps there, where a line from one frame's middle
    to the next blurred both by a quarter of the jump (issue 47's family:
    half its jerks are centred on a boundary, and those two frames stood
    0.5-5 mm off). Against PETBLUR_ESTIMATE_BOUNDARY=ramp (the line between
    the middles everywhere) on the same series; nothing else moves. Measured
    while writing this test, 12 seeds at the rule as it stands (22 more
    while it was made): the ramp left the two frames 0.73-1.49 mm off, the
    step 0.57-1.19 mm less (the frames' own error, which grows along the
    series with the phantom's uptake, stays)."""
    nf = int(rng.integers(6, 10))
    j = int(rng.integers(2, nf - 1))
    # a jump that moves the phantom's region (a ball of 25 mm about the origin) by 7.5 mm or more on average: a
    # smaller one on this smooth phantom may not part the two models by the 6 standard deviations asked, and is then
    # ramped (seed 44, 4.96 mm: the frames' evidence 35 against 36; at 6 mm, 3 of 41 seeds, among them CI's
    # 2030472541, and 5112 at evidence 22.5; both still ramped at 4 times the counts; at 7.5 mm, 83 of 83 held)
    ball = _ball(rng)
    while True:
        jump = _rigid(rng, float(rng.uniform(6.0, 10.0)), 0.0)
        v = rng.normal(size=3)
        jump[:3, 3] = float(rng.uniform(5.0, 8.0)) * v / np.linalg.norm(v)
        if _displacement(jump, np.eye(4), ball) >= 7.5:
            break

    def truth(t):
        return jump if t >= j * 10.0 else np.eye(4)

    frames, affine, starts, durations, phantom = _moving_series(rng, nf, truth, steps=1)
    points = phantom.inside(rng)
    m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
    # the line between the middles: the monotone cubic the track now lays there (f519df7) bends its ramp towards the
    # boundary, and with the frames' own error late in a series the step's gain over it fell under the bound below
    # on 3 of 55 fresh seeds (2701752237, 1754053573: 0.54 and 0.41 mm against 0.56 and 0.52), with the line on none
    monkeypatch.setenv("PETBLUR_ESTIMATE_BOUNDARY", "ramp")
    monkeypatch.setenv("PETBLUR_ESTIMATE_CURVE", "line")
    ramp = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
    err, err_ramp = (_frame_errors(x, truth, points, starts, durations) for x in (m, ramp))
    size = _displacement(jump, np.eye(4), points)
    msg = (f"{nf} frames, the jump before frame {j} ({size:.2f} mm): errors "
           f"{np.round(err, 3)} mm, with ramps {np.round(err_ramp, 3)} mm")
    print(msg)
    beside = [j - 1, j]
    others = [k for k in range(nf) if k not in beside]
    # a ramp over each half frame beside the boundary, to the poses' midpoint, is off by an eighth of the jump on
    # average over each frame; the frames' own error (the phantom's uptake changing) stays
    assert np.all(err_ramp[beside] - err[beside] > 0.5 * size / 8), msg
    assert np.all(err[others] <= err_ramp[others] + 0.02), msg
    inside = m.times[(m.times > starts[j] - 5.0) & (m.times < starts[j] + 5.0)]
    assert len(inside) == 2 and inside[0] < starts[j] < inside[1], m.times
    # the report says where: frame j's start, and no other
    assert [f["frame"] for f in m.frame_report if f["jumped_at_start"]] == [j], m.frame_report
    assert not any(f["jumped_at_start"] for f in ramp.frame_report), ramp.frame_report


def test_a_jerk_that_ends_at_a_boundary_steps_there(rng, monkeypatch):
    """A head held still but for a jerk of 12-16 degrees and 10-14 mm that
    begins inside one frame and ends just inside the next (0.03-0.08 of it,
    as issue 47's draw 3414265662's two jerks ran 0.64 s into a frame of 10):
    the frame moves along the path between its neighbours' poses, and never
    reaches the far end, the frame after's pose, which is the mean over a
    frame that holds still but for its start. That frame holds its pose from
    the boundary, so the track steps there from the last point the moving
    frame held, where it ramped from that point to the frame after's middle,
    half a still frame of motion no frame shows (3414265662's frame 3 5.64
    mm off). Against PETBLUR_ESTIMATE_PATH_ENDS=ramp on the same series.
    Measured while writing this test, 40 fresh series: every jerk's frame
    moved; in 32 the path stopped short and the step took the frame after
    at least 0.166 mm lower (0.36-1.18 mm to 0.11-0.44 on the first 20), the
    other frames within 0.002 mm; in 8 the frame held the far end and the
    tracks were the same. Where the jerk ran on for 0.15-0.25 of the next frame
    the ramp followed its tail: the step was worse by up to 0.13 mm on 5
    of 40 series, the frame after no longer still. A jerk of 8-12 degrees
    and 6-10 mm left one frame in three without a path (its gain under the
    bar). Those runs hold PATH_TWO off (PETBLUR_ESTIMATE_TWO=0), as the two
    runs compared below do. The default takes two poses of the frame's own
    in place of the path now and then, and loses there: a CI rehearsal drew
    seed 1427954178, where the jerk's frame stood at 1.332 mm against the
    path's 0.660 (one pose 1.530); on 16 fresh series (2026-12-06) it took
    them on 3, the jerk's frame 0.623-0.734 -> 1.333-1.447 mm, at most 0.88
    of one pose's error, the series' mean up to 0.118 mm above the path's;
    on the other 13 the tracks were the path's. 20 more drew seed
    1383856037, 0.540 -> 1.598 mm (one pose 1.884), the mean 0.151 mm above
    the path's and 0.165 below one pose a frame's. A jerk of 6-7 s is a
    ramp over most of the frame, which two poses held in turn are not: since
    PATH_TWO asks a line with fitted ends through the two poses whether the
    frame dwelt between them (TWO_LINE_BETWEEN), on 30 fresh series two
    poses replaced the path on 2 where they had on 8 (the mean 0.056 and
    0.068 mm above the path's), and on 20 more on none. The default must follow the jerk: the jerk's
    frame below 0.95 of one pose's error, the series' mean below one pose a
    frame's and within 0.1 mm of the path's."""
    nf, seconds = 7, 10.0
    k = int(rng.integers(2, nf - 2))
    jerk = _rigid(rng, float(rng.uniform(12.0, 16.0)), 0.0)
    v = rng.normal(size=3)
    jerk[:3, 3] = rng.uniform(10.0, 14.0) * v / np.linalg.norm(v)
    turn = Rotation.from_matrix(jerk[:3, :3]).as_rotvec()
    a, b = (k + rng.uniform(0.3, 0.5)) * seconds, (k + 1 + rng.uniform(0.03, 0.08)) * seconds

    def truth(t):
        s = min(max((t - a) / (b - a), 0.0), 1.0)
        m = np.eye(4)
        m[:3, :3] = Rotation.from_rotvec(s * turn).as_matrix()
        m[:3, 3] = s * jerk[:3, 3]
        return m

    frames, affine, starts, durations, phantom = _moving_series(rng, nf, truth, seconds=seconds, steps=40)
    points = phantom.inside(rng)
    default = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
    one = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host",
                                     frame_poses_only=True)
    monkeypatch.setenv("PETBLUR_ESTIMATE_TWO", "0")
    m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
    monkeypatch.setenv("PETBLUR_ESTIMATE_PATH_ENDS", "ramp")
    ramp = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
    err, err_ramp, err_default, err_one = (_frame_errors(x, truth, points, starts, durations)
                                           for x in (m, ramp, default, one))
    moving_default = [f["frame"] for f in default.frame_report if f["motion_inside"]]
    moving = [f["frame"] for f in m.frame_report if f["motion_inside"]]
    inside, inside_ramp = m.frame_report[k]["motion_inside"], ramp.frame_report[k]["motion_inside"]
    msg = (f"the jerk in frame {k} from {a:.2f} to {b:.2f} s: errors {np.round(err, 3)} mm, moving {moving}, "
           f"motion inside {inside and np.round(inside, 2)} s; ramping to the middle {np.round(err_ramp, 3)} mm, "
           f"motion inside {inside_ramp and np.round(inside_ramp, 2)} s; the default {np.round(err_default, 3)} mm, "
        f"moving {moving_default}; one pose a frame {np.round(err_one, 3)} mm")
    print(msg)
    # the default, two poses of the frame's own in place of the path where they fit better by the bar
    assert moving_default == [k] and err_default[k] < 0.95 * err_one[k], msg
    assert err_default.mean() < err_one.mean(), msg
    assert err_default.mean() < err.mean() + 0.1, msg
    assert moving == [k], msg
    stepped = abs(inside[1] - starts[k + 1]) < 1e-6
    assert np.all(err <= err_ramp + 0.04), msg
    if stepped:  # the path stopped short of the frame after's pose: the step is the change
        assert inside_ramp[1] < starts[k + 1] and err[k + 1] < err_ramp[k + 1] - 0.02, msg
    else:  # the frame held the frame after's pose at its end: nothing to step
        assert np.allclose(err, err_ramp, atol=1e-9), msg


def test_a_jerk_inside_a_drift_is_followed(rng, monkeypatch):
    """A head drifting steadily (2-3 mm a frame) that jerks 10-14 mm across
    the drift 0.15-0.3 of the way into a frame. The frame after's pose is off
    the jerk's line by the drift, and short of where it would lie were the
    motion going on into that frame. The path on from the frame before
    through the frame's own pose dwells at the frame before's pose, then
    along the jerk, and stops short of its far end: it claims no motion
    into the frame after, and the frame follows it (issue 47's draw
    3171377247: a jerk of 8 degrees inside a slow nod, its frame 3.71 mm off
    at one pose). Against one pose a frame and against
    PETBLUR_ESTIMATE_SHORT=0, which asks that path for the motion going on
    and, where the path between fails, holds the frame at one pose.
    Measured while writing this test, 32 fresh series (22 with the rule
    asking for no dwell at the far end, 10 for under a twentieth): every
    jerk's frame followed, at 0.34-0.82 of one pose's error (0.32-0.88 over
    20 more, hence the bound of 0.95; 1.2-2.3 mm of a
    10-14 mm jerk: the path's nine points and the drift); SHORT=0 held it at
    one pose in 10, and in 22 took another path: the same track (7) or the
    jerk's frame at 0.27-0.67 of that path's error (15); the series' mean at
    most 0.84 of one pose's a frame, never above SHORT=0's. Those runs hold
    PATH_TWO off (PETBLUR_ESTIMATE_TWO=0); the default (two poses of the
    frame's own where they explain a twentieth of what the path leaves)
    must follow the jerk too, and lose little to the path where it does:
    on 23 fresh series its jerk's frame stood at 0.30-1.08 of the path's
    error (median about 0.6; 2068306675 at 1.08) and 0.16-0.82 of one
    pose's, the series' mean at most 0.016 mm above the path's (CI's seed
    2914862482 failed before the path was held off for the SHORT
    comparison: its two runs took PATH_TWO in different ways). A CI
    rehearsal on 2026-12-06 drew seed 3188949397: 1.21 of the path's error
    on the jerk's frame and the mean 0.035 mm above it (the same with the
    line's judge off); 30 fresh series then: at most 1.11 and 0.022 mm.
    Bounds 1.3 and 0.05 mm. Another drew seed 3480099802: the path out and
    back (PATH_BACK) gained 0.004 more than the path on and laid the jerk
    past its end and back, the frame at 1.006 of one pose's error; PATH_BACK
    on neighbours a voxel apart now explains a twentieth of what a one-way
    path leaves, or yields to it (1.934 mm, 0.73 of one pose's; 20 fresh
    series then, all passed)."""
    nf, seconds = 7, 10.0
    k = int(rng.integers(2, nf - 2))
    v = rng.normal(size=3)
    v /= np.linalg.norm(v)
    u = np.cross(v, rng.normal(size=3))
    u /= np.linalg.norm(u)
    angle = np.radians(rng.uniform(90.0, 105.0))
    jump = rng.uniform(10.0, 14.0) * v
    drift = rng.uniform(2.0, 3.0) / seconds * (np.cos(angle) * v + np.sin(angle) * u)
    at = (k + rng.uniform(0.15, 0.3)) * seconds

    def truth(t):  # the reference frame's mean pose is the identity
        m = np.eye(4)
        m[:3, 3] = drift * (t - 0.5 * seconds) + min(max((t - at) / 0.5, 0.0), 1.0) * jump
        return m

    frames, affine, starts, durations, phantom = _moving_series(rng, nf, truth, seconds=seconds, steps=40)
    points = phantom.inside(rng)
    runs = {}
    for name in ("short", "off", "one", "two"):
        monkeypatch.setenv("PETBLUR_ESTIMATE_SHORT", "0" if name == "off" else "1")
        monkeypatch.setenv("PETBLUR_ESTIMATE_TWO", "2" if name == "two" else "0")
        m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host",
                                       frame_poses_only=name == "one")
        runs[name] = (_frame_errors(m, truth, points, starts, durations),
                      [f["frame"] for f in m.frame_report if f["motion_inside"]],
                      [(f["frame"], round(f["unfollowed"], 3)) for f in m.frame_report if f["unfollowed"] > 0])
    msg = (f"the jerk in frame {k} at {at:.2f} s; " + "; ".join(
        f"{n}: errors {np.round(e, 3)} mm, moving {mv}, reported not followed {r}" for n, (e, mv, r) in runs.items()))
    print(msg)
    (err, moving, shown), off, one = runs["short"], runs["off"][0], runs["one"][0]
    assert moving == [k] and shown == [], msg
    assert err[k] < 0.95 * one[k] and err.mean() < one.mean(), msg
    assert err[k] <= off[k] + 0.01 and err.mean() <= off.mean() + 0.01, msg
    two, moving_two, shown_two = runs["two"]
    assert moving_two == [k] and shown_two == [], msg
    assert two[k] < 0.9 * one[k] and two.mean() < one.mean(), msg
    assert two[k] < 1.3 * err[k] and two.mean() <= err.mean() + 0.05, msg


def test_a_move_after_a_jump_at_a_boundary_is_followed(rng, monkeypatch):
    """A head held still that jerks 12-16 degrees and 10-14 mm in 0.3-0.6 s
    across a frame boundary and then, inside the frame after, moves steadily
    on by another 9-12 degrees and 8-11 mm in another direction, held there
    after (issue 47's draw 1364193535: a jerk across a boundary in a nod,
    the frame after coming back along the nod, held at one pose 2.69 mm
    off). The frame's poses jumped at its start, and a path from where the
    head jumped to that ends at the frame after's pose (PATH_FROM) explains
    the frame. The frame before holds still, so that path stood only on
    UNSUPPORTED_GAIN, and where it did the track ramped from the frame
    before's middle to the path's start. A jump at the boundary now stands in
    for that neighbour (the fixed bar), and the track holds the frame
    before's pose to the boundary and steps there. Against
    PETBLUR_ESTIMATE_JUMP_PATH=0 (the rule before) and one pose a frame on
    the same series. Measured while writing this test, 26 fresh seeds: the
    frame followed on all, at 0.16-0.83 of one pose's error; the rule before
    left the frame before 2.2-3.6 mm off on 15 (0.05-0.21 mm now) and the
    series' mean at 0.46-0.80 mm there (0.13-0.34 now). With a move of 6-9
    degrees and 5-8 mm the path gained 1.9 % on 3 of 6 seeds, under the bar,
    and the frame kept one pose either way. With the rule's guards as they
    stand (the frames' evidence of the step, the head not come back; seed
    774117969 set the first), 20 more: the frame at 0.12-0.50 of one pose's
    error, the frame before ramped by the rule before on 7 (2.36-3.39 mm,
    now 0.09-0.16)."""
    nf, seconds = 7, 10.0
    k = int(rng.integers(2, nf - 2))
    # the phantom's region (a ball of 25 mm about the origin) moved by at most 15 mm on average at the end: the two
    # moves in line (up to 28 degrees and 25 mm) took frames past what the registration finds on this 28^3 grid of
    # 4 mm (seed 2981417670: 20 mm off from the jerk on, one pose a frame alike)
    ball = _ball(rng)
    while True:
        moves, end = [], np.eye(4)
        for deg, mm in ((rng.uniform(12.0, 16.0), rng.uniform(10.0, 14.0)),
                        (rng.uniform(9.0, 12.0), rng.uniform(8.0, 11.0))):
            r = _rigid(rng, float(deg), 0.0)
            v = rng.normal(size=3)
            r[:3, 3] = mm * v / np.linalg.norm(v)
            moves.append((Rotation.from_matrix(r[:3, :3]).as_rotvec(), r[:3, 3]))
            end = r @ end
        if _displacement(end, np.eye(4), ball) <= 15.0:
            break
    length = float(rng.uniform(0.3, 0.6))
    a = k * seconds - 0.5 * length
    r0, r1 = (k + rng.uniform(0.0, 0.1)) * seconds, (k + rng.uniform(0.8, 1.0)) * seconds

    def truth(t):
        s = min(max((t - a) / length, 0.0), 1.0)
        m = np.eye(4)
        for f, (turn, shift) in zip((s * s * (3 - 2 * s), min(max((t - r0) / (r1 - r0), 0.0), 1.0)), moves):
            step = np.eye(4)
            step[:3, :3] = Rotation.from_rotvec(f * turn).as_matrix()
            step[:3, 3] = f * shift
            m = step @ m
        return m

    frames, affine, starts, durations, phantom = _moving_series(rng, nf, truth, seconds=seconds, steps=40)
    points = phantom.inside(rng)
    runs = {}
    for name in ("jump", "before", "one"):
        monkeypatch.setenv("PETBLUR_ESTIMATE_JUMP_PATH", "0" if name == "before" else "1")
        m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host",
                                       frame_poses_only=name == "one")
        runs[name] = (_frame_errors(m, truth, points, starts, durations),
                      [f["frame"] for f in m.frame_report if f["motion_inside"]])
    msg = (f"the jerk at {a:.2f} s into frame {k}, the move from {r0:.2f} to {r1:.2f} s; " + "; ".join(
        f"{n}: errors {np.round(e, 3)} mm, moving {mv}" for n, (e, mv) in runs.items()))
    print(msg)
    (err, moving), before, one = runs["jump"], runs["before"][0], runs["one"][0]
    assert moving == [k] and err[k] < 0.9 * one[k], msg
    # the frame before held to the boundary: no worse than at its own pose, where a ramp from its middle to the
    # path's start had left it 3-4 mm off
    assert err[k - 1] <= one[k - 1] + 0.05, msg
    assert np.all(err <= before + 0.05) and err.mean() < one.mean(), msg


def test_motion_through_frames_is_not_taken_for_steps(rng, monkeypatch):
    """A head turning steadily through the series (0.8-1.6 degrees and
    0.5-1 mm a frame, so each frame is blurred by its own motion): the frames
    show the ramps, and the track keeps the lines between the frames' middles
    (no boundary is held as a step where the turn goes on)."""
    nf = int(rng.integers(6, 10))
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    rate = float(rng.uniform(0.8, 1.6)) / 10.0
    v = rng.normal(size=3)
    shift = float(rng.uniform(0.5, 1.0)) / 10.0 * v / np.linalg.norm(v)

    def truth(t):
        m = np.eye(4)
        m[:3, :3] = Rotation.from_rotvec(np.radians(rate * t) * axis).as_matrix()
        m[:3, 3] = shift * t
        return m

    frames, affine, starts, durations, phantom = _moving_series(rng, nf, truth)
    points = phantom.inside(rng)
    m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
    monkeypatch.setenv("PETBLUR_ESTIMATE_BOUNDARY", "ramp")
    ramp = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
    err, err_ramp = (_frame_errors(x, truth, points, starts, durations) for x in (m, ramp))
    msg = f"{nf} frames: errors {np.round(err, 3)} mm, with ramps {np.round(err_ramp, 3)} mm; times {m.times}"
    print(msg)
    assert err.mean() <= err_ramp.mean() + 0.01, msg
    assert not any(f["jumped_at_start"] for f in m.frame_report), m.frame_report


# ---- bad inputs -------------------------------------------------------------


def _nan(f):
    f[3, 4, 5, 2] = np.nan
    return f


def _inf(f):
    f[1, 2, 3, 1] = -np.inf
    return f


def _empty(f):
    f[..., 2] = 0.0
    return f


def _negative(f):
    f[..., 1] = -f[..., 1]
    return f


def _masked(f):
    f[3, 4, 5, 2] = np.nan
    return np.ma.masked_invalid(f)


def _sheared(a):
    a = a.copy()
    a[:3, 1] += 0.5 * a[:3, 0]
    return a


def _singular(a):
    a = a.copy()
    a[:3, 2] = 0.0
    return a


def _not_finite(a):
    a = a.copy()
    a[0, 3] = np.nan
    return a


def _last_row(a):
    a = a.copy()
    a[3, 2] = 0.5
    return a


# (frames' edit, from_frames' arguments' edit, words the message must hold)
BAD = {
    "3-D": (lambda f: f[..., 0], {"starts": [0.0], "durations": [10.0]}, ("4-D",)),
    "one frame": (lambda f: f[..., :1], {"starts": [0.0], "durations": [10.0]}, ("two frames", "got 1")),
    "5-D": (lambda f: f[..., None], {}, ("4-D",)),
    "fewer times": (None, {"starts": [0.0, 10.0, 20.0], "durations": [10.0] * 3}, ("3 frames", "holds 4")),
    "more times": (None, {"starts": [0.0, 10, 20, 30, 40], "durations": [10.0] * 5}, ("5 frames", "holds 4")),
    "starts and durations disagree": (None, {"durations": [10.0] * 3}, ("starts has 4", "durations 3")),
    "bounds count": (None, {"starts": None, "durations": None, "bounds": [0.0, 10, 20]}, ("2 frames", "holds 4")),
    "bounds and starts": (None, {"bounds": [0.0, 10, 20, 30, 40]}, ("not both",)),
    "no times": (None, {"starts": None, "durations": None}, ("starts=", "durations=", "bounds=")),
    "NaN voxel": (_nan, {}, ("frame 2", "nan", "[3, 4, 5]")),
    "infinite voxel": (_inf, {}, ("frame 1", "inf", "[1, 2, 3]")),
    "masked NaN": (_masked, {}, ("masked array",)),
    "empty frame": (_empty, {}, ("frame 2", "no counts")),
    "negative frame": (_negative, {}, ("frame 1", "no counts")),
    "reference past the end": (None, {"reference": 4}, ("reference 4", "frames 0 to 3")),
    "negative reference": (None, {"reference": -1}, ("reference -1", "frames 0 to 3")),
    "fractional reference": (None, {"reference": 1.5}, ("reference 1.5",)),
    "zero duration": (None, {"durations": [10.0, 0.0, 10.0, 10.0]}, ("frame 1", "lasts 0 s", "positive")),
    "negative duration": (None, {"durations": [10.0, -10.0, 10.0, 10.0]}, ("frame 1", "lasts -10 s", "positive")),
    "NaN duration": (None, {"durations": [10.0, np.nan, 10.0, 10.0]}, ("durations", "NaN")),
    "starts going back": (None, {"starts": [0.0, 10.0, 5.0, 30.0]}, ("frame 2 starts at 5 s", "without gaps")),
    "bounds going back": (None, {"starts": None, "durations": None, "bounds": [0.0, 10, 5, 20, 30]},
                          ("frame 1", "increase")),
    "NaN bound": (None, {"starts": None, "durations": None, "bounds": [0.0, 10, np.nan, 20, 30]},
                  ("bound 2", "nan", "finite")),
    "singular affine": (None, {"affine": _singular}, ("affine's column 2 is 0.0 mm long", "between 0.0001 and 10000")),
    "sheared affine": (None, {"affine": _sheared}, ("perpendicular", "shear")),
    "affine not finite": (None, {"affine": _not_finite}, ("finite 4x4",)),
    "affine 3x3": (None, {"affine": lambda a: a[:3, :3]}, ("4x4", "(3, 3)")),
    "affine's last row": (None, {"affine": _last_row}, ("last row", "0 0 0 1")),
    "float16 voxels": (lambda f: f.astype(np.float16), {}, ("float16", "float32")),
    "a list": (lambda f: f.tolist(), {}, ("list",)),
    "grid under 8": (lambda f: f[:7], {}, ("7 x 16 x 16", "at least 8")),
    "levels": (None, {"levels": 7}, ("levels 7", "0 (the default) to 6")),
    "iterations": (None, {"iterations": -1}, ("iterations -1",)),
    "fwhm": (None, {"fwhm": np.nan}, ("fwhm nan",)),
    "device": (None, {"device": "nonsense"}, ("nonsense", "host")),
    "reference True": (None, {"reference": True}, ("reference True",)),
    "neither affine nor voxel size": (None, {"affine": lambda a: None}, ("affine=", "voxel_size=", "voxels, not mm")),
    "affine and voxel size": (None, {"voxel_size": (4.0, 4.0, 4.0)}, ("not both",)),
    "voxel size of two": (None, {"affine": lambda a: None, "voxel_size": (4.0, 4.0)},
                          ("voxel_size", "(or one for cubes), not (4.0, 4.0)")),
    "voxel size zero": (None, {"affine": lambda a: None, "voxel_size": (4.0, 0.0, 4.0)}, ("voxel_size", "positive")),
}


@pytest.fixture
def small(rng):
    return Series(rng, (16, 16, 16), (4.0, 4.0, 4.0), 4, jerk=2)


@pytest.mark.parametrize("case", BAD)
def test_bad_input(small, case):
    edit_frames, edit_args, words = BAD[case]
    frames = np.asfortranarray(small.frames)  # what the library reads in place, unconverted
    if edit_frames is not None:
        frames = edit_frames(frames)
    args = dict(affine=small.affine, starts=small.starts.tolist(), durations=small.durations.tolist(),
                device="host")
    for k, v in edit_args.items():
        args[k] = v(small.affine) if k == "affine" else v
    before = [np.ma.copy(frames) if isinstance(frames, np.ma.MaskedArray) else np.copy(frames),
              {k: np.copy(v) for k, v in args.items() if isinstance(v, (list, np.ndarray))}]
    with pytest.raises(ArgumentError) as e:
        petblur.Motion.from_frames(frames, **args)
    # the library's own class (not a file error), its status and message; in this API's words, not the program's
    assert type(e.value) is ArgumentError and e.value.status < 0, (type(e.value), e.value.status)
    message = str(e.value)
    assert message == e.value.message and "--" not in message, message
    for w in words:
        assert w in message, message
    # the caller's arrays are as they were
    if isinstance(frames, np.ma.MaskedArray):
        assert np.array_equal(frames.mask, before[0].mask)
        assert np.array_equal(np.ma.getdata(frames), np.ma.getdata(before[0]), equal_nan=True)
    else:
        assert np.array_equal(np.asarray(frames), before[0], equal_nan=True)
    for k, v in before[1].items():
        assert np.array_equal(np.asarray(args[k]), v, equal_nan=True), k
