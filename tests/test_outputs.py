"""What petblur's outputs may be (issue 29), end to end:

1. No output names a file the command reads, nor another output: by the same path, by ./path, by a relative path, by
   a folder link, by a symbolic link to the input, through an input given by a link, by a hard link. Every command's
   every pair of an output option and an input option that can collide is refused with exit 2 before any work, and
   every input is left byte for byte as it was.
2. Outputs never go through a link: an attacker who swaps petblur's temporary for a link to a victim file while the
   output is written never gets the victim written, and never leaves a link as the output.
3. An Interfile header's data file lies inside the header's folder (the folders on the way resolved): a link to a
   folder outside, '..' and absolute names are refused; a data file beside the header (or below it, a link inside
   the folder, or a link to a file elsewhere, as git-annex and DataLad keep data) is read.

usage: test_outputs.py PATH/TO/petblur
"""
import contextlib
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import threading
import unittest

import numpy as np

PETBLUR = None
TRACK = "t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,1,0,0,1,0,0,0\n"
CALIBRATION = "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"
SIDECAR = json.dumps({"FrameTimesStart": [0], "FrameDuration": [1]})


def petblur(*args, cwd=None, timeout=120):
    return subprocess.run([PETBLUR, *map(str, args)], capture_output=True, text=True, timeout=timeout, cwd=cwd)


def digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


@contextlib.contextmanager
def attacker(folder, victim):
    """A thread that, while the block runs, swaps every '.petblur-' file in folder for a link to victim; yields the
    names it swapped."""
    stop, swaps = threading.Event(), []

    def attack():
        while not stop.is_set():
            for e in os.scandir(folder):
                if ".petblur-" in e.name and not e.is_symlink():
                    try:
                        os.unlink(e.path)
                        os.symlink(victim, e.path)
                        swaps.append(e.name)
                    except OSError:
                        pass

    t = threading.Thread(target=attack)
    t.start()
    try:
        yield swaps
    finally:
        stop.set()
        t.join()


class Case(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory(prefix="petblur-outputs-")
        self.d = self.dir.name

    def tearDown(self):
        self.dir.cleanup()

    def p(self, *names):
        return os.path.join(self.d, *names)

    def ok(self, *args, **kw):
        r = petblur(*args, **kw)
        self.assertEqual(r.returncode, 0, f"petblur {' '.join(map(str, args))}: {r.stderr}")
        return r

    def temporaries(self, folder=None):
        folder = folder or self.d
        return [f for f in os.listdir(folder) if ".petblur-" in f]

    def interfile_pair(self, header, data):
        """An Interfile pair of petblur's writing, its data file renamed to `data` (relative to the header)."""
        self.ok("phantom", "--kind", "brain", "--dims", "8,8,4", "-o", self.p("made.hv"), "-q")
        os.rename(self.p("made.v"), os.path.join(os.path.dirname(header), data))
        with open(self.p("made.hv")) as f:
            text = f.read().replace(":= made.v", ":= " + data)
        os.remove(self.p("made.hv"))
        write(header, text)


class Aliases(Case):
    """Every (output option, input option) pair of every command that can collide. The input file carries the
    output's extension (a track named t.png; an Interfile data file named dat.raw), so that the output's own checks
    let it through and only the rule can stop it."""

    def setUp(self):
        super().setUp()
        self.ok("phantom", "--kind", "brain", "--dims", "16,16,8", "-o", self.p("in.nii"), "-q")
        write(self.p("track.csv"), TRACK)
        os.symlink(".", self.p("dl"))  # a folder link back into the test folder

    # The inputs, each made under a name with the output's extension.
    def make(self, kind, name):
        path = self.p(name)
        if kind == "image":
            self.ok("phantom", "--kind", "brain", "--dims", "16,16,8", "-o", path, "-q")
        elif kind == "track":
            write(path, TRACK)
        elif kind == "calibration":
            write(path, CALIBRATION)
        elif kind == "sidecar":
            write(path, SIDECAR)
        elif kind == "data":  # the data file of h.hv
            self.interfile_pair(self.p("h.hv"), name)
        return path

    def variants(self, src, data_file):
        """(name, input argument or None for the usual one, output path, message words) for each way of naming
        src again; the output path is the name of the colliding file itself."""
        base, ext = os.path.basename(src), os.path.splitext(src)[1]
        os.link(src, self.p("hard" + ext))
        os.symlink(base, self.p("sl" + ext))
        if data_file:  # the header names its data file through a link inside its folder
            os.symlink(base, self.p("lnk" + ext))
        else:
            os.symlink(base, self.p("lnk_" + base))
        return [("the same path", None, src, None),
                ("./path", None, os.path.join(self.d, ".", base), None),
                ("a relative path", None, base, None),
                ("a folder link", None, self.p("dl", base), None),
                ("an input given through a link", "lnk" if data_file else self.p("lnk_" + base), src, None),
                ("a hard link", None, self.p("hard" + ext), None),
                ("a link at the output", None, self.p("sl" + ext), ["symbolic link"])]

    def check(self, cmd, out_opt, in_opt, kind, ext, argv, out_of=lambda p: p):
        """argv(input, output) makes the command line. out_of turns the colliding file's path into the output
        argument (OUT.v collides, -o OUT.hv is given)."""
        src = self.make(kind, ("dat" if kind == "data" else "src") + ext)
        data_file = kind == "data"
        for name, in_arg, out, words in self.variants(src, data_file):
            with self.subTest(command=cmd, output=out_opt, input=in_opt, by=name):
                if data_file and in_arg:
                    with open(self.p("h.hv")) as f:
                        text = f.read()
                    write(self.p("h.hv"), text.replace(":= " + os.path.basename(src), ":= lnk" + ext))
                inp = self.p("h.hv") if data_file else in_arg or src
                before = {f: digest(self.p(f)) for f in os.listdir(self.d)
                          if os.path.isfile(self.p(f)) and not os.path.islink(self.p(f))}
                listing = sorted(os.listdir(self.d))
                r = petblur(*argv(inp, out_of(out)), cwd=self.d, timeout=60)
                self.assertEqual(r.returncode, 2, f"{cmd}: {r.stderr}")
                self.assertTrue(r.stderr.startswith("petblur: "), r.stderr)
                for w in words or [out_opt, in_opt, "name the same file", "another name"]:
                    self.assertIn(w, r.stderr)
                for f, h in before.items():
                    self.assertEqual(digest(self.p(f)), h, f"{f} changed")
                self.assertEqual(sorted(os.listdir(self.d)), listing, "a file appeared or went")
                if data_file and in_arg:
                    write(self.p("h.hv"), text)

    @staticmethod
    def blur(args):
        """blur's command line from args(input, output), on the host."""
        return lambda i, o: ("blur", *args(i, o), "--device", "host", "-q")

    def test_blur_output_against_the_image(self):
        self.check("blur", "-o", "-i", "image", ".nii", self.blur(lambda i, o: ("-i", i, "-o", o, "--translate",
                                                                                 "1,0,0")))

    def test_blur_output_against_an_interfile_input(self):
        hv = self.blur(lambda i, o: ("-i", i, "-o", o, "--translate", "1,0,0"))
        self.check("blur", "-o", "-i", "image", ".hv", hv)  # the header
        self.tidy()
        self.check("blur", "-o", "its data file", "data", ".raw", hv)

    def test_blur_output_pair_against_the_data_file(self):
        # -o dat.hv writes dat.v, the data file that -i h.hv reads.
        self.check("blur", "-o", "its data file", "data", ".v",
                   self.blur(lambda i, o: ("-i", i, "-o", o, "--translate", "1,0,0")), out_of=lambda p: p[:-2] + ".hv")

    def test_blur_picture_against_the_data_file(self):
        self.check("blur", "--png", "its data file", "data", ".png",
                   self.blur(lambda i, o: ("-i", i, "-o", self.p("o.nii"), "--translate", "1,0,0", "--png", o)))

    def test_blur_against_the_track(self):
        for out_opt, ext in (("-o", ".nii"), ("--png", ".png"), ("-o", ".v")):
            with self.subTest(output=out_opt, ext=ext):
                if out_opt == "-o":
                    argv = self.blur(lambda i, o: ("-i", self.p("in.nii"), "-o", o, "--motion", i))
                else:
                    argv = self.blur(lambda i, o: ("-i", self.p("in.nii"), "-o", self.p("o.nii"), "--motion", i,
                                                   "--png", o))
                self.check("blur", out_opt, "--motion", "track", ext, argv,
                           out_of=(lambda p: p[:-2] + ".hv") if ext == ".v" else (lambda p: p))
                self.tidy()

    def test_blur_against_the_calibration_and_the_sidecar(self):
        for in_opt, kind in (("--calibration", "calibration"), ("--frames-from", "sidecar")):
            for out_opt, ext in (("-o", ".nii"), ("--png", ".png")):
                with self.subTest(input=in_opt, output=out_opt):
                    def argv(i, o, in_opt=in_opt, out_opt=out_opt):
                        out = ("-o", o) if out_opt == "-o" else ("-o", self.p("o.nii"), "--png", o)
                        return ("blur", "-i", self.p("in.nii"), *out, "--motion", self.p("track.csv"), in_opt, i,
                                "--device", "host", "-q")
                    self.check("blur", out_opt, in_opt, kind, ext, argv)
                    self.tidy()

    def test_motion(self):
        cases = [("the track", "track", lambda i, o: ("motion", i, "--png", o)),
                 ("its data file", "data", lambda i, o: ("motion", self.p("track.csv"), "-i", i, "--png", o)),
                 ("--calibration", "calibration",
                  lambda i, o: ("motion", self.p("track.csv"), "--calibration", i, "--png", o)),
                 ("--frames-from", "sidecar",
                  lambda i, o: ("motion", self.p("track.csv"), "--frames-from", i, "--png", o))]
        for in_opt, kind, argv in cases:
            with self.subTest(input=in_opt):
                self.check("motion", "--png", in_opt, kind, ".png", argv)
                self.tidy()

    def test_render(self):
        # The picture can name the volume it shows only through its Interfile data file.
        self.check("render", "-o", "its data file", "data", ".png", lambda i, o: ("render", i, "-o", o))

    def test_two_outputs(self):
        """phantom's -o and --png, and blur's, naming one file by a hard link or a folder link."""
        self.ok("phantom", "--kind", "brain", "--dims", "8,8,4", "-o", self.p("a.nii"), "-q")
        os.link(self.p("a.nii"), self.p("a.png"))
        for args in (("phantom", "--kind", "brain", "--dims", "8,8,4", "-o", self.p("a.nii"), "--png",
                      self.p("a.png"), "-q"),
                     ("phantom", "--kind", "brain", "--dims", "8,8,4", "-o", self.p("dl", "a.nii"), "--png",
                      self.p("a.png"), "-q"),
                     ("blur", "-i", self.p("in.nii"), "-o", self.p("a.nii"), "--png", self.p("a.png"), "--translate",
                      "1,0,0", "--device", "host", "-q")):
            with self.subTest(args=args[0]):
                before, listing = digest(self.p("a.nii")), sorted(os.listdir(self.d))
                r = petblur(*args)
                self.assertEqual(r.returncode, 2, r.stderr)
                for w in ("-o", "--png", "each output needs a file of its own"):
                    self.assertIn(w, r.stderr)
                self.assertEqual(digest(self.p("a.nii")), before)
                self.assertEqual(sorted(os.listdir(self.d)), listing)

    def test_demo(self):
        """demo reads nothing; its outputs must still be files of their own."""
        os.mkdir(self.p("demo"))
        write(self.p("demo", "ref.nii.gz"), "kept")
        os.link(self.p("demo", "ref.nii.gz"), self.p("demo", "ab.nii.gz"))
        r = petblur("demo", "--size", "16", "--points", "4", "--out-dir", self.p("demo"), "-q")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("each output needs a file of its own: choose another --out-dir", r.stderr)
        self.assertEqual(sorted(os.listdir(self.p("demo"))), ["ab.nii.gz", "ref.nii.gz"])

    def test_bench(self):
        """--brain inside DIR/volumes with --keep-volumes (by itself or as an Interfile data file), and a table of
        --out-dir that is a reference of --reference (a hard link)."""
        quick = ("bench", "--quick", "--device", "host", "--phantoms", "brain", "--scenarios", "1", "-q")
        os.makedirs(self.p("run", "volumes"))
        self.ok("phantom", "--kind", "brain", "--dims", "16,16,8", "-o", self.p("run", "volumes", "brain.raw"), "-q")
        self.interfile_pair(self.p("run", "volumes", "head.hv"), "brain_s1_ref1.raw")
        os.makedirs(self.p("refs", "volumes"))
        write(self.p("refs", "volumes", "brain_s1_ref1.raw"), "reference")
        write(self.p("refs", "volumes", "brain_s1_ref2.raw"), "reference")
        os.mkdir(self.p("tables"))
        os.link(self.p("refs", "volumes", "brain_s1_ref2.raw"), self.p("tables", "cases.csv"))
        fix = "choose another --out-dir"
        cases = [(("--brain", self.p("run", "volumes", "brain.raw"), "--dims", "16,16,8", "--keep-volumes",
                   "--out-dir", self.p("run")), ["--brain", fix], self.p("run", "volumes", "brain.raw")),
                 (("--brain", self.p("run", "volumes", "head.hv"), "--keep-volumes", "--out-dir", self.p("run")),
                  ["--brain", "its data file", fix], self.p("run", "volumes", "brain_s1_ref1.raw")),
                 (("--reference", self.p("refs"), "--out-dir", self.p("tables")), ["--reference", fix],
                  self.p("refs", "volumes", "brain_s1_ref2.raw"))]
        for args, words, victim in cases:
            with self.subTest(args=args[:2]):
                before = digest(victim)
                r = petblur(*quick, *args, timeout=60)
                self.assertEqual(r.returncode, 2, r.stderr)
                for w in words:
                    self.assertIn(w, r.stderr)
                self.assertEqual(digest(victim), before)
                self.assertFalse(os.path.exists(self.p("run", "results.csv")))
                self.assertFalse(os.path.exists(self.p("tables", "results.csv")))

    def tidy(self):
        """Removes the inputs and links one check() made, so that the next can make its own."""
        for f in os.listdir(self.d):
            if f.startswith(("src", "dat", "hard", "sl.", "lnk", "h.hv")):
                os.remove(self.p(f))


class Links(Case):
    """Outputs never go through a link, whatever stands at the output's name or comes to stand at the temporary's."""

    def test_existing_links_at_the_output_are_refused(self):
        self.ok("phantom", "--kind", "brain", "--dims", "8,8,4", "-o", self.p("in.nii"), "-q")
        write(self.p("victim.txt"), "precious")
        os.symlink(self.p("victim.txt"), self.p("o.nii"))
        os.symlink(self.p("nowhere.nii"), self.p("dangling.nii"))
        os.symlink(self.p("victim.txt"), self.p("pair.v"))
        for out in ("o.nii", "dangling.nii", "pair.hv"):
            with self.subTest(output=out):
                r = petblur("blur", "-i", self.p("in.nii"), "-o", self.p(out), "--translate", "1,0,0", "--device",
                            "host", "-q")
                self.assertEqual(r.returncode, 2, r.stderr)
                self.assertIn("symbolic link", r.stderr)
                with open(self.p("victim.txt")) as f:
                    self.assertEqual(f.read(), "precious")
                self.assertFalse(os.path.exists(self.p("nowhere.nii")))
                self.assertFalse(os.path.exists(self.p("pair.hv")))
                self.assertEqual(self.temporaries(), [])
        # the demo's outputs, named by its folder, as every other command's
        os.mkdir(self.p("demo"))
        os.symlink(self.p("victim.txt"), self.p("demo", "ab.nii.gz"))
        r = petblur("demo", "--size", "16", "--points", "4", "--out-dir", self.p("demo"), "--device", "host", "-q")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("symbolic link", r.stderr)
        self.assertTrue(os.path.islink(self.p("demo", "ab.nii.gz")))
        self.assertEqual(sorted(os.listdir(self.p("demo"))), ["ab.nii.gz"])
        with open(self.p("victim.txt")) as f:
            self.assertEqual(f.read(), "precious")

    def race(self, args, outputs, rounds=3):
        """Runs petblur `rounds` times while a thread swaps every '.petblur-' file in the output folder for a link
        to a victim file elsewhere. The victim is never written; an output is never a link: the run succeeds with
        regular files, or fails (exit 3) with a message and leaves no output. Returns how many runs were attacked."""
        victim = self.p("victim", "precious.txt")
        hit = 0
        for _ in range(rounds):
            before = os.stat(victim)
            with attacker(self.p("out"), victim) as swaps:
                r = petblur(*args, timeout=300)
            after = os.stat(victim)
            self.assertEqual(digest(victim), self.precious)
            self.assertEqual((after.st_size, after.st_mtime_ns), (before.st_size, before.st_mtime_ns))
            for out in outputs:
                self.assertFalse(os.path.islink(out), f"{out} is a link (attacked: {swaps})")
                if r.returncode == 0:
                    self.assertTrue(os.path.isfile(out))
                else:
                    self.assertFalse(os.path.lexists(out), f"{out} left after a failure")
            if r.returncode:
                self.assertEqual(r.returncode, 3, r.stderr)
                self.assertTrue(r.stderr.startswith("petblur: "), r.stderr)
                self.assertIn("was replaced", r.stderr)
            hit += bool(swaps)
            # The attacker's links at the temporaries' names are its own; petblur's outputs go for the next round.
            for f in os.listdir(self.p("out")):
                os.remove(self.p("out", f))
        return hit

    def test_racing_attacker(self):
        os.mkdir(self.p("out"))
        os.mkdir(self.p("victim"))
        write(self.p("victim", "precious.txt"), "precious\n")
        self.precious = digest(self.p("victim", "precious.txt"))
        n = 256
        np.random.default_rng().random((n, n, n), dtype=np.float32).tofile(self.p("in.raw"))
        grid = ("--dims", f"{n},{n},{n}")
        hits = 0
        for ext in (".nii", ".nii.gz", ".hv", ".raw"):
            with self.subTest(output=ext):
                out = self.p("out", "o" + ext)
                outputs = [out, out[:-3] + ".v"] if ext == ".hv" else [out]
                hits += self.race(("blur", "-i", self.p("in.raw"), *grid, "-o", out, "--translate", "0,0,0",
                                   "--device", "host", "-q"), outputs)
        with self.subTest(output=".png"):
            hits += self.race(("render", self.p("in.raw"), *grid, "-o", self.p("out", "p.png")),
                              [self.p("out", "p.png")])
        self.assertGreater(hits, 0, "the attacker never caught a temporary: the test proved nothing")

    def test_racing_attacker_on_an_existing_pair(self):
        """Writing over an existing .hv pair keeps the old data file as a hidden hard link meanwhile: that one is
        swapped too. The pair is never left as links."""
        os.mkdir(self.p("out"))
        os.mkdir(self.p("victim"))
        write(self.p("victim", "precious.txt"), "precious\n")
        self.precious = digest(self.p("victim", "precious.txt"))
        np.random.default_rng().random((128, 128, 128), dtype=np.float32).tofile(self.p("in.raw"))
        for _ in range(3):
            self.ok("phantom", "--kind", "brain", "--dims", "8,8,4", "-o", self.p("out", "o.hv"), "-q")
            with attacker(self.p("out"), self.p("victim", "precious.txt")):
                r = petblur("blur", "-i", self.p("in.raw"), "--dims", "128,128,128", "-o", self.p("out", "o.hv"),
                            "--translate", "0,0,0", "--device", "host", "-q")
            self.assertIn(r.returncode, (0, 3), r.stderr)
            self.assertEqual(digest(self.p("victim", "precious.txt")), self.precious)
            for f in ("o.hv", "o.v"):
                self.assertFalse(os.path.islink(self.p("out", f)), f"{f} is a link")
            for f in os.listdir(self.p("out")):
                os.remove(self.p("out", f))


class InterfileData(Case):
    """Where a header's data file may live: named relative to the header, no '..', and inside the header's folder
    once the folders on the way are resolved (the file itself may link anywhere, as annexed data does). The same for
    blur, motion -i, render and compare."""

    def setUp(self):
        super().setUp()
        os.mkdir(self.p("h"))
        os.mkdir(self.p("outside"))
        self.ok("phantom", "--kind", "brain", "--dims", "8,8,4", "-o", self.p("outside", "x.hv"), "-q")
        write(self.p("track.csv"), TRACK)

    def header(self, data):
        with open(self.p("outside", "x.hv")) as f:
            text = f.read().replace(":= x.v", ":= " + data)
        write(self.p("h", "x.hv"), text)
        return self.p("h", "x.hv")

    def commands(self, hv):
        yield "blur", ("blur", "-i", hv, "-o", self.p("o.nii"), "--translate", "1,0,0", "--device", "host", "-q")
        yield "motion", ("motion", self.p("track.csv"), "-i", hv)
        yield "render", ("render", hv, "-o", self.p("o.png"))
        yield "compare", ("compare", hv, hv)

    def test_outside_is_refused(self):
        os.symlink("../outside", self.p("h", "folder"))
        cases = [("a link to a folder outside", "folder/x.v", "outside the header's folder"),
                 ("'..'", "../outside/x.v", "outside the header's folder"),
                 ("'..' inside the name", "sub/../../outside/x.v", "outside the header's folder"),
                 ("an absolute name", self.p("outside", "x.v"), "outside the header's folder")]
        for what, data, words in cases:
            hv = self.header(data)
            for cmd, args in self.commands(hv):
                with self.subTest(data=what, command=cmd):
                    r = petblur(*args)
                    self.assertEqual(r.returncode, 2, r.stderr)
                    self.assertIn(words, r.stderr)
                    self.assertIn(hv, r.stderr)  # the header, the data file and the fix are named
                    self.assertIn("x.v", r.stderr)
                    self.assertFalse(os.path.exists(self.p("o.nii")) or os.path.exists(self.p("o.png")))

    def test_inside_is_read(self):
        os.mkdir(self.p("h", "sub"))
        with open(self.p("outside", "x.v"), "rb") as f:
            data = f.read()
        for name in ("x.v", "sub/y.v"):
            with open(self.p("h", name), "wb") as f:
                f.write(data)
        os.symlink("sub/y.v", self.p("h", "annexed.v"))  # git-annex and DataLad keep data as links
        os.symlink("../outside/x.v", self.p("h", "annex-top.v"))  # into .git/annex at the dataset's top
        os.symlink("h", self.p("hl"))
        for data_name, hv in (("x.v", None), ("sub/y.v", None), ("annexed.v", None), ("annex-top.v", None),
                              ("x.v", self.p("hl", "x.hv"))):  # a header reached through a folder link
            self.header(data_name)
            for cmd, args in self.commands(hv or self.p("h", "x.hv")):
                with self.subTest(data=data_name, header=hv, command=cmd):
                    r = petblur(*args)
                    self.assertEqual(r.returncode, 0, r.stderr)
            for f in ("o.nii", "o.png"):
                if os.path.exists(self.p(f)):
                    os.remove(self.p(f))

    def test_written_pairs_keep_the_rule(self):
        """An .hv that petblur writes names its data file beside it, and reads back; a link standing where the data
        file goes is refused, not written through."""
        self.ok("blur", "-i", self.p("outside", "x.hv"), "-o", self.p("h", "w.hv"), "--translate", "1,0,0",
                "--device", "host", "-q")
        with open(self.p("h", "w.hv")) as f:
            self.assertIn("name of data file := w.v\n", f.read())
        self.ok("compare", self.p("h", "w.hv"), self.p("h", "w.hv"))
        before = digest(self.p("outside", "x.v"))
        os.symlink("../outside/x.v", self.p("h", "l.v"))
        r = petblur("blur", "-i", self.p("h", "w.hv"), "-o", self.p("h", "l.hv"), "--translate", "1,0,0", "--device",
                    "host", "-q")
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("symbolic link", r.stderr)
        self.assertEqual(digest(self.p("outside", "x.v")), before)
        self.assertFalse(os.path.exists(self.p("h", "l.hv")))


if __name__ == "__main__":
    PETBLUR = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=2)
