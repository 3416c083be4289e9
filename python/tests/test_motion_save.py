"""Motion.save (issue 47): a track file that from_file and the program read back to the same motion, the conventions
applied, written whole or not at all; checked against numpy's own reading of the file and scipy's poses."""
import os
import re
import subprocess

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import petblur
from petblur.errors import ArgumentError


def _random_motion(rng, n=None, center=True):
    n = n or int(rng.integers(2, 40))
    t = np.cumsum(rng.uniform(0.01, 2.0, n)) + rng.uniform(-100, 100)
    q = Rotation.random(n, random_state=int(rng.integers(1 << 31))).as_quat()[:, [3, 0, 1, 2]]
    tr = rng.normal(0, 20, (n, 3))
    return petblur.Motion(t, tr, q, center=tuple(rng.normal(0, 50, 3)) if center else None)


def _same_poses(a, b, times):
    for t in times:
        (ta, qa), (tb, qb) = a.pose_at(t), b.pose_at(t)
        assert np.abs(ta - tb).max() < 1e-9 and abs(abs(qa @ qb) - 1) < 1e-12, (t, ta, tb, qa, qb)


def test_csv_round_trip(rng, tmp_path):
    """A csv motion, with a centre or without: the file holds its arrays to the last bit, and read back with the
    same center= it is the same motion at any time."""
    for center in (True, False):
        m = _random_motion(rng, center=center)
        path = tmp_path / "m.csv"
        m.save(path)
        back = petblur.Motion.from_file(path, center=m.center)
        assert back.times.tolist() == m.times.tolist()
        assert back.translations.tolist() == m.translations.tolist()
        assert back.quaternions.tolist() == m.quaternions.tolist()
        if center:
            _same_poses(m, back, rng.uniform(m.times[0], m.times[-1], 20))
        assert oct(os.stat(path).st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_tracker_matrices_with_conventions(rng, tmp_path):
    """A matrix-csv log read with a calibration, a reference time and inverse: saved, the file holds
    M(t) = C P(t)^-1... as scipy composes it from the raw matrices (inverse: P^-1 first), and reads back without
    conventions to the same motion."""
    n = int(rng.integers(3, 30))
    t = np.cumsum(rng.uniform(0.05, 1.0, n))
    raw = np.tile(np.eye(4), (n, 1, 1))
    raw[:, :3, :3] = Rotation.random(n, random_state=int(rng.integers(1 << 31))).as_matrix()
    raw[:, :3, 3] = rng.normal(0, 30, (n, 3))
    src = tmp_path / "log.csv"
    np.savetxt(src, np.column_stack([t, raw[:, :3, :].reshape(n, 12)]), delimiter=",", fmt="%.17g",
               header="t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz", comments="")
    cal = np.eye(4)
    cal[:3, :3] = Rotation.random(random_state=int(rng.integers(1 << 31))).as_matrix()
    cal[:3, 3] = rng.normal(0, 100, 3)
    ref = int(rng.integers(n))
    inverse = bool(rng.integers(2))
    m = petblur.Motion.from_file(src, calibration=cal, reference_time=t[ref], inverse=inverse)
    out = tmp_path / "saved.csv"
    m.save(out)
    p = np.array([np.linalg.inv(x) for x in raw]) if inverse else raw
    want = np.array([cal @ pk @ np.linalg.inv(p[ref]) @ np.linalg.inv(cal) for pk in p])
    got = np.loadtxt(out, delimiter=",", skiprows=1, ndmin=2)
    assert got[:, 0].tolist() == t.tolist()
    np.testing.assert_allclose(got[:, 1:].reshape(n, 3, 4), want[:, :3, :], rtol=0, atol=1e-9)
    back = petblur.Motion.from_file(out)
    assert back.about_origin and back._coords == "world"
    _same_poses(m, back, rng.uniform(t[0], t[-1], 20))


def test_an_estimate_in_the_grid_frame(rng, tmp_path):
    """An estimate given voxel_size= (the grid frame) saves as matrix-csv and reads back with coords='grid': an
    operator without an affine blurs alike with either, to float rounding: the rotation read back as a matrix
    gives its quaternion to the last bit (4e-17 apart on seed 2916251715, a CI rehearsal's), which moved one
    float32 voxel of 512 by one rounding (1.3e-10 of the largest value)."""
    from test_estimate_input import SIDE, _series
    frames = _series(rng, 4)
    x = frames[..., 0]
    m = petblur.Motion.from_frames(frames, voxel_size=2.0, bounds=np.arange(5) * 10.0, device="host")
    path = tmp_path / "estimate.csv"
    m.save(path)
    back = petblur.Motion.from_file(path, coords="grid")
    ops = [petblur.BlurOperator((SIDE,) * 3, 2.0, mm, frame=(5.0, 35.0), device="host") for mm in (m, back)]
    np.testing.assert_array_equal(back.times, m.times)
    np.testing.assert_allclose(back.quaternions, m.quaternions, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back.translations, m.translations, rtol=0, atol=1e-12)
    y = np.asfortranarray(x)
    a, b = np.asarray(ops[0](y)), np.asarray(ops[1](y))
    assert np.abs(a).max() > 0
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-6 * np.abs(a).max())
    with pytest.raises(ArgumentError, match="coords"):
        petblur.Motion.from_file(path, coords="voxels")
    with pytest.raises(ArgumentError):  # read as tracker matrices, in the world: an operator wants the affine
        petblur.BlurOperator((SIDE,) * 3, 2.0, petblur.Motion.from_file(path), frame=(5.0, 35.0), device="host")


def test_the_program_reads_it(rng, tmp_path, cli):
    """`petblur motion` on the saved file prints what Motion.summary gives for the motion saved."""
    m = _random_motion(rng, n=30)
    path = tmp_path / "m.csv"
    m.save(path)
    shape, voxel = (30, 28, 20), (2.0, 2.5, 3.0)
    bounds = np.linspace(m.times[0], m.times[-1], 4)
    out = subprocess.run([cli, "motion", str(path), "--frames", ",".join(repr(float(b)) for b in bounds), "--dims",
                          ",".join(map(str, shape)), "--voxel-size", ",".join(map(str, voxel)), "--center",
                          ",".join(repr(float(v)) for v in m.center)], capture_output=True, text=True,
                         check=True).stdout
    rows = [line.split() for line in out.splitlines() if re.match(r"^\s*\d+\s", line)]
    s = m.summary(bounds, shape, voxel)
    assert len(rows) == len(s["frames"]) == 3
    for row, f in zip(rows, s["frames"]):
        assert int(row[3]) == f["samples"]
        assert float(row[4]) == pytest.approx(f["max_turn_deg"], abs=5e-4)
        assert float(row[5]) == pytest.approx(f["max_corner_mm"], abs=5e-4)


def test_refusals_leave_nothing(rng, tmp_path):
    """The other format (it would turn about another centre), an unknown one, the file the motion was read from,
    and a folder that is not there: refused, nothing written, no temporary left."""
    m = _random_motion(rng)
    with pytest.raises(ArgumentError, match="format='csv'"):
        m.save(tmp_path / "a.csv", format="matrix-csv")
    with pytest.raises(ArgumentError, match="choose 'csv' or 'matrix-csv'"):
        m.save(tmp_path / "a.csv", format="polaris")
    src = tmp_path / "src.csv"
    m.save(src)
    before = src.read_bytes()
    read = petblur.Motion.from_file(src, center=m.center)
    with pytest.raises(ArgumentError, match="read from"):
        read.save(src)
    assert src.read_bytes() == before
    matrices = tmp_path / "mat.csv"
    matrices.write_text("t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz\n0,1,0,0,0,0,1,0,0,0,0,1,0\n"
                        "1,1,0,0,5,0,1,0,0,0,0,1,0\n")
    with pytest.raises(ArgumentError, match="format='matrix-csv'"):
        petblur.Motion.from_file(matrices).save(tmp_path / "b.csv", format="csv")
    with pytest.raises(FileNotFoundError, match="missing does not exist") as e:
        m.save(tmp_path / "missing" / "c.csv")
    assert e.value.filename == str(tmp_path / "missing" / "c.csv")  # the path given, not a temporary's
    with pytest.raises(IsADirectoryError) as e:
        m.save(tmp_path)
    assert e.value.filename == str(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mat.csv", "src.csv"]
