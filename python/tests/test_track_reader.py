"""Differential test of the track readers (pb_track_read, the one behind
--motion and petblur.Motion.from_file) against a small parser of the grammar
docs/motion.md states, written here independently: fresh random csv tracks,
Polaris .mt logs and Toolviewer CSVs, valid and broken in the ways such files
break, and random byte edits of them. Any disagreement fails: in what is
refused, in the line a refusal names, in a single time, translation or
quaternion of what is read, in a pose's line or its count of missing samples.

The reference reads bytes: numbers by a regular expression of the grammar and
Python's float (correctly rounded, as strtod is), so times and translations
must agree bit for bit, and so must csv quaternions, which are kept as
written. Polaris quaternions are normalised here by math.hypot, the library
scales them by their largest part first: they must agree within 1e-15 (a few
ulp of a unit quaternion's parts). No case is generated within 1e-9 of the
csv norm's 1e-3 bound, where the two norms could round apart.

Also here: Motion.from_file returns what the reader read, a rule on values a
file breaks is a FileError, and numbers read the same under a locale whose
decimal point is a comma."""

import ctypes
import locale
import math
import os
import random
import re
import shutil
import subprocess

import numpy as np
import pytest

import byte_edits

import petblur
from petblur import _lib

BLANKS = b" \t\v\f\r"  # what the readers trim and split at; never a line break
NUMBER = re.compile(rb"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
MAX_LINE = 4095
MAX_FIELDS = 64
MAX_FRAME = 10**15 - 1
MAX_UNSIGNED = 2**32 - 1
CSV, POLARIS = 1, 3


class Refused(Exception):
    """The reference refuses the file; line is the one the message names
    (None: the file as a whole)."""

    def __init__(self, line=None):
        super().__init__(line)
        self.line = line


def number(token, line):
    if not NUMBER.fullmatch(token):
        raise Refused(line)
    v = float(token)
    if math.isinf(v):
        raise Refused(line)
    return v


def whole(token, line, signed, limit):
    if not re.fullmatch(rb"[+-]?[0-9]+" if signed else rb"[0-9]+", token) or abs(int(token)) > limit:
        raise Refused(line)
    return int(token)


def lines(data):
    """(number, text) of each line as a reader gets it, lazily: a reader that
    stops early never meets a NUL or an overlong line after it."""
    parts = data.split(b"\n")
    if parts[-1].rstrip(b"\r") == b"":  # the end of the file, not a line
        parts.pop()
    for i, p in enumerate(parts, 1):
        if b"\0" in p or len(p) > MAX_LINE:
            raise Refused(i)
        yield i, p.rstrip(b"\r")


def unit(q, line, strict):
    norm = math.hypot(*q)
    if norm == 0.0 or (strict and abs(norm - 1.0) > 1e-3):
        raise Refused(line)
    return list(q) if strict else [x / norm for x in q]


class Track:
    def __init__(self):
        self.times, self.translations, self.quaternions, self.lines, self.missing = [], [], [], [], []

    def add(self, line, t, tr, q, missing=0):
        if self.times and not t > self.times[-1]:
            raise Refused(line)
        self.times.append(t)
        self.translations.append(tr)
        self.quaternions.append(q)
        self.lines.append(line)
        self.missing.append(missing)

    def done(self):
        if len(self.times) < 2:
            raise Refused(None)
        return self


def csv_columns(fields, line, xyzw):
    """The columns of t, tx, ty, tz, qw, qx, qy, qz in a csv header."""
    if len(fields) > MAX_FIELDS:
        raise Refused(line)
    low = [f.lower() for f in fields]

    def find(*names):
        at = [i for i, f in enumerate(low) if f in names]
        if len(at) > 1:
            raise Refused(line)  # ambiguous
        return at[0] if at else None

    head = [find(b"t", b"time", b"timestamp"), find(b"tx"), find(b"ty"), find(b"tz")]
    named = [find(n) for n in (b"qw", b"qx", b"qy", b"qz")]
    numbered = [find(b"q%d" % k) for k in range(5)]
    if numbered[0] is not None and numbered[4] is not None:
        raise Refused(line)
    has_named = any(c is not None for c in named)
    has_numbered = any(c is not None for c in numbered)
    if (has_named and has_numbered) or (has_named and xyzw):
        raise Refused(line)
    q = named
    if has_numbered:
        part = numbered[:4] if numbered[0] is not None else numbered[1:]
        q = [part[3], part[0], part[1], part[2]] if xyzw else part
    columns = head + q
    if None in columns:
        raise Refused(line)
    return columns


def read_csv(data, divisor, xyzw):
    track, columns, count = Track(), None, 0
    for no, text in lines(data):
        if no == 1 and text.startswith(b"\xef\xbb\xbf"):
            text = text[3:]
        text = text.strip(BLANKS)
        if not text or text.startswith(b"#"):
            continue
        fields = [f.strip(BLANKS) for f in text.split(b",")]
        if columns is None:
            columns, count = csv_columns(fields, no, xyzw), len(fields)
            continue
        if len(fields) != count:
            raise Refused(no)
        v = [number(fields[c], no) for c in columns]
        track.add(no, v[0] / divisor, v[1:4], unit(v[4:8], no, True))
    if columns is None:
        raise Refused(None)
    return track.done()


MT_FIRST = re.compile(rb"[0-9]+/[0-9]+/[0-9]+[ \t\v\f\r]+[0-9]+:[0-9]+:[0-9]+[ \t\v\f\r]+-")
TOOLVIEWER_HEADER = [b"frame", b"q0", b"qx", b"qy", b"qz", b"x", b"y", b"z", b"error", b"oov"]


def mt_stamp(tokens, no):
    t = number(tokens[0], no)
    whole(tokens[1], no, False, MAX_UNSIGNED)
    if len(tokens[2]) != 1:
        raise Refused(no)
    return t


def read_mt(rest):
    track, missing = Track(), 0
    for no, text in rest:
        tokens = text.split()  # ASCII white space, as BLANKS
        if not tokens:
            continue
        if b"".join(tokens[3:]) == b":----Missing----":
            mt_stamp(tokens, no)
            missing += 1
            continue
        if len(tokens) != 11:
            raise Refused(no)
        t = mt_stamp(tokens, no)
        v = [number(x, no) for x in tokens[3:]]
        track.add(no, t, v[4:7], unit(v[:4], no, False), missing)
        missing = 0
    return track.done()


def read_toolviewer(rest):
    track, missing, header, first = Track(), 0, False, None
    for no, text in rest:
        fields = [f.strip(BLANKS) for f in text.split(b",")]
        if not header:
            if fields[0].lower() == b"frame":
                header = True
                if [f.lower() for f in fields] != TOOLVIEWER_HEADER:
                    raise Refused(no)
            continue
        if fields == [b""]:
            continue
        if len(fields) == 2 and fields[1] == b"MISSING":
            whole(fields[0], no, True, MAX_FRAME)
            missing += 1
            continue
        if len(fields) != 10:
            raise Refused(no)
        frame = whole(fields[0], no, True, MAX_FRAME)
        v = [number(x, no) for x in fields[1:9]]
        whole(fields[9], no, False, MAX_UNSIGNED)
        first = frame if first is None else first
        track.add(no, (frame - first) / 60, v[4:7], unit(v[:4], no, False), missing)
        missing = 0
    return track.done()


def read_polaris(data):
    rest = lines(data)
    no, first = next(rest, (None, None))
    if first is None:
        raise Refused(None)
    if first.startswith(b"\xef\xbb\xbf"):
        first = first[3:]
    if first.startswith(b"Collection Data"):
        return read_toolviewer(rest)
    if MT_FIRST.match(first):
        return read_mt(rest)
    raise Refused(1)


def reference(data, fmt, divisor=1.0, xyzw=False):
    """The track these bytes hold, or Refused."""
    return read_csv(data, divisor, xyzw) if fmt == CSV else read_polaris(data)


def library(path, fmt, divisor=1.0, xyzw=False):
    """The library's track as arrays, or its message."""
    opts = _lib.TrackReadOptions(fmt, divisor, int(xyzw))
    handle = ctypes.c_void_p()
    if _lib.lib.pb_track_read(os.fsencode(path), ctypes.byref(opts), ctypes.byref(handle)) != 0:
        return None, _lib.message()
    try:
        lib = _lib.lib
        n = lib.pb_track_count(handle)
        poses = (_lib.Pose * n).from_address(ctypes.addressof(lib.pb_track_poses(handle).contents))
        return {"times": np.ctypeslib.as_array(lib.pb_track_times(handle), (n,)).copy(),
                "translations": np.array([p.translation[:] for p in poses]),
                "quaternions": np.array([p.rotation[:] for p in poses]),
                "lines": np.ctypeslib.as_array(lib.pb_track_lines(handle), (n,)).copy(),
                "missing": np.ctypeslib.as_array(lib.pb_track_missing(handle), (n,)).copy()}, ""
    finally:
        _lib.lib.pb_track_free(handle)


# ---- spellings ------------------------------------------------------------------------------------------------

def spell(rng, x):
    """x as a track may write it: any spelling of the grammar."""
    k = rng.randrange(7)
    if k == 4 and x != 0 and abs(x) < 1e-3:
        k = 0  # fixed point would write a tiny quaternion's parts as 0 (1e-170: seed 1272642753), a zero quaternion
    s = [repr(x), "%.17g" % x, "%.17e" % x, "%.17E" % x, "%.12f" % x, "%.9g" % x, "%.6e" % x][k]
    u = rng.random()
    if u < 0.08 and not s.startswith("-"):
        s = "+" + s
    elif u < 0.16:
        s = re.sub(r"^([+-]?)0\.", r"\1.", s)  # .5, -.5
    elif u < 0.2 and re.fullmatch(r"-?[0-9]+\.0+", s):
        s = s.split(".")[0] + "."  # 5.
    return s


def pad(rng, s):
    return rng.choice(["", "", " ", "  ", "\t", " \v", "\f "]) + s + rng.choice(["", "", " ", "\t ", " \r"])


def unit_quaternion(rng):
    while True:
        q = [rng.uniform(-1, 1) for _ in range(4)]
        n = math.hypot(*q)
        if n > 0.1:
            return [x / n for x in q]


def _times(rng, n, t0, step):
    t = [t0]
    for _ in range(n - 1):
        t.append(t[-1] + rng.uniform(*step))
    return t


BAD_NUMBERS = ["0x1p-2", "0X1.8P1", "-0x10", "inf", "-Infinity", "nan", "NaN", "1e999", "-1e400", "9" * 400,
               "1e", "1.2.3", "--1", "+-1", "1e5.5", "1_000", ".", "e5", "+", "-", "1 5", "\u0661",
               "\uff11", "0b1", "1,5", "1e+", "0x", "infinity", "1d5", "1.5f"]
ODD_NUMBERS = ["1e-400", "4.9e-324", "2.5e-324", "-0", "+.5", "5.", "00012", "1E+05", "-0.0e-0", "1" * 300]


# ---- csv --------------------------------------------------------------------------------------------------------

CSV_RESERVED = ["t", "time", "timestamp", "tx", "ty", "tz", "qw", "qx", "qy", "qz", "q0", "q1", "q2", "q3", "q4"]


def csv_case(rng):
    """(text lines, divisor, xyzw) of a valid csv track in a random layout."""
    n = rng.randint(2, 25)
    ms = rng.random() < 0.3
    times = _times(rng, n, rng.choice([0.0, rng.uniform(-1e3, 1e3), rng.uniform(0, 1e5)]), (1e-3, 2.0))
    numbered = rng.random() < 0.35
    xyzw = numbered and rng.random() < 0.5
    time_name = rng.choice(["t", "time", "timestamp", "T", "Time", "TIMESTAMP"])
    if numbered:
        base = rng.choice([0, 1])
        qnames = [f"{rng.choice('qQ')}{base + k}" for k in range(4)]
        order = [3, 0, 1, 2] if xyzw else [0, 1, 2, 3]  # which part each numbered column holds
    else:
        qnames = [rng.choice([n, n.upper()]) for n in ("qw", "qx", "qy", "qz")]
        order = [0, 1, 2, 3]
    names = [time_name, "tx", "ty", "tz"] + qnames
    extras = [rng.choice(["error", "frame", "note", "", "x", "quality", "q", "tq"]) for _ in range(rng.randint(0, 3))]
    columns = list(range(8)) + [-1 - i for i in range(len(extras))]
    rng.shuffle(columns)
    header = ",".join(pad(rng, names[c] if c >= 0 else extras[-1 - c]) for c in columns)
    rows = []
    for i in range(n):
        q = unit_quaternion(rng)
        values = [times[i] * (1000 if ms else 1)] + [rng.uniform(-500, 500) for _ in range(3)]
        values += [q[order[k]] for k in range(4)]
        cells = []
        for c in columns:
            if c >= 0:
                digits = 17 if c == 0 else rng.choice([6, 9, 17])
                cells.append(pad(rng, spell(rng, values[c]) if digits == 17 else f"{values[c]:.{digits}f}"))
            else:
                cells.append(pad(rng, rng.choice(["0.18", "abc", "0x10", "", "nan", "42"])))
        rows.append(",".join(cells))
    return [header] + rows, 1000.0 if ms else 1.0, xyzw


def csv_bytes(rng, lines_):
    out = []
    for i, line in enumerate(lines_):
        while rng.random() < 0.08:
            out.append(rng.choice(["", "# a logger's comment", "   ", "\t#, 1, 2", "#" + "x" * rng.randint(0, 200)]))
        out.append(line)
    end = rng.choice(["\n", "\n", "\r\n"])
    text = end.join(out) + rng.choice([end, end, "", end + end])
    data = text.encode("utf-8")
    return (b"\xef\xbb\xbf" + data) if rng.random() < 0.05 else data


def broken_csv(rng):
    lines_, divisor, xyzw = csv_case(rng)
    header, rows = lines_[0], lines_[1:]
    row = rng.randrange(len(rows))
    cells = rows[row].split(",")
    kind = rng.randrange(16)
    if kind == 0:  # a number outside the grammar, or beyond a double, in any field (extra ones are not read)
        cells[rng.randrange(len(cells))] = pad(rng, rng.choice(BAD_NUMBERS))
    elif kind == 1:  # odd spellings the grammar takes
        cells[rng.randrange(len(cells))] = pad(rng, rng.choice(ODD_NUMBERS))
    elif kind == 2:  # a column named twice, or the time twice
        header += "," + rng.choice(CSV_RESERVED + [s.upper() for s in CSV_RESERVED])
        rows = [r + ",1" for r in rows]
    elif kind == 3:  # a column missing
        names = header.split(",")
        del names[rng.randrange(len(names))]
        header = ",".join(names)
    elif kind == 4:  # a field more or fewer
        if rng.random() < 0.5:
            cells.append(rng.choice(["1", "", " "]))
        else:
            cells.pop()
    elif kind == 5:  # an empty field
        cells[rng.randrange(len(cells))] = rng.choice(["", "  ", "\t"])
    elif kind == 6:  # time going back, or repeated
        if len(rows) > 1:
            i = rng.randrange(len(rows) - 1)
            rows[i], rows[i + 1] = (rows[i + 1], rows[i]) if rng.random() < 0.5 else (rows[i], rows[i])
    elif kind == 7:  # a quaternion off unit norm, scaled far, or zero
        names = [h.strip().lower() for h in header.split(",")]
        qcols = [i for i, h in enumerate(names) if re.fullmatch(r"q[wxyz0-4]", h)]
        scale = rng.choice([0.0, 1.01, 0.99, 0.5, 2.0, 1e200, 1e-170, 1.0005])
        for i in qcols:
            try:
                cells[i] = repr(float(cells[i]) * scale)
            except ValueError:
                pass
    elif kind == 8:  # one row or none
        rows = rows[:rng.randint(0, 1)]
    elif kind == 9:  # a NUL byte
        cells[rng.randrange(len(cells))] += "\0"
    elif kind == 10:  # an overlong line, or one just short enough, in a comment
        rows.insert(row, "#" + "x" * rng.choice([MAX_LINE - 1, MAX_LINE, MAX_LINE + 1, 5000]))
    elif kind == 11:  # more than 64 columns
        header += "," + ",".join(f"extra{i}" for i in range(rng.randint(56, 60)))
        rows = [r + ",0" * (len(header.split(",")) - len(r.split(","))) for r in rows]
    elif kind == 12:  # the quaternion order option where the header names the parts
        xyzw = True
    elif kind == 13:  # a comment after a row's values
        cells[-1] += " # note"
    elif kind == 14:  # a header with both numberings, or named and numbered parts
        header += rng.choice([",q0,q4", ",q1", ",qw"])
        rows = [r + ",0" * (len(header.split(",")) - len(r.split(","))) for r in rows]
    else:  # blanks and tabs inside a number
        i = rng.randrange(len(cells))
        cells[i] = cells[i].strip()[:2] + rng.choice([" ", "\t"]) + cells[i].strip()[2:]
    if kind not in (2, 3, 6, 8, 10, 11, 12, 14) and row < len(rows):
        rows[row] = ",".join(cells)
    return csv_bytes(rng, [header] + rows), divisor, xyzw


# ---- Polaris ----------------------------------------------------------------------------------------------------

def ndi_quaternion(rng):
    """A unit quaternion scaled as NDI's need not be: 1e200 and 1e-170 too."""
    s = rng.choice([1.0, rng.uniform(0.5, 2.0), rng.uniform(0.5, 2.0), 1e200, 1e-170, 1e-300])
    return [x * s for x in unit_quaternion(rng)]


def mt_case(rng):
    n = rng.randint(2, 25)
    lines_ = [f"{rng.randint(1, 28)}/{rng.randint(1, 12)}/{rng.randint(1990, 2030)} "
              f"{rng.randint(0, 23)}:{rng.randint(0, 59):02d}:{rng.randint(0, 59):02d} - 11 1 966_IRSL_II"]
    times = _times(rng, n, rng.uniform(0, 80000), (0.01, 0.5))

    def sep():
        return rng.choice([" ", " ", "  ", "\t", " \t "])

    for i in range(n):
        while rng.random() < 0.25:
            word = rng.choice([": ---- Missing ----", ":----Missing----", " :  ---- Missing  ----",
                               ": ----Missing ----"])
            lines_.append(f"{times[i] - rng.uniform(0.001, 0.009):.3f}{sep()}{rng.randint(0, 99)}{sep()}A {word}")
        while rng.random() < 0.05:
            lines_.append(rng.choice(["", "  ", "\t"]))
        q = ndi_quaternion(rng)
        values = [spell(rng, x) for x in q] + [spell(rng, rng.uniform(-2000, 2000)) for _ in range(3)]
        values.append(f"{rng.uniform(0, 1):.2f}")
        fields = [spell(rng, times[i]) if rng.random() < 0.3 else f"{times[i]:.6f}", str(rng.randint(0, 2**32 - 1)),
                  rng.choice("ABCD1z")] + values
        lines_.append(pad(rng, sep().join(fields)))
    return lines_


def toolviewer_case(rng):
    n = rng.randint(2, 25)
    header = ",".join(pad(rng, rng.choice([h, h.upper(), h.capitalize()]))
                      for h in ("Frame", "Q0", "Qx", "Qy", "Qz", "x", "y", "z", "Error", "OOV"))
    lines_ = ["Collection Data : Port 0B  ( ICL          S/N: 3608C803 Type: 01000000 Rev: 000 )",
              "[June 25, 2010  04:00PM]", "", header]
    frame = rng.choice([rng.randint(0, 10**6), rng.randint(-10**6, 0), rng.randint(-30, 0),
                        rng.randint(-MAX_FRAME, MAX_FRAME)])
    for _ in range(n):
        while rng.random() < 0.25:
            lines_.append(f"{pad(rng, str(frame))},{pad(rng, 'MISSING')}")
            frame += 1
        q = ndi_quaternion(rng)
        values = [str(frame)] + [spell(rng, x) for x in q]
        values += [f"{rng.uniform(-2000, 2000):.2f}" for _ in range(3)]
        values += [f"{rng.uniform(0, 1):.4f}", str(rng.randint(0, 3))]
        lines_.append(",".join(pad(rng, v) for v in values))
        frame += rng.randint(1, 4)
    return lines_


def polaris_bytes(rng, lines_):
    data = rng.choice(["\n", "\r\n"]).join(lines_) + rng.choice(["\n", "", "\n\n"])
    data = data.encode()
    return (b"\xef\xbb\xbf" + data) if rng.random() < 0.03 else data


def broken_polaris(rng, toolviewer):
    lines_ = toolviewer_case(rng) if toolviewer else mt_case(rng)
    start = 4 if toolviewer else 1
    i = rng.choice([j for j in range(start, len(lines_)) if lines_[j].strip()])
    split = (lambda s: s.split(",")) if toolviewer else (lambda s: s.split())
    join = (lambda f: ",".join(f)) if toolviewer else (lambda f: " ".join(f))
    fields = split(lines_[i])
    kind = rng.randrange(12)
    if kind == 0:
        fields[rng.randrange(len(fields))] = rng.choice(BAD_NUMBERS).replace(",", ";").replace(" ", "_")
    elif kind == 1:
        fields[rng.randrange(len(fields))] = rng.choice(ODD_NUMBERS)
    elif kind == 2:  # a field more or fewer
        fields = fields[:-1] if rng.random() < 0.5 else fields + ["0"]
    elif kind == 3:  # a zero quaternion, or a tiny one
        if len(fields) >= 7:
            k = 1 if toolviewer else 3
            z = rng.choice(["0", "0.0", "-0", "1e-400", "5e-324"])
            fields[k:k + 4] = [z, "0", "0", "-0"]
    elif kind == 4:  # frame or rand and tool or OOV broken
        k = rng.choice([0, len(fields) - 1] if toolviewer else [1, 2])
        fields[k] = rng.choice(["1.5", "-1", "+7", "AB", "", "4294967296", "4294967295", str(MAX_FRAME + 1),
                                str(-MAX_FRAME), "0x1f", "1e3", "00"])
    elif kind == 5:  # times going back: two records swapped
        j = rng.randrange(start, len(lines_))
        lines_[i], lines_[j] = lines_[j], lines_[i]
        fields = split(lines_[i])
    elif kind == 6:  # a missing sample misspelt
        fields = split(lines_[i])[:1] + (["missing"] if toolviewer else ["2", "A", ":", "----", "missing", "----"])
    elif kind == 7:  # the first line or the header broken
        if toolviewer:
            lines_[3] = rng.choice(["Frame,Q0,Qx,Qy,Qz,Tx,Ty,Tz,Error,OOV", "Frame,Q0,Qx,Qy,Qz,x,y,z,Error",
                                    "Frame,Qx,Q0,Qy,Qz,x,y,z,Error,OOV", "Frame", "Frames,Q0"])
        else:
            lines_[0] = rng.choice(["23-5-2003 18:18:32 - 11 1 tool", "23/5/2003 18:18:32- 11", "23/5/2003 - 1",
                                    " 23/5/2003 18:18:32 - 1", "+23/5/2003 18:18:32 - 1", "23/5/2003\t18:18:32\t-"])
    elif kind == 8:  # a comment line, which Polaris logs do not have
        lines_.insert(i, "# " + lines_[i])
    elif kind == 9:  # one record or none
        lines_ = lines_[:start + rng.randint(0, 1)]
    elif kind == 10:  # a NUL byte or an overlong line
        lines_.insert(i, rng.choice(["\0", "x" * (MAX_LINE + rng.randint(0, 2)), " " * MAX_LINE]))
    else:  # the other layout's record
        fields = (mt_case(rng) if toolviewer else toolviewer_case(rng))[-1].split(" " if toolviewer else ",")
    if kind not in (5, 7, 8, 9, 10) and i < len(lines_):
        lines_[i] = join(fields)
    return polaris_bytes(rng, lines_)


def mutated(rng, data):
    return byte_edits.mutated(rng, data, b"0123456789.eE+-, \t\r\n#xXpPinfaINFA:M\0")


# ---- the comparison --------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def seed():
    s = int(os.environ.get("PETBLUR_TEST_SEED") or int.from_bytes(os.urandom(4), "little"))
    print(f"track reader seed {s}")
    return s


def _agree(path, data, fmt, divisor, xyzw, counts):
    path.write_bytes(data)
    try:
        want = reference(data, fmt, divisor, xyzw)
    except Refused as e:
        want, line = None, e.line
    got, message = library(path, fmt, divisor, xyzw)
    where = f"{data[:3000]!r} ({fmt}, divisor {divisor}, xyzw {xyzw})"
    if want is None:
        assert got is None, f"{where}: the library reads {len(got['times'])} poses, the reference refuses (line {line})"
        start = f"{path}:{line}: " if line else f"{path}: "
        assert message.startswith(start), f"{where}: the message should start {start!r}: {message}"
        counts["refused"] += 1
        return
    assert got is not None, f"{where}: the library refuses ({message}), the reference reads {len(want.times)} poses"
    np.testing.assert_array_equal(got["times"], want.times, err_msg=where)
    np.testing.assert_array_equal(got["translations"], np.array(want.translations), err_msg=where)
    np.testing.assert_array_equal(got["lines"], want.lines, err_msg=where)
    np.testing.assert_array_equal(got["missing"], want.missing, err_msg=where)
    q = np.array(want.quaternions)
    if fmt == CSV:
        np.testing.assert_array_equal(got["quaternions"], q, err_msg=where)
    else:
        np.testing.assert_allclose(got["quaternions"], q, rtol=0, atol=1e-15, err_msg=where)
        counts["worst"] = max(counts["worst"], float(np.abs(got["quaternions"] - q).max()))
    counts["read"] += 1


@pytest.mark.parametrize("layout", ["csv", "mt", "toolviewer"])
def test_tracks_agree_with_the_grammar(tmp_path, seed, layout):
    rng = random.Random(f"{seed}-{layout}")
    counts = {"read": 0, "refused": 0, "worst": 0.0}
    path = tmp_path / ("log.mt" if layout == "mt" else "track.csv")
    for i in range(1200):
        kind = i % 3
        if layout == "csv":
            fmt = CSV
            if kind == 1:
                data, divisor, xyzw = broken_csv(rng)
            else:
                lines_, divisor, xyzw = csv_case(rng)
                data = csv_bytes(rng, lines_)
                data = mutated(rng, data) if kind == 2 else data
        else:
            fmt, divisor, xyzw = POLARIS, 1.0, False
            tv = layout == "toolviewer"
            if kind == 1:
                data = broken_polaris(rng, tv)
            else:
                data = polaris_bytes(rng, toolviewer_case(rng) if tv else mt_case(rng))
                data = mutated(rng, data) if kind == 2 else data
        _agree(path, data, fmt, divisor, xyzw, counts)
    print(f"{layout}: {counts}")
    # Both outcomes exercised in numbers, valid files read in full.
    assert counts["read"] > 450 and counts["refused"] > 300, f"seed {seed}: {counts}"


def test_number_grammar_edges(tmp_path):
    """Each spelling in one csv field: read exactly as float() reads it where
    the grammar takes it, refused naming the field and its line otherwise."""
    path = tmp_path / "t.csv"
    good = ["1", "+1", "-1", "1.", ".5", "-.5", "+.5e-3", "1e5", "1E+05", "1e-05", "00012", "-0", "0.0e-0",
            "1e-400", "4.9e-324", "2.4703282292062328e-324", "1.7976931348623157e308", "1" * 300,
            "0." + "0" * 400 + "1"]
    beyond = ["1e999", "-1e400", "1.7976931348623159e308", "9" * 400]
    bad = ["", ".", "e5", "1e", "1e+", "+", "-", "--1", "+-1", "1.2.3", "1e5.5", "0x10", "0x1p-2", "0X1.8P1", "inf",
           "-inf", "Infinity", "nan", "NaN", "1_000", "1'000", "1d5", "1.5f", "\u0661", "\uff11", "1 5"] + beyond
    for text in good + bad:
        data = f"t,tx,ty,tz,qw,qx,qy,qz\n0,{text},0,0,1,0,0,0\n1,0,0,0,1,0,0,0\n".encode()
        path.write_bytes(data)
        got, message = library(path, CSV)
        if text in good:
            assert got is not None, f"{text!r}: {message}"
            assert got["translations"][0, 0] == float(text) and math.copysign(1, got["translations"][0, 0]) == \
                math.copysign(1, float(text)), text
        else:
            assert got is None, f"{text!r} read as {got['translations'][0, 0]}"
            assert message.startswith(f"{path}:2: field tx is "), message
            assert ("empty" if not text else "beyond" if text in beyond else "not a number") in message, message


def test_from_file_is_the_library_reader(tmp_path, seed):
    rng = random.Random(f"{seed}-from-file")
    for layout in ("csv", "mt", "toolviewer"):
        for _ in range(5):
            if layout == "csv":
                lines_, divisor, xyzw = csv_case(rng)
                data, kw = csv_bytes(rng, lines_), {"time_unit": "ms" if divisor == 1000 else "s",
                                                   "quaternion_order": "xyzw" if xyzw else "wxyz"}
                want = reference(data, CSV, divisor, xyzw)
            else:
                data, kw = polaris_bytes(rng, mt_case(rng) if layout == "mt" else toolviewer_case(rng)), {}
                want = reference(data, POLARIS)
            path = tmp_path / f"log.{layout}"
            path.write_bytes(data)
            m = petblur.Motion.from_file(path, **kw)
            np.testing.assert_array_equal(m.times, want.times)
            np.testing.assert_array_equal(m.translations, np.array(want.translations))
            np.testing.assert_allclose(m.quaternions, np.array(want.quaternions), rtol=0, atol=1e-15)


def test_a_file_that_breaks_a_rule_is_a_file_error(tmp_path):
    """docs/python.md: a malformed track raises FileError, whatever the C
    status; it stays an ArgumentError where the status is of that group."""
    head = "t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n"
    cases = {"zero quaternion": (head + "1,0,0,0,0,0,0,0\n", -5), "norm 2": (head + "1,0,0,0,2,0,0,0\n", -5),
             "time back": (head + "-1,0,0,0,1,0,0,0\n", -7), "one pose": (head, -8),
             "overflow": (head + "1,1e999,0,0,1,0,0,0\n", -4), "hex": (head + "1,0x1p0,0,0,1,0,0,0\n", -600),
             "not rigid": ("t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz\n0,2,0,0,0,0,2,0,0,0,0,2,0\n", -11)}
    for name, (text, status) in cases.items():
        path = tmp_path / f"{name.replace(' ', '_')}.csv"
        path.write_text(text)
        with pytest.raises(petblur.FileError, match=re.escape(str(path))) as e:
            petblur.Motion.from_file(path)
        assert e.value.status == status, name
        assert isinstance(e.value, petblur.ArgumentError) == (status > -100), name
    zero = tmp_path / "zero.mt"
    zero.write_text("23/5/2003 18:18:32 - 11 1 966_IRSL_II\n65900 1 A 1 0 0 0 1 2 3 0.1\n65901 2 A 0 0 0 0 1 2 3 0.1\n")
    with pytest.raises(petblur.FileContentError, match=r"zero\.mt:3: the quaternion is zero"):
        petblur.Motion.from_file(zero)
    cal = tmp_path / "cal.txt"
    cal.write_text("2 0 0 0\n0 1 0 0\n0 0 1 0\n")
    good = tmp_path / "good.csv"
    good.write_text(head + "1,0,0,0,1,0,0,0\n")
    with pytest.raises(petblur.FileError, match="cal.txt: .*not a rotation"):
        petblur.Motion.from_file(good, calibration=cal)
    cal.write_text("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1, 7\n")
    with pytest.raises(petblur.FileError, match=r"cal\.txt:4: '7' is a 17th value"):
        petblur.Motion.from_file(good, calibration=cal)
    sidecar = tmp_path / "pet.json"
    sidecar.write_text('{"FrameTimesStart": [0, 70], "FrameDuration": [60, 60]}')
    with pytest.raises(petblur.FileContentError, match="frame 0 ends"):
        petblur.frames_from_sidecar(sidecar)
    # The caller's own arguments stay an ArgumentError, not the file's.
    mt = tmp_path / "log.mt"
    mt.write_text(zero.read_text().replace("65901 2 A 0 0 0 0", "65901 2 A 1 0 0 0"))
    with pytest.raises(petblur.ArgumentError, match="quaternion_order") as e:
        petblur.Motion.from_file(mt, quaternion_order="xyzw")
    assert not isinstance(e.value, petblur.FileError)


@pytest.fixture
def decimal_comma(tmp_path):
    """LC_NUMERIC set to de_DE (decimal comma) for this process, compiled by
    localedef into tmp_path where the system has no such locale."""
    saved = locale.setlocale(locale.LC_NUMERIC)
    for name in ("de_DE.UTF-8", "de_DE.utf8"):
        try:
            locale.setlocale(locale.LC_NUMERIC, name)
            break
        except locale.Error:
            pass
    else:
        localedef = shutil.which("localedef")
        if not localedef or subprocess.run([localedef, "-i", "de_DE", "-f", "UTF-8", str(tmp_path / "de_DE.UTF-8")],
                                           capture_output=True).returncode not in (0, 1):
            pytest.skip("no de_DE locale, and localedef cannot make one (Debian: apt-get install locales)")
        old = os.environ.get("LOCPATH")
        os.environ["LOCPATH"] = str(tmp_path)
        try:
            locale.setlocale(locale.LC_NUMERIC, "de_DE.UTF-8")
        except locale.Error:
            pytest.skip("localedef made no usable de_DE locale")
        finally:
            os.environ.pop("LOCPATH") if old is None else os.environ.__setitem__("LOCPATH", old)
    try:
        assert locale.localeconv()["decimal_point"] == ","  # the C library's strtod now reads "1,5"
        yield
    finally:
        locale.setlocale(locale.LC_NUMERIC, saved)


def test_numbers_ignore_the_locale(tmp_path, decimal_comma):
    track = tmp_path / "t.csv"
    track.write_text("t,tx,ty,tz,qw,qx,qy,qz\n0.5,1.25,-2.5e-1,0,0.6,0.8,0,0\n1.5,0,0,0,1,0,0,0\n")
    got, message = library(track, CSV)
    assert got is not None, message
    np.testing.assert_array_equal(got["times"], [0.5, 1.5])
    np.testing.assert_array_equal(got["translations"][0], [1.25, -0.25, 0.0])
    np.testing.assert_array_equal(got["quaternions"][0], [0.6, 0.8, 0.0, 0.0])
    mt = tmp_path / "log.mt"
    mt.write_text("23/5/2003 18:18:32 - 11 1 966_IRSL_II\n65900.5 1 A 2 0 0 0 1.5 2 3 0.1\n"
                  "65900.75 2 A 0.5 0.5 0.5 0.5 1 2 3 0.1\n")
    got, message = library(mt, POLARIS)
    assert got is not None, message
    np.testing.assert_array_equal(got["times"], [65900.5, 65900.75])
    np.testing.assert_array_equal(got["translations"][0], [1.5, 2.0, 3.0])
    cal = tmp_path / "cal.txt"
    cal.write_text("1 0 0 0.5\n0 1 0 -1.25\n0 0 1 2.5e-1\n")
    m = (ctypes.c_double * 16)()
    assert _lib.lib.pb_calibration_read(os.fsencode(cal), m) == 0, _lib.message()
    assert (m[3], m[7], m[11]) == (0.5, -1.25, 0.25)
    # A decimal comma is no decimal point in a track: two fields, not 1.25.
    track.write_text("t,tx,ty,tz,qw,qx,qy,qz\n0,\"1,25\",0,0,1,0,0,0\n1,0,0,0,1,0,0,0\n")
    assert library(track, CSV)[0] is None
