"""The command-line contract, end to end: formats, tracks, phantoms, pictures,
errors. Drives the real program in a fresh folder; volumes written by another
tool (nibabel) are read back and compared with numpy.

usage: test_cli.py PATH/TO/petblur
"""
import os
import re
import struct
import subprocess
import sys
import tempfile
import unittest
import zlib

import nibabel as nib
import numpy as np

PETBLUR = None
# A fresh draw each run, printed so that a failure replays: PETBLUR_TEST_SEED=N.
SEED = int(os.environ.get("PETBLUR_TEST_SEED") or np.random.SeedSequence().entropy % 2**32)
print(f"seed {SEED} (replay with PETBLUR_TEST_SEED={SEED})", file=sys.stderr)
RNG = np.random.default_rng(SEED)


def run(*args, expect=0):
    """Runs petblur; asserts the exit status and returns (stdout, stderr)."""
    p = subprocess.run([PETBLUR, *map(str, args)], capture_output=True, text=True, timeout=600)
    if p.returncode != expect:
        raise AssertionError(f"petblur {' '.join(map(str, args))}: exit {p.returncode}, expected {expect}\n"
                             f"stdout: {p.stdout}\nstderr: {p.stderr}")
    return p.stdout, p.stderr


def read_raw(path, dims):
    return np.fromfile(path, dtype="<f4").reshape(dims[::-1])


def slurp(path):
    with open(path, "rb") as f:
        return f.read()


def spill(path, data):
    with open(path, "wb") as f:
        f.write(data)


def write_raw(path, vol):
    vol.astype("<f4").tofile(path)


def png_size(path):
    with open(path, "rb") as f:
        data = f.read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    assert data[12:16] == b"IHDR"
    w, h = struct.unpack(">II", data[16:24])
    # Every chunk's CRC must hold: a truncated or garbled file fails here.
    pos = 8
    while pos < len(data):
        n = struct.unpack(">I", data[pos:pos + 4])[0]
        body = data[pos + 4:pos + 8 + n]
        assert struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0] == zlib.crc32(body), "bad PNG chunk CRC"
        pos += 12 + n
    return w, h


class Case(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory(prefix="petblur-cli-")
        self.d = self.dir.name

    def tearDown(self):
        self.dir.cleanup()

    def p(self, name):
        return os.path.join(self.d, name)

    def assert_clean(self, *absent):
        """No output of a failed run exists, and no temporary is left behind."""
        for name in absent:
            self.assertFalse(os.path.exists(self.p(name)), f"{name} exists after a failed run")
        left = [f for f in os.listdir(self.d) if ".petblur-" in f]
        self.assertEqual(left, [], "temporaries left behind")

    def random_volume(self, dims=(13, 11, 7)):
        vol = RNG.random(dims[::-1], dtype=np.float32) * 10
        vol[RNG.random(vol.shape) < 0.3] = 0
        return vol


class Formats(Case):
    """Zero motion returns the input bit for bit, so `blur` with no motion is
    a format converter: every round trip must be exact."""

    def convert(self, src, dst, *extra):
        run("blur", "-i", self.p(src), "-o", self.p(dst), "--translate", "0,0,0", "--device", "host", "-q", *extra)

    def test_round_trip_every_format(self):
        vol = self.random_volume()
        write_raw(self.p("a.raw"), vol)
        self.convert("a.raw", "b.nii", "--dims", "13,11,7", "--voxel-size", "2,2.5,3")
        self.convert("b.nii", "c.nii.gz")
        self.convert("c.nii.gz", "d.hv")
        self.convert("d.hv", "e.raw")
        np.testing.assert_array_equal(read_raw(self.p("e.raw"), (13, 11, 7)), vol)
        # The voxel size travelled through NIfTI and Interfile headers.
        img = nib.load(self.p("c.nii.gz"))
        np.testing.assert_allclose(img.header.get_zooms()[:3], (2, 2.5, 3))
        with open(self.p("d.hv")) as f:
            header = f.read().lower()
        self.assertIn("scaling factor (mm/pixel) [2] := 2.5", header)

    def test_nibabel_files_read_with_scaling(self):
        for dtype in (np.float32, np.float64, np.int16, np.uint16, np.uint8):
            with self.subTest(dtype=dtype.__name__):
                info = np.iinfo(dtype) if np.issubdtype(dtype, np.integer) else None
                hi = min(info.max, 1000) if info else 100
                stored = (RNG.random((7, 9, 5)) * hi).astype(dtype)  # nibabel arrays are x, y, z
                affine = np.diag([1.5, 2.0, 2.5, 1.0])
                affine[:3, 3] = (-40, 12, 7)
                img = nib.Nifti1Image(stored, affine)
                img.header.set_data_dtype(dtype)
                slope, inter = (0.5, 3.0) if info else (1.0, 0.0)
                img.header.set_slope_inter(slope, inter)
                name = f"n_{dtype.__name__}.nii"
                nib.save(img, self.p(name))
                expected = nib.load(self.p(name)).get_fdata()  # nibabel applies slope and inter
                self.convert(name, "back.raw")
                got = read_raw(self.p("back.raw"), (7, 9, 5)).transpose(2, 1, 0)
                np.testing.assert_allclose(got, expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max())
                # The float32 output keeps the input's geometry.
                self.convert(name, "back.nii")
                out = nib.load(self.p("back.nii"))
                self.assertEqual(out.get_data_dtype(), np.float32)
                np.testing.assert_allclose(out.affine, affine, atol=1e-5)
                np.testing.assert_allclose(out.get_fdata(), expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max())

    def test_big_endian_interfile(self):
        vol = self.random_volume((6, 5, 4))
        with open(self.p("be.v"), "wb") as f:
            f.write(b"\0" * 16 + vol.astype(">f4").tobytes())
        with open(self.p("be.hv"), "w") as f:
            f.write("!INTERFILE  :=\n!imaging modality := PT\n!name of data file := be.v\n"
                    "!GENERAL DATA :=\n!GENERAL IMAGE DATA :=\n!type of data := PET\n"
                    "imagedata byte order := BIGENDIAN\n!number format := float\n!number of bytes per pixel := 4\n"
                    "number of dimensions := 3\n!matrix size [1] := 6\n!matrix size [2] := 5\n"
                    "!matrix size [3] := 4\nscaling factor (mm/pixel) [1] := 2\nscaling factor (mm/pixel) [2] := 2\n"
                    "scaling factor (mm/pixel) [3] := 3.27\ndata offset in bytes [1] := 16\n!END OF INTERFILE :=\n")
        self.convert("be.hv", "be.raw")
        np.testing.assert_array_equal(read_raw(self.p("be.raw"), (6, 5, 4)), vol)

    def test_compare_prints_relative_errors(self):
        ref = self.random_volume()
        test = ref + 0.05 * self.random_volume()
        write_raw(self.p("ref.raw"), ref)
        write_raw(self.p("test.raw"), test)
        out, _ = run("compare", self.p("ref.raw"), self.p("test.raw"), "--dims", "13,11,7")
        last = out.strip().splitlines()[-1]
        got = dict(kv.split(" = ") for kv in re.findall(r"\S+ = \S+", last))
        r, t = ref.astype(np.float64), test.astype(np.float64)
        want = {"rms%": 100 * np.sqrt(((t - r) ** 2).sum() / (r ** 2).sum()),
                "max%": 100 * np.abs(t - r).max() / np.abs(r).max(),
                "eq5%": 100 * ((t - r) ** 2).sum() / (r ** 2).sum()}
        self.assertEqual(set(got), set(want), last)
        for k, v in want.items():
            self.assertAlmostEqual(float(got[k]), v, delta=1e-5 * v, msg=k)
        # The worst voxel named, in the array's x, y, z (raw: x fastest).
        d = np.abs(t - r)
        z, y, x = np.unravel_index(np.argmax(d), d.shape)
        self.assertIn(f"at voxel {x},{y},{z} of frame 0", out)


class Motion(Case):
    def setUp(self):
        super().setUp()
        self.vol = self.random_volume((12, 10, 8))
        write_raw(self.p("in.raw"), self.vol)

    def blur(self, out, *motion, device="host"):
        run("blur", "-i", self.p("in.raw"), "--dims", "12,10,8", "-o", self.p(out), "--device", device, "-q",
            *motion)
        return read_raw(self.p(out), (12, 10, 8))

    def write_track(self, rows, name="track.csv"):
        # As a spreadsheet saves it: a byte-order mark, CRLF line ends, spaces.
        with open(self.p(name), "w", encoding="utf-8-sig", newline="\r\n") as f:
            f.write("t, tx, ty, tz, qw, qx, qy, qz\n")
            for r in rows:
                f.write(",".join(map(str, r)) + "\n")
        return self.p(name)

    def test_track_equals_the_same_pose(self):
        """A two-pose track is the --translate/--rotate frame; half of a
        straight track is the same frame with half the motion."""
        angle = np.radians(8.0)
        q = (np.cos(angle / 2), 0, 0, np.sin(angle / 2))
        a = self.blur("a.raw", "--translate", "1.5,-2,0.5", "--rotate", "8")
        track = self.write_track([(0, 0, 0, 0, 1, 0, 0, 0), (1, 1.5, -2, 0.5, *q)])
        b = self.blur("b.raw", "--motion", track)
        np.testing.assert_allclose(b, a, rtol=1e-6, atol=1e-6)
        self.assertGreater(np.abs(a - self.vol).max(), 0.1, "the motion did nothing")
        track2 = self.write_track([(0, 0, 0, 0, 1, 0, 0, 0), (2, 3, -4, 1, 1, 0, 0, 0)], "t2.csv")
        c = self.blur("c.raw", "--motion", track2, "--frame", "0,1")
        d = self.blur("d.raw", "--translate", "1.5,-2,0.5")
        np.testing.assert_allclose(c, d, rtol=1e-6, atol=1e-6)

    def test_translation_along_x_is_the_analytic_box_blur(self):
        """Moving by 2 voxels along x over the frame blurs each voxel over
        [x-2, x] with the trilinear kernel: check one interior row by hand."""
        out = self.blur("x.raw", "--translate", "2,0,0", "--method", "ab", "--filter", "exact")
        f = self.vol[4, 5, :].astype(np.float64)
        # The mean over s in [0, 2] of the linear interpolant at x - s.
        for x in range(3, 11):
            xs = x - np.linspace(0, 2, 20001)
            expected = np.interp(xs, np.arange(12), f).mean()
            self.assertAlmostEqual(float(out[4, 5, x]), expected, delta=1e-4 * max(1.0, abs(expected)))

    def test_max_path_error(self):
        """A 40 degree turn: AB's distance to the true path (CL with dense
        steps) falls from the paper's one segment to the default bound to a
        tighter one."""
        truth = self.blur("cl.raw", "--rotate", "40", "--method", "cl", "--filter", "exact", "--steps", "2000")

        def err(x):
            return float(np.sum((x - truth) ** 2.0) / np.sum(truth ** 2.0))
        errs = [err(self.blur(f"ab{i}.raw", "--rotate", "40", "--filter", "exact", *bound))
                for i, bound in enumerate((("--max-path-error", "paper"), (), ("--max-path-error", "0.01")))]
        self.assertLess(errs[1], errs[0] / 5, errs)
        self.assertLess(errs[2], errs[1], errs)

    def test_ab_sampling(self):
        """--ab-sampling sweep on a long oblique translation (the paper's walk):
        nearer the true blur (the mean of the linear interpolant over the path,
        by scipy) than the paper's one point a slice; slice is the default's
        name; chord reads it exactly. On a short one (at most 5 voxels along
        its major axis) AB is the exact average every way."""
        from scipy import ndimage
        idx = np.stack(np.meshgrid(*[np.arange(n) for n in self.vol.shape], indexing="ij"), 0).reshape(3, -1)
        for move, short in ((np.array([6.6, 4.8, -3.9]), False), (np.array([2.2, 1.6, -1.3]), True)):  # voxels
            truth = np.zeros(idx.shape[1])
            for t in (np.arange(2000) + 0.5) / 2000:  # the volume is (z, y, x)
                truth += ndimage.map_coordinates(self.vol.astype(np.float64), idx - t * move[::-1, None], order=1,
                                                 mode="grid-constant")
            truth = (truth / 2000).reshape(self.vol.shape)
            inner = (slice(3, -3),) * 3

            def err(x):
                return float(np.linalg.norm((x - truth)[inner]) / np.linalg.norm(truth[inner]))
            motion = ("--translate", ",".join(str(v) for v in move), "--filter", "exact")  # 1 mm voxels
            errs = [err(self.blur(f"ab-{s}.raw", *motion, *(("--ab-sampling", s) if s else ())))
                    for s in ("", "slice", "sweep", "chord")]
            self.assertEqual(errs[0], errs[1], errs)
            # The midpoint rule over 2000 times is the truth's own error, about 1e-7; a long chord's float
            # sums over its 16 pieces add about as much again (2.3e-7 to 4.0e-7 on 20 seeds).
            self.assertLess(errs[3], 2e-6, errs)
            if short:
                self.assertLess(max(errs), 1e-6, errs)
            else:
                self.assertLess(errs[2], 0.7 * errs[0], errs)
                self.assertGreater(errs[0], 1e-3, errs)  # the walk's own error, which chord does not make

    def test_adjoint_is_the_transpose(self):
        """--adjoint through files: <B x, y> = <x, B^T y> for a fresh y, on
        the host (double) and on OpenCL (float atomics), NIfTI in and out."""
        y = self.random_volume((12, 10, 8))
        nib.save(nib.Nifti1Image(np.asarray(y.transpose(2, 1, 0), dtype=np.float32), np.diag([1, 1, 1, 1.0])),
                 self.p("y.nii"))
        motion = ("--translate", "2.5,-1,1.5", "--rotate", "25", "--axis", "0.2,1,0.3")
        bx = self.blur("bx.raw", *motion)
        for device in ("host", "opencl"):
            with self.subTest(device=device):
                run("blur", "-i", self.p("y.nii"), "-o", self.p(f"bty-{device}.nii.gz"), "--device", device, "-q",
                    "--adjoint", *motion)
                bty = nib.load(self.p(f"bty-{device}.nii.gz")).get_fdata().transpose(2, 1, 0)
                lhs, rhs = float(np.sum(bx * y, dtype=np.float64)), float(np.sum(self.vol * bty, dtype=np.float64))
                self.assertLess(abs(lhs - rhs) / abs(lhs), 1e-5, (lhs, rhs))
                self.assertGreater(float(np.abs(bty - y).max()), 0.1, "the adjoint did nothing")

    def test_dynamic_frames(self):
        """--frames: a 4-D NIfTI in and out; each frame equals that frame
        blurred alone with --frame, forward and --adjoint, on OpenCL; a 3-D
        input serves every frame; even frames give pixdim[4]."""
        rows = []
        for k in range(0, 91):  # 3 s at 30 Hz: a drift and a nod
            t = k / 30.0
            a = np.radians(6.0 * np.sin(1.7 * t)) / 2
            rows.append((t, 1.2 * t, -0.8 * t, 0.3 * np.sin(t), np.cos(a), 0, 0, np.sin(a)))
        track = self.write_track(rows)
        dyn = np.stack([self.random_volume((12, 10, 8)) for _ in range(3)])  # t, z, y, x
        affine = np.diag([1.0, 1.0, 1.0, 1.0])
        nib.save(nib.Nifti1Image(dyn.transpose(3, 2, 1, 0), affine), self.p("dyn.nii.gz"))
        bounds = (0.2, 1.0, 1.9, 2.9)
        for extra in ((), ("--adjoint",)):
            with self.subTest(extra=extra):
                run("blur", "-i", self.p("dyn.nii.gz"), "-o", self.p("out.nii.gz"), "--motion", track, "--frames",
                    ",".join(map(str, bounds)), "--device", "opencl", "-q", *extra)
                out = nib.load(self.p("out.nii.gz"))
                self.assertEqual(out.shape, (12, 10, 8, 3))
                got = out.get_fdata().transpose(3, 2, 1, 0)
                for f in range(3):
                    write_raw(self.p("one.raw"), dyn[f])
                    run("blur", "-i", self.p("one.raw"), "--dims", "12,10,8", "-o", self.p("one-out.raw"), "--motion",
                        track, "--frame", f"{bounds[f]},{bounds[f + 1]}", "--device", "opencl", "-q", *extra)
                    want = read_raw(self.p("one-out.raw"), (12, 10, 8))
                    tol = 1e-5 if extra else 0.0  # the adjoint's float atomics add in any order
                    np.testing.assert_allclose(got[f], want, rtol=tol, atol=tol * float(np.abs(want).max()))
                    self.assertGreater(float(np.abs(got[f] - dyn[f]).max()), 0.1, "the motion did nothing")
        # --sum-frames: the frames' back projections added into one 3-D volume,
        # the transpose of one activity blurred through every frame:
        # <x, sum_f B_f^T y_f> = sum_f <B_f x, y_f>, here through files.
        x = self.random_volume((12, 10, 8))
        write_raw(self.p("x.raw"), x)
        spec = ("--motion", track, "--frames", ",".join(map(str, bounds)), "--device", "opencl", "-q")
        run("blur", "-i", self.p("x.raw"), "--dims", "12,10,8", "-o", self.p("bx.nii"), *spec)
        run("blur", "-i", self.p("dyn.nii.gz"), "-o", self.p("summed.nii"), *spec, "--adjoint", "--sum-frames")
        summed = nib.load(self.p("summed.nii"))
        self.assertEqual(summed.shape, (12, 10, 8))
        bty = summed.get_fdata().transpose(2, 1, 0)
        bx = nib.load(self.p("bx.nii")).get_fdata().transpose(3, 2, 1, 0)
        lhs = float(np.sum(bx * dyn, dtype=np.float64))
        rhs = float(np.sum(x * bty, dtype=np.float64))
        self.assertLess(abs(lhs - rhs) / abs(lhs), 1e-5, (lhs, rhs))
        # ... and equals the sum of the frames' own back projections (out.nii.gz,
        # last written by the --adjoint subtest above).
        frames = nib.load(self.p("out.nii.gz")).get_fdata().transpose(3, 2, 1, 0)
        np.testing.assert_allclose(bty, frames.sum(axis=0), rtol=1e-5, atol=1e-5 * float(np.abs(bty).max()))
        # A 3-D activity through even frames: 4-D out, pixdim[4] the frames' length.
        write_raw(self.p("static.raw"), dyn[0])
        run("blur", "-i", self.p("static.raw"), "--dims", "12,10,8", "-o", self.p("even.nii"), "--motion", track,
            "--frames", "0,1,2", "--device", "opencl", "-q")
        even = nib.load(self.p("even.nii"))
        self.assertEqual(even.shape, (12, 10, 8, 2))
        self.assertAlmostEqual(float(even.header["pixdim"][4]), 1.0, places=6)
        self.assertEqual(even.header.get_xyzt_units(), ("mm", "sec"))

    def test_default_device_runs(self):
        a = self.blur("auto.raw", "--translate", "1,2,-1", "--rotate", "5", device="auto")
        h = self.blur("host.raw", "--translate", "1,2,-1", "--rotate", "5", "--filter", "exact")
        np.testing.assert_allclose(a, h, atol=1e-2 * self.vol.max())


class Phantoms(Case):
    def test_each_kind(self):
        # The phantoms are fixed objects in mm (the default grids' 256 mm and 281.6 mm fields of view); these
        # coarser grids keep the field of view.
        for kind, dims, vs in (("homogeneity", (32, 32, 32), (8, 8, 8)), ("derenzo", (64, 64, 16), (4, 4, 16)),
                               ("brain", None, None)):
            with self.subTest(kind=kind):
                args = ["phantom", "--kind", kind, "-o", self.p(f"{kind}.nii.gz"), "--png", self.p(f"{kind}.png")]
                if dims:
                    args += ["--dims", ",".join(map(str, dims)), "--voxel-size", ",".join(map(str, vs))]
                run(*args)
                img = nib.load(self.p(f"{kind}.nii.gz"))
                self.assertEqual(img.shape, dims or (128, 128, 64))
                data = img.get_fdata()
                self.assertGreaterEqual(data.min(), 0.0)
                self.assertGreater(data.max(), 0.0)
                w, h = png_size(self.p(f"{kind}.png"))
                self.assertGreater(w, 200)
                self.assertGreater(h, 100)
                # Placed as a head-first supine patient, centred on the scanner's origin.
                n = np.array(img.shape)
                d = np.array(vs if vs else (2.2, 2.2, 2.8))
                expect = np.diag(np.append(-d, 1.0))
                expect[:3, 3] = (n - 1) / 2 * d
                for affine, code in (img.get_sform(coded=True), img.get_qform(coded=True)):
                    self.assertEqual(int(code), 1)
                    np.testing.assert_allclose(affine, expect, atol=1e-4)
                np.testing.assert_allclose(nib.affines.apply_affine(img.affine, (n - 1) / 2), 0, atol=1e-4)
        cubes = nib.load(self.p("homogeneity.nii.gz")).get_fdata()
        # Eight cubes of distinct activity: the centre of each octant.
        centres = {round(cubes[x, y, z], 4) for x in (8, 24) for y in (8, 24) for z in (8, 24)}
        self.assertEqual(len(centres), 8)
        # The brain's hottest lesion (8 x white matter, 8 mm across) sits where it is defined in mm, in RAS+:
        # at (44, 52, 30) mm from the scanner's origin, on the default grid.
        brain = nib.load(self.p("brain.nii.gz"))
        hot = np.argwhere(brain.get_fdata() > 7.0)
        np.testing.assert_allclose(nib.affines.apply_affine(brain.affine, hot).mean(axis=0), (44, 52, 30), atol=1.5)

    def test_render_and_blur_picture(self):
        run("phantom", "--kind", "homogeneity", "--dims", "24,24,24", "-o", self.p("c.hv"), "-q")
        run("render", self.p("c.hv"), "-o", self.p("c.png"))
        png_size(self.p("c.png"))
        run("blur", "-i", self.p("c.hv"), "-o", self.p("b.hv"), "--translate", "3,0,0", "--png", self.p("b.png"),
            "--device", "host", "-q")
        w1, h1 = png_size(self.p("c.png"))
        w3, h3 = png_size(self.p("b.png"))
        self.assertGreater(h3, 2 * h1, "the blur picture should hold three rows")


class BadInput(Case):
    """Each bad input: its exit status, a message that starts with petblur:
    and names the problem, and no output file."""

    def setUp(self):
        super().setUp()
        write_raw(self.p("in.raw"), self.random_volume((8, 8, 8)))

    def fails(self, status, words, *args, out="out.nii"):
        _, err = run(*args, expect=status)
        self.assertTrue(err.startswith("petblur: "), err)
        for w in words:
            self.assertIn(w, err)
        self.assert_clean(out)
        return err

    def blur(self, *args, device="host"):
        return ("blur", "-i", self.p("in.raw"), "--dims", "8,8,8", "-o", self.p("out.nii"), "--device", device, *args)

    def track(self, *rows, header="t,tx,ty,tz,qw,qx,qy,qz"):
        with open(self.p("t.csv"), "w") as f:
            f.write(header + "\n" + "".join(r + "\n" for r in rows))
        return self.p("t.csv")

    def test_files(self):
        self.fails(2, ["missing.nii", "No such file"], "blur", "-i", self.p("missing.nii"), "-o", self.p("out.nii"),
                   "--translate", "1,0,0")
        self.fails(2, ["--dims"], "blur", "-i", self.p("in.raw"), "-o", self.p("out.nii"), "--translate", "1,0,0")
        self.fails(2, ["8,8,9"], "blur", "-i", self.p("in.raw"), "--dims", "8,8,9", "-o", self.p("out.nii"),
                   "--translate", "1,0,0")
        # a count of voxels in digits alone: 8.0 or 8e0 is as often a size in mm slipped into the wrong option
        for dims in ("8.0,8,8", "8,8e0,8", "8,8,+8", "8, 8,8"):
            self.fails(2, ["--dims", dims, "whole numbers"], "blur", "-i", self.p("in.raw"), "--dims", dims, "-o",
                       self.p("out.nii"), "--translate", "1,0,0")
        self.fails(2, [".xyz"], *self.blur("--translate", "1,0,0")[:5], "-o", self.p("out.xyz"), "--translate",
                   "1,0,0", out="out.xyz")
        self.fails(2, ["folder", "nowhere"], *self.blur("--translate", "1,0,0")[:5], "-o",
                   self.p("nowhere/out.nii"), "--translate", "1,0,0")
        spill(self.p("in.xyz"), b"\0" * 2048)
        self.fails(2, [".xyz"], "blur", "-i", self.p("in.xyz"), "-o", self.p("out.nii"), "--translate", "1,0,0")

    def test_frames(self):
        with open(self.p("track.csv"), "w") as f:
            f.write("t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,1,0,0,1,0,0,0\n2,2,1,0,1,0,0,0\n")
        nib.save(nib.Nifti1Image(np.ones((8, 8, 8, 3), np.float32), np.eye(4)), self.p("dyn.nii"))
        track = ("--motion", self.p("track.csv"))
        dyn = ("blur", "-i", self.p("dyn.nii"), "-o", self.p("out.nii"), "--device", "host")
        self.fails(2, ["3 time frames", "--frames"], *dyn, *track)
        self.fails(2, ["3 frames", "--frames gives 2"], *dyn, *track, "--frames", "0,1,2")
        self.fails(2, ["--frames", "increasing"], *self.blur(*track, "--frames", "0,1.5,1"))
        self.fails(2, ["--frames", "at least two"], *self.blur(*track, "--frames", "1"))
        self.fails(2, ["--frame and --frames"], *self.blur(*track, "--frames", "0,1", "--frame", "0,1"))
        self.fails(2, ["NIfTI", "out.hv"], *self.blur(*track, "--frames", "0,1")[:5], "-o", self.p("out.hv"),
                   "--device", "host", *track, "--frames", "0,1", out="out.hv")
        self.fails(2, ["frame 1 (1 to 2.5 s) lies outside the track", "covers 0 to 2"], *self.blur(*track, "--frames", "0,1,2.5"))
        self.fails(2, ["--sum-frames", "--adjoint"], *self.blur(*track, "--frames", "0,1", "--sum-frames"))
        self.fails(2, ["--sum-frames", "--frames"], *self.blur(*track, "--frame", "0,1", "--adjoint", "--sum-frames"))

    def test_truncated_files(self):
        img = nib.Nifti1Image(np.ones((8, 8, 8), np.float32), np.eye(4))
        nib.save(img, self.p("full.nii"))
        spill(self.p("cut.nii"), slurp(self.p("full.nii"))[:-100])
        self.fails(2, ["cut.nii"], "blur", "-i", self.p("cut.nii"), "-o", self.p("out.nii"), "--translate", "1,0,0")
        run("blur", *self.blur("--translate", "0,0,0")[1:5], "-o", self.p("ok.hv"), "--translate", "0,0,0",
            "--device", "host")
        with open(self.p("ok.v"), "r+b") as f:
            f.truncate(8 * 8 * 8 * 4 - 4)
        self.fails(2, ["ok.v"], "blur", "-i", self.p("ok.hv"), "-o", self.p("out.nii"), "--translate", "1,0,0")

    def test_tracks(self):
        ok = "1,0,0,0,1,0,0,0"
        cases = [
            (["1,0,,0,1,0,0,0", "2,1,0,0,1,0,0,0"], ["field ty", "empty"]),
            (["0,0,0,0,1,0,0,0", "1,nan,0,0,1,0,0,0"], ["tx", "nan"]),
            (["0,0,0,0,1,0,0,0", "2,0,0,0,1,0,0,0", ok], ["time", "increase"]),
            (["0,0,0,0,1,0,0,0", "2,0,0,0,0,0,0,0"], ["quaternion", "zero"]),
            ([], ["at least two"]),
        ]
        for rows, words in cases:
            with self.subTest(rows=rows):
                self.fails(2, words, *self.blur("--motion", self.track(*rows)))
        open(self.p("t.csv"), "w").close()
        self.fails(2, ["empty"], *self.blur("--motion", self.p("t.csv")))
        self.fails(2, ["header"], *self.blur("--motion", self.track(ok, ok, header="time,x,y,z")))
        track = self.track("0,0,0,0,1,0,0,0", "10,1,0,0,1,0,0,0")
        self.fails(2, ["frame 0 (5 to 12 s)", "covers 0 to 10"], *self.blur("--motion", track, "--frame", "5,12"))

    def test_output_equal_to_input_is_refused(self):
        before = slurp(self.p("in.raw"))
        _, err = run("blur", "-i", self.p("in.raw"), "--dims", "8,8,8", "-o", self.p("in.raw"), "--translate",
                     "1,0,0", expect=2)
        self.assertIn("input", err)
        # The same file by another name is refused too.
        _, err = run("blur", "-i", self.p("in.raw"), "--dims", "8,8,8", "-o", self.d + "/./in.raw", "--translate",
                     "1,0,0", expect=2)
        self.assertEqual(slurp(self.p("in.raw")), before)

    def test_interfile_data_file_is_an_input_too(self):
        """An Interfile input's data file may have any name: an output (or the
        .v that an .hv output writes) that names it is refused."""
        for data, out in (("data.raw", "data.raw"), ("other.v", "other.hv")):
            with self.subTest(out=out):
                run("blur", *self.blur()[1:5], "-o", self.p("a.hv"), "--translate", "0,0,0", "--device", "host")
                os.rename(self.p("a.v"), self.p(data))
                with open(self.p("a.hv")) as f:
                    header = f.read().replace("a.v", data)
                with open(self.p("a.hv"), "w") as f:
                    f.write(header)
                before = slurp(self.p(data))
                _, err = run("blur", "-i", self.p("a.hv"), "-o", self.p(out), "--translate", "1,0,0", "--device",
                             "host", expect=2)
                self.assertIn("data file", err)
                self.assertEqual(slurp(self.p(data)), before)
                self.assertFalse(os.path.exists(self.p("other.hv")))
                self.assert_clean()

    def test_failed_run_keeps_an_existing_output(self):
        with open(self.p("out.nii"), "w") as f:
            f.write("keep me")
        _, err = run(*self.blur("--motion", self.track("0,0,0,0,1,0,0,0", "1,0,0,0,0,0,0,0")), expect=2)
        self.assertEqual(slurp(self.p("out.nii")), b"keep me")
        self.assert_clean()

    def test_usage_and_devices(self):
        self.fails(2, ["--bogus"], *self.blur("--translate", "1,0,0", "--bogus"))
        self.fails(2, ["no motion"], *self.blur())
        self.fails(2, ["--method"], *self.blur("--translate", "1,0,0", "--method", "fast"))
        for bad in ("0", "-1", "nan", "tight"):
            self.fails(2, ["--max-path-error"], *self.blur("--rotate", "10", "--max-path-error", bad))
        self.fails(2, ["--ab-sampling 'diagonal'", "slice (", "sweep ("],
                   *self.blur("--rotate", "10", "--ab-sampling", "diagonal"))
        self.fails(2, ["--ab-sampling", "RM"], *self.blur("--rotate", "10", "--method", "rm", "--ab-sampling",
                                                          "sweep"))
        self.fails(2, ["--dims"], *self.blur("--translate", "1,0,0")[:4], "1,x,8", "-o", self.p("out.nii"),
                   "--translate", "1,0,0")
        self.fails(2, ["unknown command"], "frobnicate")
        self.fails(3, ["opencl:99"], *self.blur("--translate", "1,0,0", device="opencl:99"))
        out, _ = run("devices")
        self.assertIn("host:0", out)
        for cmd in ("blur", "phantom", "compare", "render", "devices", "demo"):
            with self.subTest(cmd=cmd):
                text, _ = run(cmd, "--help")
                self.assertIn(f"usage: petblur {cmd}", text)
        # petblur motion takes the track as its argument: its help lists no
        # option it refuses (the poses of --translate/--rotate, --motion)
        text, _ = run("motion", "--help")
        self.assertIn("usage: petblur motion", text)
        self.assertIn("--calibration", text)
        for refused in ("--translate", "--rotate", "--axis", "--motion "):
            self.assertNotIn(f"  {refused}", text)
        track = self.p("track.csv")
        with open(track, "w") as f:
            f.write("t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,1,0,0,1,0,0,0\n")
        self.fails(2, ["unknown option '--translate'"], "motion", track, "--dims", "8,8,8", "--translate", "1,0,0")
        self.fails(2, ["drop --motion"], "motion", track, "--dims", "8,8,8", "--motion", track)


class Demo(Case):
    def test_demo_small(self):
        out, _ = run("demo", "--size", "16", "--points", "20", "--out-dir", self.p("demo"))
        for name in ("REF", "AB", "RM", "CL"):
            self.assertIn(name, out)
        errors = [float(line.split()[2]) for line in out.splitlines() if line.split()[:1] in (["AB"], ["RM"], ["CL"])]
        self.assertEqual(len(errors), 3)
        for e in errors:
            self.assertTrue(0 <= e < 20, out)
        for f in ("phantom", "ref", "ab", "rm", "cl"):
            self.assertEqual(nib.load(self.p(f"demo/{f}.nii.gz")).shape, (16, 16, 8))
        png_size(self.p("demo/demo.png"))


if __name__ == "__main__":
    PETBLUR = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
