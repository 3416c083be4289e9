"""petblur bench and the paper pipeline (bench/paper.sh --quick) on PoCL:
the numbers it reports are checked against numpy on the volumes it wrote, the
peers against the same reference, and the report against the paper's CSV.

usage: test_bench.py PATH/TO/petblur PATH/TO/bench
"""
import csv
import math
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

PETBLUR = BENCH = None
PAPER = None  # the paper's rows, from bench/paper_tables.csv


def run(*args, expect=0, cwd=None):
    p = subprocess.run([*map(str, args)], capture_output=True, text=True, timeout=1200, cwd=cwd)
    if p.returncode != expect:
        raise AssertionError(f"{' '.join(map(str, args))}: exit {p.returncode}, expected {expect}\n"
                             f"stdout: {p.stdout[-4000:]}\nstderr: {p.stderr[-4000:]}")
    return p.stdout, p.stderr


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(r for r in f if not r.startswith("#")))


def eq5(ref, x):
    ref, x = ref.astype(np.float64), x.astype(np.float64)
    return 100.0 * np.sum((x - ref) ** 2) / np.sum(ref ** 2)


def max_pct(ref, x):
    """Relative max error in percent: 100 max |x - ref| / max |ref|."""
    ref, x = ref.astype(np.float64), x.astype(np.float64)
    return 100.0 * np.abs(x - ref).max() / np.abs(ref).max()


def ab_slices_numpy(case):
    """The most slices AB visits, from the scenario alone: every voxel centre
    mapped through the frame's two poses into object texel coordinates."""
    n = np.array([int(case["nx"]), int(case["ny"]), int(case["nz"])])
    vs = np.array([float(case[k]) for k in ("vx", "vy", "vz")])
    t = np.array([float(case[k]) for k in ("tx", "ty", "tz")]) * vs
    a = math.radians(float(case["rot_deg"]))
    R = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    c = n * vs / 2
    z, y, x = np.meshgrid(*(np.arange(k) + 0.5 for k in n[::-1]), indexing="ij")
    u = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    start = u
    end = ((u * vs - c - t) @ R + c) / vs  # R^T applied to row vectors
    d = np.abs(end - start)
    m = np.argmax(d, axis=1)  # ties: the lower axis, as the kernel
    lo = np.minimum(start, end)[np.arange(len(m)), m] - 0.5
    hi = np.maximum(start, end)[np.arange(len(m)), m] - 0.5
    s = np.ceil(hi - 1e-6) - np.floor(lo + 1e-6) + 1
    s[hi - lo < 1e-4] = 1
    return int(s.max()), float(s.sum())


class Bench(unittest.TestCase):
    """One quick bench of the brain phantom under two motions, volumes kept."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.dir = os.path.join(cls.tmp.name, "run")
        cls.out, _ = run(PETBLUR, "bench", "--quick", "--device", "opencl", "--phantoms", "brain", "--scenarios",
                         "2,5", "--out-dir", cls.dir, "--keep-volumes", "-q")
        cls.results = rows(os.path.join(cls.dir, "results.csv"))
        cls.cases = rows(os.path.join(cls.dir, "cases.csv"))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def vol(self, case, path):
        shape = (int(case["nz"]), int(case["ny"]), int(case["nx"]))
        return np.fromfile(os.path.join(self.dir, path), dtype="<f4").reshape(shape)

    def test_every_method_and_filter_reported(self):
        got = {(r["scenario"], r["method"], r["filter"]) for r in self.results}
        want = {(s, m, f) for s in ("2", "5") for m in ("AB", "RM", "CL", "AB-E", "RM-E", "AB-C")
                for f in ("hardware", "exact")}
        want |= {("2", "REF", "exact"), ("5", "REF", "exact")}
        self.assertEqual(got, want)
        for r in self.results:
            self.assertEqual((r["nx"], r["ny"], r["nz"]), ("48", "48", "24"))
            self.assertGreater(float(r["kernel_ms"]), 0.0)
            if r["method"] != "REF":
                self.assertGreater(float(r["e2e_ms"]), 0.0)
                # The brain under these motions, quick grid: every method's eq. (5) well under 1 %; its relative
                # RMS is 10 sqrt(eq. (5)).
                self.assertLess(float(r["eq5_pct"]), 1.0, r)
                self.assertAlmostEqual(float(r["rms_pct"]) / (10 * float(r["eq5_pct"]) ** 0.5), 1.0, places=4)
                self.assertGreater(float(r["max_pct"]), 0.0, r)

    def test_reference_noise_is_eq5_of_the_two_references(self):
        for case in self.cases:
            r1, r2 = self.vol(case, case["ref_file"]), self.vol(case, case["ref2_file"])
            self.assertFalse(np.array_equal(r1, r2), "two seeds must draw different points")
            noise = eq5(r1, r2)
            self.assertAlmostEqual(float(case["ref_noise_eq5_pct"]) / noise, 1.0, places=4)
            self.assertAlmostEqual(float(case["ref_noise_rms_pct"]) / (10 * noise ** 0.5), 1.0, places=4)
            ref_row = next(r for r in self.results if r["scenario"] == case["scenario"] and r["method"] == "REF")
            self.assertAlmostEqual(float(ref_row["eq5_pct"]) / noise, 1.0, places=4)
            self.assertAlmostEqual(float(ref_row["max_pct"]) / max_pct(r1, r2), 1.0, places=4)

    def test_s_and_fetches_match_numpy(self):
        for case in self.cases:
            s, fetches = ab_slices_numpy(case)
            self.assertEqual(int(case["S"]), s)
            ab = next(r for r in self.results if r["scenario"] == case["scenario"] and r["method"] == "AB")
            self.assertAlmostEqual(float(ab["ab_fetches"]) / fetches, 1.0, places=6)

    def test_errors_recomputed_from_a_blur(self):
        """The bench's AB error equals eq. 5 of petblur blur's AB output
        against the bench's reference (same device, same motion)."""
        case = next(c for c in self.cases if c["scenario"] == "2")
        ph = os.path.join(self.dir, case["phantom_file"])
        out = os.path.join(self.tmp.name, "ab.raw")
        vs = ",".join(case[k] for k in ("vx", "vy", "vz"))
        t = ",".join(str(float(case[k]) * float(case[v])) for k, v in (("tx", "vx"), ("ty", "vy"), ("tz", "vz")))
        run(PETBLUR, "blur", "-i", ph, "-o", out, "--dims", "48,48,24", "--voxel-size", vs, "--translate", t,
            "--method", "ab", "--device", "opencl", "-q")
        ab = np.fromfile(out, dtype="<f4").reshape(24, 48, 48)
        ref = self.vol(case, case["ref_file"])
        want = eq5(ref, ab)
        row = next(r for r in self.results if r["scenario"] == "2" and r["method"] == "AB" and r["filter"] == "hardware")
        self.assertAlmostEqual(float(row["eq5_pct"]) / want, 1.0, places=4)
        self.assertAlmostEqual(float(row["rms_pct"]) / (10 * want ** 0.5), 1.0, places=4)
        self.assertAlmostEqual(float(row["max_pct"]) / max_pct(ref, ab), 1.0, places=4)

    def test_reference_from_an_earlier_run(self):
        other = os.path.join(self.tmp.name, "again")
        run(PETBLUR, "bench", "--quick", "--device", "opencl", "--phantoms", "brain", "--scenarios", "2",
            "--reference", self.dir, "--out-dir", other, "-q")
        again = {(r["method"], r["filter"]): r for r in rows(os.path.join(other, "results.csv"))}
        for r in self.results:
            if r["scenario"] == "2":
                # Same device, same kernels, same reference: the same numbers.
                for k in ("rms_pct", "max_pct", "eq5_pct"):
                    self.assertEqual(again[(r["method"], r["filter"])][k], r[k])

    def test_scipy_peer_against_the_same_reference(self):
        out = os.path.join(self.tmp.name, "peers.csv")
        run(sys.executable, os.path.join(BENCH, "peers.py"), os.path.join(self.dir, "cases.csv"), out,
            "--peers", "scipy", "--runs", "1")
        peers = rows(out)
        self.assertEqual(len(peers), 2)
        for p in peers:
            cl = next(r for r in self.results
                      if r["scenario"] == p["scenario"] and r["method"] == "CL" and r["filter"] == "exact")
            # The same classical blur with S samples everywhere (CL takes as many
            # per voxel as AB's slices, S at most): as accurate as CL, within the
            # reference's noise. A wrong pose convention would be off by whole %.
            noise = float(cl["ref_noise_eq5_pct"])
            self.assertLess(float(p["eq5_pct"]), float(cl["eq5_pct"]) + noise, p)
            self.assertGreater(float(p["time_ms"]), 0.0)

    def test_bad_inputs(self):
        empty = os.path.join(self.tmp.name, "empty")
        os.makedirs(empty, exist_ok=True)
        target = os.path.join(self.tmp.name, "bad")
        zeros = os.path.join(empty, "zeros.raw")
        with open(zeros, "wb") as f:
            f.write(bytes(8 * 8 * 8 * 4))
        for args, words in (
                (("--scenarios", "2,3,2"), "'2' is listed twice"),
                (("--phantoms", "homogeneity", "--brain", zeros, "--dims", "8,8,8"), "--phantoms leaves out"),
                (("--phantoms", "brain", "--brain", zeros, "--dims", "8,8,8"), "zero everywhere"),
                (("--reference", empty), "make them first"),
                (("--reference", self.dir, "--keep-volumes"), "--keep-volumes"),
                (("--phantoms", "brain,foo"), "unknown phantom"),
                (("--scenarios", "2,9"), "--scenarios"),
                (("--dims", "4,4,4"), "--brain"),
                (("--brain", os.path.join(empty, "none.nii")), "none.nii")):
            _, err = run(PETBLUR, "bench", "--quick", "--device", "opencl", "--out-dir", target, "-q", *args,
                         expect=2)
            self.assertTrue(err.startswith("petblur: ") and words in err, err)
            self.assertFalse(os.path.exists(os.path.join(target, "results.csv")))
            self.assertFalse([f for f in os.listdir(target) if f.startswith(".")] if os.path.isdir(target) else [])


    def test_brain_file_is_never_rewritten(self):
        d = os.path.join(self.tmp.name, "own")
        os.makedirs(os.path.join(d, "volumes"), exist_ok=True)
        brain = os.path.join(d, "volumes", "brain.raw")
        run(PETBLUR, "phantom", "--kind", "brain", "--dims", "16,16,8", "-o", brain)
        with open(brain, "rb") as f:
            before = f.read()
        _, err = run(PETBLUR, "bench", "--device", "opencl", "--phantoms", "brain", "--brain", brain, "--dims",
                     "16,16,8", "--scenarios", "2", "--runs", "1", "--points", "4", "--keep-volumes", "--out-dir", d,
                     "-q", expect=2)
        self.assertIn("choose another --out-dir", err)
        with open(brain, "rb") as f:
            self.assertEqual(f.read(), before)
        self.assertFalse(os.path.exists(os.path.join(d, "results.csv")))


class Pipeline(unittest.TestCase):
    """bench/paper.sh --quick end to end: bench, the CPU bench against the same
    references, the peers, the report."""

    def test_quick_pipeline(self):
        with tempfile.TemporaryDirectory() as tmp:
            d = os.path.join(tmp, "paper")
            env = dict(os.environ, PYTHON=sys.executable)
            p = subprocess.run(["bash", os.path.join(BENCH, "paper.sh"), os.path.dirname(os.path.dirname(
                os.path.dirname(PETBLUR))), d, "--quick", "--size", "16", "--points", "8", "--runs", "1",
                "--device", "opencl", "--cpu-device", "opencl"],
                capture_output=True, text=True, env=env, timeout=1200)
            self.assertEqual(p.returncode, 0, p.stdout[-3000:] + p.stderr[-3000:])
            res = rows(os.path.join(d, "results.csv"))
            self.assertEqual(len(res), 3 * 8 * 13)  # phantoms x motions x (12 methods + REF)
            for r in res:
                self.assertTrue(math.isfinite(float(r["rms_pct"])) and math.isfinite(float(r["max_pct"])), r)
            self.assertEqual(len(rows(os.path.join(d, "results-pocl.csv"))), 8 * 13)
            peers = rows(os.path.join(d, "peers.csv"))
            self.assertEqual({(r["phantom"], r["peer"]) for r in peers}, {("brain", "scipy")})
            self.assertFalse(os.path.exists(os.path.join(d, "volumes")), "the volumes are removed at the end")
            with open(os.path.join(d, "paper.md")) as f:
                md = f.read()
            for p_ in PAPER:  # every paper number appears beside ours
                for k in ("error_cl", "error_rm", "error_ab"):
                    self.assertIn("%.4f" % float(p_[k]), md)
            for title in ("Homogeneity phantom (Table 1)", "Derenzo phantom (Table 2)", "Brain phantom (Table 3)",
                          "## Targets", "PoCL against SciPy"):
                self.assertIn(title, md)
            long = rows(os.path.join(d, "paper.csv"))
            self.assertEqual(sum(r["source"] == "paper" for r in long), 3 * 8 * 3)
            for ph in ("homogeneity", "derenzo", "brain"):
                with open(os.path.join(d, f"plot-{ph}.png"), "rb") as f:
                    self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")


if __name__ == "__main__":
    PETBLUR, BENCH = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    PAPER = rows(os.path.join(BENCH, "paper_tables.csv"))
    unittest.main(argv=sys.argv[:1], verbosity=2)
