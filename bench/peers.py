#!/usr/bin/env python3
"""The tools a user would pick instead of petblur, run on the same volumes and
motions as `petblur bench` and compared with the same reference.

  torch: the classical blur a user writes in PyTorch on the GPU: for each of S
         poses, affine_grid + grid_sample (trilinear, zeros outside), summed
         and divided by S. Kernel time with CUDA events (warm-up, median),
         end-to-end time with the upload and download.
  cupy:  the same with cupyx.scipy.ndimage.affine_transform (order 1,
         grid-constant) on the GPU, CUDA events.
  scipy: the same on the CPU with scipy.ndimage.map_coordinates (order 1,
         grid-constant: zero outside, interpolated across the border).

S is the most slices AB visits on the case (cases.csv column S), the paper's
sample count; the poses sit at the midpoints of S equal pieces of the frame,
as petblur's CL takes them. Usage:

  peers.py CASES.csv OUT.csv [--peers torch,scipy] [--phantoms brain] [--runs N]

A peer whose library is missing is reported and left out (exit 0), so that
the report says what was not measured rather than failing the whole run.
"""
import argparse
import csv
import math
import os
import statistics
import sys
import time

import numpy as np


def pose_maps(case, S):
    """For each of the S poses: A (3x3) and b (3) with object texel coordinates
    o = A u + b of tomograph texel coordinates u (centre of voxel i at i + 0.5);
    axes x, y, z. The pose at frame fraction s: translation s t, rotation s deg
    about z through the grid's centre (LERP and SLERP from the identity)."""
    n = np.array([case["nx"], case["ny"], case["nz"]], dtype=float)
    vs = np.array([case["vx"], case["vy"], case["vz"]], dtype=float)
    t = np.array([case["tx"], case["ty"], case["tz"]], dtype=float) * vs
    c = 0.5 * n * vs
    maps = []
    for j in range(S):
        s = (j + 0.5) / S
        a = math.radians(case["rot_deg"] * s)
        R = np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
        # p_obj = R^T (p - c - s t) + c, in texels: divide by vs.
        A = np.diag(1.0 / vs) @ R.T @ np.diag(vs)
        b = (R.T @ (-c - s * t) + c) / vs
        maps.append((A, b))
    return maps


def errors_percent(ref, x):
    """Relative RMS and max error in percent, and the paper's eq. (5)."""
    ref = ref.astype(np.float64)
    x = x.astype(np.float64)
    eq5 = 100.0 * float(np.sum((x - ref) ** 2) / np.sum(ref ** 2))
    return 10.0 * eq5 ** 0.5, 100.0 * float(np.abs(x - ref).max() / np.abs(ref).max()), eq5


def load(path, case):
    return np.fromfile(path, dtype="<f4").reshape(case["nz"], case["ny"], case["nx"])


class TorchPeer:
    name = "torch"

    def __init__(self):
        import torch  # noqa: F401 (ImportError reports the peer as missing)
        self.torch = torch
        if not torch.cuda.is_available():
            raise ImportError("PyTorch finds no CUDA GPU")
        self.device = torch.device("cuda")
        self.label = "PyTorch %s grid_sample on %s" % (torch.__version__, torch.cuda.get_device_name(0))

    def thetas(self, case, S):
        n = np.array([case["nx"], case["ny"], case["nz"]], dtype=float)
        out = []
        for A, b in pose_maps(case, S):
            # Normalised coordinates (align_corners=False): xn = 2 u / n - 1.
            D1, D2 = np.diag(n / 2.0), np.diag(2.0 / n)
            M = D2 @ A @ D1
            off = M @ np.ones(3) + D2 @ b - 1.0
            out.append(np.hstack([M, off[:, None]]))
        return self.torch.tensor(np.stack(out), dtype=self.torch.float32, device=self.device)

    def blur(self, vol, thetas):
        F = self.torch.nn.functional
        acc = self.torch.zeros_like(vol)
        for j in range(thetas.shape[0]):
            grid = F.affine_grid(thetas[j:j + 1], list(vol.shape), align_corners=False)
            acc += F.grid_sample(vol, grid, mode="bilinear", padding_mode="zeros", align_corners=False)
        return acc / thetas.shape[0]

    def measure(self, host, case, S, runs):
        torch = self.torch
        thetas = self.thetas(case, S)
        vol = torch.from_numpy(host).to(self.device)[None, None]
        with torch.no_grad():
            out = self.blur(vol, thetas)  # warm-up
            torch.cuda.synchronize()
            ms = []
            for _ in range(runs):
                a, b = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
                a.record()
                out = self.blur(vol, thetas)
                b.record()
                b.synchronize()
                ms.append(a.elapsed_time(b))
            e2e = []
            for _ in range(min(runs, 5)):
                t0 = time.perf_counter()
                v = torch.from_numpy(host).to(self.device)[None, None]
                res = self.blur(v, thetas).cpu().numpy()[0, 0]
                e2e.append(1e3 * (time.perf_counter() - t0))
        return res, statistics.median(ms), statistics.median(e2e)


class CupyPeer:
    """cupyx.scipy.ndimage.affine_transform (order 1, zero outside) looped
    over the S poses on the GPU, summed and divided by S: SciPy's resampling
    as a CuPy user runs it."""
    name = "cupy"

    def __init__(self):
        import cupy
        import cupyx.scipy.ndimage
        self.cupy, self.ndimage = cupy, cupyx.scipy.ndimage
        if cupy.cuda.runtime.getDeviceCount() < 1:
            raise ImportError("CuPy finds no CUDA GPU")
        name = cupy.cuda.runtime.getDeviceProperties(0)["name"].decode()
        self.label = "CuPy %s affine_transform on %s" % (cupy.__version__, name)

    def maps(self, case, S):
        """Each pose as affine_transform takes it on a (z, y, x) array: index
        j = M i + off, from o = A u + b with u = i + 0.5, j = o - 0.5."""
        out = []
        for A, b in pose_maps(case, S):
            M = A[::-1, ::-1]
            off = (A @ np.full(3, 0.5) + b - 0.5)[::-1]
            out.append((self.cupy.asarray(M), tuple(float(v) for v in off)))
        return out

    def blur(self, vol, maps):
        acc = self.cupy.zeros_like(vol)
        for M, off in maps:
            acc += self.ndimage.affine_transform(vol, M, offset=off, order=1, mode="grid-constant", cval=0.0,
                                                 prefilter=False)
        return acc / len(maps)

    def measure(self, host, case, S, runs):
        cupy = self.cupy
        maps = self.maps(case, S)
        vol = cupy.asarray(host)
        res = self.blur(vol, maps)  # warm-up (and the kernels' compile)
        ms = []
        for _ in range(runs):
            a, b = cupy.cuda.Event(), cupy.cuda.Event()
            a.record()
            res = self.blur(vol, maps)
            b.record()
            b.synchronize()
            ms.append(cupy.cuda.get_elapsed_time(a, b))
        e2e = []
        for _ in range(min(runs, 5)):
            t0 = time.perf_counter()
            out = cupy.asnumpy(self.blur(cupy.asarray(host), maps))
            e2e.append(1e3 * (time.perf_counter() - t0))
        return out, statistics.median(ms), statistics.median(e2e)


class ScipyPeer:
    name = "scipy"

    def __init__(self):
        import scipy
        import scipy.ndimage  # noqa: F401
        self.ndimage = scipy.ndimage
        self.label = "SciPy %s map_coordinates on the CPU (one thread)" % scipy.__version__

    def blur(self, host, case, maps):
        nz, ny, nx = host.shape
        # Index coordinates (voxel i's centre at i) of every voxel, z, y, x.
        z, y, x = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
        u = np.stack([x.ravel() + 0.5, y.ravel() + 0.5, z.ravel() + 0.5])
        acc = np.zeros(host.size, dtype=np.float64)
        for A, b in maps:
            o = A @ u + b[:, None] - 0.5
            acc += self.ndimage.map_coordinates(host, o[::-1], order=1, mode="grid-constant", cval=0.0,
                                                prefilter=False)
        return (acc / len(maps)).astype(np.float32).reshape(host.shape)

    def measure(self, host, case, S, runs):
        maps = pose_maps(case, S)
        ms = []
        for r in range(runs):
            t0 = time.perf_counter()
            res = self.blur(host, case, maps)
            ms.append(1e3 * (time.perf_counter() - t0))
            if ms[-1] > 2000.0:  # one run of a slow case is enough to compare
                break
        t = statistics.median(ms)
        return res, t, t  # on the CPU, end to end is the whole time


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases")
    ap.add_argument("out")
    ap.add_argument("--peers", default="torch,scipy")
    ap.add_argument("--phantoms", default=None, help="comma-separated; default: every phantom in CASES")
    ap.add_argument("--scipy-phantoms", default="brain", help="phantoms SciPy runs on (default brain, as the issue)")
    ap.add_argument("--runs", type=int, default=10)
    a = ap.parse_args()
    with open(a.cases, newline="") as f:
        cases = list(csv.DictReader(f))
    for c in cases:
        for k in ("nx", "ny", "nz", "scenario", "S"):
            c[k] = int(c[k])
        for k in ("vx", "vy", "vz", "tx", "ty", "tz", "rot_deg"):
            c[k] = float(c[k])
    base = os.path.dirname(os.path.abspath(a.cases))
    peers = []
    for name in a.peers.split(","):
        cls = {"torch": TorchPeer, "cupy": CupyPeer, "scipy": ScipyPeer}.get(name)
        if cls is None:
            sys.exit("peers.py: unknown peer %r; choose torch, cupy and/or scipy" % name)
        try:
            peers.append(cls())
            print("peer %s: %s" % (name, peers[-1].label), flush=True)
        except ImportError as e:
            print("peer %s: not measured (%s)" % (name, e), flush=True)
    want = set(a.phantoms.split(",")) if a.phantoms else None
    rows = []
    for c in cases:
        if want and c["phantom"] not in want:
            continue
        vol = ref = None
        for p in peers:
            if p.name == "scipy" and c["phantom"] not in a.scipy_phantoms.split(","):
                continue
            if vol is None:
                # Paths in CASES are relative to its folder (or absolute).
                vol = load(os.path.join(base, c["phantom_file"]), c)
                ref = load(os.path.join(base, c["ref_file"]), c)
            res, ms, e2e = p.measure(vol, c, c["S"], a.runs)
            rms, mx, eq5 = errors_percent(ref, res)
            print("%-11s %d %-6s S=%-4d rms %8.4f %%  max %8.4f %%  eq5 %9.5f %%  %10.3f ms  (end to end %10.3f ms)"
                  % (c["phantom"], c["scenario"], p.name, c["S"], rms, mx, eq5, ms, e2e), flush=True)
            rows.append({"phantom": c["phantom"], "nx": c["nx"], "ny": c["ny"], "nz": c["nz"],
                         "scenario": c["scenario"], "peer": p.name, "device": p.label, "S": c["S"],
                         "rms_pct": "%.6g" % rms, "max_pct": "%.6g" % mx,
                         "eq5_pct": "%.6g" % eq5, "time_ms": "%.6g" % ms, "e2e_ms": "%.6g" % e2e})
    tmp = a.out + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["phantom", "nx", "ny", "nz", "scenario", "peer", "device", "S",
                                          "rms_pct", "max_pct", "eq5_pct", "time_ms", "e2e_ms"])
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, a.out)


if __name__ == "__main__":
    main()
