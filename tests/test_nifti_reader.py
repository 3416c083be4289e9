"""Differential test of the program's NIfTI orientation against nibabel's on
the same bytes: fresh NIfTI-1 and NIfTI-2 files whose orientation fields are
drawn at random, sane and damaged (codes, quaternions over unit length, NaN
and infinite quaternions, offsets and sform rows, singular sforms, qfac and
negative pixdims, units of m and micron). Each file goes through
`petblur blur --translate 0,0,0` and the output's affine is compared with the
affine nibabel loads from the input.

The expected verdict is nibabel's, with what petblur documents as stricter
(docs/cli.md, "NIfTI orientation"): a used form that is not finite, is
singular or reaches beyond 1e9 mm, a quaternion nibabel would refuse, and a
code outside 0 to 4 are refused; with both codes 0 petblur takes no placement (nibabel a default
one). Units: petblur keeps mm, nibabel the file's units."""

import os
import random
import subprocess
import sys
import tempfile
import unittest
import warnings

import nibabel as nib
import numpy as np

PETBLUR = None
UNITS = {"mm": 1.0, "meter": 1000.0, "micron": 1e-3, "unknown": 1.0}


def random_rotation_quaternion(rng):
    q = np.array([rng.gauss(0, 1) for _ in range(4)])
    q /= np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def make_file(rng, path):
    """A small NIfTI with random orientation fields; returns its raw fields."""
    version = rng.choice([1, 2])
    shape = (rng.randint(2, 5), rng.randint(2, 5), rng.randint(2, 5))
    data = np.array([rng.random() for _ in range(int(np.prod(shape)))], dtype=np.float32).reshape(shape)
    klass = nib.Nifti1Image if version == 1 else nib.Nifti2Image
    img = klass(data, np.eye(4))
    hdr = img.header
    hdr["pixdim"][1:4] = [rng.choice([1, -1, 1, 1]) * rng.uniform(0.5, 4) for _ in range(3)]
    hdr["pixdim"][0] = rng.choice([1, 1, -1, -1, 0, 0.5, -0.5, 2])
    q = random_rotation_quaternion(rng)
    bcd = q[1:]
    kind = rng.randrange(10)
    if kind == 0:
        bcd = bcd * rng.choice([1.0 + 1e-3, 1.5, 1.0 + 1e-7, 1.0 - 1e-7])
    elif kind == 1:
        bcd = bcd.copy()
        bcd[rng.randrange(3)] = rng.choice([np.nan, np.inf, -np.inf])
    hdr["quatern_b"], hdr["quatern_c"], hdr["quatern_d"] = bcd
    offs = [rng.uniform(-200, 200) for _ in range(3)]
    if kind == 2:
        offs[rng.randrange(3)] = rng.choice([np.nan, np.inf, -np.inf, 1e38])
    hdr["qoffset_x"], hdr["qoffset_y"], hdr["qoffset_z"] = offs
    rows = np.array([[rng.uniform(-4, 4) for _ in range(4)] for _ in range(3)])
    if kind == 3:
        rows[rng.randrange(3), rng.randrange(4)] = rng.choice([np.nan, np.inf])
    elif kind == 4:
        rows[2, :3] = rows[0, :3] * rng.choice([2.0, -1.0])  # two axes along one line
    elif kind == 5:
        rows[:, rng.randrange(3)] = 0.0  # an axis of length 0
    hdr["srow_x"], hdr["srow_y"], hdr["srow_z"] = rows
    hdr["sform_code"] = rng.choice([0, 0, 1, 2, 4, -1, 7] if kind == 6 else [0, 1, 2])
    hdr["qform_code"] = rng.choice([0, 1, 1, 2, 3, -2, 9] if kind == 7 else [0, 1, 1])
    hdr.set_xyzt_units(rng.choice(list(UNITS)), "sec")
    # nibabel's to_filename would set its own sform and qform: write raw.
    with open(path, "wb") as f:
        hdr.set_data_offset(len(hdr.binaryblock) + 4)
        f.write(hdr.binaryblock)
        f.write(b"\0" * 4)
        f.write(data.astype("<f4" if hdr.endianness == "<" else ">f4").tobytes(order="F"))
    return hdr


def expected(path):
    """('refuse', why) or ('affine', 4x4 in mm) or ('none', None)."""
    with open(path, "rb") as f:
        block = f.read(540)
    klass = nib.Nifti2Header if int.from_bytes(block[:4], "little") == 540 else nib.Nifti1Header
    raw = klass(block[:klass.template_dtype.itemsize], check=False)
    scode, qcode = int(raw["sform_code"]), int(raw["qform_code"])
    if not 0 <= scode <= 4 or not 0 <= qcode <= 4:
        return "refuse", "code"
    if scode == 0 and qcode == 0:
        return "none", None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            affine = np.asarray(nib.load(path).affine, dtype=np.float64)
    except Exception as e:  # nibabel refuses the qform it would use
        return "refuse", repr(e)
    if not np.all(np.isfinite(affine)):
        return "refuse", "not finite"
    m = affine[:3, :3]
    cols = np.prod(np.linalg.norm(m, axis=0))
    if not cols > 0 or abs(np.linalg.det(m)) <= 1e-6 * cols:
        return "refuse", "singular"
    unit = {1: 1000.0, 2: 1.0, 3: 1e-3}.get(int(raw["xyzt_units"]) & 7, 1.0)  # NIFTI_UNITS_METER, MM, MICRON
    affine[:3, :] *= unit
    if np.abs(affine).max() > 1e9:  # beyond 1000 km: damaged, and no float32 holds it in mm
        return "refuse", "beyond 1e9 mm"
    return "affine", affine


class NiftiOrientation(unittest.TestCase):
    def test_orientation_agrees_with_nibabel(self):
        seed = int.from_bytes(os.urandom(4), "little")
        rng = random.Random(seed)
        counts = {"affine": 0, "none": 0, "refuse": 0}
        with tempfile.TemporaryDirectory() as tmp:
            for i in range(150):
                src, dst = os.path.join(tmp, f"in{i}.nii"), os.path.join(tmp, f"out{i}.nii")
                make_file(rng, src)
                verdict, want = expected(src)
                r = subprocess.run([PETBLUR, "blur", "-i", src, "-o", dst, "--translate", "0,0,0", "--coords", "grid",
                                    "--device", "host", "-q"], capture_output=True, text=True, timeout=60)
                where = f"seed {seed}, file {i} ({verdict}: {want if verdict != 'affine' else ''}): {r.stderr}"
                counts[verdict] += 1
                if verdict == "refuse":
                    self.assertEqual(r.returncode, 2, where)
                    self.assertIn(src, r.stderr, where)
                    self.assertFalse(os.path.exists(dst), where)
                    continue
                self.assertEqual(r.returncode, 0, where)
                out = nib.load(dst)
                if verdict == "none":
                    self.assertEqual((int(out.header["sform_code"]), int(out.header["qform_code"])), (0, 0), where)
                    continue
                got = np.asarray(out.affine, dtype=np.float64)
                scale = max(1.0, np.abs(want).max())
                self.assertLess(np.abs(got - want).max(), 2e-5 * scale, f"{where}\n{got}\n{want}")
        print(f"seed {seed}: {counts}")
        self.assertGreater(counts["affine"], 40, counts)
        self.assertGreater(counts["refuse"], 15, counts)


if __name__ == "__main__":
    PETBLUR = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
