"""petblur motion estimate, end to end, against a truth made without petblur.

bench/head_frames.py simulates a dynamic series of a moving head with SciPy (a fresh seed each run): tracer uptake
changing from frame to frame, Poisson noise, an LAS grid turned 10 degrees, a nod and a jerk of 10 degrees and 8 mm
inside one frame. The error is what users measure: the displacement of points inside the head, mean over each frame.
On this small, coarse series (4.5 mm voxels, 8 frames whose uptake changes fast) first runs gave a mean of
0.75-0.84 mm against 4.3 mm uncorrected, a worst frame of 1.7-1.9 mm, and 1.7-1.9 mm in the jerk's frame against 3.5-3.6
mm with one pose per frame; the bounds leave room for other seeds (docs/motion.md gives the full-size numbers). The bad
inputs of issue 30 must exit 2 and write nothing.

usage: test_motion_estimate.py PATH/TO/petblur
"""
import json
import os
import sys
import tempfile
import unittest

import nibabel as nib
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "bench"))
import head_frames as hf  # noqa: E402
import pass4_family  # noqa: E402

import test_cli  # noqa: E402
from test_cli import run  # noqa: E402

SEED = int(np.random.SeedSequence().entropy % 2**32)
SETUP = hf.Setup(frames=8, shape=(40, 40, 36), voxel=(4.5, 4.5, 4.5), jerk_frame=5, counts=1e6, las=True,
                 oblique_deg=10.0)


class Estimate(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.TemporaryDirectory()
        d = cls.dir.name
        rng = np.random.default_rng(SEED)
        cls.frames, cls.affine, cls.bounds, cls.truth = hf.simulate(SETUP, rng, steps=4, jerk_steps=40)
        cls.points = hf.head_points(rng)
        cls.nii = os.path.join(d, "sub-01_pet.nii.gz")
        cls.json = os.path.join(d, "sub-01_pet.json")
        nib.save(nib.Nifti1Image(cls.frames, cls.affine), cls.nii)
        with open(cls.json, "w") as f:
            json.dump({"FrameTimesStart": cls.bounds[:-1].tolist(), "FrameDuration": np.diff(cls.bounds).tolist(),
                       "TracerName": "FDG"}, f)

    @classmethod
    def tearDownClass(cls):
        cls.dir.cleanup()

    def errors(self, path):
        return hf.displacement_errors(hf.track_maps(*hf.read_matrix_csv(path)), self.truth, self.bounds, self.points)

    def test_track_against_truth(self):
        inside, frames = (os.path.join(self.dir.name, n) for n in ("inside.csv", "frames.csv"))
        out, _ = run("motion", "estimate", self.nii, "--frames-from", self.json, "-o", inside, "--reference", "0")
        self.assertIn("8 frames", out)
        self.assertIn("relative to frame 0\n", out)
        run("motion", "estimate", self.nii, "--frames-from", self.json, "-o", frames, "--frame-poses-only", "-q",
            "--reference", "0")
        e_in, e_frames = self.errors(inside), self.errors(frames)
        none = hf.displacement_errors(lambda t: np.eye(4), self.truth, self.bounds, self.points)
        msg = f"seed {SEED}: per frame {np.round(e_in, 2)}, one pose per frame {np.round(e_frames, 2)}"
        j = SETUP.jerk_frame
        # the motion, frames 6 and 7 about 12 mm, is taken out to about a fifth
        self.assertLess(e_in.mean(), 0.3 * none.mean(), msg)
        self.assertLess(e_in.max(), 2.6, msg)
        # the jerk's frame: poses on both sides of the jerk beat one pose
        self.assertLess(e_in[j], 0.75 * e_frames[j], msg)
        # the reference frame is the identity (to the rounding of poses composed in the world)
        t, maps = hf.read_matrix_csv(inside)
        self.assertTrue(np.allclose(maps[0], np.eye(4), atol=1e-5), maps[0])
        self.check_frame_table(out, msg)

    def check_frame_table(self, out, msg):
        """The line a frame after the summary: its times, the share its fit explains, and the motion inside it: the
        jerk's frame among those with motion, its motion within the frame and about the jerk's time."""
        lines = out.splitlines()
        head = next(i for i, line in enumerate(lines) if line.split()[:2] == ["frame", "start"])
        rows = [line.split(maxsplit=5) for line in lines[head + 1:head + 1 + SETUP.frames]]
        self.assertEqual([int(r[0]) for r in rows], list(range(SETUP.frames)), out)
        self.assertTrue(np.allclose([[float(r[1]), float(r[2])] for r in rows],
                                    np.stack([self.bounds[:-1], self.bounds[1:]], 1), atol=1e-3), out)
        explained = np.array([float(r[3]) for r in rows])
        self.assertTrue(np.all((explained > 0) & (explained <= 100)), out)
        moving = {int(r[0]): [float(x) for x in r[5].split()[1::2]] for r in rows if r[5].startswith("from ")}
        summary = int(out.split(" with motion inside")[0].rsplit("(", 1)[1])
        self.assertEqual(len(moving), summary, out)
        # the jumps at boundaries the summary counts are the frames whose line says so, none with motion inside
        jumps = int(out.split(" at a boundary)")[0].rsplit(", ", 1)[1].split()[0])
        jumped = [int(r[0]) for r in rows if r[5].endswith("(the head jumped at its start)")]
        self.assertEqual(len(jumped), jumps, out)
        self.assertFalse(set(jumped) & set(moving), out)
        j, T = SETUP.jerk_frame, self.bounds[1] - self.bounds[0]
        self.assertIn(j, moving, out + msg)
        a, b = moving[j]
        self.assertTrue(self.bounds[j] <= a <= b <= self.bounds[j + 1], out)
        jerk = self.bounds[j] + SETUP.jerk_at * T
        self.assertTrue(a - 0.1 * T <= jerk <= b + 0.1 * T, f"jerk at {jerk:.2f} s, motion from {a} to {b}; {msg}")

    def test_csv_is_the_same_motion(self):
        """--format csv (poses about the grid's centre in the world) against matrix-csv, converted in numpy; and
        the track goes into petblur blur as it is."""
        m, c = (os.path.join(self.dir.name, n) for n in ("m.csv", "c.csv"))
        run("motion", "estimate", self.nii, "--frames-from", self.json, "-o", m, "-q", "--frame-poses-only",
            "--levels", "2")
        run("motion", "estimate", self.nii, "--frames-from", self.json, "-o", c, "-q", "--frame-poses-only",
            "--levels", "2", "--format", "csv")
        t, maps = hf.read_matrix_csv(m)
        rows = np.loadtxt(c, delimiter=",", skiprows=1)
        np.testing.assert_allclose(rows[:, 0], t)
        from scipy.spatial.transform import Rotation
        r = Rotation.from_quat(rows[:, [5, 6, 7, 4]]).as_matrix()
        centre = self.affine[:3, :3] @ ((np.array(SETUP.shape) - 1) / 2) + self.affine[:3, 3]
        np.testing.assert_allclose(r, maps[:, :3, :3], atol=1e-9)
        np.testing.assert_allclose(rows[:, 1:4] + centre - r @ centre, maps[:, :3, 3], atol=1e-6)
        out = os.path.join(self.dir.name, "blurred.nii.gz")
        run("blur", "-i", self.nii, "-o", out, "--motion", m, "--frames-from", self.json, "-q")
        self.assertEqual(nib.load(out).shape, self.frames.shape)

    def refused(self, image, *args, words=()):
        out = os.path.join(self.dir.name, "refused.csv")
        _, err = run("motion", "estimate", image, "-o", out, *args, expect=2)
        self.assertFalse(os.path.exists(out), err)
        for w in words:
            self.assertIn(w, err)
        return err

    def write(self, name, data, affine=None):
        path = os.path.join(self.dir.name, name)
        nib.save(nib.Nifti1Image(data.astype(np.float32), self.affine if affine is None else affine), path)
        return path

    def test_bad_input(self):
        f = self.frames
        self.refused(self.write("three.nii", f[..., 0]), "--frames", "0,10", words=("4-D",))
        self.refused(self.write("one.nii", f[..., :1]), "--frames", "0,10", words=("4-D",))
        self.refused(self.nii, "--frames", "0,10,20,30", words=("8 frames",))
        # Each frame measurable, the series not: a track over it would hold times no blur can subtract.
        far = ",".join(["-1e308"] + [str(10 * i) for i in range(7)] + ["1e308"])
        self.refused(self.nii, "--frames", far, words=("too long to measure",))
        bad = f.copy()
        bad[3, 4, 5, 2] = np.nan
        self.refused(self.write("nan.nii", bad), "--frames-from", self.json, words=("NaN",))
        empty = f.copy()
        empty[..., 4] = 0
        self.refused(self.write("empty.nii", empty), "--frames-from", self.json, words=("frame 4", "no counts"))
        self.refused(self.nii, "--frames-from", self.json, "--reference", "8", words=("--reference",))
        for bad in ("first", "-1", "1.5", ""):
            self.refused(self.nii, "--frames-from", self.json, "--reference", bad, words=("--reference", "or auto"))
        self.refused(self.nii, "--frames-from", self.json, "--format", "polaris", words=("--format",))
        self.refused(self.nii, words=("--frames",))
        # the output must not replace an input
        _, err = run("motion", "estimate", self.nii, "--frames-from", self.json, "-o", self.json, expect=2)
        self.assertTrue(os.path.getsize(self.json) > 0, err)


class Together(unittest.TestCase):
    """Pass 4 (src/estimate/contrast_poses.c) on 24 frames (bench/pass4_family.py's SETUP), the series where it runs:
    the frames' poses corrected together along the contrast, against the same estimate without it
    (PETBLUR_ESTIMATE_CONTRAST=0), by that script's one(), which its family runs on many. On a family of 24 fresh
    series of this setup (bench/pass4_family.py on CUDA, bench/results/2026-11-29_H200_42c3321_contrast) it took
    13-71 % off the mean (median 44 %) and never made the worst frame worse; on one series CI drew (seed 432804490,
    host and PoCL alike) it added 4 % to the mean (0.890 -> 0.925 mm) and 0.01 mm to the worst frame; on seed
    2269693955 (drawn by a run of the suite on the host) 12 % (0.442 -> 0.497 mm) and 0.03 mm, its correction of
    0.8 mm as large as on series it helps, where 12 fresh series on the host at 25fc14c gained 14-65 % (median 47 %).
    So one draw asserts what holds on every series seen, in mm as a user measures it: the pass may not add more than
    0.1 mm to the mean nor to the worst frame, and the track stays within the bounds below; the gain itself is the
    family's to show. The bounds: on 48 fresh series at d690735
    (bench/results/2026-12-02_H200_d690735_pass4-family) the mean with the pass
    0.257-0.883 mm and without it 0.863-1.087, the worst frame at most 1.80 mm; CI drew seed 1700318083, where the
    pass takes 1.003 to 0.994 mm on the CPU and on CUDA alike, above the 0.95 mm this bound was then. So the mean
    within 1.2 mm, above every series seen with the pass or without it: a sanity bound on the estimate. CI also drew
    seed 3179720955, where the pass, weighing the frames by their energy beyond at the registered poses (which holds
    the bias sought), added 0.109 mm to the worst frame (1.728 -> 1.837); weighed by each frame's own noise it takes
    that series to 0.537 / 1.417 mm from 0.932 / 1.728 (bench/results/2026-12-02_H200_537f1cc_pass4-noise)."""

    def test_pass_4(self):
        seed = int(os.environ.get("PETBLUR_TEST_SEED_24") or np.random.SeedSequence().entropy % 2**32)
        r = pass4_family.one(test_cli.PETBLUR, seed)
        e, off = np.array(r["on"]), np.array(r["off"])
        msg = f"seed {seed} (PETBLUR_TEST_SEED_24): with pass 4 {np.round(e, 2)} (mean {e.mean():.3f}), " \
              f"without {np.round(off, 2)} (mean {off.mean():.3f})"
        print(msg)
        # the pass acts on its own kind: under the earlier-half check (c59959d) on 14 fresh series on the host
        # (bench/results/2026-12-03_cpu2_pass4-early) and 16 on CUDA (bench/results/2026-12-03_H200_cb89977_family-early),
        # every one (traced on 8 other series, seeds 11-18, the earlier half showed the second image at 9.8-10.9 times
        # the noise; the check asks 5)
        self.assertTrue(r["moved"], msg)
        self.assertLess(e.mean(), off.mean() + 0.1, msg)
        self.assertLessEqual(e.max(), off.max() + 0.1, msg)
        self.assertLess(e.mean(), 1.2, msg)
        self.assertLess(e.max(), 2.2, msg)


if __name__ == "__main__":
    test_cli.PETBLUR = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
