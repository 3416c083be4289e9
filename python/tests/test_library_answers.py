"""What both front ends need, computed once by the library: option names
(pb_method_parse and kin), a track's and its frames' summary
(pb_track_summarize, pb_motion_frame_summary; `petblur motion` prints the same)
and the pose gradient images (pb_pose_gradient_images), each against a
reference written here with numpy and SciPy, on fresh random cases."""
import re
import subprocess

import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.spatial.transform import Rotation, Slerp

import petblur
from petblur import pose


@pytest.mark.parametrize("kind, names", [("method", ["ab", "rm", "cl", "ref"]), ("filter", ["hardware", "exact"]),
                                         ("ab_sampling", ["slice", "sweep", "chord"])])
def test_option_names_are_the_library_s(kind, names):
    m = petblur.Motion.from_axis_angle((1.0, 0.0, 0.0))
    for name in names:
        petblur.BlurOperator((6, 5, 4), (2.0, 2.0, 2.0), m, device="host", **{kind: name})
    for bad in ("AB", "", "ab ", 3, None if kind != "ab_sampling" else 1.5):
        with pytest.raises(petblur.ArgumentError) as e:
            petblur.BlurOperator((6, 5, 4), (2.0, 2.0, 2.0), m, device="host", **{kind: bad})
        text = str(e.value)
        assert text.startswith(f"{kind} {bad!r}: choose "), text
        assert all(f"{n} (" in text for n in names), text  # every choice, with what it means


def test_track_format_names(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,1,0,0,1,0,0,0\n")
    for f in (None, "auto", "csv"):
        assert len(petblur.Motion.from_file(p, format=f)) == 2
    with pytest.raises(petblur.ArgumentError, match=r"^format 'CSV': choose auto .*csv .*matrix-csv .*polaris"):
        petblur.Motion.from_file(p, format="CSV")


def _random_track(rng):
    """A tracker's log: 20-60 Hz with jitter, a slow drift and a nod of up to
    15 degrees about a random axis, about a random centre."""
    rate = rng.uniform(20, 60)
    n = int(rng.integers(200, 600))
    t = np.cumsum(rng.uniform(0.8, 1.2, n) / rate) + rng.uniform(-5, 5)
    s = (t - t[0]) / (t[-1] - t[0])
    trans = np.outer(s, rng.normal(0, 5, 3)) + rng.normal(0, 0.05, (n, 3))
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = np.radians(rng.uniform(1, 15)) * np.sin(np.pi * s * rng.uniform(0.5, 3)) + rng.normal(0, 0.002, n)
    rot = Rotation.from_rotvec(angle[:, None] * axis)
    center = rng.uniform(20, 120, 3)
    q = rot.as_quat()[:, [3, 0, 1, 2]]
    return t, trans, rot, q, center


def _reference(t, trans, rot, center, shape, voxel, t0, t1):
    """The frame's summary from scipy: samples in [t0, t1], the largest turn
    and corner displacement from the pose at t0 (LERP, SLERP) to each of them
    and to t1."""
    slerp = Slerp(t, rot)

    def at(x):
        return np.array([np.interp(x, t, trans[:, i]) for i in range(3)]), slerp([x])[0]
    ext = np.array(shape) * np.array(voxel)
    corners = np.array([[(k & 1) * ext[0], (k >> 1 & 1) * ext[1], (k >> 2 & 1) * ext[2]] for k in range(8)])
    ts, rs = at(t0)
    inside = np.flatnonzero((t >= t0) & (t <= t1))
    poses = [(trans[i], rot[i]) for i in inside] + [at(t1)]
    turn = max(np.degrees((r * rs.inv()).magnitude()) for _, r in poses)
    start = center + ts + rs.apply(corners - center)
    disp = max(np.linalg.norm(center + tp + rp.apply(corners - center) - start, axis=1).max() for tp, rp in poses)
    return inside.size, turn, disp


def test_summary_against_scipy(rng):
    for _ in range(5):
        t, trans, rot, q, center = _random_track(rng)
        m = petblur.Motion(t, trans, q, center=center)
        shape = tuple(int(v) for v in rng.integers(8, 80, 3))
        voxel = tuple(rng.uniform(0.8, 4.0, 3))
        bounds = np.sort(rng.uniform(t[0], t[-1], int(rng.integers(2, 6))))
        s = m.summary(bounds, shape, voxel)
        assert s["samples"] == t.size and s["first"] == t[0] and s["last"] == t[-1]
        assert s["median_step"] == pytest.approx(np.median(np.diff(t)), rel=0, abs=np.ptp(np.diff(t)))
        assert s["missing"] == 0 and s["gaps"] == 0
        for f, t0, t1 in zip(s["frames"], bounds[:-1], bounds[1:]):
            samples, turn, disp = _reference(t, trans, rot, center, shape, voxel, t0, t1)
            assert f["samples"] == samples, (f, samples)
            assert f["max_turn_deg"] == pytest.approx(turn, abs=1e-6), f
            assert f["max_corner_mm"] == pytest.approx(disp, rel=1e-6, abs=1e-6), f


def test_summary_is_the_program_s(rng, cli, tmp_path):
    """`petblur motion` prints what Motion.summary returns, on the same track
    file and grid."""
    t, trans, rot, q, center = _random_track(rng)
    path = tmp_path / "track.csv"
    np.savetxt(path, np.column_stack([t, trans, q]), delimiter=",", fmt="%.17g",
               header="t,tx,ty,tz,qw,qx,qy,qz", comments="")
    shape, voxel = (40, 36, 30), (2.0, 2.5, 3.0)
    bounds = np.round(np.linspace(t[0], t[-1], 4)[1:-1], 3)
    bounds = np.concatenate([[np.ceil(t[0] * 1e3) / 1e3], bounds, [np.floor(t[-1] * 1e3) / 1e3]])
    c = ",".join(repr(float(v)) for v in center)
    out = subprocess.run([cli, "motion", str(path), "--frames", ",".join(repr(float(b)) for b in bounds),
                          "--dims", ",".join(map(str, shape)), "--voxel-size", ",".join(map(str, voxel)),
                          "--center", c], capture_output=True, text=True, check=True).stdout
    s = petblur.Motion.from_file(path, center=center).summary(bounds, shape, voxel)
    rows = [line.split() for line in out.splitlines() if re.match(r"^\s*\d+\s", line)]
    assert len(rows) == len(s["frames"])
    for row, f in zip(rows, s["frames"]):
        assert int(row[3]) == f["samples"]
        assert float(row[4]) == pytest.approx(f["max_turn_deg"], abs=5e-4)
        assert float(row[5]) == pytest.approx(f["max_corner_mm"], abs=5e-4)
        assert float(row[6]) == pytest.approx(f["noise_mm"], abs=5e-4) and int(row[7]) == f["segments"]
    assert f"{s['samples']} poses" in out


def test_summary_measures_tracker_noise(rng):
    """Motion.summary's noise_mm (the planner's, issue 46): a 20 Hz log of a
    steady drift and a slow turn with white translation noise of a random
    sigma per axis (every corner moved alike: sqrt(3) sigma, the 3-D
    scatter's RMS, within 25 %, where the estimate over 800 samples scatters
    by about 7 %), the turn and drift a few segments at most under it; the
    same log without noise: none measured."""
    sigma = rng.uniform(0.05, 0.25)
    t = np.arange(800) / 20.0 + rng.uniform(0, 100)
    axis = rng.normal(size=3)
    rot = Rotation.from_rotvec(np.outer((t - t[0]) * np.radians(rng.uniform(0.01, 0.05)), axis / np.linalg.norm(axis)))
    q = rot.as_quat()[:, [3, 0, 1, 2]]
    drift = np.outer(t - t[0], rng.uniform(-0.03, 0.03, 3))
    shape, voxel = tuple(int(v) for v in rng.integers(40, 90, 3)), tuple(rng.uniform(2.0, 4.0, 3))
    bounds = [t[0], t[-1]]
    noisy = petblur.Motion(t, drift + rng.normal(0, sigma, drift.shape), q).summary(bounds, shape, voxel)["frames"][0]
    clean = petblur.Motion(t, drift, q).summary(bounds, shape, voxel)["frames"][0]
    msg = f"sigma {sigma:.3f} mm, {shape} of {np.round(voxel, 2)} mm: noisy {noisy}, clean {clean}"
    assert noisy["noise_mm"] == pytest.approx(np.sqrt(3) * sigma, rel=0.25), msg
    assert clean["noise_mm"] == 0.0, msg
    assert noisy["segments"] <= clean["segments"] + 2, msg


def test_gradient_images_against_numpy(rng):
    shape = tuple(int(v) for v in rng.integers(1, 12, 3))
    voxel = rng.uniform(0.5, 4.0, 3)
    center = rng.uniform(-10, 40, 3)
    x = rng.normal(size=shape).astype(np.float32)
    got = pose.gradient_images(x, voxel, center)
    xd = np.pad(x.astype(np.float64), 1)
    grad = []
    for a in range(3):
        hi = np.roll(xd, -1, axis=a)[1:-1, 1:-1, 1:-1]
        lo = np.roll(xd, 1, axis=a)[1:-1, 1:-1, 1:-1]
        grad.append((hi - lo) / (2 * voxel[a]))
    p = np.meshgrid(*[(np.arange(n) + 0.5) * v - c for n, v, c in zip(shape, voxel, center)], indexing="ij")
    want = grad + list(np.cross(np.stack(p, -1), np.stack(grad, -1)).transpose(3, 0, 1, 2))
    for j in range(6):
        assert got[j].shape == shape and got[j].dtype == np.float32
        np.testing.assert_allclose(got[j], want[j], rtol=1e-6, atol=1e-6 * (np.abs(want[j]).max() + 1e-30),
                                   err_msg=f"image {j}")


def test_gradient_images_of_torch_tensors_equal_the_library_s(rng):
    torch = pytest.importorskip("torch")
    x = rng.normal(size=(9, 7, 5)).astype(np.float32)
    voxel, center = (1.5, 2.0, 2.5), (3.0, -2.0, 7.0)
    host = pose.gradient_images(x, voxel, center)
    dev = pose.gradient_images(torch.from_numpy(x), voxel, center)
    for j in range(6):
        np.testing.assert_allclose(dev[j].numpy(), host[j], rtol=1e-6, atol=1e-7)


def test_summary_shows_a_frame_no_path_walks(rng):
    """A frame whose default path would take more segments than a blur walks
    (a 20 Hz random walk of 1 mm steps held near the grid by a pull of 0.1 %
    a step back to it, 100 minutes of it, every sample followed) gets None for noise_mm and segments, as the program prints '-';
    the frame beside it is summarised as ever. That frame is 1000 s, 20001
    samples: the whiteness test took such a walk for noise in 11 of 400
    frames of 2001 samples and in none of 400 of 20001
    (bench/results/2026-11-29_cpu2_noise-scatter)."""
    t = np.arange(0, 7000, 0.05)
    walk = lfilter([1.0], [1.0, -0.999], rng.normal(0, 1.0, (t.size, 3)), axis=0)
    q = np.tile([1.0, 0.0, 0.0, 0.0], (t.size, 1))
    frames = petblur.Motion(t, walk, q).summary([0, 1000, 6999], (100, 100, 60), (2, 2, 2))["frames"]
    assert frames[0]["noise_mm"] == 0.0 and frames[0]["segments"] > 10000, frames[0]
    assert frames[1]["noise_mm"] is None and frames[1]["segments"] is None, frames[1]
    assert frames[1]["samples"] == 119981 and frames[1]["max_corner_mm"] > 0, frames[1]
