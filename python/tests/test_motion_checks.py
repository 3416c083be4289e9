"""The program and Python on the same track files refuse and warn alike,
since both stand on the library's checks (include/petblur.h, "the motion
layer"): a track that leaves the grid for the whole frame, a one-sample
glitch of 120 degrees, a grid out of view at most poses, and a whole track
written x,y,z,w but read as w,x,y,z. Also the binding's layout check, made to
fail on purpose."""

import ctypes
import json
import re
import subprocess
import warnings

import nibabel as nib
import numpy as np
import pytest

import petblur
from petblur import _lib
from scipy.spatial.transform import Rotation


def _track(path, times, trans, quats):
    rows = ["t,tx,ty,tz,q0,q1,q2,q3"] + [",".join(f"{v:.10g}" for v in (t, *p, *q))
                                         for t, p, q in zip(times, trans, quats)]
    path.write_text("\n".join(rows) + "\n")
    return path


def _cases(tmp_path, rng):
    n = 31
    times = np.linspace(0.0, 3.0, n)
    rest = Rotation.from_rotvec(rng.normal(scale=0.03, size=(n, 3)))
    wxyz = np.roll(rest.as_quat(), 1, axis=1)  # scipy gives x,y,z,w
    small = rng.uniform(-2, 2, (n, 3))
    away = small + [900.0, 0, 0]
    most = small.copy()
    most[2:] += [0, 0, -900.0]
    glitch = wxyz.copy()
    glitch[12] = np.roll(Rotation.from_rotvec([0, np.radians(120), 0]).as_quat(), 1)
    return {
        "away": (_track(tmp_path / "away.csv", times, away, wxyz), "refuse", "out of the field of view"),
        "glitch": (_track(tmp_path / "glitch.csv", times, small, glitch), "warn", "degrees from the one before"),
        "most": (_track(tmp_path / "most.csv", times, most, wxyz), "warn", "wholly outside the field of view"),
        "xyzw": (_track(tmp_path / "xyzw.csv", times, small, rest.as_quat()), "warn",
                 "every pose turns more than 90 degrees from rest"),
    }


def _cli_words(err):
    """The program's warnings and refusal, in Python's option names."""
    lines = [re.sub(r"^petblur: (warning: )?", "", line) for line in err.splitlines()]
    return [petblur.motion.python_words(line) for line in lines if line]


def test_program_and_python_refuse_and_warn_alike(tmp_path, rng, cli):
    shape, vox = (20, 18, 12), np.array([2.0, 2.0, 3.0])
    affine = np.diag(np.append(vox, 1.0))
    affine[:3, 3] = [-19.0, -17.0, -16.5]
    x = rng.random(shape, dtype=np.float32)
    nib.Nifti1Image(x, affine).to_filename(str(tmp_path / "x.nii"))
    for name, (path, kind, words) in _cases(tmp_path, rng).items():
        out = tmp_path / f"{name}.nii"
        p = subprocess.run([cli, "blur", "-q", "-i", str(tmp_path / "x.nii"), "-o", str(out), "--device", "host",
                            "--motion", str(path)], capture_output=True, text=True)
        cli_lines = _cli_words(p.stderr)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                petblur.BlurOperator(shape, vox, petblur.Motion.from_file(path), affine=affine, device="host")
                refused = None
            except petblur.ArgumentError as e:
                refused = e.message
        py_lines = [str(w.message) for w in caught] + ([refused] if refused else [])
        if kind == "refuse":
            assert p.returncode == 2 and not out.exists(), (name, p.stderr)
            assert refused is not None and words in refused, (name, refused)
        else:
            assert p.returncode == 0 and out.exists(), (name, p.stderr)
            assert refused is None, (name, refused)
            assert any(words in line for line in py_lines), (name, py_lines)
        # Word for word the same messages, in each API's option names.
        assert sorted(cli_lines) == sorted(py_lines), (name, cli_lines, py_lines)
        assert any(words in line for line in cli_lines), (name, cli_lines)


def test_summaries_warn_where_a_blur_refuses(tmp_path, rng, cli):
    """A track that takes the grid out of view for a whole frame: a blur
    refuses it (above), the summaries show it, the program's (`petblur
    motion`, exit 0) and Python's (Motion.summary) with the same warning,
    and the same frame table."""
    shape, vox = (20, 18, 12), np.array([2.0, 2.0, 3.0])
    path, _, words = _cases(tmp_path, rng)["away"]
    frames = [0.0, 1.0, 3.0]
    p = subprocess.run([cli, "motion", str(path), "--dims", ",".join(map(str, shape)), "--voxel-size",
                        ",".join(f"{v:g}" for v in vox), "--coords", "grid", "--frames", "0,1,3"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    cli_lines = [line for line in _cli_words(p.stderr) if words in line]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = petblur.Motion.from_file(path).summary(frames, shape, vox)
    py_lines = [str(w.message) for w in caught if words in str(w.message)]
    assert len(cli_lines) == 1 and cli_lines == py_lines, (p.stderr, py_lines)
    rows = [line.split() for line in p.stdout.splitlines() if re.match(r"^ *\d+ ", line)]
    assert len(rows) == len(s["frames"]) == 2, p.stdout
    for row, frame in zip(rows, s["frames"]):
        assert int(row[3]) == frame["samples"], (row, frame)
        assert abs(float(row[5]) - frame["max_corner_mm"]) <= 0.01, (row, frame)


def test_the_order_that_fits_is_named(tmp_path, rng):
    cases = _cases(tmp_path, rng)
    with pytest.warns(UserWarning, match=r"read as x,y,z,w \(quaternion_order='xyzw'\) instead"):
        petblur.BlurOperator((20, 18, 12), 2.0, petblur.Motion.from_file(cases["xyzw"][0]), device="host")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # read as written: no warning at all
        petblur.BlurOperator((20, 18, 12), 2.0, petblur.Motion.from_file(cases["xyzw"][0], quaternion_order="xyzw"),
                             device="host")


def test_frames_from_a_sidecar_and_mean_pose(tmp_path):
    side = tmp_path / "sub-01_pet.json"
    side.write_text('{"FrameTimesStart": [0, 10, 20], "FrameDuration": [10, 10, 30], "Other": {"FrameDuration": 1}}')
    np.testing.assert_array_equal(petblur.frames_from_sidecar(side), [0, 10, 20, 50])
    side.write_text('{"FrameTimesStart": [0, 10], "FrameDuration": [5, 10]}')
    with pytest.raises(petblur.ArgumentError, match="frame 0 ends at 5 s but frame 1 starts at 10 s"):
        petblur.frames_from_sidecar(side)
    # A steady turn of 40 degrees about z over [0, 4]: the mean over [0, 4] is
    # the turn at 2 s, the translation's mean its midpoint.
    m = petblur.Motion.from_axis_angle(translation=(8, 0, -4), angle=40, duration=4.0)
    t, q = m.mean_pose(0.0, 4.0)
    np.testing.assert_allclose(t, [4, 0, -2], atol=1e-12)
    np.testing.assert_allclose(q, [np.cos(np.radians(10)), 0, 0, np.sin(np.radians(10))], atol=1e-12)
    t, q = m.pose_at(1.0)
    np.testing.assert_allclose(t, [2, 0, -1], atol=1e-12)
    np.testing.assert_allclose(q, [np.cos(np.radians(5)), 0, 0, np.sin(np.radians(5))], atol=1e-12)


def test_bounds_in_milliseconds_are_warned_of_where_given(tmp_path, rng):
    """Frames in milliseconds (a frame of hours) are warned of by the first
    call given the bounds: frames_from_sidecar, from_frames, mean_pose, not
    first when an operator is made; the same frames in seconds pass quietly."""
    n = int(rng.integers(2, 6))
    durations = rng.uniform(10, 600, n).round(3)
    durations[rng.integers(n)] = round(float(rng.uniform(30, 600)), 3)  # over 21.6 s: hours as milliseconds
    starts = np.concatenate([[0.0], np.cumsum(durations)[:-1]]).round(3) + float(rng.integers(0, 100))
    longest = int(np.argmax(durations))

    def words(frame):
        return (rf"frame {frame} \([0-9.e+]+ to [0-9.e+]+ s\) lasts [0-9.e+]+ h: are the times in milliseconds\? "
                r".*time_unit='ms'")

    for scale in (1.0, 1000.0):
        side = tmp_path / f"sub-01_pet_{scale:g}.json"
        side.write_text(json.dumps({"FrameTimesStart": (starts * scale).tolist(),
                                    "FrameDuration": (durations * scale).tolist()}))
        frames = (rng.random((8, 8, 8, n)) + 1.0).astype(np.float32)
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            bounds = petblur.frames_from_sidecar(side)
            from_sidecar = list(seen)
            petblur.Motion.from_frames(frames, None, starts * scale, durations * scale, voxel_size=2.0,
                                       device="host", levels=1)
            from_frames = seen[len(from_sidecar):]
            m = petblur.Motion(bounds[[0, -1]], np.zeros((2, 3)), [[1.0, 0, 0, 0]] * 2)
            before = len(seen)
            m.mean_pose(bounds[longest], bounds[longest + 1])
            from_mean = seen[before:]
        for got, frame in ((from_sidecar, longest), (from_frames, longest), (from_mean, 0)):
            texts = [str(w.message) for w in got if re.search("milliseconds", str(w.message))]
            if scale == 1.0:
                assert texts == [], texts
            else:
                assert len(texts) == 1 and re.search(words(frame), texts[0]), texts
                assert all(w.filename == __file__ for w in got if "milliseconds" in str(w.message))


def test_a_wrong_binding_layout_is_caught():
    _lib.check_layout()  # the real one passes

    class Pose(ctypes.Structure):  # rotation before translation: the same size, the wrong offsets
        _fields_ = [("rotation", ctypes.c_double * 4), ("translation", ctypes.c_double * 3)]

    with pytest.raises(ImportError, match=r"pb_pose\.translation is at 32"):
        _lib.check_layout(structs={"pb_pose": Pose}, enums={})
    with pytest.raises(ImportError, match="PB_PATH_TRACKED is 3 here, 2 in the library"):
        _lib.check_layout(structs={}, enums={"PB_PATH_TRACKED": 3})


def test_another_library_is_refused_by_name(tmp_path, rng):
    """PETBLUR_LIBRARY naming a library that loads but is not petblur's (the C
    library, zlib, libm, any of them under another name): the import fails
    with petblur's LibraryError naming the path, a call it lacks and the fix,
    not ctypes' AttributeError."""
    import ctypes.util
    import os
    import shutil
    import sys
    found = [ctypes.util.find_library(n) for n in ("c", "m", "z", "dl", "pthread")]
    names = [n for n in found if n]
    assert names, "no system library to load in petblur's place"
    path = _loaded_path(str(rng.choice(names)))
    if rng.integers(2):  # under a name of its own, as a mistaken build's would be
        copy = tmp_path / f"libpetblur-{int(rng.integers(1 << 30))}.so"
        shutil.copy(path, copy)
        path = str(copy)
    env = dict(os.environ, PETBLUR_LIBRARY=path)
    r = subprocess.run([sys.executable, "-c", "import petblur"], env=env, capture_output=True, text=True)
    assert r.returncode != 0
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("petblur.errors.LibraryError: "), r.stderr
    assert f"{path} (PETBLUR_LIBRARY) is not petblur's C library: it has no pb_" in last, last
    assert "point PETBLUR_LIBRARY at libpetblur.so" in last and "or unset it" in last, last


def _loaded_path(name):
    """The file a loaded library's name resolves to, from /proc/self/maps."""
    ctypes.CDLL(name)
    with open("/proc/self/maps") as f:
        for line in f:
            if line.split()[-1].rsplit("/", 1)[-1].startswith(name):  # libz.so.1 maps as libz.so.1.2.13
                return line.split()[-1]
    raise AssertionError(f"{name} is not mapped")


def test_options_checked_by_the_library():
    m = petblur.Motion.from_axis_angle(angle=10)
    for bad, words in ((-1, "from 0.001"), (float("nan"), "from 0.001"), (5000, "to 1000"), (1e-9, "1e-09: .*from 0.001"),
                       ("fine", "bound in voxels")):
        with pytest.raises(petblur.ArgumentError, match=words):
            petblur.BlurOperator((8, 8, 8), 1.0, m, max_path_error=bad, device="host")
    with pytest.raises(petblur.ArgumentError, match="steps 200000 is above 100000"):
        petblur.BlurOperator((8, 8, 8), 1.0, m, steps=200000, method="rm", device="host")


def test_progress_and_frames_last(rng):
    shape = (9, 8, 7)
    m = petblur.Motion(np.linspace(0, 4, 5), rng.uniform(-2, 2, (5, 3)), [[1, 0, 0, 0]] * 5)
    seen = []
    op = petblur.BlurOperator(shape, 1.5, m, device="host", progress=seen.append)
    op(rng.random(shape, dtype=np.float32))
    assert seen and seen[-1] == 1.0 and all(0 <= f <= 1 for f in seen)
    frames = petblur.FramesOperator(shape, 1.5, m, [0, 1, 3, 4], per_frame=True, device="host")
    last = petblur.FramesOperator(shape, 1.5, m, [0, 1, 3, 4], per_frame=True, device="host", frames_last=True)
    x = rng.random((3,) + shape, dtype=np.float32)
    xl = np.asfortranarray(np.moveaxis(x, 0, -1))  # nibabel's [x, y, z, t]
    assert last.in_shape == shape + (3,)
    np.testing.assert_array_equal(np.moveaxis(last(xl), -1, 0), frames(x))
    y = rng.random((3,) + shape, dtype=np.float32)
    np.testing.assert_array_equal(np.moveaxis(last.adjoint(np.moveaxis(y, 0, -1)), -1, 0), frames.adjoint(y))


def test_a_walk_of_millions_of_voxels_is_refused(rng):
    """A blur walks each voxel's path slice by slice: on a grid whose voxels
    along one axis are micrometres (a unit slip, or a sliver of a grid) a
    turn of degrees carries the object millions of voxels along it, and the
    walk ran for hours (a 10^3 grid of 0.0001 x 5000 x 5000 mm turned 5
    degrees: over 60 s before 2026-12-06). It is refused at once, naming the
    axis and the units, by every method, and by a gate's intervals together;
    a head's motion on a PET grid is walked as before."""
    import time

    n = (10, 10, 10)
    thin = int(rng.integers(0, 3))
    voxel = rng.uniform(100.0, 5000.0, 3)
    voxel[thin] = 10 ** rng.uniform(-4.0, -3.0)
    axis = rng.normal(size=3)
    axis[thin] = 0.0  # turning about the thin axis would not carry the object along it
    angle = np.radians(rng.uniform(2.0, 10.0))
    q = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis / np.linalg.norm(axis)])
    m = petblur.Motion([0.0, 1.0], np.zeros((2, 3)), [[1.0, 0.0, 0.0, 0.0], q])
    x = rng.random(n).astype(np.float32)
    for method in ("ab", "rm", "cl", "ref"):
        start = time.monotonic()
        with pytest.raises(petblur.ArgumentError, match=f"voxels along {'xyz'[thin]}.*units"):
            petblur.BlurOperator(n, voxel, m, method=method, device="host")(x)
        assert time.monotonic() - start < 10.0, method
    # AB's steps cut a segment into pieces that are walked all the same: no way past the check.
    with pytest.raises(petblur.ArgumentError, match=f"voxels along {'xyz'[thin]}.*units"):
        petblur.BlurOperator(n, voxel, m, method="ab", steps=int(rng.integers(1, 5)), device="host")(x)
    # REF counted its time steps in the smallest voxels, whatever the axis: a shift of voxels along a coarser axis
    # took 2e10 steps on this grid (an unsigned overflow) and ran for hours. Each axis in its own voxels: a shift of
    # 9-14 voxels along the middle axis takes 18-28 steps, as on a grid of the middle axis's voxels (counted in the
    # coarsest voxels, as many as 16).
    mid, coarse_axis = (thin + 1) % 3, (thin + 2) % 3
    voxel[mid], voxel[coarse_axis] = rng.uniform(100.0, 1000.0), rng.uniform(2500.0, 5000.0)
    shift = np.zeros(3)
    shift[mid] = rng.uniform(9.0, 14.0) * voxel[mid] * rng.choice([-1.0, 1.0])
    slide = petblur.Motion([0.0, 1.0], [np.zeros(3), shift], [[1.0, 0.0, 0.0, 0.0]] * 2)
    start = time.monotonic()
    y = petblur.BlurOperator(n, voxel, slide, method="ref", device="host")(x)
    assert time.monotonic() - start < 10.0
    np.testing.assert_array_equal(y, petblur.BlurOperator(n, np.full(3, voxel[mid]), slide, method="ref",
                                                          device="host")(x))
    # and the blur a dense CL gives, to REF's own sampling of a noise object
    cl = petblur.BlurOperator(n, voxel, slide, method="cl", steps=4000, filter="exact", device="host")(x)
    assert np.sqrt(((y - cl) ** 2).sum() / (cl ** 2).sum()) <= 0.01 and np.abs(y - cl).max() <= 0.025 * cl.max()
    # Fixed steps cost steps times segments whatever the motion: 100000 steps on each of 200 tracked intervals (2e7
    # samples a voxel) are refused at once; a dense reference of 4000 on one segment is taken (above).
    log = petblur.Motion(np.linspace(0.0, 10.0, 201), rng.normal(0.0, 0.2, (201, 3)), [[1.0, 0.0, 0.0, 0.0]] * 201)
    for method in ("cl", "rm"):
        start = time.monotonic()
        with pytest.raises(petblur.ArgumentError, match=r"200 segments at 100000 fixed steps each take 2e\+07 samples"):
            petblur.BlurOperator((12, 12, 12), 2.0, log, method=method, steps=100000, max_path_error="paper",
                                 device="host")(rng.random((12, 12, 12)).astype(np.float32))
        assert time.monotonic() - start < 10.0, method
    # A gate of many intervals, each walked within a frame's limits, all of them together past a frame's.
    k = 100
    swing = np.zeros((k + 1, 3))
    swing[1::2, thin] = rng.uniform(0.9, 1.0) * 1000.0 * voxel[thin]  # 900-1000 voxels an interval
    log = petblur.Motion(np.arange(k + 1, dtype=float), swing, [[1.0, 0.0, 0.0, 0.0]] * (k + 1))
    gate = [[(float(i), i + 1.0) for i in range(k)]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the swing takes the grid out of the field of view, and back
        with pytest.raises(petblur.ArgumentError, match=f"voxels along {'xyz'[thin]}.* by .*units"):
            petblur.FramesOperator(n, voxel, log, gate, device="host")(x)
        few = petblur.FramesOperator(n, voxel, log, [gate[0][:10]], device="host")(x)
    assert np.isfinite(few).all() and np.abs(few).max() > 0
    # a head's turn and shift on a PET grid: walked
    grid = (32, 32, 24)
    head = petblur.Motion([0.0, 1.0], [[0.0, 0.0, 0.0], rng.uniform(-10.0, 10.0, 3)], [[1.0, 0.0, 0.0, 0.0], q])
    y = petblur.BlurOperator(grid, rng.uniform(2.0, 4.0, 3), head, device="host")(rng.random(grid).astype(np.float32))
    assert np.isfinite(y).all() and np.abs(y).max() > 0
