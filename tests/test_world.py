"""Motions in the scanner's world coordinates and from trackers' logs, end to end.

The reference is independent of petblur: nibabel's affines and SciPy's map_coordinates (trilinear, zero outside)
average the object resampled at dense times along the world-space motion (SciPy's Slerp between key rotations).
petblur's CL method on the host backend (exact weights, dense steps) must land on it; the same run in the grid
frame must not.

usage: test_world.py PATH/TO/petblur
"""
import json
import os
import sys
import unittest

import nibabel as nib
import numpy as np
from scipy.ndimage import gaussian_filter, map_coordinates
from scipy.signal import lfilter
from scipy.spatial.transform import Rotation, Slerp

import test_cli
from test_cli import Case, run

# A fresh draw each run, printed so that a failure replays: PETBLUR_TEST_SEED=N.
SEED = int(os.environ.get("PETBLUR_TEST_SEED") or np.random.SeedSequence().entropy % 2**32)
print(f"seed {SEED} (replay with PETBLUR_TEST_SEED={SEED})", file=sys.stderr)
RNG = np.random.default_rng(SEED)
DIMS = (24, 20, 16)
# CL with 64 steps against a 400-step average: measured 1.0e-4 to 1.7e-4 of the largest value on these volumes;
# the same motion taken along the array's axes misses by 0.4 to 0.7.
WORLD_TOL = 2e-3


def smooth_volume(dims=DIMS):
    vol = gaussian_filter(RNG.random(dims), 1.5)
    return (vol - vol.min()).astype(np.float32)


def rot_x(deg):
    return Rotation.from_euler("x", deg, degrees=True).as_matrix()


def affines():
    """An LAS file, one tilted 20 degrees about x, and one stored coronally; offsets drawn fresh."""
    las = np.diag([-2.0, 2.0, 3.0, 1.0])
    oblique = np.eye(4)
    oblique[:3, :3] = rot_x(20) @ np.diag([2.0, 2.5, 3.0])
    coronal = np.eye(4)
    coronal[:3, :3] = [[2.0, 0, 0], [0, 0, -3.0], [0, 2.5, 0]]
    out = {}
    for name, a in (("las", las), ("oblique", oblique), ("coronal", coronal)):
        a = a.copy()
        a[:3, 3] = RNG.uniform(-40, 40, 3)
        out[name] = a
    return out


def save_nifti(path, vol, affine):
    img = nib.Nifti1Image(vol, affine)
    img.set_qform(affine, 1)
    img.set_sform(affine, 1)
    nib.save(img, path)


def reference_blur(vol, affine, times, rotations, translations, centre, frame, k=400):
    """The frame's time average of the object moved by w' = R (w - c) + c + t (world mm), resampled on the grid."""
    ijk = np.indices(vol.shape).reshape(3, -1).T.astype(float)
    world = nib.affines.apply_affine(affine, ijk)
    inverse = np.linalg.inv(affine)
    slerp = Slerp(times, rotations)
    acc = np.zeros(len(ijk))
    for s in frame[0] + (np.arange(k) + 0.5) / k * (frame[1] - frame[0]):
        r = slerp([s])[0].as_matrix()
        t = np.array([np.interp(s, times, translations[:, i]) for i in range(3)])
        obj = (world - centre - t) @ r + centre  # R^T (w - c - t) + c, as rows
        idx = nib.affines.apply_affine(inverse, obj)
        acc += map_coordinates(vol.astype(float), idx.T, order=1, mode="grid-constant", cval=0.0)
    return (acc / k).reshape(vol.shape)


def grid_centre(affine, dims=DIMS):
    return nib.affines.apply_affine(affine, (np.array(dims) - 1) / 2)


CL = ("--method", "cl", "--filter", "exact", "--steps", "64", "--device", "host", "-q")


class World(Case):
    def setUp(self):
        super().setUp()
        self.vol = smooth_volume()

    def blur(self, src, out, *motion):
        run("blur", "-i", self.p(src), "-o", self.p(out), *motion, *CL)
        return nib.load(self.p(out)).get_fdata()

    def check(self, out, ref, what):
        err = np.abs(out - ref).max() / self.vol.max()
        self.assertLess(err, WORLD_TOL, f"{what}: {err:.3g} of the largest value from the world-space reference")
        return err

    def test_pose_options_in_world_coordinates(self):
        """--rotate about world z through the grid's centre with --translate; --axis and --center; both against
        the reference, and --coords grid against the reference in the grid frame (which the world one is not)."""
        for name, a in affines().items():
            with self.subTest(affine=name):
                save_nifti(self.p("in.nii"), self.vol, a)
                deg, t = RNG.uniform(15, 30), RNG.uniform(-5, 5, 3)
                motion = ("--rotate", f"{deg:.6f}", "--translate", ",".join(f"{v:.6f}" for v in t))
                two = lambda r: Rotation.from_rotvec([[0, 0, 0], np.radians(r)])  # noqa: E731
                ref = reference_blur(self.vol, a, [0, 1], two([0, 0, deg]), np.array([[0, 0, 0], t]),
                                     grid_centre(a), (0, 1))
                self.check(self.blur("in.nii", "w.nii", *motion), ref, "--rotate/--translate")
                axis = RNG.normal(size=3)
                axis /= np.linalg.norm(axis)
                centre = grid_centre(a) + RNG.uniform(-8, 8, 3)
                ref = reference_blur(self.vol, a, [0, 1], two(axis * deg), np.array([[0, 0, 0], t]), centre, (0, 1))
                self.check(self.blur("in.nii", "c.nii", *motion, "--axis", ",".join(f"{v:.9f}" for v in axis),
                                     "--center", ",".join(f"{v:.9f}" for v in centre)), ref, "--axis/--center")
                # The grid frame: mm from the grid's corner along the array's axes.
                vs = np.sqrt((a[:3, :3] ** 2).sum(axis=0))
                g = np.diag(np.append(vs, 1.0))
                g[:3, 3] = vs / 2
                ref_grid = reference_blur(self.vol, g, [0, 1], two([0, 0, deg]), np.array([[0, 0, 0], t]),
                                          grid_centre(g), (0, 1))
                out_grid = self.blur("in.nii", "g.nii", *motion, "--coords", "grid")
                self.check(out_grid, ref_grid, "--coords grid")
                self.assertGreater(np.abs(out_grid - ref).max() / self.vol.max(), 20 * WORLD_TOL,
                                   "the grid frame should differ from the world frame here")

    def test_track_in_world_coordinates(self):
        """A three-pose csv track about --center, in world mm, and a frame inside it."""
        for name, a in affines().items():
            with self.subTest(affine=name):
                save_nifti(self.p("in.nii"), self.vol, a)
                rots = Rotation.from_rotvec(np.vstack([np.zeros(3), RNG.normal(size=(2, 3)) * 0.2]))
                trans = np.vstack([np.zeros(3), RNG.uniform(-4, 4, (2, 3))])
                times = [0.0, 1.0, 2.5]
                centre = grid_centre(a) + RNG.uniform(-5, 5, 3)
                with open(self.p("t.csv"), "w") as f:
                    f.write("t,tx,ty,tz,qw,qx,qy,qz\n")
                    for ti, q, tr in zip(times, rots.as_quat(), trans):
                        f.write(",".join(f"{v:.17g}" for v in (ti, *tr, q[3], q[0], q[1], q[2])) + "\n")
                out = self.blur("in.nii", "o.nii", "--motion", self.p("t.csv"), "--frame", "0.4,2.2",
                                "--center", ",".join(f"{v:.17g}" for v in centre))
                self.check(out, reference_blur(self.vol, a, times, rots, trans, centre, (0.4, 2.2)), "track")

    def test_default_device(self):
        """The placement is host-side maths shared by every backend: the default device (PoCL in CI) blurs a world
        motion as the host does, within the HARDWARE filter's bound (test_cli's test_default_device_runs)."""
        a = affines()["oblique"]
        save_nifti(self.p("in.nii"), self.vol, a)
        motion = ("--rotate", "14", "--axis", "1,1,0", "--translate", "3,-2,5", "-q")
        run("blur", "-i", self.p("in.nii"), "-o", self.p("dev.nii"), *motion, "--device", "auto")
        run("blur", "-i", self.p("in.nii"), "-o", self.p("host.nii"), *motion, "--device", "host")
        np.testing.assert_allclose(nib.load(self.p("dev.nii")).get_fdata(), nib.load(self.p("host.nii")).get_fdata(),
                                   atol=1e-2 * self.vol.max())

    def test_rotation_beyond_180_follows_the_arc(self):
        """--rotate 270 turns three quarters round, not -90; checked against the arc in the reference."""
        a = affines()["las"]
        save_nifti(self.p("in.nii"), self.vol, a)
        times = np.linspace(0, 1, 7)
        rots = Rotation.from_rotvec(np.outer(times * np.radians(270), [0, 0, 1]))
        ref = reference_blur(self.vol, a, times, rots, np.zeros((7, 3)), grid_centre(a), (0, 1), k=600)
        out = self.blur("in.nii", "o.nii", "--rotate", "270")
        self.check(out, ref, "--rotate 270")
        short = self.blur("in.nii", "s.nii", "--rotate", "-90")
        self.assertGreater(np.abs(short - out).max() / self.vol.max(), 20 * WORLD_TOL)

    def test_interfile_placement(self):
        """STIR's placement: an Interfile header's keys give the affine STIR's convention implies (computed here
        from STIR's rules), an Interfile output keeps the keys, and a world motion blurs an Interfile image as it
        blurs the NIfTI with that affine."""
        vs, fpo = np.array([2.0, 2.5, 3.0]), RNG.uniform(-50, 50, 3)
        # STIR: gantry p = fpo + index * d; LPS = diag(s) p per patient position; RAS = diag(-1, -1, 1) LPS.
        lps_sign = {("head_in", "supine"): (1, 1, -1), ("head_in", "prone"): (-1, -1, -1),
                    ("feet_in", "supine"): (-1, 1, 1), ("feet_in", "prone"): (1, -1, 1)}
        for (orient, rot), s in lps_sign.items():
            with self.subTest(position=(orient, rot)):
                self.vol.T.astype("<f4").tofile(self.p("in.v"))
                keys = "".join(f"first pixel offset (mm) [{i + 1}] := {float(fpo[i])!r}\n" for i in range(3))
                with open(self.p("in.hv"), "w") as f:
                    f.write("!INTERFILE :=\n!name of data file := in.v\n!number format := float\n"
                            "!number of bytes per pixel := 4\nimagedata byte order := LITTLEENDIAN\n"
                            "number of dimensions := 3\n"
                            + "".join(f"!matrix size [{i + 1}] := {DIMS[i]}\nscaling factor (mm/pixel) [{i + 1}] := "
                                      f"{vs[i]}\n" for i in range(3))
                            + f"patient orientation := {orient}\npatient rotation := {rot}\n" + keys
                            + "!END OF INTERFILE :=\n")
                ras = np.array(s) * np.array([-1, -1, 1])
                expect = np.diag(np.append(ras * vs, 1.0))
                expect[:3, 3] = ras * fpo
                run("blur", "-i", self.p("in.hv"), "-o", self.p("z.nii"), "--translate", "0,0,0", "-q")
                np.testing.assert_allclose(nib.load(self.p("z.nii")).affine, expect, atol=1e-4)
                run("blur", "-i", self.p("in.hv"), "-o", self.p("out.hv"), "--translate", "0,0,0", "-q")
                header = open(self.p("out.hv")).read()
                self.assertIn(f"patient orientation := {orient}", header)
                self.assertIn(f"patient rotation := {rot}", header)
                for i in range(3):
                    line = [ln for ln in header.splitlines() if ln.startswith(f"first pixel offset (mm) [{i + 1}]")]
                    self.assertEqual(len(line), 1)
                    self.assertEqual(float(line[0].split(":=")[1]), fpo[i])
                save_nifti(self.p("same.nii"), self.vol, expect)
                motion = ("--rotate", "12", "--translate", "3,-2,4", "--device", "host", "-q")
                run("blur", "-i", self.p("in.hv"), "-o", self.p("hv.nii"), *motion)
                run("blur", "-i", self.p("same.nii"), "-o", self.p("nii.nii"), *motion)
                self.assertTrue(np.array_equal(nib.load(self.p("hv.nii")).get_fdata(),
                                               nib.load(self.p("nii.nii")).get_fdata()))


def matrix(q_wxyz, t):
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat([q_wxyz[1], q_wxyz[2], q_wxyz[3], q_wxyz[0]]).as_matrix()
    m[:3, 3] = t
    return m


def quat_wxyz(m):
    x, y, z, w = Rotation.from_matrix(m[:3, :3]).as_quat()
    return np.array([w, x, y, z])


class Tracks(Case):
    """One world motion, written in every format; the tracker formats with a calibration C and a reference time,
    so that their logs hold the tool's pose P(t) = C^-1 M(t) C P(ref)."""

    TIMES = np.array([0.0, 0.5, 1.0, 1.5])  # on Toolviewer's 60 Hz clock
    REF = 0.5

    def setUp(self):
        super().setUp()
        vol = smooth_volume()
        self.affine = affines()["oblique"]
        save_nifti(self.p("in.nii"), vol, self.affine)
        # M(t) about the world's origin, the identity at the reference time.
        self.M = []
        for t in self.TIMES:
            m = np.eye(4)
            if t != self.REF:
                m[:3, :3] = Rotation.from_rotvec(RNG.normal(size=3) * 0.15).as_matrix()
                m[:3, 3] = RNG.uniform(-4, 4, 3)
            self.M.append(m)
        self.C = np.eye(4)
        self.C[:3, :3] = Rotation.random(random_state=RNG.integers(1 << 31)).as_matrix()
        self.C[:3, 3] = RNG.uniform(-500, 500, 3)
        self.P_ref = np.eye(4)
        self.P_ref[:3, :3] = Rotation.random(random_state=RNG.integers(1 << 31)).as_matrix()
        self.P_ref[:3, 3] = RNG.uniform(-300, 300, 2).tolist() + [-1800.0]
        with open(self.p("cal.txt"), "w") as f:
            f.write("# tracker to scanner\n" + "\n".join(" ".join(f"{v:.17g}" for v in row) for row in self.C) + "\n")

    def blur(self, out, *motion):
        run("blur", "-i", self.p("in.nii"), "-o", self.p(out), "--device", "host", "-q", *motion)
        return nib.load(self.p(out)).get_fdata()

    def tool_poses(self):
        ci = np.linalg.inv(self.C)
        return [ci @ m @ self.C @ self.P_ref for m in self.M]

    def write_csv(self, name, header, order="wxyz", unit=1.0):
        """petblur's csv, its poses about --center 0,0,0 (the world's origin, as a tracker's matrices are): the
        centre is part of a track's meaning, since translations are interpolated about it."""
        cols = header.split(",")
        with open(self.p(name), "w") as f:
            f.write(header + ",note\n")
            for t, m in zip(self.TIMES, self.M):
                q = quat_wxyz(m)
                tc = m[:3, 3]
                val = {"t": t * unit, "tx": tc[0], "ty": tc[1], "tz": tc[2], "qw": q[0], "qx": q[1], "qy": q[2],
                       "qz": q[3]}
                numbered = q if order == "wxyz" else np.roll(q, -1)
                val.update({f"q{i}": numbered[i] for i in range(4)})
                f.write(",".join(f"{val[k]:.17g}" for k in cols) + ",x\n")
        return self.p(name)

    def test_every_format_gives_the_same_blur(self):
        frame = ("--frame", "0.1,1.4")
        centre = ("--center", "0,0,0")
        base = self.blur("csv.nii", "--motion", self.write_csv("a.csv", "t,tx,ty,tz,qw,qx,qy,qz"), *frame, *centre)
        # Columns by name in any order; numbered quaternions in either order; milliseconds.
        same = {
            "reordered": ("--motion", self.write_csv("b.csv", "qz,tz,t,qx,ty,qw,tx,qy")),
            "xyzw": ("--motion", self.write_csv("c.csv", "t,tx,ty,tz,q0,q1,q2,q3", order="xyzw"),
                     "--quaternion-order", "xyzw"),
            "ms": ("--motion", self.write_csv("d.csv", "t,tx,ty,tz,qw,qx,qy,qz", unit=1000.0), "--time-unit", "ms"),
        }
        for what, motion in same.items():
            with self.subTest(format=what):
                self.assertTrue(np.array_equal(base, self.blur(f"{what}.nii", *motion, *frame, *centre)), what)
        # matrix-csv: with a header, and as yrt-pet writes it (no header, ms, an error column, and the inverse map).
        with open(self.p("m.csv"), "w") as f:
            f.write("t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz\n")
            for t, m in zip(self.TIMES, self.M):
                f.write(",".join(f"{v:.17g}" for v in [t, *m[:3].ravel()]) + "\n")
        with open(self.p("yrt.csv"), "w") as f:
            for t, m in zip(self.TIMES, self.M):
                f.write(",".join([str(int(t * 1000))] + [f"{v:.17f}" for v in np.linalg.inv(m)[:3].ravel()]
                                 + ["0.95"]) + "\n")
        # Polaris .mt and Toolviewer: the tool's pose in the tracker's frame, and missing samples between.
        with open(self.p("p.mt"), "w") as f:
            f.write("23/11/2026 10:15:00 - 11 1 IRSL_head\n")
            for i, (t, p) in enumerate(zip(self.TIMES, self.tool_poses())):
                q = quat_wxyz(p) * 1.0004  # NDI's quaternions need not be unit
                f.write(f"{t:.17g} {i + 3} A " + " ".join(f"{v:.17g}" for v in (*q, *p[:3, 3])) + " 0.21\n")
                f.write(f"{t + 0.25:.17g} {i + 7} A : ---- Missing ----\n")
        with open(self.p("p.csv"), "w") as f:
            f.write("Collection Data : Port 0B  ( ICL          S/N: 3608C803 Type: 01000000 Rev: 000 )\n"
                    "[June 25, 2010  04:00PM]\n\n"
                    "Frame,         Q0,         Qx,         Qy,         Qz,          x,          y,          z,"
                    "      Error,        OOV\n")
            for t, p in zip(self.TIMES, self.tool_poses()):
                q = quat_wxyz(p)
                f.write(f"   {402115 + int(round(t * 60))}," + ",".join(f" {v:.17g}" for v in (*q, *p[:3, 3]))
                        + ",     0.1800,          0\n")
                f.write(f"   {402115 + int(round(t * 60)) + 1},    MISSING\n")
        tracker = ("--calibration", self.p("cal.txt"), "--reference-time", str(self.REF))
        close = {
            "matrix-csv": ("--motion", self.p("m.csv")),
            "yrt-pet": ("--motion", self.p("yrt.csv"), "--time-unit", "ms", "--motion-inverse"),
            "polaris-mt": ("--motion", self.p("p.mt"), *tracker),
            "polaris-toolviewer": ("--motion", self.p("p.csv"), *tracker),
        }
        outs = {}
        for what, motion in close.items():
            with self.subTest(format=what):
                outs[what] = self.blur(f"{what}.nii", *motion, *frame)
                # The same rigid maps, composed and rounded another way: float rounding of the output apart.
                np.testing.assert_allclose(outs[what], base, rtol=0, atol=2e-6 * base.max())
        # The two Polaris layouts hold the same poses, the .mt's quaternions
        # scaled by 1.0004 (NDI's need not be unit): equal once normalised, to
        # its rounding, which may move a key pose by an ulp and the output by
        # float rounding (array_equal held on most draws, not all).
        np.testing.assert_allclose(outs["polaris-mt"], outs["polaris-toolviewer"], rtol=0, atol=2e-6 * base.max(),
                                   err_msg="the two Polaris layouts hold the same numbers")
        # Without the calibration the tracker's frame is taken for the scanner's: another motion.
        wrong = self.blur("nocal.nii", "--motion", self.p("p.mt"), "--reference-time", str(self.REF), *frame)
        self.assertGreater(np.abs(wrong - base).max(), 0.05 * base.max())

    def test_frames_from_a_bids_sidecar(self):
        track = self.write_csv("a.csv", "t,tx,ty,tz,qw,qx,qy,qz")
        with open(self.p("s.json"), "w") as f:
            json.dump({"TimeZero": "10:15:00", "FrameTimesStart": [0, 0.5, 1.0], "FrameDuration": [0.5, 0.5, 0.5]}, f)
        run("blur", "-i", self.p("in.nii"), "-o", self.p("a.nii"), "--motion", track, "--frames-from",
            self.p("s.json"), "--device", "host", "-q")
        run("blur", "-i", self.p("in.nii"), "-o", self.p("b.nii"), "--motion", track, "--frames", "0,0.5,1,1.5",
            "--device", "host", "-q")
        a = nib.load(self.p("a.nii")).get_fdata()
        self.assertEqual(a.shape, DIMS + (3,))
        self.assertTrue(np.array_equal(a, nib.load(self.p("b.nii")).get_fdata()))
        with open(self.p("gap.json"), "w") as f:
            json.dump({"FrameTimesStart": [0, 0.6], "FrameDuration": [0.5, 0.5]}, f)
        _, err = run("blur", "-i", self.p("in.nii"), "-o", self.p("c.nii"), "--motion", track, "--frames-from",
                     self.p("gap.json"), expect=2)
        self.assertIn("frame 0 ends at 0.5 s but frame 1 starts at 0.6 s", err)


class MotionCommand(Case):
    def test_summary_and_picture(self):
        """petblur motion: per frame, the largest rotation and corner displacement from the frame's first pose,
        computed here with SciPy over the same samples; a gap counted; the picture a valid PNG."""
        t = np.arange(0, 20, 1 / 30)
        rot = Rotation.from_euler("xz", np.stack([3 * np.sin(t / 2), np.where(t > 12, 10.0, 0.0)], 1), degrees=True)
        trans = np.stack([0.1 * t, np.zeros_like(t), np.where(t > 12, 6.0, 0.0)], 1)
        keep = (t < 5) | (t > 5.5)
        with open(self.p("m.csv"), "w") as f:
            f.write("t,tx,ty,tz,qw,qx,qy,qz\n")
            for ti, q, tr in zip(t[keep], rot.as_quat()[keep], trans[keep]):
                f.write(",".join(f"{v:.17g}" for v in (ti, *tr, q[3], q[0], q[1], q[2])) + "\n")
        dims, vs = np.array([40, 30, 20]), np.array([2.0, 2.0, 3.0])
        out, _ = run("motion", self.p("m.csv"), "--dims", "40,30,20", "--voxel-size", "2,2,3", "--frames",
                     "0,10,19.9", "--png", self.p("m.png"))
        rows = [ln.split() for ln in out.splitlines() if ln[:1] == " " or ln[:1].isdigit()]
        self.assertEqual(len(rows), 2, out)
        corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)]) * dims * vs
        centre = dims * vs / 2
        for (t0, t1), row in zip(((0, 10), (10, 19.9)), rows):
            inside = keep & (t >= t0) & (t <= t1)
            first = np.argmax(inside)
            r0 = rot[first]
            angles = np.degrees((r0.inv() * rot[inside]).magnitude())
            moved = lambda r, tr: (corners - centre) @ r.as_matrix().T + centre + tr  # noqa: E731
            disp = max(np.linalg.norm(moved(r, tr) - moved(r0, trans[first]), axis=1).max()
                       for r, tr in zip(rot[inside], trans[inside]))
            self.assertAlmostEqual(float(row[4]), angles.max(), delta=2e-3)
            self.assertAlmostEqual(float(row[5]), disp, delta=2e-3)
        self.assertIn("median step 0.0333", out)
        test_cli.png_size(self.p("m.png"))

    def test_tracker_noise_reported(self):
        """petblur motion's noise column (issue 46): a 20 Hz log of a steady drift with white noise of a random sigma
        per axis in its second frame (but its first and last second), the same drift without noise in the first, and a
        noise-free tremor at a random 4-9 Hz in the third. Translation noise moves every corner alike, so the frame's
        noise is sqrt(3) sigma (the 3-D scatter's RMS; within 25 %: over 1160 samples the estimate scatters by about 6
        %); the noise-free frames report none, the tremor being motion; and the steady drift takes one segment under its
        noise, where following the samples took one a sample."""
        sigma, hz = RNG.uniform(0.05, 0.25), RNG.uniform(4, 9)
        t = np.arange(0, 180, 0.05) + RNG.uniform(0, 1)
        trans = np.outer(t - t[0], RNG.uniform(-0.03, 0.03, 3))
        second = (t >= t[0] + 61) & (t < t[0] + 119)  # a second inside: the frames' ends are interpolated
        trans[second] += RNG.normal(0, sigma, (second.sum(), 3))
        last = t >= t[0] + 120
        trans[last, 2] += 0.5 * np.sin(2 * np.pi * hz * t[last])
        with open(self.p("noisy.csv"), "w") as f:
            f.write("t,tx,ty,tz,qw,qx,qy,qz\n")
            f.writelines(f"{ti:.6f},{x:.6f},{y:.6f},{z:.6f},1,0,0,0\n" for ti, (x, y, z) in zip(t, trans))
        bounds = ",".join(f"{t[0] + 60 * i:.6f}" for i in range(3)) + f",{t[-1]:.6f}"
        out, _ = run("motion", self.p("noisy.csv"), "--dims", "90,90,50", "--voxel-size", "2.5,2.5,3", "--frames",
                     bounds)
        rows = [ln.split() for ln in out.splitlines() if ln[:1] == " " or ln[:1].isdigit()]
        self.assertEqual(len(rows), 3, out)
        noise, segments = [float(r[6]) for r in rows], [int(r[7]) for r in rows]
        msg = f"sigma {sigma:.3f} mm, tremor {hz:.2f} Hz:\n{out}"
        self.assertAlmostEqual(noise[1], np.sqrt(3) * sigma, delta=0.25 * np.sqrt(3) * sigma, msg=msg)
        self.assertEqual([noise[0], noise[2]], [0.0, 0.0], msg)
        self.assertEqual(segments[:2], [1, 1], msg)
        self.assertGreater(segments[2], 100, msg)
        self.assertIn("noise mm: the tracker's noise", out)

    def test_a_frame_no_path_walks_is_still_shown(self):
        """A frame whose default path would take more segments than a blur walks (a 20 Hz random walk of 1 mm steps,
        held near the grid by a pull of 0.1 % a step back to it, 100 minutes of it: motion, not noise, and every sample followed) is shown with '-' for its noise and segments
        and the reason after the table; the command succeeds, and the frame beside it (1000 s: at 2001 samples the
        whiteness test took such a walk for noise in 11 of 400 frames, at 20001 in none) is summarised as ever."""
        t = np.arange(0, 7000, 0.05)
        walk = lfilter([1.0], [1.0, -0.999], RNG.normal(0, 1.0, (t.size, 3)), axis=0)
        np.savetxt(self.p("walk.csv"), np.column_stack([t, walk, np.ones(t.size), np.zeros((t.size, 3))]),
                   delimiter=",", fmt="%.4f", header="t,tx,ty,tz,qw,qx,qy,qz", comments="")
        out, _ = run("motion", self.p("walk.csv"), "--dims", "100,100,60", "--voxel-size", "2,2,2", "--frames",
                     "0,1000,6999")
        rows = [ln.split() for ln in out.splitlines() if ln[:1] == " " or ln[:1].isdigit()]
        self.assertEqual(len(rows), 2, out)
        self.assertEqual(rows[1][6:], ["-", "-"], out)
        self.assertGreater(int(rows[0][7]), 10000, out)  # a random walk is followed, not taken for noise
        self.assertEqual(float(rows[0][6]), 0.0, out)
        self.assertIn("no path at the default bound; frame 1: max_path_error", out)


class Sanity(Case):
    """Every warning and refusal, triggered, with its message."""

    def setUp(self):
        super().setUp()
        save_nifti(self.p("in.nii"), smooth_volume((12, 10, 8)), np.diag([2.0, 2.0, 2.0, 1.0]))

    def track(self, rows, header="t,tx,ty,tz,qw,qx,qy,qz", name="t.csv"):
        with open(self.p(name), "w") as f:
            f.write(header + "\n" + "".join(r + "\n" for r in rows))
        return self.p(name)

    def blur(self, *args, expect=0):
        return run("blur", "-i", self.p("in.nii"), "-o", self.p("o.nii"), "--device", "host", "-q", *args,
                   expect=expect)[1]

    def test_warnings(self):
        turn = Rotation.from_rotvec([0, 0, 0.2]).as_quat()  # x, y, z, w: written as if w came first
        slip = self.track(["0,0,0,0,1,0,0,0", "0.033,0,0,0," + ",".join(f"{v:.9f}" for v in turn)])
        self.assertRegex(self.blur("--motion", slip), r"petblur: warning: .*t\.csv:3: the pose turns \d+ degrees .*"
                                                      r"--quaternion-order")
        ms = self.track(["0,0,0,0,1,0,0,0", "1800000,1,0,0,1,0,0,0", "3600000,2,0,0,1,0,0,0"], name="ms.csv")
        err = self.blur("--motion", ms, "--frame", "0,60000")
        self.assertIn("are its times in milliseconds? then give --time-unit ms", err)
        self.assertIn("spans", err)
        err = self.blur("--motion", ms)
        self.assertIn("lasts 1e+03 h: are the times in milliseconds?", err)
        long = self.track(["0,0,0,0,1,0,0,0", "1000,1,0,0,1,0,0,0"], name="long.csv")
        self.assertIn("spans 0.05 % of the track", self.blur("--motion", long, "--frame", "10,10.5"))
        polaris = os.path.join(self.d, "p.mt")
        with open(polaris, "w") as f:
            f.write("23/11/2026 10:15:00 - 11 1 head\n0.0 1 A 1 0 0 0 10 20 -1800 0.2\n"
                    "1.0 2 A 1 0 0 0 11 20 -1800 0.2\n")
        self.assertIn("no --reference-time; the motion is taken relative to the first sample",
                      self.blur("--motion", polaris))

    def test_refusals(self):
        self.assertIn("at 1 of the frame's 2 poses the grid lies wholly outside the field of view",
                      self.blur("--translate", "1000,0,0"))
        os.remove(self.p("o.nii"))
        away = self.track(["0,1000,0,0,1,0,0,0", "1,1000,0,5,1,0,0,0"], name="away.csv")
        err = self.blur("--motion", away, expect=2)
        self.assertIn("takes the whole grid out of the field of view for the whole frame 0 to 1 s", err)
        self.assertFalse(os.path.exists(self.p("o.nii")))
        # Both samples out of view, but the motion sweeps through the grid between them: not refused.
        sweep = self.track(["0,-1000,0,0,1,0,0,0", "1,1000,0,0,1,0,0,0"], name="sweep.csv")
        self.assertIn("at 2 of the frame's 2 poses", self.blur("--motion", sweep))
        self.assertTrue(os.path.exists(self.p("o.nii")))
        with open(self.p("gap.mt"), "w") as f:
            f.write("23/11/2026 10:15:00 - 11 1 head\n0.0 1 A 1 0 0 0 0 0 0 0.2\n0.5 1 A 1 0 0 0 1 0 0 0.2\n"
                    + "".join(f"{0.5 + 0.05 * i:.2f} 2 A : ---- Missing ----\n" for i in range(1, 40))
                    + "2.5 3 A 1 0 0 0 2 0 0 0.2\n3.0 3 A 1 0 0 0 3 0 0 0.2\n")
        err = self.blur("--motion", self.p("gap.mt"), "--frame", "0.2,2.8", expect=2)
        self.assertIn("gap.mt:3-43: 39 missing samples leave a gap of 2 s", err)
        self.blur("--motion", self.p("gap.mt"), "--frame", "0,0.5")  # a frame beside the gap is fine
        raw = self.p("in.raw")
        nib.load(self.p("in.nii")).get_fdata().astype("<f4").T.tofile(raw)
        _, err = run("blur", "-i", raw, "--dims", "12,10,8", "-o", self.p("r.raw"), "--translate", "1,0,0",
                     "--coords", "world", expect=2)
        self.assertIn("carries no placement in the world", err)
        shear = np.array([[2.0, 0.5, 0, 0], [0, 2.0, 0, 0], [0, 0, 2.0, 0], [0, 0, 0, 1]])
        img = nib.Nifti1Image(smooth_volume((12, 10, 8)), shear)
        img.set_sform(shear, 1)
        img.set_qform(None, 0)
        nib.save(img, self.p("shear.nii"))
        _, err = run("blur", "-i", self.p("shear.nii"), "-o", self.p("s.nii"), "--translate", "1,0,0", expect=2)
        self.assertIn("shear", err)
        with open(self.p("bad.txt"), "w") as f:
            f.write("2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n")
        err = self.blur("--motion", self.p("gap.mt"), "--calibration", self.p("bad.txt"), expect=2)
        self.assertIn("is not a rotation", err)
        err = self.blur("--motion", self.p("gap.mt"), "--center", "1,2,3", expect=2)
        self.assertIn("drop --center", err)

    def test_bad_rows_name_their_line(self):
        cases = [
            (["0,0,0,0,1,0,0,0", "1,nan,0,0,1,0,0,0"], "t.csv:3: field tx is 'nan', not a number"),
            (["0,0,0,0,1,0,0,0", "1,0x10,0,0,1,0,0,0"], "t.csv:3: field tx is '0x10', not a number"),
            (["1,0,0,0,1,0,0,0", "0.5,0,0,0,1,0,0,0"], "t.csv:3: time 0.5 s does not come after"),
            (["0,0,0,0,1,0,0,0", "1,0,0,0,1,0,0"], "t.csv:3: 7 fields where the header has 8"),
        ]
        for rows, words in cases:
            with self.subTest(words=words):
                self.assertIn(words, self.blur("--motion", self.track(rows), expect=2))
        err = self.blur("--motion", self.track(["0,0,0,0,1,0,0,0", "1,0,0,0,1,0,0,0"], header="time,x,y,z,a,b,c,d"),
                        expect=2)
        self.assertIn("found 'time,x,y,z,a,b,c,d', expected the columns t,tx,ty,tz,qw,qx,qy,qz", err)
        m = self.track(["0,1,0,0,0,0,1,0,0,0,0,1,0", "1,1,0,0,0,0,1,0,0,0,0,2,0"], header="t,r00,r01,r02,tx,r10,r11,"
                       "r12,ty,r20,r21,r22,tz", name="m.csv")
        self.assertIn("m.csv:3: the pose matrix's 3x3 part is not a rotation", self.blur("--motion", m, expect=2))


if __name__ == "__main__":
    test_cli.PETBLUR = sys.argv.pop(1)
    unittest.main(verbosity=2)
