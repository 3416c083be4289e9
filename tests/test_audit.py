"""The reliability audit's inputs (tests/audit/, from ../shared/cases/audit/), replayed as tests: each ends within
10 s with exit 0 (valid input) or 2 (bad input), a message that starts with "petblur:", no output left behind and
the input untouched; and a blur's time is bounded by its grid, whatever the motion.

usage: test_audit.py PATH/TO/petblur
"""
import glob
import hashlib
import os
import signal
import subprocess
import sys
import time
import unittest

import nibabel as nib
import numpy as np
import test_cli
from test_cli import Case

AUDIT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "audit")
LIMIT_S = 10.0


def digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


class Audit(Case):
    def setUp(self):
        super().setUp()
        test_cli.run("phantom", "--kind", "brain", "--dims", "16,16,8", "-o", self.p("in.nii"), "-q")
        with open(self.p("track.csv"), "w") as f:
            f.write("t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0.5,1,2,-1,0.9998,0,0.02,0\n1,3,1,2,0.9986,0.05,0,0.02\n")

    def replay(self, allowed, out, *args):
        if os.path.isfile(self.p(out)):
            os.remove(self.p(out))
        inputs = [a for a in args if os.path.isfile(str(a))]
        before = {a: digest(a) for a in inputs}
        start = time.monotonic()
        p = subprocess.run([test_cli.PETBLUR, *map(str, args)], capture_output=True, text=True, timeout=60,
                           stdin=subprocess.DEVNULL)
        took = time.monotonic() - start
        what = f"petblur {' '.join(map(str, args))}"
        self.assertLess(took, LIMIT_S, f"{what}: {took:.1f} s")
        self.assertIn(p.returncode, allowed, f"{what}: exit {p.returncode}\n{p.stderr}")
        if p.returncode != 0:
            first = [ln for ln in p.stderr.splitlines() if not ln.startswith("petblur: warning")][:1]
            self.assertTrue(first and first[0].startswith("petblur: "), f"{what}: {p.stderr!r}")
            self.assertFalse(os.path.exists(self.p(out)), f"{what}: output left after failure")
        self.assertEqual([f for f in os.listdir(self.d) if ".petblur-" in f], [], f"{what}: temporary left")
        for a, h in before.items():
            self.assertEqual(digest(a), h, f"{what}: input {a} changed")
        return p

    def test_images(self):
        for f in sorted(glob.glob(os.path.join(AUDIT, "*.nii"))):
            with self.subTest(image=os.path.basename(f)):
                self.replay((0, 2) if "tiny_pixdim" in f else (2,), "o.nii", "blur", "-i", f, "-o", self.p("o.nii"),
                            "--translate", "1,0,0", "--device", "host", "-q")

    def test_multi_member_gzip(self):
        """A .nii.gz of two gzip members (bgzip writes such files) is valid: its trailer gives only the last
        member's size, so the size check counts instead of refusing; a truncated stream is still refused."""
        import gzip
        raw = open(self.p("in.nii"), "rb").read()
        with open(self.p("multi.nii.gz"), "wb") as f:
            f.write(gzip.compress(raw[:3000]) + gzip.compress(raw[3000:]))
        self.replay((0,), "o.nii", "blur", "-i", self.p("multi.nii.gz"), "-o", self.p("o.nii"), "--translate", "1,0,0",
                    "--device", "host", "-q")
        with open(self.p("cut.nii.gz"), "wb") as f:
            f.write(gzip.compress(raw)[:400])
        self.replay((2,), "c.nii", "blur", "-i", self.p("cut.nii.gz"), "-o", self.p("c.nii"), "--translate", "1,0,0",
                    "--device", "host", "-q")

    def test_fuzzed_headers(self):
        for d in sorted(glob.glob(os.path.join(AUDIT, "cli", "nii-*"))):
            f = os.path.join(d, "in.nii")
            with self.subTest(case=os.path.basename(d)):
                self.replay((0, 2), "o.nii.gz", "blur", "-i", f, "-o", self.p("o.nii.gz"), "--translate", "1,0,0",
                            "--device", "host", "-q")
                self.replay((0, 2), "o.nii", "blur", "-i", f, "-o", self.p("o.nii"), "--motion", self.p("track.csv"),
                            "--frames", "0,0.5,1", "--device", "host", "-q")
                self.replay((0, 2), "o.png", "render", f, "-o", self.p("o.png"))

    def test_tracks(self):
        cases = [("nan_output_track.csv", (2,), ()), ("hang_rm_hex_translation.csv", (0, 2), ("--method", "rm")),
                 ("ub_translation_1e308.csv", (2,), ()), (os.path.join("cli", "csv-b5faf88af8", "t.csv"), (0, 2),
                                                          ("--method", "rm"))]
        for name, allowed, extra in cases:
            with self.subTest(track=name):
                self.replay(allowed, "o.nii", "blur", "-i", self.p("in.nii"), "-o", self.p("o.nii"), "--motion",
                            os.path.join(AUDIT, name), "--device", "host", "-q", *extra)

    def test_long_header(self):
        """A header longer than the message shows (the fuzzer's find: the text it collects overran its buffer,
        which the sanitizer run of this suite catches)."""
        with open(self.p("long.csv"), "w") as f:
            f.write(",".join(f"column_{i:03d}_with_a_long_name" for i in range(40)) + "\n0,1\n")
        p = self.replay((2,), "o.nii", "blur", "-i", self.p("in.nii"), "-o", self.p("o.nii"), "--motion",
                        self.p("long.csv"), "--device", "host", "-q")
        self.assertIn("the header has no column 't'; found 'column_000_with_a_long_name", p.stderr)

    def test_huge_translations_end(self):
        for t in ("1e9,0,0", "1e200,0,0", "0,-3e11,2e11"):
            for method in ("ab", "rm", "cl"):
                with self.subTest(translate=t, method=method):
                    self.replay((0, 2), "o.nii", "blur", "-i", self.p("in.nii"), "-o", self.p("o.nii"), "--translate",
                                t, "--method", method, "--device", "host", "-q")

    def test_outputs(self):
        os.mkdir(self.p("adir.nii"))
        self.replay((2,), "adir.nii/x", "blur", "-i", self.p("in.nii"), "-o", self.p("adir.nii"), "--translate",
                    "1,0,0", "--device", "host", "-q")
        self.assertTrue(os.path.isdir(self.p("adir.nii")))
        # An existing .hv/.v pair survives a failed write: a folder stands where the header goes.
        test_cli.run("phantom", "--kind", "brain", "--dims", "8,8,4", "-o", self.p("out.hv"), "-q")
        kept = digest(self.p("out.v"))
        os.rename(self.p("out.hv"), self.p("keep.hv"))
        os.mkdir(self.p("out.hv"))
        self.replay((2, 3), "none", "blur", "-i", self.p("in.nii"), "-o", self.p("out.hv"), "--translate", "1,0,0",
                    "--device", "host", "-q")
        self.assertEqual(digest(self.p("out.v")), kept, "the existing out.v was lost or changed")
        # An existing output that is a link, or read-only, is refused; a replaced one keeps its mode.
        os.symlink(self.p("in.nii"), self.p("link.nii"))
        self.replay((2,), "none", "blur", "-i", self.p("in.nii"), "-o", self.p("link.nii"), "--translate", "1,0,0", "-q")
        self.assertTrue(os.path.islink(self.p("link.nii")))
        for mode, allowed in ((0o444, (2,)), (0o640, (0,))):
            with open(self.p("old.nii"), "wb") as f:
                f.write(b"old")
            os.chmod(self.p("old.nii"), mode)
            p = subprocess.run([test_cli.PETBLUR, "blur", "-i", self.p("in.nii"), "-o", self.p("old.nii"),
                                "--translate", "1,0,0", "-q"], capture_output=True, text=True, timeout=60)
            self.assertIn(p.returncode, allowed, p.stderr)
            self.assertEqual(os.stat(self.p("old.nii")).st_mode & 0o777, mode)
            if mode == 0o444:
                self.assertIn("write-protected", p.stderr)
                self.assertEqual(open(self.p("old.nii"), "rb").read(), b"old")
            os.chmod(self.p("old.nii"), 0o644)
            os.remove(self.p("old.nii"))
        long = "x" * 250 + ".nii"
        p = self.replay((2,), long, "blur", "-i", self.p("in.nii"), "-o", self.p(long), "--translate", "1,0,0", "-q")
        self.assertIn("too long", p.stderr)


class InterfileData(Case):
    """An Interfile header may name any data file: only a regular file beside the header or below it is read, so
    /etc/passwd is not read as voxels, a FIFO does not block and a folder is called one."""

    def header(self, name, data):
        with open(self.p(name), "w") as f:
            f.write("!INTERFILE :=\n!name of data file := %s\n!number format := unsigned integer\n"
                    "!number of bytes per pixel := 1\n" % data
                    + "".join(f"!matrix size [{i}] := 4\nscaling factor (mm/pixel) [{i}] := 1\n" for i in (1, 2, 3))
                    + "!END OF INTERFILE :=\n")
        return self.p(name)

    def test_data_files(self):
        os.mkfifo(self.p("fifo.v"))
        os.mkdir(self.p("dir.v"))
        os.mkdir(self.p("sub"))
        with open(self.p("sub/real.v"), "wb") as f:
            f.write(bytes(range(64)))
        os.symlink("sub/real.v", self.p("annexed.v"))  # git-annex and DataLad keep data as links
        p = subprocess.run([test_cli.PETBLUR, "blur", "-i", self.header("annexed.hv", "annexed.v"), "-o",
                            self.p("a.nii"), "--translate", "0,0,0", "--coords", "grid", "-q"], capture_output=True,
                           text=True, timeout=30)
        self.assertEqual(p.returncode, 0, p.stderr)
        cases = [("passwd.hv", "/etc/passwd", "lies outside the header's folder"),
                 ("up.hv", "../" + os.path.basename(self.d) + "/sub/real.v", "lies outside the header's folder"),
                 ("fifo.hv", "fifo.v", "is a device, pipe or socket"), ("dir.hv", "dir.v", "is a folder")]
        for name, data, words in cases:
            with self.subTest(data=data):
                start = time.monotonic()
                p = subprocess.run([test_cli.PETBLUR, "blur", "-i", self.header(name, data), "-o", self.p("o.nii"),
                                    "--translate", "1,0,0", "-q"], capture_output=True, text=True, timeout=30)
                self.assertLess(time.monotonic() - start, LIMIT_S)
                self.assertEqual(p.returncode, 2, p.stderr)
                self.assertIn(words, p.stderr)
                self.assertFalse(os.path.exists(self.p("o.nii")))


class FourD(Case):
    def test_render_compare_and_pictures_of_frames(self):
        """render and compare take petblur's own --frames output; compare's relative RMS error is over every frame
        (numpy); the --png of --frames and --sum-frames is written."""
        test_cli.run("phantom", "--kind", "brain", "--dims", "16,16,8", "-o", self.p("in.nii"), "-q")
        with open(self.p("t.csv"), "w") as f:
            f.write("t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n3,6,2,-3,1,0,0,0\n")
        common = ("-i", self.p("in.nii"), "--motion", self.p("t.csv"), "--frames", "0,1,2,3", "--device", "host", "-q")
        test_cli.run("blur", "-o", self.p("a.nii"), *common, "--png", self.p("a.png"))
        test_cli.run("blur", "-o", self.p("b.nii"), *common, "--method", "rm")
        test_cli.run("blur", "-o", self.p("s.nii"), *common, "--adjoint", "--sum-frames", "--png", self.p("s.png"))
        w1, h1 = test_cli.png_size(self.p("a.png"))
        w2, h2 = test_cli.png_size(self.p("s.png"))
        self.assertLess(h2, h1, "the sum's picture has no difference row")
        test_cli.run("render", self.p("a.nii"), "-o", self.p("r.png"))
        test_cli.run("render", self.p("in.nii"), "-o", self.p("one.png"))
        self.assertGreater(test_cli.png_size(self.p("r.png"))[1], 2 * test_cli.png_size(self.p("one.png"))[1],
                           "three frames, three rows")
        out, _ = test_cli.run("compare", self.p("a.nii"), self.p("b.nii"))
        a, b = nib.load(self.p("a.nii")).get_fdata(), nib.load(self.p("b.nii")).get_fdata()
        self.assertEqual(a.shape, (16, 16, 8, 3))
        expect = 100 * np.sqrt(((b - a) ** 2).sum() / (a ** 2).sum())
        got = float(out.strip().splitlines()[-1].split("rms% = ")[1].split()[0])
        self.assertAlmostEqual(got, expect, delta=1e-4 * expect)
        _, err = test_cli.run("compare", self.p("a.nii"), self.p("in.nii"), expect=2)
        self.assertIn("has 3 frames and", err)
        # the same grid placed elsewhere compares nothing: refused, naming how far apart
        img = nib.load(self.p("a.nii"))
        data = np.asarray(img.dataobj)
        for name, move, refused in (("flip", np.diag([-1.0, 1, 1, 1]), True), ("shift", None, True),
                                    ("rounding", None, False)):
            aff = img.affine.copy()
            if move is not None:
                aff = move @ aff
            elif name == "shift":
                aff[:3, 3] += [0.0, 0.5, 0.0]
            else:
                aff[:3, 3] += [1e-4, 0.0, 0.0]
            nib.save(nib.Nifti1Image(data, aff), self.p(f"{name}.nii"))
            out, err = test_cli.run("compare", self.p("a.nii"), self.p(f"{name}.nii"), expect=2 if refused else 0)
            if refused:
                self.assertIn("placed", err)
                self.assertIn("resampling one onto the other", err)
            else:
                self.assertIn("rms% = 0 ", out)


class Interrupted(Case):
    def test_signal_during_a_write_leaves_nothing(self):
        """SIGTERM or SIGINT while the output is being written removes the temporary: no hidden file is left and
        no output appears. The output is a .nii.gz of random voxels, slow to compress, and the signal is sent once
        its temporary exists."""
        np.random.default_rng().random((96, 96, 96), dtype=np.float32).astype("<f4").tofile(self.p("in.raw"))
        for sig in (signal.SIGTERM, signal.SIGINT):
            with self.subTest(signal=sig.name):
                p = subprocess.Popen([test_cli.PETBLUR, "blur", "-i", self.p("in.raw"), "--dims", "96,96,96", "-o",
                                      self.p("o.nii.gz"), "--translate", "0,0,0", "--device", "host", "-q"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                deadline = time.monotonic() + 30
                while p.poll() is None and time.monotonic() < deadline:
                    if any(".petblur-" in f for f in os.listdir(self.d)):
                        p.send_signal(sig)
                        break
                    time.sleep(0.001)
                p.wait(timeout=30)
                if p.returncode == 0:  # the write won the race; nothing to check this round
                    os.remove(self.p("o.nii.gz"))
                    continue
                self.assertEqual(p.returncode, -sig, "the signal should end the program as it would have")
                self.assertEqual([f for f in os.listdir(self.d) if ".petblur-" in f], [])
                self.assertFalse(os.path.exists(self.p("o.nii.gz")))


class Bounded(Case):
    def test_time_is_bounded_by_the_grid(self):
        """A translation of 1e9 mm costs about what one across the grid costs: the walk is clipped to the grid."""
        test_cli.run("phantom", "--kind", "brain", "--dims", "48,48,24", "--voxel-size", "5.87,5.87,7.47", "-o",
                     self.p("in.nii"), "-q")

        def timed(t):
            start = time.monotonic()
            subprocess.run([test_cli.PETBLUR, "blur", "-i", self.p("in.nii"), "-o", self.p("o.nii"), "--translate", t,
                            "--device", "host", "-q"], check=True, capture_output=True, timeout=120)
            return time.monotonic() - start

        across = timed("300,0,0")  # the field of view is 282 mm
        for t in ("1e9,0,0", "0,1e11,-1e11"):
            with self.subTest(translate=t):
                self.assertLess(timed(t), 3 * across + 1.0, f"--translate {t} against {across:.2f} s across the grid")


if __name__ == "__main__":
    test_cli.PETBLUR = sys.argv.pop(1)
    unittest.main(verbosity=2)
