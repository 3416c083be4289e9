"""Differential test of the BIDS-PET sidecar reader (pb_frames_read_sidecar,
the one behind --frames-from and petblur.frames_from_sidecar) against Python's
json module on the same bytes: fresh random sidecars, valid and broken in the
ways JSON files break, and random byte edits of them. Any disagreement, in
what is refused or in a single bound, fails.

The reference is strict JSON as Python reads it (json.loads on UTF-8, no NaN
or Infinity) followed by the frame rules of the BIDS text, written here
independently: top-level FrameTimesStart and FrameDuration, arrays of finite
numbers of one length, positive durations, each frame starting where the one
before ends (to 1e-6 s relative) and ending after it starts in doubles. One documented difference is folded into the
reference: an escaped lone surrogate ("\\ud800") is refused, as jansson refuses
it; RFC 8259 section 8.2 leaves such strings undefined."""

import ctypes
import json
import math
import os
import random

import numpy as np
import pytest

import byte_edits

import petblur
from petblur import _lib

KEYS = ("FrameTimesStart", "FrameDuration")


def _no_constants(name):
    raise ValueError(f"{name} is not JSON")


def _lone_surrogate(obj):
    if isinstance(obj, str):
        return any(0xD800 <= ord(c) <= 0xDFFF for c in obj)
    if isinstance(obj, dict):
        return any(_lone_surrogate(k) or _lone_surrogate(v) for k, v in obj.items())
    if isinstance(obj, list):
        return any(_lone_surrogate(v) for v in obj)
    return False


def _numbers(value):
    if not isinstance(value, list):
        return None
    out = []
    for x in value:
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            return None
        try:
            f = float(x)
        except OverflowError:
            return None
        if not math.isfinite(f):
            return None
        out.append(f)
    return out


def reference(data):
    """The bounds a sidecar of these bytes gives, or None where it is refused."""
    try:
        obj = json.loads(data.decode("utf-8"), parse_constant=_no_constants)
    except (ValueError, RecursionError):
        return None
    if not isinstance(obj, dict) or _lone_surrogate(obj):
        return None
    starts, durations = (_numbers(obj.get(k)) for k in KEYS)
    if starts is None or durations is None or not starts or len(starts) != len(durations):
        return None
    for i, (s, d) in enumerate(zip(starts, durations)):
        if not d > 0:
            return None
        if i + 1 < len(starts) and abs(s + d - starts[i + 1]) > 1e-6 * max(1.0, abs(starts[i + 1])):
            return None
    end = starts[-1] + durations[-1]
    if not math.isfinite(end):
        return None
    bounds = starts + [end]
    if any(not b > a for a, b in zip(bounds, bounds[1:])):
        return None  # a frame shorter than its start's rounding step
    return bounds


def library(path):
    """The library's bounds, or None where it refuses; its message then."""
    name = os.fsencode(path)
    frames = ctypes.c_size_t()
    st = _lib.lib.pb_frames_read_sidecar(name, None, 0, ctypes.byref(frames))
    if st != 0:
        return None, _lib.lib.pb_last_error(None).decode("utf-8", "replace")
    bounds = (ctypes.c_double * (frames.value + 1))(*([float("nan")] * (frames.value + 1)))
    st = _lib.lib.pb_frames_read_sidecar(name, bounds, frames.value + 1, ctypes.byref(frames))
    assert st == 0, _lib.lib.pb_last_error(None)
    return list(bounds), ""


def _number_text(rng, x):
    """x in one of JSON's spellings of it."""
    if float(x).is_integer() and abs(x) < 1e15 and rng.random() < 0.5:
        i = int(x)
        return rng.choice([str(i), f"{i}.0", f"{i}e0", f"{i}E+0", f"{i * 10}e-1"])
    return rng.choice([repr(float(x)), f"{x:.17e}", f"{x:.17E}".replace("E+", "E")])


def _frames(rng):
    n = rng.randint(1, 12)
    t0 = rng.choice([0.0, rng.uniform(-100, 100), float(rng.randint(0, 3600))])
    durations = [rng.choice([float(rng.randint(1, 600)), rng.uniform(1e-3, 600)]) for _ in range(n)]
    starts = [t0]
    for d in durations[:-1]:
        starts.append(starts[-1] + d)
    return starts, durations


def _array(rng, values):
    return "[" + rng.choice([",", ", ", " ,\n  "]).join(_number_text(rng, v) for v in values) + "]"


def _filler(rng):
    """Other keys a sidecar holds, some of them decoys."""
    items = [('"Manufacturer"', json.dumps(rng.choice(["Siemens", "GE", "Ünïcode ✓", "FrameDuration"]))),
             ('"TracerName"', '"FDG"'),
             ('"ReconFilterSize"', rng.choice(["0", "2.5", "-1e-3", "[1, 2]", "null", "true"])),
             ('"Nested"', '{"FrameTimesStart": [999], "FrameDuration": [1]}'),
             ('"List"', '[{"FrameDuration": [5]}, "FrameTimesStart", 3]'),
             ('"FrameDuration "', "[1]"), ('"frameduration"', "[1]")]
    rng.shuffle(items)
    return items[:rng.randint(0, len(items))]


def _object(rng, items):
    sep = rng.choice([",", ", ", ",\n  ", "\t,\r\n"])
    colon = rng.choice([":", ": ", " : "])
    return "{" + sep.join(f"{k}{colon}{v}" for k, v in items) + "}"


def valid_sidecar(rng):
    starts, durations = _frames(rng)
    items = [('"FrameTimesStart"', _array(rng, starts)), ('"FrameDuration"', _array(rng, durations))]
    items += _filler(rng)
    rng.shuffle(items)
    return _object(rng, items).encode()


def broken_sidecar(rng):
    """A sidecar with one thing wrong, or odd but valid, chosen at random."""
    starts, durations = _frames(rng)
    s, d = _array(rng, starts), _array(rng, durations)
    kind = rng.randrange(24)
    items = [('"FrameTimesStart"', s), ('"FrameDuration"', d)] + _filler(rng)
    if kind == 0:  # duplicate keys: the last counts
        other = _array(rng, [x + 1 for x in starts])
        items.insert(rng.randrange(len(items) + 1), ('"FrameTimesStart"', other))
    elif kind == 1:  # both keys only in a nested object
        items = [('"Time"', _object(rng, items[:2]))] + items[2:]
    elif kind == 2:
        items[0] = ('"FrameTimesStart"', s.replace("[", "[true, ", 1))
    elif kind == 3:
        items[1] = ('"FrameDuration"', "[]")
        items[0] = ('"FrameTimesStart"', "[]")
    elif kind == 4:  # one duration missing
        items[1] = ('"FrameDuration"', _array(rng, durations[:-1]) if len(durations) > 1 else "[]")
    elif kind == 5:  # a gap or an overlap
        shifted = list(starts)
        shifted[-1] += rng.choice([-1, 1]) * rng.choice([1e-3, 1.0, 30.0])
        items[0] = ('"FrameTimesStart"', _array(rng, shifted))
    elif kind == 6:
        bad = list(durations)
        bad[rng.randrange(len(bad))] = rng.choice([0.0, -1.0, -0.0])
        items[1] = ('"FrameDuration"', _array(rng, bad))
    elif kind == 7:
        items[0] = ('"FrameTimesStart"', s.replace("]", ", NaN]") if rng.random() < 0.5 else "[Infinity]")
    elif kind == 8:
        items[1] = ('"FrameDuration"', rng.choice(["[1e400]", "[" + "9" * 400 + "]", "[1.7976931348623157e308]"]))
        items[0] = ('"FrameTimesStart"', rng.choice(["[1.7976931348623157e308]", "[0]"]))
    elif kind == 9:
        items[0] = ('"FrameTimesStart"', s.replace(",", ",0x10,", 1) if "," in s else "[0x0]")
    elif kind == 10:
        text = _object(rng, items)
        return (text[:-1] + ", }" if rng.random() < 0.5 else text.replace("[", "[ /* s */ ", 1)).encode()
    elif kind == 11:
        return b"\xef\xbb\xbf" + _object(rng, items).encode()
    elif kind == 12:
        items.append(('"Note"', rng.choice(['"\\ud800"', '"\\udc00x"', '"\\ud83d\\ude00"', '"\\u0000"', '"a\\"b"'])))
    elif kind == 13:
        items.append(('"Bytes"', '"' + rng.choice(["\xff", "\xc3", "\x01", "\t"]) + '"'))
        return _object(rng, items).encode("latin-1")
    elif kind == 14:  # a value equal to a key name
        items.append(('"Key"', '"FrameTimesStart"'))
        items.append(('"FrameTimesStart2"', '"FrameDuration"'))
    elif kind == 15:
        return ("[" + _object(rng, items) + "]").encode()
    elif kind == 16:
        return _object(rng, items).encode() + rng.choice([b"x", b"{}", b"\n\n", b" \x00"])
    elif kind == 17:
        items[0] = ('"FrameTimesStart"', '"' + s + '"')
    elif kind == 18:
        items[1] = ('"FrameDuration"', "[[" + d[1:] + "]")
    elif kind == 19:
        items = [("'FrameTimesStart'", s), ('"FrameDuration"', d)]
    elif kind == 20:
        items[0] = ('"FrameTimesStart"', s.replace("[", "[+", 1) if rng.random() < 0.5 else s.replace("[", "[.5,", 1))
    elif kind == 21:
        items[1] = ('"FrameDuration"', d.replace("[", "[01,", 1))
    elif kind == 22:
        return (" " * rng.randint(0, 3) + _object(rng, items) + rng.choice(["", "\n", " \t\r\n"])).encode()
    else:
        depth = rng.randint(1, 60)
        items.append(('"Deep"', "[" * depth + "]" * depth))
    rng.shuffle(items)
    return _object(rng, items).encode()


def mutated(rng, data):
    return byte_edits.mutated(rng, data, b'{}[],:"0123456789.eE+-\\ \n')


@pytest.fixture(scope="module")
def seed():
    s = int.from_bytes(os.urandom(4), "little")
    print(f"sidecar seed {s}")
    return s


def _agree(path, data, counts):
    path.write_bytes(data)
    want = reference(data)
    got, message = library(path)
    if want is None:
        assert got is None, f"{data!r}: the library reads {got}, Python's json and the BIDS rules refuse it"
        assert message.startswith(str(path)), f"{data!r}: the message does not name the file: {message}"
        counts["refused"] += 1
    else:
        assert got is not None, f"{data!r}: the library refuses ({message}), the reference reads {want}"
        assert got == want, f"{data!r}: the library reads {got}, the reference {want}"
        counts["read"] += 1


def test_sidecars_agree_with_python_json(tmp_path, seed):
    rng = random.Random(seed)
    counts = {"read": 0, "refused": 0}
    path = tmp_path / "sub-01_pet.json"
    for i in range(1500):
        kind = i % 3
        data = valid_sidecar(rng) if kind == 0 else broken_sidecar(rng) if kind == 1 else mutated(rng, valid_sidecar(rng))
        _agree(path, data, counts)
    print(f"sidecars: {counts}")
    # Both outcomes were exercised in numbers, not by a handful of cases.
    assert counts["read"] > 400 and counts["refused"] > 300, f"seed {seed}: {counts}"


def test_frames_from_sidecar_is_the_library_reader(tmp_path, seed):
    rng = random.Random(seed + 1)
    path = tmp_path / "pet.json"
    starts, durations = _frames(rng)
    path.write_text(json.dumps({"FrameTimesStart": starts, "FrameDuration": durations}))
    np.testing.assert_array_equal(petblur.frames_from_sidecar(path), np.array(starts + [starts[-1] + durations[-1]]))
    path.write_text('{"FrameTimesStart": [0, 60], "FrameDuration": [60, 60], "FrameDuration": [60, 30]}')
    np.testing.assert_array_equal(petblur.frames_from_sidecar(path), [0.0, 60.0, 90.0])
    path.write_text('{"Time": {"FrameTimesStart": [0], "FrameDuration": [60]}}')
    with pytest.raises(petblur.Error, match="no top-level \"FrameTimesStart\""):
        petblur.frames_from_sidecar(path)
    with pytest.raises(petblur.Error, match="cannot open"):
        petblur.frames_from_sidecar(tmp_path / "missing.json")
    path.write_bytes(b" " * (5 << 20))
    with pytest.raises(petblur.Error, match="not a JSON sidecar"):
        petblur.frames_from_sidecar(path)
    # A raw control byte outside a string, which jansson let by (the random
    # cases above found it: a NUL after a number in a nested object).
    for raw in (b"\x00", b"\x01", b"\x1f"):
        data = (b'{"Nested": {"FrameTimesStart": [999' + raw + b'], "FrameDuration": [1]}, '
                b'"FrameTimesStart": [0, 60], "FrameDuration": [60, 60]}')
        path.write_bytes(data)
        assert reference(data) is None
        with pytest.raises(petblur.Error, match="raw control character"):
            petblur.frames_from_sidecar(path)


def test_sizes_across_the_read_buffer(tmp_path, seed):
    """The reader grows its buffer while the file goes on (16 KiB, doubled, up
    to the 4 MiB limit): sidecars whose length falls on, just before and just
    after each doubling read as Python's json reads them; one of exactly
    4 MiB is read, one byte more is refused."""
    rng = random.Random(seed + 2)
    path = tmp_path / "sub-01_pet.json"
    counts = {"read": 0, "refused": 0}
    starts, durations = _frames(rng)
    body = json.dumps({"FrameTimesStart": starts, "FrameDuration": durations}).encode()
    for size in [(1 << 14) << k for k in range(9)]:  # 16 KiB to 4 MiB
        for delta in (-1, 0, 1):
            n = size + delta
            if n > 4 << 20:
                continue
            # the frames first and white space after (a pretty-printed tail),
            # or a long string in front of them: both sides of the boundary
            if rng.random() < 0.5:
                data = body + b" " * (n - len(body))
            else:
                data = b'{"Note": "' + b"x" * (n - len(body) - 12) + b'", ' + body[1:]
            assert len(data) == n
            _agree(path, data, counts)
    assert counts == {"read": 26, "refused": 0}, counts
    path.write_bytes(body + b" " * ((4 << 20) + 1 - len(body)))
    with pytest.raises(petblur.Error, match="not a JSON sidecar"):
        petblur.frames_from_sidecar(path)
