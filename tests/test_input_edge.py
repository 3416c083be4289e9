"""The input edge's third round (issue 43), through the program, on fresh cases each run:

1. Bounded work: a path bound below what the walk resolves, and outputs that cannot hold what a command would
   make, are refused before any work, in a time that does not depend on the size asked for.
2. Numbers that survive: every number the program writes reads back to the same double.
3. Messages of their own: a value is quoted as given, and a finite value beyond float32's range is named so.
4. Nothing silently wrong: NIfTI scaling is read as nibabel reads it (a NaN intercept refused).

usage: test_input_edge.py PATH/TO/petblur
"""
import json
import os
import struct
import subprocess
import sys
import tempfile
import time
import unittest

import nibabel as nib
import numpy as np

PETBLUR = None
# A fresh draw each run, printed so that a failure replays: PETBLUR_TEST_SEED=N.
SEED = int(os.environ.get("PETBLUR_TEST_SEED") or np.random.SeedSequence().entropy % 2**32)
print(f"seed {SEED} (replay with PETBLUR_TEST_SEED={SEED})", file=sys.stderr)
RNG = np.random.default_rng(SEED)


def run(*args, expect=0, timeout=120):
    t0 = time.monotonic()
    p = subprocess.run([PETBLUR, *map(str, args)], capture_output=True, text=True, timeout=timeout)
    took = time.monotonic() - t0
    if p.returncode != expect:
        raise AssertionError(f"petblur {' '.join(map(str, args))}: exit {p.returncode}, expected {expect}\n"
                             f"stdout: {p.stdout}\nstderr: {p.stderr}")
    return p.stdout, p.stderr, took


class Case(unittest.TestCase):
    def setUp(self):
        self._dir = tempfile.TemporaryDirectory()
        self.dir = self._dir.name

    def tearDown(self):
        self._dir.cleanup()

    def p(self, name):
        return os.path.join(self.dir, name)

    def phantom(self, dims, name="in.nii"):
        run("phantom", "--kind", "brain", "--dims", ",".join(map(str, dims)), "-o", self.p(name), "-q")
        return self.p(name)


class BoundedWork(Case):
    def test_path_bound_below_the_walk_is_refused_at_once(self):
        """A bound of 1e-9 voxels under a 15 degree turn took 42 s on 32^3 (1e-10: past 60 s); now refused
        in well under a second with the range, and the tightest bound taken runs in bounded time."""
        src = self.phantom((32, 32, 32))
        for bad in (10 ** RNG.uniform(-12, -3.01), 0.0009999, -RNG.uniform(0, 5), 1000.0000001):
            text = repr(float(bad))
            _, err, took = run("blur", "-i", src, "-o", self.p("o.nii"), "--rotate", RNG.uniform(5, 30),
                               "--max-path-error", text, "--device", "host", "-q", expect=2, timeout=30)
            self.assertIn(f"--max-path-error {text}:", err)
            self.assertIn("from 0.001 to 1000", err)
            self.assertLess(took, 5.0, err)
            self.assertFalse(os.path.exists(self.p("o.nii")))
        # The floor itself: sqrt(0.1 / 0.001) = 10x the default's segments at most, so seconds, not minutes
        # (0.1 s on two cores here; the limit leaves room for a loaded machine).
        run("blur", "-i", src, "-o", self.p("o.nii"), "--rotate", "15", "--max-path-error", "0.001", "--device",
            "host", "-q", timeout=120)

    def test_frames_an_output_cannot_hold_are_refused_before_blurring(self):
        """200000 frames into a .nii (NIfTI-1 holds 32767) were refused after 254 s and 6.4 GB of blurring;
        now before any."""
        src = self.phantom((12, 12, 10))
        n = int(RNG.integers(32768, 60000))  # a sidecar of at most 4 MB, as the program takes
        step = int(RNG.integers(1, 10))
        with open(self.p("frames.json"), "w") as f:
            json.dump({"FrameTimesStart": [i * step for i in range(n)], "FrameDuration": [step] * n}, f)
        with open(self.p("track.csv"), "w") as f:
            f.write(f"t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n{n * step + 1},1,2,-1,1,0,0,0\n")
        _, err, took = run("blur", "-i", src, "-o", self.p("o.nii"), "--motion", self.p("track.csv"),
                           "--frames-from", self.p("frames.json"), "--device", "host", "-q", expect=2, timeout=60)
        self.assertIn(f"at most 32767 frames and there are {n}", err)
        self.assertLess(took, 10.0, err)
        self.assertFalse(os.path.exists(self.p("o.nii")))

    def test_phantom_grid_an_output_cannot_hold_is_refused_before_making_it(self):
        n = int(RNG.integers(32768, 65537))
        _, err, _ = run("phantom", "--kind", "homogeneity", "--dims", f"{n},2,2", "-o", self.p("o.nii"), "-q",
                        expect=2)
        self.assertIn("NIfTI-1 holds at most 32767 entries", err)

    def test_phantom_and_demo_refuse_what_the_other_commands_would(self):
        """A phantom's voxel size outside what blur reads (a header of infinities at 1e300), and demo's --out-dir
        naming a file: exit 2 (bad input, not a runtime failure), nothing written."""
        for v in (10 ** RNG.uniform(4.1, 300), 10 ** -RNG.uniform(4.1, 300)):
            _, err, _ = run("phantom", "--kind", "brain", "--dims", "8,8,8", "--voxel-size", f"{v:.6g},2,2", "-o",
                            self.p("v.nii"), "-q", expect=2)
            self.assertIn("from 0.0001 to 10000 mm", err)
            self.assertFalse(os.path.exists(self.p("v.nii")))
        with open(self.p("afile"), "w") as f:
            f.write("mine")
        _, err, _ = run("demo", "--out-dir", self.p("afile"), "--size", "16", "-q", expect=2)
        self.assertIn("is a file, not a folder", err)
        with open(self.p("afile")) as f:
            self.assertEqual(f.read(), "mine")


class NumbersSurvive(Case):
    def test_every_image_format_at_the_edges_of_the_range(self):
        """Voxels at float32's edges (its largest, its smallest normal and subnormal, random magnitudes) and
        voxel sizes at the ends of the range petblur takes go through an identity blur into every output
        format and read back (by nibabel, numpy, or petblur for its own Interfile) to the same numbers."""
        f32 = np.finfo(np.float32)
        shape = tuple(int(n) for n in RNG.integers(4, 9, 3))
        data = (RNG.choice([-1, 1], shape) * 10.0 ** RNG.uniform(-30, 30, shape)).astype(np.float32)
        edges = [f32.max, -f32.max, f32.tiny, np.float32(1e-45), -np.float32(1e-45), np.float32(0)]
        flat = data.reshape(-1)
        flat[RNG.choice(flat.size, len(edges), replace=False)] = edges
        sizes = RNG.permutation([1.0001e-4, 10000.0, float(RNG.uniform(0.5, 5))])  # float32 rounds 1e-4 below it
        affine = np.diag([*sizes, 1.0])
        affine[:3, 3] = RNG.uniform(-1e5, 1e5, 3)
        nib.save(nib.Nifti1Image(data, affine), self.p("edge.nii"))
        expected_sizes = np.float32(sizes)
        for out in ("o.nii", "o.nii.gz", "o.hv", "o.raw"):
            run("blur", "-i", self.p("edge.nii"), "-o", self.p(out), "--translate", "0,0,0", "--device", "host", "-q")
            if out == "o.raw":
                back = np.fromfile(self.p(out), "<f4").reshape(shape[::-1]).T
            else:
                path = self.p(out)
                if out == "o.hv":  # read back by petblur, Interfile's one reader here
                    run("blur", "-i", path, "-o", self.p("hv.nii"), "--translate", "0,0,0", "--device", "host", "-q")
                    path = self.p("hv.nii")
                img = nib.load(path)
                back = np.asanyarray(img.dataobj)
                np.testing.assert_array_equal(np.float32(img.header.get_zooms()[:3]), expected_sizes, err_msg=out)
                if out != "o.hv":  # Interfile keeps STIR's placement only (a warning says so)
                    np.testing.assert_array_equal(img.affine, np.float32(affine).astype(np.float64), err_msg=out)
            self.assertEqual(back.dtype, np.float32)
            # Equal as numbers: the blur's sum makes -0.0 a +0.0.
            np.testing.assert_array_equal(back, data, err_msg=out)


class ValuesAsGiven(Case):
    def nifti(self, data, slope, inter, name):
        """data written by nibabel, with the scaling fields set in the header's bytes (nibabel itself would
        not write a NaN intercept)."""
        img = nib.Nifti1Image(data, np.diag([2.0, 2.0, 2.5, 1.0]))
        img.header.set_slope_inter(1, 0)
        nib.save(img, self.p(name))
        with open(self.p(name), "r+b") as f:
            f.seek(112)
            f.write(struct.pack("<ff", slope, inter))
        return self.p(name)

    def test_nan_intercept_refused_as_nibabel_refuses_it(self):
        for _ in range(4):
            dtype = RNG.choice([np.int16, np.uint8, np.float32, np.int32])
            data = RNG.integers(0, 100, size=tuple(RNG.integers(3, 9, 3))).astype(dtype)
            slope = float(RNG.choice([1.0, RNG.uniform(0.01, 10)]))
            inter = float(RNG.choice([np.nan, np.inf, -np.inf]))
            path = self.nifti(data, slope, inter, "scaled.nii")
            with self.assertRaisesRegex(Exception, "invalid intercept"):
                nib.load(path).get_fdata()
            _, err, _ = run("blur", "-i", path, "-o", self.p("o.nii"), "--translate", "1,0,0", "--device", "host",
                            "-q", expect=2)
            self.assertIn("scl_inter is", err)
            self.assertIn("scl_inter to 0", err)
            self.assertFalse(os.path.exists(self.p("o.nii")))
        # A slope of 0 or NaN means no scaling, to nibabel and to petblur alike.
        data = RNG.integers(0, 100, size=(5, 4, 3)).astype(np.int16)
        for slope in (0.0, np.nan):
            path = self.nifti(data, slope, float(RNG.uniform(-5, 5)), "unscaled.nii")
            run("blur", "-i", path, "-o", self.p("same.nii"), "--translate", "0,0,0", "--device", "host", "-q")
            np.testing.assert_allclose(nib.load(self.p("same.nii")).get_fdata(), nib.load(path).get_fdata(),
                                       rtol=1e-6, atol=1e-6)

    def test_values_beyond_float32_are_named_with_their_place(self):
        for kind in ("float64", "int16 scaled"):
            shape = tuple(int(n) for n in RNG.integers(3, 9, 3))
            where = tuple(int(RNG.integers(0, n)) for n in shape)
            if kind == "float64":
                data = RNG.uniform(0, 1, shape)
                value = float(10 ** RNG.uniform(39, 307))
                data[where] = value
                path = self.nifti(data, 1.0, 0.0, "big.nii")
            else:
                data = np.ones(shape, np.int16)
                data[where] = 200
                slope = float(10 ** RNG.uniform(37, 38.2))
                value = float(np.float32(slope)) * 200
                path = self.nifti(data, slope, 0.0, "big.nii")
            _, err, _ = run("blur", "-i", path, "-o", self.p("o.nii"), "--translate", "1,0,0", "--device", "host",
                            "-q", expect=2)
            self.assertIn("beyond float32's range", err)
            self.assertNotIn("NaN or infinite", err)
            self.assertIn("x,y,z = %d,%d,%d" % where, err)
            quoted = float(err.split("the value ")[1].split(" ")[0])
            self.assertEqual(quoted, value, err)


class NewUsersTrial(Case):
    def test_motion_takes_the_4d_image_the_docs_show(self):
        frames = int(RNG.integers(3, 9))
        shape = (*(int(n) for n in RNG.integers(6, 12, 3)), frames)
        nib.save(nib.Nifti1Image(RNG.uniform(0, 1, shape).astype(np.float32), np.diag([2.0, 2.0, 2.5, 1.0])),
                 self.p("dynamic.nii.gz"))
        length = float(RNG.uniform(5, 60))
        with open(self.p("pet.json"), "w") as f:
            json.dump({"FrameTimesStart": [i * length for i in range(frames)], "FrameDuration": [length] * frames}, f)
        with open(self.p("track.csv"), "w") as f:
            # ends a second after the last frame: the sidecar's starts plus durations may round past frames * length
            f.write(f"t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n{frames * length + 1},1,2,-1,0.9998,0,0.02,0\n")
        out, _, _ = run("motion", self.p("track.csv"), "-i", self.p("dynamic.nii.gz"), "--frames-from",
                        self.p("pet.json"), "--png", self.p("motion.png"))
        rows = [line for line in out.splitlines() if line.split() and line.split()[0].isdigit()]
        self.assertEqual(len(rows), frames, out)
        self.assertTrue(os.path.getsize(self.p("motion.png")) > 0)

    def test_render_shows_the_frames_asked_for(self):
        frames = int(RNG.integers(13, 30))  # more frames than any --rows asked for
        nib.save(nib.Nifti1Image(RNG.uniform(0, 1, (10, 10, 8, frames)).astype(np.float32), np.eye(4)),
                 self.p("sub-01_ses-baseline_task-rest_pet.nii.gz"))
        heights = {}
        for rows in (4, int(RNG.integers(5, 13))):
            run("render", self.p("sub-01_ses-baseline_task-rest_pet.nii.gz"), "-o", self.p(f"r{rows}.png"),
                "--rows", rows)
            with open(self.p(f"r{rows}.png"), "rb") as f:
                heights[rows] = struct.unpack(">II", f.read(24)[16:24])[1]
        (a, ha), (b, hb) = sorted(heights.items())
        self.assertGreater(hb, ha * (b - 0.5) / a, heights)
        run("render", self.p("sub-01_ses-baseline_task-rest_pet.nii.gz"), "-o", self.p("x.png"), "--rows", "13",
            expect=2)


if __name__ == "__main__":
    PETBLUR = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
