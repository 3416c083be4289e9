"""Motions from tracker logs, read by the library's readers, placed with the
command line's conventions: the same blur through Python as through the
program, for each format and convention option."""

import subprocess

import nibabel as nib
import numpy as np
import pytest

import petblur


def _unit(q):
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _small_turns(rng, n, deg=4.0):
    axes = _unit(rng.normal(size=(n, 3)))
    a = np.radians(rng.uniform(-deg, deg, n))
    return np.hstack([np.cos(a / 2)[:, None], np.sin(a / 2)[:, None] * axes])


def _rigid(rng, deg, shift):
    q = _small_turns(rng, 1, deg)[0]
    w, x, y, z = q
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = R, rng.uniform(-shift, shift, 3)
    return m


@pytest.fixture
def volume(tmp_path, rng):
    shape, vox = (15, 13, 10), np.array([2.0, 1.8, 2.4])
    affine = np.diag(np.append(vox, 1.0))
    affine[:3, 3] = rng.uniform(-40, 40, 3)
    x = rng.random(shape, dtype=np.float32)
    path = tmp_path / "x.nii"
    nib.Nifti1Image(x, affine).to_filename(str(path))
    img = nib.load(str(path))  # the geometry as stored, float32, as the program reads it
    return path, np.asfortranarray(x), img.affine, np.array(img.header.get_zooms()[:3], dtype=np.float64)


def _compare(cli, volume, tmp_path, motion, args, frame):
    path, x, affine, vox = volume
    out = tmp_path / "y.nii"
    subprocess.run([cli, "blur", "-q", "-i", str(path), "-o", str(out), "--device", "host", "--frame",
                    f"{frame[0]:.17g},{frame[1]:.17g}"] + args, check=True)
    want = nib.load(str(out)).get_fdata(dtype=np.float32)
    op = petblur.BlurOperator(x.shape, vox, motion, frame=frame, device="host", affine=affine)
    got = op(x)
    assert np.abs(want - x).max() > 1e-3  # the motion moves something
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6 * want.max())


def test_polaris_with_calibration(tmp_path, rng, cli, volume):
    n = 12
    t = 65912.5 + 0.05 * np.arange(n)
    # A head 1.9 m from the camera: 0.15 degrees move it by about 5 mm.
    q = np.round(_small_turns(rng, n, 0.15), 4)
    tr = np.round(np.array([-12.4, 56.8, -1893.3]) + rng.uniform(-2, 2, (n, 3)), 2)
    lines = ["23/5/2003 18:18:32 - 11 1 966_IRSL_II"]
    for i in range(n):
        lines.append(f"{t[i]:.3f} {13 + i} A " + " ".join(f"{v:.4f}" for v in q[i]) + " " +
                     " ".join(f"{v:.2f}" for v in tr[i]) + " 0.18")
        if i == 4:
            lines.append(f"{t[i] + 0.025:.3f}  2 A : ---- Missing ----")
    log = tmp_path / "head.mt"
    log.write_text("\n".join(lines) + "\n")
    cal = _rigid(rng, 20, 300)
    cal_path = tmp_path / "cal.txt"
    cal_path.write_text("\n".join(" ".join(f"{v:.17g}" for v in row) for row in cal) + "\n")
    ref = float(t[2])
    m = petblur.Motion.from_file(log, calibration=cal_path, reference_time=ref)
    assert len(m) == n and m.about_origin
    frame = (float(t[3]), float(t[9]))
    _compare(cli, volume, tmp_path, m, ["--motion", str(log), "--calibration", str(cal_path),
                                        "--reference-time", f"{ref:.17g}"], frame)
    # The matrix itself gives the same motion as its file.
    m2 = petblur.Motion.from_file(log, calibration=cal, reference_time=ref)
    _compare(cli, volume, tmp_path, m2, ["--motion", str(log), "--calibration", str(cal_path),
                                         "--reference-time", f"{ref:.17g}"], frame)
    # No reference time: the first sample, with a warning, as the program does.
    with pytest.warns(UserWarning, match="first sample"):
        m3 = petblur.Motion.from_file(log)
        _compare(cli, volume, tmp_path, m3, ["--motion", str(log)], frame)


def test_matrix_csv_in_ms_inverted(tmp_path, rng, cli, volume):
    n = 8
    rows = []
    for i in range(n):
        m = _rigid(rng, 5, 6)
        rows.append(",".join([f"{1000.0 * i:.17g}"] + [f"{v:.17g}" for v in m[:3].reshape(-1)]))
    log = tmp_path / "yrt.csv"
    log.write_text("\n".join(rows) + "\n")
    m = petblur.Motion.from_file(log, format="matrix-csv", time_unit="ms", inverse=True)
    assert m.times[-1] == pytest.approx(n - 1)
    _compare(cli, volume, tmp_path, m, ["--motion", str(log), "--motion-format", "matrix-csv", "--time-unit", "ms",
                                        "--motion-inverse"], (0.5, 5.5))


def test_csv_xyzw_about_a_centre(tmp_path, rng, cli, volume):
    n = 6
    q = _small_turns(rng, n, 8.0)
    tr = rng.uniform(-5, 5, (n, 3))
    lines = ["t,tx,ty,tz,q0,q1,q2,q3"]
    for i in range(n):
        xyzw = [q[i, 1], q[i, 2], q[i, 3], q[i, 0]]
        lines.append(",".join(f"{v:.17g}" for v in [0.5 * i, *tr[i], *xyzw]))
    log = tmp_path / "track.csv"
    log.write_text("\n".join(lines) + "\n")
    c = rng.uniform(-20, 20, 3)
    m = petblur.Motion.from_file(log, quaternion_order="xyzw", center=c)
    np.testing.assert_allclose(m.quaternions, q, atol=1e-15)
    _compare(cli, volume, tmp_path, m, ["--motion", str(log), "--quaternion-order", "xyzw", "--center",
                                        ",".join(f"{v:.17g}" for v in c)], (0.2, 2.3))
    # The same track as arrays.
    _compare(cli, volume, tmp_path, petblur.Motion(0.5 * np.arange(n), tr, q, center=c),
             ["--motion", str(log), "--quaternion-order", "xyzw", "--center", ",".join(f"{v:.17g}" for v in c)],
             (0.2, 2.3))


def test_bad_files(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0,zero,0,1,0,0,0\n")
    with pytest.raises(petblur.FileError, match=r"bad\.csv:3:") as e:
        petblur.Motion.from_file(bad)
    assert e.value.status == -600
    with pytest.raises(petblur.FileError, match="cannot open"):
        petblur.Motion.from_file(tmp_path / "missing.csv")
    order = tmp_path / "order.csv"
    order.write_text("t,tx,ty,tz,qw,qx,qy,qz\n1,0,0,0,1,0,0,0\n0,0,0,0,1,0,0,0\n")
    with pytest.raises(petblur.ArgumentError, match=r"order\.csv:3"):
        petblur.Motion.from_file(order)
    one = tmp_path / "one.csv"
    one.write_text("t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n")
    with pytest.raises(petblur.Error, match="at least two"):
        petblur.Motion.from_file(one)
    with pytest.raises(petblur.ArgumentError, match="format"):
        petblur.Motion.from_file(one, format="json")
    # The reader's refusal of an option the format does not take, in this API's words.
    with pytest.raises(petblur.Error, match="quaternion_order") as e:
        petblur.Motion.from_file(_matrix_file(tmp_path), quaternion_order="xyzw")
    assert "--" not in e.value.message
    good = tmp_path / "good.csv"
    good.write_text("t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,1,0,0,1,0,0,0\n")
    with pytest.raises(petblur.ArgumentError, match="calibration"):
        petblur.Motion.from_file(good, calibration=np.eye(3))
    with pytest.raises(petblur.ArgumentError, match="calibration: .*not a rotation"):
        petblur.Motion.from_file(good, calibration=np.diag([2.0, 1, 1, 1]))
    with pytest.raises(petblur.ArgumentError, match="reference_time"):
        petblur.Motion.from_file(good, reference_time=5.0)
    with pytest.raises(petblur.ArgumentError, match="origin"):
        petblur.Motion.from_file(_matrix_file(tmp_path), center=(1, 2, 3))


def _matrix_file(tmp_path):
    p = tmp_path / "m.csv"
    p.write_text("0,1,0,0,0,0,1,0,0,0,0,1,0\n1,1,0,0,2,0,1,0,0,0,0,1,0\n")
    return p
