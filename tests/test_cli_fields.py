"""Non-rigid motion on the command line (`petblur blur --fields`, `petblur motion --fields`), end to end.

The reference is independent of petblur: nibabel's affines and SciPy's map_coordinates. A field file holds RAS
displacements on its own grid; the reference samples it trilinearly (held at its edge values, as petblur's
convention says) at each image voxel's world position, then resamples the object (trilinear, zero outside) at the
displaced point, averaged over dense times with the fields linear in time between their samples. Image and field
grids differ in size, voxel size, obliquity and handedness, so a slip in the map between them, in the world-to-grid
turn of the vectors or in a convention's signs shows.

usage: test_cli_fields.py PATH/TO/petblur
"""
import os
import subprocess
import sys
import unittest

import nibabel as nib
import numpy as np
from scipy.ndimage import gaussian_filter, map_coordinates
from scipy.spatial.transform import Rotation

import test_cli
from test_cli import Case, run

# A fresh draw each run, printed so that a failure replays: PETBLUR_TEST_SEED=N.
SEED = int(os.environ.get("PETBLUR_TEST_SEED") or np.random.SeedSequence().entropy % 2**32)
print(f"seed {SEED} (replay with PETBLUR_TEST_SEED={SEED})", file=sys.stderr)
RNG = np.random.default_rng(SEED)
DIMS = (22, 18, 14)
FIELD_DIMS = (9, 8, 7)
# A still warp is one trilinear resampling on both sides: measured 0.7e-7 to 1.4e-7 of the largest value (the
# field kept in float32).
STILL_TOL = 1e-5
# RM with 64 steps a segment against a 400-sample time average of a smooth object moving about a voxel: measured
# 0.9e-5 to 3.4e-5 over 33 draws; a field grid taken unturned misses by 0.007 to 0.2, ITK's signs by more.
MOVING_TOL = 2e-4
HOST = ("--method", "rm", "--filter", "exact", "--device", "host", "-q")


def image_affine():
    """An oblique grid (20 degrees about x, then a few about z) with random offsets."""
    a = np.eye(4)
    a[:3, :3] = Rotation.from_euler("xz", [20, RNG.uniform(-8, 8)], degrees=True).as_matrix() @ np.diag([2.0, 2.5, 3.0])
    a[:3, 3] = RNG.uniform(-30, 30, 3)
    return a


def field_affine(image):
    """A coarser LPS-stored grid (x and y flipped), turned a little, that covers the image's field of view."""
    a = np.eye(4)
    a[:3, :3] = Rotation.from_euler("z", RNG.uniform(-15, 15), degrees=True).as_matrix() @ np.diag([-6.5, -7.0, 7.5])
    centre = nib.affines.apply_affine(image, (np.array(DIMS) - 1) / 2)
    a[:3, 3] = centre - a[:3, :3] @ ((np.array(FIELD_DIMS) - 1) / 2) + RNG.uniform(-3, 3, 3)
    return a


def smooth_volume(dims=DIMS):
    vol = gaussian_filter(RNG.random(dims[::-1]).T, 1.5)
    return (vol - vol.min()).astype(np.float32)


def smooth_field(amplitude):
    """RAS displacements (mm) on the field grid: smooth, at most `amplitude` along each axis, not folding."""
    d = np.stack([gaussian_filter(RNG.standard_normal(FIELD_DIMS), 1.2) for _ in range(3)], axis=-1)
    return (d / np.abs(d).max() * amplitude).astype(np.float32)


def save_volume(path, vol, affine):
    img = nib.Nifti1Image(vol, affine)
    img.set_sform(affine, 1)
    img.set_qform(affine, 1)
    nib.save(img, path)


def save_field(path, ras, affine, convention="nifti", shape5=True, qform=True):
    """ras (nx, ny, nz, 3) written as a registration tool writes it."""
    data, code, name, p1 = ras, 1006, b"", 0.0
    if convention == "itk":  # ITK, ANTs, SimpleITK: LPS vectors, intent VECTOR, no name
        data, code = ras * np.array([-1, -1, 1], np.float32), 1007
    elif convention == "niftyreg-disp":
        code, name, p1 = 1007, b"NREG_TRANS", 1.0
    elif convention == "niftyreg-def":  # positions: where each field voxel goes, in world mm
        ijk = np.indices(ras.shape[:3]).reshape(3, -1).T
        world = nib.affines.apply_affine(affine, ijk).reshape(ras.shape)
        data, code, name, p1 = (world + ras).astype(np.float32), 1007, b"NREG_TRANS", 0.0
    elif convention == "vector":  # intent VECTOR with no mark of whose
        code = 1007
    img = nib.Nifti1Image(data[:, :, :, None, :] if shape5 else data, None)
    img.set_sform(affine, 1)
    if qform:
        img.set_qform(affine, 1)
    img.header["intent_code"] = code
    img.header["intent_name"] = name
    img.header["intent_p1"] = p1
    nib.save(img, path)


def field_at_voxels(ras, f_affine, i_affine):
    """A field (RAS mm) at every image voxel: trilinear in the field's index space, held at its edges."""
    ijk = np.indices(DIMS).reshape(3, -1).T.astype(float)
    q = nib.affines.apply_affine(np.linalg.inv(f_affine), nib.affines.apply_affine(i_affine, ijk))
    return np.stack([map_coordinates(ras[..., c].astype(float), q.T, order=1, mode="nearest") for c in range(3)], 1)


def reference_blur(vol, i_affine, times, fields, f_affine, frame, k=400):
    """The frame's time average of the object at r + D(t)(r), D linear in time between the fields."""
    ijk = np.indices(DIMS).reshape(3, -1).T.astype(float)
    world = nib.affines.apply_affine(i_affine, ijk)
    at = [field_at_voxels(f, f_affine, i_affine) for f in fields]
    inverse = np.linalg.inv(i_affine)
    acc = np.zeros(len(ijk))
    for s in frame[0] + (np.arange(k) + 0.5) / k * (frame[1] - frame[0]):
        j = min(np.searchsorted(times, s, side="right") - 1, len(times) - 2)
        a = (s - times[j]) / (times[j + 1] - times[j])
        d = (1 - a) * at[j] + a * at[j + 1]
        idx = nib.affines.apply_affine(inverse, world + d)
        acc += map_coordinates(vol.astype(float), idx.T, order=1, mode="grid-constant", cval=0.0)
    return (acc / k).reshape(DIMS)


def rel_error(out, ref):
    return float(np.abs(out - ref).max() / np.abs(ref).max())


class Fields(Case):
    def setUp(self):
        super().setUp()
        self.a = image_affine()
        self.fa = field_affine(self.a)
        self.vol = smooth_volume()
        save_volume(self.p("act.nii.gz"), self.vol, self.a)

    def table(self, rows, name="fields.csv"):
        with open(self.p(name), "w") as f:
            f.write("time,path\n" + "".join(f"{t},{p}\n" for t, p in rows))
        return self.p(name)

    def blur(self, table, *extra, out="out.nii.gz", inp="act.nii.gz", expect=0):
        _, err = run("blur", "-i", self.p(inp), "-o", self.p(out), "--fields", table, *HOST, *extra, expect=expect)
        return err

    def out(self, name="out.nii.gz"):
        return np.asarray(nib.load(self.p(name)).dataobj, dtype=np.float64)

    def test_still_warp_is_one_resampling(self):
        """Two identical fields: the blur is the object resampled once at r + D(r)."""
        ras = smooth_field(RNG.uniform(2, 4))
        save_field(self.p("gate.nii.gz"), ras, self.fa)
        self.blur(self.table([(0, "gate.nii.gz"), (1, "gate.nii.gz")]))
        err = rel_error(self.out(), reference_blur(self.vol, self.a, [0, 1], [ras, ras], self.fa, (0, 1), k=1))
        print(f"still warp: max error {err:.2e} of the largest value", file=sys.stderr)
        self.assertLess(err, STILL_TOL)

    def test_moving_fields_against_time_average(self):
        times = np.array([0.0, 1.0, 2.5])
        fields = [smooth_field(RNG.uniform(2, 4)) for _ in times]
        for i, f in enumerate(fields):
            save_field(self.p(f"f{i}.nii.gz"), f, self.fa)
        table = self.table([(t, f"f{i}.nii.gz") for i, t in enumerate(times)])
        self.blur(table, "--frame", "0.3,2.2", "--steps", "64")
        err = rel_error(self.out(), reference_blur(self.vol, self.a, times, fields, self.fa, (0.3, 2.2)))
        print(f"moving fields: max error {err:.2e} of the largest value", file=sys.stderr)
        self.assertLess(err, MOVING_TOL)
        # The test can tell: the same vectors read as ITK's (x and y negated) land elsewhere.
        lps = [f * np.array([-1, -1, 1], np.float32) for f in fields]
        wrong = reference_blur(self.vol, self.a, times, lps, self.fa, (0.3, 2.2), k=40)
        self.assertGreater(rel_error(self.out(), wrong), 10 * MOVING_TOL)

    def test_conventions_and_shapes_agree(self):
        """One displacement, written as NIfTI, ITK, NiftyReg (displacement and deformation) and 4-D: one blur."""
        ras = [smooth_field(3.0), smooth_field(3.0)]
        outs = {}
        for conv, shape5, extra in (("nifti", True, ()), ("nifti", False, ()), ("itk", True, ("--field-convention",
                                                                                              "itk")),
                                    ("niftyreg-disp", True, ()), ("niftyreg-def", True, ())):
            name = f"{conv}{'5' if shape5 else '4'}"
            for k in range(2):
                save_field(self.p(f"{name}{k}.nii.gz"), ras[k], self.fa, conv, shape5)
            table = self.table([(0, f"{name}0.nii.gz"), (2, f"{name}1.nii.gz")], f"{name}.csv")
            self.blur(table, "--steps", "8", *extra, out=f"{name}.nii.gz")
            outs[name] = self.out(f"{name}.nii.gz")
        for name, out in outs.items():
            with self.subTest(name=name):
                # The deformation's positions are float32 world mm: a few 1e-6 of the values.
                self.assertLess(rel_error(out, outs["nifti5"]), 1e-4)

    def test_adjoint_dot_products(self):
        """<B x, y> = <x, B^T y> on the files, one frame and three frames summed."""
        times = [0.0, 1.0, 2.0]
        for i in range(3):
            save_field(self.p(f"f{i}.nii.gz"), smooth_field(3.0), self.fa)
        table = self.table([(t, f"f{i}.nii.gz") for i, t in enumerate(times)])
        y = RNG.random(DIMS).astype(np.float32)
        save_volume(self.p("y.nii.gz"), y, self.a)
        self.blur(table, "--frame", "0.2,1.7", out="bx.nii.gz")
        self.blur(table, "--frame", "0.2,1.7", "--adjoint", inp="y.nii.gz", out="bty.nii.gz")
        lhs, rhs = np.vdot(self.out("bx.nii.gz"), y), np.vdot(self.vol, self.out("bty.nii.gz"))
        print(f"dot test, one frame: {abs(lhs - rhs) / abs(lhs):.1e}", file=sys.stderr)
        self.assertAlmostEqual(lhs / rhs, 1.0, delta=1e-5)
        ys = RNG.random((3,) + DIMS).astype(np.float32)
        save_volume(self.p("ys.nii.gz"), np.moveaxis(ys, 0, -1), self.a)
        bounds = "0,0.5,1.4,2"
        self.blur(table, "--frames", bounds, out="bxs.nii.gz")
        self.blur(table, "--frames", bounds, "--adjoint", "--sum-frames", inp="ys.nii.gz", out="btys.nii.gz")
        bxs = self.out("bxs.nii.gz")
        self.assertEqual(bxs.shape, DIMS + (3,))
        lhs = sum(np.vdot(bxs[..., i], ys[i]) for i in range(3))
        rhs = np.vdot(self.vol, self.out("btys.nii.gz"))
        self.assertAlmostEqual(lhs / rhs, 1.0, delta=1e-5)
        # Frame 1 of --frames is --frame 0.5,1.4.
        self.blur(table, "--frame", "0.5,1.4", out="frame1.nii.gz")
        np.testing.assert_allclose(bxs[..., 1], self.out("frame1.nii.gz"), rtol=0, atol=1e-6 * np.abs(bxs).max())

    def test_motion_summary(self):
        """petblur motion --fields: each frame's largest displacement of a field voxel from the frame's start."""
        times = [0.0, 1.0, 3.0]
        fields = [smooth_field(3.0) for _ in times]
        for i, f in enumerate(fields):
            save_field(self.p(f"f{i}.nii.gz"), f, self.fa)
        table = self.table([(t, f"f{i}.nii.gz") for i, t in enumerate(times)])
        out, _ = run("motion", "--fields", table, "-i", self.p("act.nii.gz"), "--frames", "0,0.5,2")
        rows = [line.split() for line in out.splitlines() if line.split()[:1] in (["0"], ["1"])]
        d0 = 0.5 * (fields[0] + fields[1])  # at 0.5 s
        d2 = 0.5 * (fields[1] + fields[2])  # at 2 s
        expect = [np.linalg.norm(d0 - fields[0], axis=-1).max(),
                  max(np.linalg.norm(fields[1] - d0, axis=-1).max(), np.linalg.norm(d2 - d0, axis=-1).max())]
        for row, e, samples in zip(rows, expect, (2, 3)):
            self.assertEqual(int(row[3]), samples, out)
            self.assertAlmostEqual(float(row[4]), e, delta=2e-3, msg=out)

    def refused(self, table, words, *extra, expect=2):
        err = self.blur(table, *extra, expect=expect)
        for w in words:
            self.assertIn(w, err)
        self.assert_clean("out.nii.gz")

    def test_refusals(self):
        good = smooth_field(2.0)
        save_field(self.p("good.nii.gz"), good, self.fa)
        bad = good.copy()
        bad[3, 2, 1, 1] = np.nan
        save_field(self.p("nan.nii.gz"), bad, self.fa)
        self.refused(self.table([(0, "good.nii.gz"), (1, "nan.nii.gz")]), ["nan.nii.gz", "NaN", "(3, 2, 1)"])
        flat = nib.Nifti1Image(good[..., 0], self.fa)
        flat.header["intent_code"] = 1006
        nib.save(flat, self.p("flat.nii.gz"))
        self.refused(self.table([(0, "good.nii.gz"), (1, "flat.nii.gz")]), ["flat.nii.gz", "(nx, ny, nz, 1, 3)"])
        save_field(self.p("vec.nii.gz"), good, self.fa, "vector")
        self.refused(self.table([(0, "vec.nii.gz"), (1, "vec.nii.gz")]), ["vec.nii.gz", "--field-convention"])
        elsewhere = self.fa.copy()
        elsewhere[:3, 3] += 5
        save_field(self.p("moved.nii.gz"), good, elsewhere)
        self.refused(self.table([(0, "good.nii.gz"), (1, "moved.nii.gz")]), ["good.nii.gz", "moved.nii.gz",
                                                                              "different grids"])
        singular = self.fa.copy()
        singular[:3, 2] = 0
        save_field(self.p("singular.nii.gz"), good, singular, qform=False)
        self.refused(self.table([(0, "singular.nii.gz"), (1, "singular.nii.gz")]), ["singular.nii.gz"])
        table = self.table([(0, "good.nii.gz"), (1, "good.nii.gz")])
        self.refused(table, ["cover 0 to 1 s"], "--frame", "0.5,1.5")
        self.refused(table, ["--fields and --motion"], "--motion", self.p("track.csv"))
        # A field is an input: an output of its name is refused, the field untouched.
        before = test_cli.slurp(self.p("good.nii.gz"))
        err = self.blur(table, out="good.nii.gz", expect=2)
        self.assertIn("never writes over its inputs", err)
        self.assertEqual(test_cli.slurp(self.p("good.nii.gz")), before)
        # Absurd tables are refused before any file they name is opened.
        self.refused(self.table([(i, "missing.nii.gz") for i in range(10001)]), ["more than 10000 fields"])
        with open(self.p("noheader.csv"), "w") as f:
            f.write("0,good.nii.gz\n1,good.nii.gz\n")
        self.refused(self.p("noheader.csv"), ["header 'time,path'"])
        self.refused(self.table([(0, "good.nii.gz"), (0, "good.nii.gz")]), ["is not after"])
        # A row naming no file, or a folder: named as such, not as a damaged NIfTI.
        self.refused(self.table([(0, "good.nii.gz"), (1, "gone.nii.gz")]), ["gone.nii.gz", "cannot read it"])
        self.refused(self.table([(0, "good.nii.gz"), (1, ".")]), ["is a folder"])
        # NiftyReg's mark with an intent_p1 of NaN (which nifti_clib reads as 0, a deformation): none of its kinds.
        save_field(self.p("nan_p1.nii.gz"), good, self.fa, "niftyreg-disp")
        img = nib.load(self.p("nan_p1.nii.gz"))
        img.header["intent_p1"] = np.nan
        nib.save(img, self.p("nan_p1.nii.gz"))
        self.refused(self.table([(0, "nan_p1.nii.gz"), (1, "nan_p1.nii.gz")]), ["intent_p1 nan", "NiftyReg"])
        # A field whose header says metres beside one in mm, the numbers alike: the units named, not only
        # "different grids".
        img = nib.load(self.p("good.nii.gz"))
        img.header.set_xyzt_units("meter")
        nib.save(img, self.p("metres.nii.gz"))
        self.refused(self.table([(0, "good.nii.gz"), (1, "metres.nii.gz")]), ["xyz_units", "in mm"])

    def test_what_leaves_the_grid_or_float32_is_refused(self):
        """A field in micrometres read as mm moves every voxel out of the grid: refused at once, naming the units
        (its walk follows the displacement's length, so it would run for minutes). A result beyond float32's range,
        the mass-preserving blur of values near its top or the frames' back projections summed, is not written: an
        image of infinities would pass for a result."""
        good = smooth_field(2.0)
        save_field(self.p("good.nii.gz"), good, self.fa)
        save_field(self.p("micro.nii.gz"), good * 1000.0, self.fa)
        self.refused(self.table([(0, "good.nii.gz"), (1, "micro.nii.gz")]),
                     ["field 1", "twice the image grid's diagonal", "micrometres"])
        # An expansion about the field grid's centre: det(I + dD/dr) = 1.5^3, within the grid's reach.
        ijk = np.indices(FIELD_DIMS).reshape(3, -1).T.astype(float)
        world = nib.affines.apply_affine(self.fa, ijk)
        grow = (0.5 * (world - world.mean(axis=0))).reshape(FIELD_DIMS + (3,)).astype(np.float32)
        save_field(self.p("grow.nii.gz"), grow, self.fa)
        table = self.table([(0, "grow.nii.gz"), (1, "grow.nii.gz")])
        top = np.full(DIMS, 3.0e38, np.float32)
        save_volume(self.p("top.nii.gz"), top, self.a)
        self.blur(table, inp="top.nii.gz")  # a mean of values under float32's top stays under it
        self.assertTrue(np.isfinite(self.out()).all())
        os.remove(self.p("out.nii.gz"))
        err = self.blur(table, "--jacobian", inp="top.nii.gz", expect=2)
        for w in ("not written", "float32's range", "--jacobian", "rescale"):
            self.assertIn(w, err)
        self.assert_clean("out.nii.gz")
        save_volume(self.p("tops.nii.gz"), np.stack([top, top], axis=-1), self.a)
        table = self.table([(0, "good.nii.gz"), (1, "good.nii.gz")])
        err = self.blur(table, "--frames", "0,0.5,1", "--adjoint", "--sum-frames", inp="tops.nii.gz", expect=2)
        for w in ("not written", "float32's range", "--sum-frames"):
            self.assertIn(w, err)
        self.assert_clean("out.nii.gz")

    def test_fold_is_a_warning(self):
        fold = np.zeros(FIELD_DIMS + (3,), np.float32)
        fold[4, :, :, :] = self.fa[:3, 0] * 3.0  # the plane x = 4 of the field grid jumps past x = 5 and 6
        save_field(self.p("fold.nii.gz"), fold, self.fa)
        err = self.blur(self.table([(0, "fold.nii.gz"), (1, "fold.nii.gz")]))
        self.assertIn("warning", err)
        self.assertIn("fold.nii.gz", err)
        self.assertTrue(os.path.exists(self.p("out.nii.gz")))


def belt(duration=14.0, rate=25.0):
    """An irregular respiratory belt: 25 Hz, its period drifting about 4 s and its depth about 1 (arbitrary units)."""
    t = np.arange(0.0, duration, 1.0 / rate)
    period = 4.0 + 0.6 * np.sin(2 * np.pi * t / 11.0 + RNG.uniform(0, 2 * np.pi))
    phase = 2 * np.pi * np.concatenate([[0.0], np.cumsum(np.diff(t) / period[1:])]) + RNG.uniform(0, 2 * np.pi)
    depth = 1.0 + 0.12 * np.sin(2 * np.pi * t / 9.0 + RNG.uniform(0, 2 * np.pi))
    return t, depth * 0.5 * (1 - np.cos(phase)) + 0.01 * RNG.standard_normal(t.size)


def reference_gates(vol, i_affine, values, fields, f_affine, t, s, edges, span, dt=0.002):
    """Each gate's time average of the object at r + D(s(t))(r), D linear in s between the fields' values, over
    dense times of the span at which the signal (linear between its samples) lies in [edges[g], edges[g+1])."""
    ijk = np.indices(DIMS).reshape(3, -1).T.astype(float)
    world = nib.affines.apply_affine(i_affine, ijk)
    at = [field_at_voxels(f, f_affine, i_affine) for f in fields]
    inverse = np.linalg.inv(i_affine)
    dense = np.arange(span[0] + dt / 2, span[1], dt)
    sig = np.interp(dense, t, s)
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        inside = sig[(sig >= lo) & (sig < hi)]
        # The gate's amplitudes, binned finely: the warp depends on s alone.
        hist, bins = np.histogram(inside, bins=200, range=(lo, hi))
        acc = np.zeros(len(ijk))
        for w, v in zip(hist, 0.5 * (bins[:-1] + bins[1:])):
            if not w:
                continue
            j = min(max(np.searchsorted(values, v, side="right") - 1, 0), len(values) - 2)
            a = (v - values[j]) / (values[j + 1] - values[j])
            idx = nib.affines.apply_affine(inverse, world + (1 - a) * at[j] + a * at[j + 1])
            acc += w * map_coordinates(vol.astype(float), idx.T, order=1, mode="grid-constant", cval=0.0)
        out.append((acc / hist.sum()).reshape(DIMS))
    return np.stack(out, axis=-1)


def rms_error(out, ref):
    return float(np.sqrt(np.mean((out - ref) ** 2) / np.mean(ref ** 2)))


# RM along the belt's polyline against a dense time average binned by amplitude (200 bins a gate): measured 6e-7 to
# 1.2e-4 of the gate's RMS over 9 draws; the gates differ from one another by 0.1 and more.
GATES_TOL = 1e-3


class Gates(Case):
    """--fields at a surrogate's values, --signal and --gates: amplitude-gated blurs of an irregular belt."""

    def setUp(self):
        super().setUp()
        self.a = image_affine()
        self.fa = field_affine(self.a)
        self.vol = smooth_volume()
        save_volume(self.p("act.nii.gz"), self.vol, self.a)
        self.t, self.s = belt()
        with open(self.p("belt.csv"), "w") as f:
            f.write("time,value\n" + "".join(f"{a:.6f},{b:.9g}\n" for a, b in zip(self.t, self.s)))
        self.values = np.array([-0.1, 0.3, 0.6, 0.9, 1.3])
        base = smooth_field(4.0)
        self.fields = [(v * base + smooth_field(0.6)).astype(np.float32) for v in self.values]
        for i, f in enumerate(self.fields):
            save_field(self.p(f"a{i}.nii.gz"), f, self.fa)
        self.table = self.p("amplitudes.csv")
        with open(self.table, "w") as f:
            f.write("value,path\n" + "".join(f"{v},a{i}.nii.gz\n" for i, v in enumerate(self.values)))

    def blur(self, *extra, table=None, out="out.nii.gz", inp="act.nii.gz", expect=0):
        _, err = run("blur", "-i", self.p(inp), "-o", self.p(out), "--fields", table or self.table, *HOST, *extra,
                     expect=expect)
        return err

    def out(self, name="out.nii.gz"):
        return np.asarray(nib.load(self.p(name)).dataobj, dtype=np.float64)

    def test_gates_against_dense_average(self):
        edges = [0.02, 0.25, 0.5, 0.75, 0.95]
        span = (1.3, 12.7)
        self.blur("--signal", self.p("belt.csv"), "--gates", ",".join(map(str, edges)), "--frame",
                  f"{span[0]},{span[1]}", "--steps", "16")
        out = self.out()
        self.assertEqual(out.shape, DIMS + (4,))
        ref = reference_gates(self.vol, self.a, self.values, self.fields, self.fa, self.t, self.s, edges, span)
        errs = [rms_error(out[..., g], ref[..., g]) for g in range(4)]
        print("gates: RMS error " + ", ".join(f"{e:.2e}" for e in errs) + " of the gates' RMS", file=sys.stderr)
        for g, e in enumerate(errs):
            self.assertLess(e, GATES_TOL, f"gate {g}")
        # The belt's samples walked in time (the paper's polyline) rather than the values it visits: as close.
        self.blur("--signal", self.p("belt.csv"), "--gates", ",".join(map(str, edges)), "--frame",
                  f"{span[0]},{span[1]}", "--steps", "16", "--max-path-error", "paper", out="paper.nii.gz")
        in_time = self.out("paper.nii.gz")
        for g in range(4):
            self.assertLess(rms_error(in_time[..., g], ref[..., g]), GATES_TOL, f"gate {g} walked in time")
        # The test can tell: the gates differ from one another by far more than the error.
        self.assertGreater(rms_error(out[..., 0], out[..., 3]), 10 * GATES_TOL)
        # A whole-signal blur (no --gates) is the time average of every sample, a 3-D volume.
        self.blur("--signal", self.p("belt.csv"), "--steps", "16", out="all.nii.gz")
        self.assertEqual(self.out("all.nii.gz").shape, DIMS)

    def test_adjoint_dot_products(self):
        edges = "0.05,0.4,0.7,0.9"
        common = ("--signal", self.p("belt.csv"), "--gates", edges)
        ys = RNG.random((3,) + DIMS).astype(np.float32)
        save_volume(self.p("ys.nii.gz"), np.moveaxis(ys, 0, -1), self.a)
        self.blur(*common, out="bx.nii.gz")
        bx = self.out("bx.nii.gz")
        self.blur(*common, "--adjoint", inp="ys.nii.gz", out="bty.nii.gz")
        bty = self.out("bty.nii.gz")
        self.assertEqual(bty.shape, DIMS + (3,))
        for g in range(3):
            lhs, rhs = np.vdot(bx[..., g], ys[g]), np.vdot(self.vol, bty[..., g])
            print(f"dot test, gate {g}: {abs(lhs - rhs) / abs(lhs):.1e}", file=sys.stderr)
            self.assertAlmostEqual(lhs / rhs, 1.0, delta=1e-5)
        self.blur(*common, "--adjoint", "--sum-frames", inp="ys.nii.gz", out="sum.nii.gz")
        lhs = sum(np.vdot(bx[..., g], ys[g]) for g in range(3))
        self.assertAlmostEqual(lhs / np.vdot(self.vol, self.out("sum.nii.gz")), 1.0, delta=1e-5)

    def refused(self, words, *extra, table=None, out="out.nii.gz", expect=2):
        err = self.blur(*extra, table=table, out=out, expect=expect)
        for w in words:
            self.assertIn(w, err)
        self.assert_clean("out.nii.gz")

    def test_refusals(self):
        belt_csv = self.p("belt.csv")
        self.refused(["--signal"])  # a value table alone
        timed = self.p("timed.csv")
        with open(timed, "w") as f:
            f.write("time,path\n0,a0.nii.gz\n1,a1.nii.gz\n")
        self.refused(["value,path", "--signal"], "--signal", belt_csv, table=timed)
        _, err = run("blur", "-i", self.p("act.nii.gz"), "-o", self.p("out.nii.gz"), "--signal", belt_csv, *HOST,
                     expect=2)
        self.assertIn("--fields", err)
        self.assert_clean("out.nii.gz")
        _, err = run("blur", "-i", self.p("act.nii.gz"), "-o", self.p("out.nii.gz"), "--gates", "0,1", *HOST,
                     expect=2)
        self.assertIn("--signal", err)
        self.refused(["gate 3", "[2, 3]", "never visited", "--frame"], "--signal", belt_csv, "--gates",
                     "0.1,0.5,0.9,2,3")
        narrow = self.p("narrow.csv")
        with open(narrow, "w") as f:
            f.write("value,path\n0.2,a1.nii.gz\n0.7,a2.nii.gz\n")
        err = self.blur("--signal", belt_csv, table=narrow, expect=2)
        self.assertIn("outside the fields' values [0.2, 0.7]", err)
        self.assertIn("add a field", err)
        self.assert_clean("out.nii.gz")
        self.refused(["--gates", ".nii"], "--signal", belt_csv, "--gates", "0.1,0.5", out="out.raw")
        self.assert_clean("out.raw")
        self.refused(["header 'time,value'"], "--signal", self.table)
        _, err = run("motion", "--fields", self.table, expect=2)
        self.assertIn("petblur blur --signal", err)


class LongBelts(Case):
    """Gating a long belt costs its samples, not its samples times its gates' intervals (a 4-hour belt and ten
    gates were planned for minutes), and a gate's edge at a field's value is not refused for the rounding of the
    signal's value where it crosses the edge."""

    def setUp(self):
        super().setUp()
        self.a = image_affine()
        self.fa = field_affine(self.a)
        save_volume(self.p("act.nii.gz"), smooth_volume(), self.a)
        for i, amp in enumerate((0.0, 3.0)):
            save_field(self.p(f"v{i}.nii.gz"), smooth_field(amp) if amp else np.zeros(FIELD_DIMS + (3,)), self.fa)
        with open(self.p("values.csv"), "w") as f:
            f.write("value,path\n0,v0.nii.gz\n1,v1.nii.gz\n")

    def gate(self, t, s, edges, timeout):
        with open(self.p("belt.csv"), "w") as f:
            f.write("time,value\n" + "".join(f"{a:.3f},{b:.6f}\n" for a, b in zip(t, s)))
        p = subprocess.run([test_cli.PETBLUR, "blur", "-i", self.p("act.nii.gz"), "-o", self.p("out.nii.gz"),
                            "--fields", self.p("values.csv"), "--signal", self.p("belt.csv"), "--gates",
                            ",".join(map(str, edges)), *HOST], capture_output=True, text=True, timeout=timeout)
        self.assertEqual(p.returncode, 0, p.stderr)
        out = np.asarray(nib.load(self.p("out.nii.gz")).dataobj, dtype=np.float64)
        self.assertEqual(out.shape, DIMS + ((len(edges) - 1,) if len(edges) > 2 else ()))
        self.assertTrue(np.isfinite(out).all())
        return out

    def test_a_long_belt_and_an_edge_at_a_fields_value(self):
        t = np.arange(0.0, 4 * 3600.0, 0.04)
        s = 0.5 - 0.5 * np.cos(2 * np.pi * t / RNG.uniform(3.5, 4.5)) + 0.01 * RNG.standard_normal(t.size)
        s = np.clip(s, 0.0, 1.0)  # the fields' values: every sample inside them, the crossings of 0 and 1 at them
        out = self.gate(t, s, np.linspace(0.0, 1.0, 11), timeout=60)
        # The gates are told apart: the lowest and the highest amplitudes are blurred differently.
        self.assertGreater(np.abs(out[..., 0] - out[..., -1]).max(), 1e-3 * np.abs(out).max())
        # A sample below 0, outside every gate: the crossings of the edge at 0 beside it round past it.
        self.gate([103.04, 103.08, 103.12], [0.0448, -0.00629, 0.07799], [0.0, 1.0], timeout=60)
        # The same in epoch seconds, where the crossing time's own rounding moves the value more.
        self.gate([1.7e9 + 103.04, 1.7e9 + 103.08, 1.7e9 + 103.12], [0.0448, -0.00629, 0.07799], [0.0, 1.0],
                  timeout=60)
        # A belt logged in epoch seconds that dips below the lowest field's value between the gates: the dips stay
        # outside every gate (a join of two intervals as wide as a millisecond there took them in, and was refused).
        t = 1.7e9 + np.arange(0.0, 600.0, 0.04)
        s = 0.48 - 0.5 * np.cos(2 * np.pi * (t - 1.7e9) / RNG.uniform(3.5, 4.5)) + 0.01 * RNG.standard_normal(t.size)
        self.assertLess(s.min(), 0.0)
        self.gate(t, np.clip(s, -1.0, 1.0), [0.0, 0.25, 0.5, 0.75, 1.0], timeout=60)
        # The top gate is closed, as Python's amplitude_gates makes it: a breath held at its top edge is in it.
        self.gate([0.0, 1.0, 2.0], [1.0, 1.0, 1.0], [0.5, 1.0], timeout=60)


def reference_track_gates(vol, affine, shift, axis, turn, t, s, edges, span, dt=0.002):
    """Each gate's time average of the object under a rigid pose that follows the belt, p' = R (p - c) + c + t with
    t = s shift and R a turn of s turn radians about axis through the grid's centre c (world mm): the pose is a
    function of s alone, so the dense times of the span at which s lies in [edges[g], edges[g+1]) are binned by s."""
    ijk = np.indices(DIMS).reshape(3, -1).T.astype(float)
    world = nib.affines.apply_affine(affine, ijk)
    c = nib.affines.apply_affine(affine, (np.array(DIMS) - 1) / 2)
    inverse = np.linalg.inv(affine)
    sig = np.interp(np.arange(span[0] + dt / 2, span[1], dt), t, s)
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        hist, bins = np.histogram(sig[(sig >= lo) & (sig < hi)], bins=120, range=(lo, hi))
        acc = np.zeros(len(ijk))
        for w, v in zip(hist, 0.5 * (bins[:-1] + bins[1:])):
            if w:
                r = Rotation.from_rotvec(v * turn * axis).as_matrix()
                p = (world - c - v * shift) @ r + c  # rows times R: R^T applied to each
                acc += w * map_coordinates(vol.astype(float), nib.affines.apply_affine(inverse, p).T, order=1,
                                           mode="grid-constant", cval=0.0)
        out.append((acc / hist.sum()).reshape(DIMS))
    return np.stack(out, axis=-1)


class TrackGates(Case):
    """--motion with --signal and --gates: a rigid track's amplitude gates, each frame the time-weighted mean of its
    intervals' blurs (pb_plan_create_gates), the gates computed as for --fields."""

    def setUp(self):
        super().setUp()
        self.a = image_affine()
        self.vol = smooth_volume()
        save_volume(self.p("act.nii.gz"), self.vol, self.a)
        self.t, self.s = belt()
        with open(self.p("belt.csv"), "w") as f:
            f.write("time,value\n" + "".join(f"{a:.6f},{b:.9g}\n" for a, b in zip(self.t, self.s)))
        # A chest that breathes rigidly: a shift of 3 to 6 mm and a turn of 2 to 4 degrees per unit of the belt.
        u, k = RNG.standard_normal(3), RNG.standard_normal(3)
        self.shift = RNG.uniform(3.0, 6.0) * u / np.linalg.norm(u)
        self.axis = k / np.linalg.norm(k)
        self.turn = np.radians(RNG.uniform(2.0, 4.0))
        q = Rotation.from_rotvec(np.outer(self.s * self.turn, self.axis)).as_quat()  # x, y, z, w
        with open(self.p("track.csv"), "w") as f:
            f.write("t,tx,ty,tz,qw,qx,qy,qz\n")
            for ti, si, qi in zip(self.t, self.s, q):
                f.write(",".join(f"{v:.9g}" for v in [ti, *(si * self.shift), qi[3], *qi[:3]]) + "\n")

    def blur(self, *extra, out="out.nii.gz", inp="act.nii.gz", expect=0):
        _, err = run("blur", "-i", self.p(inp), "-o", self.p(out), "--motion", self.p("track.csv"), *HOST, *extra,
                     expect=expect)
        return err

    def out(self, name="out.nii.gz"):
        return np.asarray(nib.load(self.p(name)).dataobj, dtype=np.float64)

    def test_gates_against_dense_average_and_transpose(self):
        edges = [0.02, 0.3, 0.6, 0.95]
        span = (1.1, 12.9)
        common = ("--signal", self.p("belt.csv"), "--gates", ",".join(map(str, edges)), "--frame",
                  f"{span[0]},{span[1]}", "--steps", "16", "--max-path-error", "0.01")
        self.blur(*common)
        out = self.out()
        self.assertEqual(out.shape, DIMS + (3,))
        ref = reference_track_gates(self.vol, self.a, self.shift, self.axis, self.turn, self.t, self.s, edges, span)
        errs = [rms_error(out[..., g], ref[..., g]) for g in range(3)]
        print("track gates: RMS error " + ", ".join(f"{e:.2e}" for e in errs) + " of the gates' RMS", file=sys.stderr)
        for g, e in enumerate(errs):
            self.assertLess(e, TRACK_GATES_TOL, f"gate {g}")
        self.assertGreater(rms_error(out[..., 0], out[..., 2]), 10 * TRACK_GATES_TOL)  # the test can tell
        # The transpose: the dot test gate by gate (--sum-frames runs the same code as for --fields, tested there).
        ys = RNG.random((3,) + DIMS).astype(np.float32)
        save_volume(self.p("ys.nii.gz"), np.moveaxis(ys, 0, -1), self.a)
        self.blur(*common, "--adjoint", inp="ys.nii.gz", out="bty.nii.gz")
        bty = self.out("bty.nii.gz")
        for g in range(3):
            lhs, rhs = np.vdot(out[..., g], ys[g]), np.vdot(self.vol, bty[..., g])
            print(f"track dot test, gate {g}: {abs(lhs - rhs) / abs(lhs):.1e}", file=sys.stderr)
            self.assertAlmostEqual(lhs / rhs, 1.0, delta=1e-5)

    def test_refusals(self):
        belt_csv = self.p("belt.csv")
        err = self.blur("--signal", belt_csv, expect=2)
        self.assertIn("--gates", err)
        err = self.blur("--signal", belt_csv, "--gates", "0.1,0.5,0.9,2,3", expect=2)
        for w in ("gate 3", "[2, 3]", "never visited", "--frame"):
            self.assertIn(w, err)
        err = self.blur("--signal", belt_csv, "--gates", "0.1,0.5", "--frame", "-1,5", expect=2)
        self.assertIn("the signal", err)
        # A belt recorded longer than the track: the span is outside the track.
        with open(self.p("long.csv"), "w") as f:
            f.write("time,value\n" + "".join(f"{a:.6f},{b:.9g}\n" for a, b in zip(self.t, self.s)) + "30,0.5\n")
        err = self.blur("--signal", self.p("long.csv"), "--gates", "0.1,0.5,0.9", expect=2)
        self.assertIn("outside the track", err)
        err = self.blur("--signal", belt_csv, "--gates", "0.1,0.5", "--frames", "1,2,3", expect=2)
        self.assertIn("--gates and --frames", err)
        self.assert_clean("out.nii.gz")


# RM with 16 steps a segment, the path within 0.01 voxels of the belt-driven track's, against the dense average
# binned by amplitude (120 bins a gate): measured 2e-5 to 2.2e-4 of the gate's RMS (at the default bound, 0.1 voxels, the chords merged
# across the belt's samples leave 5e-4 to 6e-3).
TRACK_GATES_TOL = 1e-3


if __name__ == "__main__":
    test_cli.PETBLUR = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
