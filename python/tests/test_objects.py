"""Operators and motions as Python objects: copy.copy shares an operator's C
plans and outlives the original; deepcopy and pickle rebuild from the
description (in this process and in a fresh one), small and free of C
pointers and volumes; masked arrays, NaN and infinity are refused; a zero
quaternion in a track file is refused, naming file and line.

Inputs are fresh random ones each run (conftest's rng: the seed is printed,
PETBLUR_TEST_SEED replays it). The operators take no output array, so there
is none to fill with NaN beforehand."""

import copy
import gc
import os
import pathlib
import pickle
import re
import subprocess
import sys
import threading
import warnings
import weakref

import numpy as np
import pytest

import petblur
from petblur import _lib, pose

SHAPE = (32, 32, 32)  # of the pickle whose size is bounded


def _motion(rng, n=100):
    """n poses over 10 s: small turns about random axes, moves of a few mm."""
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    half = np.radians(rng.uniform(0, 6, n)) / 2
    q = np.c_[np.cos(half), np.sin(half)[:, None] * axes]
    return petblur.Motion(np.linspace(0, 10, n), rng.uniform(-3, 3, (n, 3)), q)


def _operator(kind, device, rng, shape=None, **kw):
    """A BlurOperator of a part of a 100-pose track, or a FramesOperator of
    four frames (frames last or first, at random), on a grid of shape (a
    random one of 12 to 19 voxels a side when None)."""
    shape = tuple(int(n) for n in rng.integers(12, 20, 3)) if shape is None else shape
    m = _motion(rng)
    vox = rng.uniform(1.5, 2.5, 3)
    if kind == "blur":
        t0 = rng.uniform(0, 3)
        return petblur.BlurOperator(shape, vox, m, frame=(t0, t0 + rng.uniform(2, 6)), device=device, **kw)
    return petblur.FramesOperator(shape, vox, m, np.sort(rng.uniform(0, 10, 5)), device=device,
                                  frames_last=bool(rng.integers(2)), **kw)


KINDS = pytest.mark.parametrize("kind", ["blur", "frames"])


def laid_out(a, order, frames_last=False):
    """a with each volume in memory order 'C' or 'F' (which picks the
    operator's plan: 'F' is made with the operator, 'C' at its first use)."""
    if a.ndim == 3:
        return np.asarray(a, order=order)
    f = np.moveaxis(a, -1 if frames_last else 0, 0)  # frames first, then each volume laid out
    f = np.ascontiguousarray(f) if order == "C" else np.moveaxis(np.asfortranarray(np.moveaxis(f, 0, -1)), -1, 0)
    return np.moveaxis(f, 0, -1 if frames_last else 0)


def _inputs(op, rng, order):
    """Random x and y for apply and adjoint, each volume in memory order 'C'
    or 'F' (laid_out)."""
    last = getattr(op, "frames_last", False)
    return (laid_out(rng.random(op.in_shape, dtype=np.float32), order, last),
            laid_out(rng.random(op.out_shape, dtype=np.float32), order, last))


def _results(op, x, y):
    return op(x), op.adjoint(y)


def _assert_same(got, want, device):
    """(B x, B^T y) against what another operator gave: the same to the bit,
    but for a device's adjoint, which scatters with float atomics whose order
    varies from run to run, even on one operator (docs/testing.md): to their
    rounding, here of many adds and of four frames' sums."""
    for g, w, adjoint in zip(got, want, (False, True)):
        assert g.shape == w.shape and g.dtype == w.dtype
        if adjoint and device != "host":
            np.testing.assert_allclose(g, w, rtol=0, atol=1e-4 * np.abs(w).max())
        else:
            assert np.array_equal(g, w), f"results differ: max |diff| {np.abs(g - w).max()}"


@KINDS
def test_copy_shares_the_plans_and_outlives_the_original(device, rng, kind):
    op = _operator(kind, device, rng)
    x, y = _inputs(op, rng, "F")
    want = _results(op, x, y)  # the original's, from its Fortran plan only
    rebuilt = copy.deepcopy(op)  # for the C-order plan below
    c = copy.copy(op)
    assert c._handles is op._handles and c.device == op.device
    handles = weakref.ref(op._handles)
    del op
    gc.collect()
    assert handles() is not None  # the copy holds them
    _assert_same(_results(c, x, y), want, device)
    # The C-order plan, made by the copy after the original went, into the
    # handles it shares, and seen by a copy of the copy.
    xc, yc = _inputs(c, rng, "C")
    want_c = _results(rebuilt, xc, yc)
    _assert_same(_results(c, xc, yc), want_c, device)
    assert c.adjointness_test(rtol=1e-4, seed=int(rng.integers(1 << 30))) <= 1e-4
    cc = copy.copy(c)
    del c
    gc.collect()
    assert set(cc._handles.plans) == {"F", "C"}
    _assert_same(_results(cc, xc, yc), want_c, device)
    # The last holder gone: the C objects with it.
    del cc
    gc.collect()
    assert handles() is None


def test_copies_run_together_from_threads(device, rng):
    """Copies share one plan; the context's lock lets them take turns."""
    op = _operator("blur", device, rng)
    xs = [rng.random(op.in_shape, dtype=np.float32) for _ in range(4)]
    want = [op(x) for x in xs]
    copies = [copy.copy(op) for _ in xs]
    del op
    gc.collect()
    got = [None] * len(xs)

    def run(i):
        got[i] = copies[i](xs[i])

    threads = [threading.Thread(target=run, args=(i,)) for i in range(len(xs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


@KINDS
def test_deepcopy_rebuilds(device, rng, kind):
    op = _operator(kind, device, rng, method=str(rng.choice(["ab", "rm"])), max_path_error=rng.uniform(0.1, 0.5))
    x, y = _inputs(op, rng, str(rng.choice(["C", "F"])))
    want = _results(op, x, y)
    d = copy.deepcopy(op)
    assert d._handles is not op._handles and d.motion is not op.motion and d.device == op.device
    assert type(d) is type(op) and d.in_shape == op.in_shape and d.out_shape == op.out_shape
    assert d.method == op.method and d._common == op._common
    np.testing.assert_array_equal(d.voxel_size, op.voxel_size)
    del op
    gc.collect()
    _assert_same(_results(d, x, y), want, device)


@KINDS
def test_pickle_round_trip(device, rng, kind):
    op = _operator(kind, device, rng, filter=str(rng.choice(["hardware", "exact"])),
                   max_path_error=rng.choice([None, "paper"]), steps=int(rng.integers(0, 3)))
    x, y = _inputs(op, rng, str(rng.choice(["C", "F"])))
    want = _results(op, x, y)
    loaded = pickle.loads(pickle.dumps(op))
    assert type(loaded) is type(op) and loaded._handles is not op._handles and loaded.device == op.device
    assert loaded._common == op._common and loaded.in_shape == op.in_shape and loaded.out_shape == op.out_shape
    if kind == "frames":
        assert loaded.frames_last == op.frames_last and loaded.per_frame == op.per_frame
        np.testing.assert_array_equal(loaded.bounds, op.bounds)
    else:
        assert loaded.frame == op.frame
    del op
    gc.collect()
    _assert_same(_results(loaded, x, y), want, device)


@KINDS
def test_pickle_is_small(device, rng, kind):
    """The description of a 32^3 grid and a 100-pose motion: no volume, no
    ctypes object, and the same bytes after a call made the operator's
    volumes and its C-order plan."""
    op = _operator(kind, device, rng, shape=SHAPE)
    data = pickle.dumps(op)
    assert len(data) < 64 * 1024, len(data)
    assert b"ctypes" not in data and b"_Handles" not in data
    op(rng.random(SHAPE, dtype=np.float32))
    assert pickle.dumps(op) == data


_CHILD = """
import pickle, sys
import numpy as np
sys.path.insert(0, sys.argv[6])
from test_objects import laid_out
with open(sys.argv[1], "rb") as f:
    op = pickle.load(f)
order, last = sys.argv[7], sys.argv[8] == "1"
x, y = laid_out(np.load(sys.argv[2]), order, last), laid_out(np.load(sys.argv[3]), order, last)
np.save(sys.argv[4], op(x))
np.save(sys.argv[5], op.adjoint(y))
print(op.device)
"""


@KINDS
def test_pickle_loads_in_a_fresh_process(device, rng, tmp_path, kind):
    """The loading process plans again on its own: the same results, saved
    as .npy.

    The child lays its inputs out as they were here (laid_out): np.save
    writes an array that is neither C- nor Fortran-contiguous (frames first,
    each volume in Fortran order) in C order, and the child then ran the C
    plan (the transposed grid) where this process ran the Fortran plan. On a
    float32 device the two plans differ where a path segment's two largest
    extents tie within float rounding: the walk's major axis (ties: the lower
    axis, another axis in the transposed grid) and so its slices differ. Seed
    1792915305 (PoCL, frames): segment extents 1.25526952 and 1.25527028
    voxels along x and z, one tomograph voxel's row off by 2.5 % of its
    entries, the adjoint by 5.6e-4 of its largest value, where the same
    operator run twice differs by 6.4e-7 (its atomics' order) and the host,
    in double, gives the C and Fortran plans bit for bit. Laid out alike,
    over 150 draws of each kind (PoCL, seeds 10000-10149): the forward bit
    for bit every time, the adjoint off by median 0 (blur) and 4.0e-7
    (frames) of its largest value, 99th percentile 1.4e-6, largest 1.45e-6,
    against _assert_same's 1e-4."""
    env = dict(os.environ)
    package = str(pathlib.Path(petblur.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([package] + [p for p in [env.get("PYTHONPATH")] if p])
    op = _operator(kind, device, rng)
    order = str(rng.choice(["C", "F"]))
    x, y = _inputs(op, rng, order)
    want = _results(op, x, y)
    files = [tmp_path / name for name in ("op.pickle", "x.npy", "y.npy", "bx.npy", "bty.npy")]
    files[0].write_bytes(pickle.dumps(op))
    np.save(files[1], x)
    np.save(files[2], y)
    args = [str(f) for f in files] + [str(pathlib.Path(__file__).parent), order,
                                      str(int(getattr(op, "frames_last", False)))]
    run = subprocess.run([sys.executable, "-c", _CHILD] + args, env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split()[-1] == op.device
    _assert_same((np.load(files[3]), np.load(files[4])), want, device)


def test_pickle_keeps_the_device_spec(monkeypatch, rng):
    """The spec as given, resolved where the pickle is loaded: 'auto' picks
    that process's device."""
    spec = "auto" if any(s.startswith("opencl") for s, _ in petblur.devices()) else "host"
    op, frames = _operator("blur", spec, rng), _operator("frames", spec, rng)
    asked = []
    real = _lib.context

    def context(device):
        asked.append(device)
        return real(device)

    monkeypatch.setattr(_lib, "context", context)
    pickle.loads(pickle.dumps(op))
    copy.deepcopy(frames)
    assert asked == [spec, spec]


def test_rebuilt_operators_do_not_warn_again(device):
    """Every pose turned 180 degrees: the quaternion-order warning once, when
    the operator is made, not again in its copies."""
    flipped = petblur.Motion([0.0, 1.0], np.zeros((2, 3)), [[0, 0, 0, 1], [0, 0, 0, 1]])
    with pytest.warns(UserWarning, match="quaternion_order"):
        op = petblur.BlurOperator((12, 12, 12), 2.0, flipped, device=device)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        copy.deepcopy(op)
        pickle.loads(pickle.dumps(op))
        copy.copy(op)


def _progress(fraction):
    _progress.seen.append(fraction)


_progress.seen = []


class _Bar:
    """A progress callable that holds a lock, as progress bars do."""

    def __init__(self):
        self.lock = threading.Lock()
        self.seen = []

    def __call__(self, fraction):
        self.seen.append(fraction)


@KINDS
def test_progress_and_pickles(device, rng, kind):
    shape = (12, 11, 10)
    x = rng.random(shape, dtype=np.float32)
    loaded = pickle.loads(pickle.dumps(_operator(kind, device, rng, shape, progress=_progress)))
    assert loaded._progress is _progress
    _progress.seen.clear()
    loaded(x)
    assert _progress.seen and _progress.seen[-1] == 1.0
    for progress in (lambda f: None, _Bar()):
        op = _operator(kind, device, rng, shape, progress=progress)
        with pytest.raises(pickle.PicklingError, match=r"progress=None.*module's top level"):
            pickle.dumps(op)
        # deepcopy needs no pickle, and reports to the same callable.
        assert copy.deepcopy(op)._progress is progress
    bar = _Bar()
    copy.deepcopy(_operator(kind, device, rng, shape, progress=bar))(x)
    assert bar.seen and bar.seen[-1] == 1.0


@KINDS
def test_progress_raises_and_reenters(device, rng, kind):
    """An exception inside progress is raised when the call returns (ctypes alone printed it, and a KeyboardInterrupt
    never stopped the call's caller), and the operator called from its own progress, whose buffers hold the call in
    progress, is refused (on OpenCL the outer call returned the inner's result)."""
    shape = (12, 11, 10)
    x = rng.random(shape, dtype=np.float32)

    def stop(fraction):
        raise KeyboardInterrupt("stop")
    with pytest.raises(KeyboardInterrupt, match="stop"):
        _operator(kind, device, rng, shape, progress=stop)(x)
    holder = []

    def again(fraction):
        holder[0](x)
    op = _operator(kind, device, rng, shape, progress=again)
    holder.append(copy.copy(op))  # a shallow copy shares the operator's buffers
    with pytest.raises(petblur.ArgumentError, match="its own progress"):
        op(x)
    # and afterwards the operator works as before, its progress left as it was
    quiet = copy.copy(_operator(kind, device, rng, shape))
    assert np.isfinite(quiet(x)).all()


@KINDS
def test_values_an_operator_reads_are_bounded(device, rng, kind):
    """An adjoint adds each voxel's weights and a frames' adjoint the frames: near float32's top they left its range
    and returned infinities for finite input. The operators read magnitudes up to 1e30, and name the voxel beyond."""
    shape = (12, 11, 10)
    op = _operator(kind, device, rng, shape)
    y = op(rng.random(shape, dtype=np.float32))
    big = (y * 1e29).astype(np.float32)
    assert np.isfinite(op.adjoint(big)).all()
    at = tuple(int(rng.integers(0, n)) for n in big.shape)
    big[at] = rng.uniform(2e30, 3e38)
    with pytest.raises(petblur.ArgumentError, match=r"beyond 1e\+30.*scale the values"):
        op.adjoint(big)
    # a tolerance that no difference can meet is the caller's mistake, not the operator's failed test
    with pytest.raises(petblur.ArgumentError, match="rtol nan"):
        op.adjointness_test(rtol=float("nan"))


def test_motion_copies(tmp_path, rng):
    """Arrays and conventions (centre, calibration, reference time, inverse)
    survive deepcopy and pickle: the same poses."""
    m = _motion(rng, 20)
    path = tmp_path / "track.csv"
    with open(path, "w") as f:
        f.write("t,tx,ty,tz,qw,qx,qy,qz\n")
        for t, tr, q in zip(m.times, m.translations, m.quaternions):
            f.write(",".join(f"{v:.17g}" for v in (t, *tr, *q)) + "\n")
    cal = np.eye(4)
    cal[:3, 3] = rng.uniform(-50, 50, 3)
    read = petblur.Motion.from_file(path, calibration=cal, reference_time=rng.uniform(0, 10), inverse=True,
                                    center=rng.uniform(-20, 20, 3))
    for motion in (m, read):
        for other in (copy.deepcopy(motion), pickle.loads(pickle.dumps(motion))):
            assert other is not motion and other.times is not motion.times
            for name in ("times", "translations", "quaternions"):
                np.testing.assert_array_equal(getattr(other, name), getattr(motion, name))
            for t in rng.uniform(0, 10, 5):
                for a, b in zip(other.pose_at(t), motion.pose_at(t)):
                    np.testing.assert_array_equal(a, b)
    # A pickle is checked when it is loaded, as the arrays were when made.
    state = m.__getstate__()
    state["quaternions"] = state["quaternions"].copy()
    state["quaternions"][int(rng.integers(len(m)))] = 0.0
    with pytest.raises(petblur.ArgumentError, match="zero"):
        petblur.Motion.__new__(petblur.Motion).__setstate__(state)


def _loads(reduced):
    """What pickle.loads makes of a pickle whose load calls reduced,
    (callable, args[, state]): a pickle tampered with, or cut short, as it
    would arrive from a file or another process."""

    class Tampered:
        def __reduce__(self):
            return reduced

    # Protocol 1: 2 and later refuse to write copyreg.__newobj__ of a class
    # not the object's own; loading calls the same __new__ and __setstate__.
    return pickle.loads(pickle.dumps(Tampered(), protocol=1))


def _any_motion(tmp_path, rng):
    """A motion of arrays, of a csv file with conventions, or of tracker
    matrices; at random with an estimate's report and coordinates."""
    m = _motion(rng, int(rng.integers(2, 30)))
    kind = int(rng.integers(3))
    if kind:
        path = tmp_path / f"track{int(rng.integers(1 << 30))}.csv"
        if kind == 1:
            rows = ["t,tx,ty,tz,qw,qx,qy,qz"] + [",".join(f"{v:.17g}" for v in (t, *tr, *q))
                                                 for t, tr, q in zip(m.times, m.translations, m.quaternions)]
        else:
            rows = ["t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz"]
            for t, tr in zip(m.times, m.translations):
                rows.append(",".join(f"{v:.17g}" for v in (t, 1, 0, 0, tr[0], 0, 1, 0, tr[1], 0, 0, 1, tr[2])))
        path.write_text("\n".join(rows) + "\n")
        cal = np.eye(4)
        cal[:3, 3] = rng.uniform(-50, 50, 3)
        m = petblur.Motion.from_file(path, calibration=cal, reference_time=rng.uniform(0, 10),
                                     inverse=bool(rng.integers(2)),
                                     center=rng.uniform(-20, 20, 3) if kind == 1 else None)
    if rng.integers(2):
        m.estimate_seconds, m.moving_frames = float(rng.uniform(0, 9)), int(rng.integers(0, 9))
        m._coords = str(rng.choice(["world", "grid"]))
    return m


def _tamper_motion(state, rng):
    """One random edit of a Motion's state: a key dropped or added, an array
    of the wrong length, a field of the wrong type, a NaN; the state and the
    words its refusal must hold."""
    n = len(state["times"])
    edit = str(rng.choice(["missing", "extra", "length", "type", "nan", "not a dict"]))
    if edit == "missing":
        # _coords alone may be missing: a Motion pickled before it was recorded (unknown, as for arrays)
        key = str(rng.choice([k for k in petblur.motion._STATE if k != "_coords"]))
        del state[key]
        return state, rf"its state lacks {key}"
    if edit == "extra":
        key = "_" + "".join(rng.choice(list("abcdefgh"), int(rng.integers(1, 8))))
        state[key] = rng.random()
        return state, rf"its state holds '{key}', which no Motion has"
    if edit == "not a dict":
        return list(state.items()), "its state is a list"
    if edit == "length":
        key = str(rng.choice(["times", "translations", "quaternions", "center", "_lines", "_missing",
                              "_calibration"]))
        other = int(rng.choice([k for k in range(1, n + 4) if k != n]))
        if key == "times":
            state[key] = np.arange(other, dtype=float)
            return state, rf"translations must have shape \({other}, 3\), one row per time, not \({n}, 3\)"
        if key in ("translations", "quaternions"):
            width = 3 if key == "translations" else 4
            state[key] = rng.random((other, width)) if rng.integers(2) else rng.random((n, width - 1))
            return state, rf"{key} must have shape \({n}, {width}\)"
        if key == "center":
            state[key] = rng.random(int(rng.choice([1, 2, 4, 6])))
            return state, r"center must be 3 numbers"
        if key == "_calibration":
            state[key] = np.eye(int(rng.choice([2, 3, 5])))
            return state, r"_calibration is .*give None or a finite 4x4 matrix"
        state[key] = np.arange(other)
        return state, rf"{key} is .*give None or {n} whole numbers, one per sample"
    if edit == "type":
        key = str(rng.choice([k for k in petblur.motion._STATE] + [k for k in petblur.motion._REPORT if k in state]))
        bad = [f"x{int(rng.integers(100))}", {"a": 1}, object()]
        if key in ("_source", "_coords"):
            bad = [int(rng.integers(100)), b"bytes", [1.0]]
        state[key] = bad[int(rng.integers(len(bad)))]
        return state, rf"{key} (must be|is)"
    key = str(rng.choice([k for k in ("times", "translations", "quaternions", "center", "_calibration",
                                      "_reference_time", "estimate_seconds") if state.get(k) is not None]))
    v = np.array(state[key], dtype=float)
    i = tuple(int(rng.integers(d)) for d in v.shape)
    v[i] = rng.choice([np.nan, np.inf, -np.inf])
    state[key] = v if v.ndim else float(v)
    words = {"times": rf"sample {i[0] if i else 0}'s time is", "center": "center holds NaN or infinity"}
    return state, words.get(key, rf"{key}(\[{i[0] if i else 0}\])? is")


def test_motion_pickled_before_its_coordinates_loads(rng):
    """A Motion pickled before it recorded its poses' coordinates loads as one
    of arrays (coordinates unknown), checked as a new one is."""
    m = petblur.Motion(np.arange(3.0), rng.uniform(-5, 5, (3, 3)), np.tile([1.0, 0, 0, 0], (3, 1)))
    state = dict(m.__getstate__() if hasattr(m, "__getstate__") else m.__dict__)
    state.pop("_coords", None)
    old = petblur.Motion.__new__(petblur.Motion)
    old.__setstate__(state)
    assert old._coords is None and old.translations.tolist() == m.translations.tolist()


def test_tampered_motion_pickles_are_refused(tmp_path, rng):
    """A Motion's pickle is checked when loaded as a new Motion is: a state
    with a field missing or added, an array of the wrong length, a field of
    the wrong type or a NaN raises petblur's ArgumentError naming the field,
    never IndexError or AttributeError, and never loads."""
    m = _any_motion(tmp_path, rng)
    reduced = m.__reduce_ex__(2)
    back = _loads(reduced)
    for a, b in zip(back.pose_at(m.times[0] + 0.3 * (m.times[-1] - m.times[0])),
                    m.pose_at(m.times[0] + 0.3 * (m.times[-1] - m.times[0]))):
        np.testing.assert_array_equal(a, b)
    # The two the campaign found: 2 times with 5 translations loaded, 3 with 2
    # were called a zero quaternion.
    state = copy.deepcopy(_motion(rng, 2).__getstate__())
    state["translations"] = rng.random((5, 3))
    with pytest.raises(petblur.ArgumentError, match=r"translations must have shape \(2, 3\)"):
        _loads(reduced[:2] + (state,) + reduced[3:])
    state = copy.deepcopy(_motion(rng, 3).__getstate__())
    state["translations"] = rng.random((2, 3))
    with pytest.raises(petblur.ArgumentError, match=r"translations must have shape \(3, 3\)"):
        _loads(reduced[:2] + (state,) + reduced[3:])
    for _ in range(60):
        m = _any_motion(tmp_path, rng)
        reduced = m.__reduce_ex__(2)
        state, words = _tamper_motion(copy.deepcopy(reduced[2]), rng)
        with pytest.raises(petblur.ArgumentError) as e:
            _loads(reduced[:2] + (state,) + reduced[3:])
        text = str(e.value)
        assert re.search(words, text), (words, text)
        assert text.startswith("the pickled petblur.Motion is not one petblur made: "), text
        assert text.endswith("; pickle the Motion again from its source"), text


# Each field of an operator's description, and values of the wrong type for it.
_WRONG = {"shape": ["x", [4, 4], {"a": 1}], "voxel_size": ["x", {"a": 1}, [1, 2]], "motion": ["x", {"a": 1}],
          "track": ["x", np.eye(4)], "frame": ["x", 5], "bounds": ["x", {"a": 1}, [3.0]],
          "method": [["ab"], 5, "x"], "filter": [{"a": 1}, 5, "x"], "max_path_error": [{"a": 1}, "x", -1],
          "device": [5, "x"], "affine": ["x", np.eye(3)], "steps": ["x", 2.5, -1],
          "ab_sampling": [5, ["slice"], "x"]}
_NAN = ("voxel_size", "frame", "bounds", "affine", "max_path_error", "steps")


def test_tampered_operator_pickles_are_refused(rng):
    """An operator's pickle is its constructor's arguments, checked as a new
    operator's are: a missing or added argument, a wrong type or a NaN raises
    petblur's error naming the argument."""
    for _ in range(30):
        kind = str(rng.choice(["blur", "frames"]))
        op = _operator(kind, "host", rng, shape=tuple(int(n) for n in rng.integers(4, 8, 3)))
        fn, (cls, description, progress) = op.__reduce__()
        if rng.integers(2):
            description = dict(description, affine=np.diag([*op.voxel_size, 1.0]))
        _loads((fn, (cls, description, progress)))  # untouched, it loads
        d = dict(description)
        edit = str(rng.choice(["missing", "extra", "type", "nan"]))
        if edit == "missing":
            key = str(rng.choice(list(d)))
            del d[key]
            words = rf"its description lacks {key}"
        elif edit == "extra":
            key = "".join(rng.choice(list("abcdefgh"), int(rng.integers(1, 8))))
            d[key] = 1
            words = rf"its description holds '{key}', which {cls.__name__} does not take"
        elif edit == "type":
            key = str(rng.choice([k for k in d if k in _WRONG]))
            d[key] = _WRONG[key][int(rng.integers(len(_WRONG[key])))]
            words = {"frame": "frame", "bounds": "bounds|frame", "device": "device|backend"}.get(key, key)
        else:
            key = str(rng.choice([k for k in _NAN if k in d]))
            v = np.array(1.0 if d[key] is None else d[key], dtype=float)
            v[tuple(int(rng.integers(n)) for n in v.shape)] = np.nan
            d[key] = v if v.ndim else float(v)
            words = {"frame": "frame", "bounds": "frame bound"}.get(key, key)
        with pytest.raises(petblur.Error) as e:
            _loads((fn, (cls, d, progress)))
        text = str(e.value)
        assert re.search(words, text), (key, d[key] if key in d else None, words, text)
        assert text.startswith(f"the pickled petblur.{cls.__name__} is not one petblur made: "), text
        assert text.endswith("; pickle the operator again"), text


def _masked(a, rng):
    """a as a masked array with NaN under its mask."""
    mask = rng.random(a.shape) < 0.1
    data = a.copy()
    data[mask] = np.nan
    return np.ma.MaskedArray(data, mask=mask)


@KINDS
def test_masked_arrays_are_refused(device, rng, kind):
    op = _operator(kind, device, rng)
    x, y = _inputs(op, rng, "C")
    for call, a in ((op.apply, x), (op.adjoint, y)):
        for m in (_masked(a, rng), np.ma.MaskedArray(a)):  # NaN under the mask; no mask at all
            with pytest.raises(petblur.ArgumentError, match=r"masked array.*x\.filled\(0\).*np\.ma\.getdata"):
                call(m)


@KINDS
def test_nan_and_infinity_are_refused(device, rng, kind):
    """Host arrays are checked before the library reads them, on the host
    backend (which reads them in place) as on a device: the voxel named."""
    op = _operator(kind, device, rng)
    for order in ("C", "F"):
        x, y = _inputs(op, rng, order)
        _refuses_nonfinite(op, x, y, rng)


def _refuses_nonfinite(op, x, y, rng):
    for call, a in ((op.apply, x), (op.adjoint, y)):
        for bad in (np.nan, np.inf, -np.inf):
            for dtype in (np.float32, np.float64):
                b = a.astype(dtype, order="K")
                where = tuple(int(rng.integers(n)) for n in b.shape)
                b[where] = bad
                if b.ndim == 4 and getattr(op, "frames_last", False):
                    where = (where[3],) + where[:3]  # named as (frame, x, y, z)
                with pytest.raises(petblur.ArgumentError, match=rf"is {bad} at \[{', '.join(map(str, where))}\]"):
                    call(b)


def _beyond(rng, low, high):
    """A random finite float64 of magnitude 10^low to 10^high, either sign."""
    return float(rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(low, high))


def test_values_are_named_as_given(rng):
    """A value that does not survive its conversion is named as it was given,
    with what is allowed: finite float64 values beyond float32's range in an
    array an operator or from_frames reads (not "NaN or infinite"), voxel
    sizes beyond 0.0001 to 10000 mm given as voxel_size= or as an affine's
    columns (not "inf mm"), a max_path_error or an angle just past its limit
    (not rounded onto it)."""
    for _ in range(6):
        op = _operator(str(rng.choice(["blur", "frames"])), "host", rng, shape=(6, 5, 4))
        x, y = _inputs(op, rng, str(rng.choice(["C", "F"])))
        call, a = (op.apply, x) if rng.integers(2) else (op.adjoint, y)
        a = a.astype(np.float64, order="K")
        where = tuple(int(rng.integers(n)) for n in a.shape)
        value = _beyond(rng, 38.6, 308)
        a[where] = value
        if a.ndim == 4 and getattr(op, "frames_last", False):
            where = (where[3],) + where[:3]  # named as (frame, x, y, z)
        with pytest.raises(petblur.ArgumentError) as e:
            call(a)
        assert f"is {value!r} at [{', '.join(map(str, where))}]" in str(e.value), str(e.value)
        assert "beyond float32's range" in str(e.value) and "NaN" not in str(e.value), str(e.value)
    op = _operator("blur", "host", rng, shape=(6, 5, 4))
    x = rng.random((6, 5, 4))
    where, value = tuple(int(rng.integers(n)) for n in x.shape), _beyond(rng, 38.6, 308)
    x[where] = value
    with pytest.raises(petblur.ArgumentError, match=re.escape(f"is {value!r} at {list(where)}") +
                       ".*beyond float32's range"):
        pose.derivatives(op, x)
    frames = rng.random((6, 5, 4, 3)) + 1.0
    k, where = int(rng.integers(3)), tuple(int(rng.integers(n)) for n in (6, 5, 4))
    value = _beyond(rng, 38.6, 308)
    frames[where + (k,)] = value
    with pytest.raises(petblur.ArgumentError, match=re.escape(f"the frame {k} is {value!r} at {list(where)}") +
                       ".*beyond float32's range"):
        petblur.Motion.from_frames(frames, None, [0, 1, 2], [1, 1, 1], voxel_size=2.0, device="host")
    m = petblur.Motion.from_axis_angle(angle=5)
    frames = rng.random((6, 5, 4, 3)).astype(np.float32) + 1
    for _ in range(4):
        size = 10.0 ** (rng.uniform(4.1, 308) if rng.integers(2) else -rng.uniform(4.1, 300))
        sizes = [size, 2.0, 2.0]
        rng.shuffle(sizes)
        given = size if rng.integers(2) else tuple(sizes)
        words = rf"voxel_size {re.escape(repr(given))}: give sizes in mm, between 0.0001 and 10000"
        with pytest.raises(petblur.ArgumentError, match=words):
            petblur.BlurOperator((6, 5, 4), given, m, device="host")
        with pytest.raises(petblur.ArgumentError, match=words):
            petblur.Motion.from_frames(frames, None, [0, 1, 2], [1, 1, 1], voxel_size=given, device="host")
        affine = np.diag([2.0, 2.0, 2.0, 1.0])
        axis = int(rng.integers(3))
        affine[:3, axis] = size * _unit_vector(rng)
        with pytest.raises(petblur.ArgumentError, match=rf"affine's column {axis} is ([0-9.e+-]+) mm long, the "
                           r"voxels' size along axis .*between 0.0001 and 10000 mm") as e:
            petblur.Motion.from_frames(frames, affine, [0, 1, 2], [1, 1, 1], device="host")
        length = float(re.search(r"is ([0-9.e+-]+) mm long", str(e.value)).group(1))
        assert length == pytest.approx(size, rel=1e-12), (length, size)  # the column's length, not inf nor 0
    bound = 1000.0 + 10.0 ** -rng.uniform(1, 10)
    with pytest.raises(petblur.ArgumentError, match=rf"max_path_error {re.escape(repr(bound))}: .*to 1000"):
        petblur.BlurOperator((6, 5, 4), 2.0, m, max_path_error=bound, device="host")
    angle = float(rng.choice([-1.0, 1.0])) * (3600.0 + 10.0 ** -rng.uniform(1, 10))
    with pytest.raises(petblur.ArgumentError, match=rf"angle {re.escape(repr(angle))}: give at most ten turns"):
        petblur.Motion.from_axis_angle(angle=angle)


def _unit_vector(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


@pytest.mark.parametrize("fmt", ["csv", "csv-xyzw", "polaris-mt", "polaris-toolviewer", "matrix-csv"])
def test_zero_quaternion_in_a_file_is_refused(tmp_path, rng, fmt):
    """An all-zero rotation in a record that is not marked missing: an error
    naming the file and the line, in every format."""
    n = int(rng.integers(3, 12))
    bad = int(rng.integers(n))
    path = tmp_path / ("log.mt" if fmt == "polaris-mt" else "log.csv")
    kw = {}
    if fmt in ("csv", "csv-xyzw"):
        xyzw = fmt == "csv-xyzw"
        header = ["t,tx,ty,tz,q0,q1,q2,q3" if xyzw else "t,tx,ty,tz,qw,qx,qy,qz"]
        rows = [f"{i},1,2,3," + ("0,0,0,0" if i == bad else "0,0,0,1" if xyzw else "1,0,0,0") for i in range(n)]
        kw = {"quaternion_order": "xyzw"} if xyzw else {}
    elif fmt == "polaris-mt":
        header = ["23/5/2003 18:18:32 - 11 1 966_IRSL_II", "65899.9 0 A : ---- Missing ----"]
        rows = [f"{65900 + 0.1 * i:.1f} {i} A {'0' if i == bad else '0.5'} 0 0 0 1 2 3 0.18" for i in range(n)]
    elif fmt == "polaris-toolviewer":
        header = ["Collection Data : Port 0B  ( ICL          S/N: 3608C803 Type: 01000000 Rev: 000 )",
                  "[June 25, 2010  04:00PM]", "", "Frame, Q0, Qx, Qy, Qz, x, y, z, Error, OOV", "99, MISSING"]
        rows = [f"{100 + i}, {'0' if i == bad else '2'}, 0, 0, 0, 1, 2, 3, 0.18, 0" for i in range(n)]
    else:
        header = ["t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz"]
        rows = [f"{i}," + ("0,0,0,1,0,0,0,2,0,0,0,3" if i == bad else "1,0,0,1,0,1,0,2,0,0,1,3") for i in range(n)]
    path.write_text("\n".join(header + rows) + "\n")
    line = len(header) + bad + 1
    with pytest.raises(petblur.Error, match=rf"{path}:{line}: .*(zero|not a rotation)"):
        petblur.Motion.from_file(path, **kw)
    # The same poses as arrays.
    q = np.tile([1.0, 0, 0, 0], (n, 1))
    q[bad] = 0
    with pytest.raises(petblur.ArgumentError, match="zero"):
        petblur.Motion(np.arange(n, dtype=float), np.zeros((n, 3)), q)
