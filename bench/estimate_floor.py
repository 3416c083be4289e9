#!/usr/bin/env python3
"""The counts' floor under motion from the frames (issue 47): how well one pose a frame could be known at all.

For a draw of bench/estimate_family.py, each frame's Fisher information about its six pose numbers from its Poisson
counts, given the frame's activity exactly (an oracle no estimator has: it knows every tissue's uptake at that time):
I = sum over voxels of (d lambda / d pose)(d lambda / d pose)^T / lambda, lambda the frame's expected counts (the
family's own rendering, before its noise; the smoothing after the counts is invertible and adds nothing), its
derivatives by central differences of that rendering under the pose moved about the draw's pivot. Its inverse
(Cramer-Rao) bounds an unbiased pose's covariance. Errors are what the family measures: the displacement of the
family's points inside the head between each frame's pose and the truth's, relative to frame 0 (whose own pose is as
uncertain as its counts make it), mean over the points, then over the frames: drawn 400 times from those covariances,
each frame's error independent, the draw's mean error's median and 90th percentile.

It bounds one pose a frame found from the frame's counts alone; an estimate that pools frames held still (a smoother
along the series) can go below it, one whose model of the activity is wrong stays above it. Read beside the family's
petblur and SimpleITK columns: how much of a draw's error the counts explain.

    python3 bench/estimate_floor.py --draws bench/results/RUN/draws.jsonl --out /tmp/floor    # beside a run's draws
    python3 bench/estimate_floor.py --seed 123 --seed 456 --out /tmp/floor
    python3 bench/estimate_floor.py --check 123 0 16 --out /tmp/floor    # the bound against maximum likelihood
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import estimate_family as ef  # noqa: E402
import head_frames as hf  # noqa: E402

# Central differences: mm of translation, degrees of turn about the pivot
STEPS = np.array([0.3, 0.3, 0.3, 0.2, 0.2, 0.2])


class Frames:
    """A draw's frames as estimate_family.simulate renders them, before their counts: each frame's expected counts
    at its mid-time, the head moved further by pose numbers x (translation mm, turn degrees about the pivot)."""

    def __init__(self, d: ef.Draw):
        self.d, self.truth, self.scene = d, ef.Truth(d), ef.Scene(d)
        self.bounds = np.array(d.bounds)
        self.pivot = np.array(d.pivot)
        self.scale = {}

    def _render(self, m, t, levels=None):
        img = self.scene.sample(m, t, levels).astype(np.float64)
        return ndimage.gaussian_filter(img, self.scene.sigma, mode="constant")

    def pose(self, x):
        m = np.eye(4)
        r = Rotation.from_rotvec(np.deg2rad(x[3:])).as_matrix()
        m[:3, :3] = r
        m[:3, 3] = self.pivot - r @ self.pivot + x[:3]
        return m

    def counts(self, k, x=np.zeros(6)):
        """Frame k's expected counts a voxel (flat), the head moved by x after the truth."""
        b, d = self.bounds, self.d
        t = 0.5 * (b[k] + b[k + 1])
        img = self._render(self.pose(x) @ self.truth(t), t)
        if k not in self.scale:  # as simulate scales a frame: its counts as its length
            lengths = np.diff(b)
            base = img if not np.any(x) else self._render(self.truth(t), t)
            self.scale[k] = d.counts_per_voxel * self.scene.head * lengths[k] / lengths.mean() / base.sum()
        return (img * self.scale[k]).ravel()

    def jacobian(self, k, x=np.zeros(6)):
        return np.array([(self.counts(k, x + STEPS[i] * np.eye(6)[i]) - self.counts(k, x - STEPS[i] * np.eye(6)[i]))
                         / (2 * STEPS[i]) for i in range(6)])

    def tissue_counts(self, k):
        """Frame k's expected counts from each tissue alone (grey, white, blood, lesions): the derivatives by each
        tissue's level, relative (d / d log level)."""
        b = self.bounds
        t = 0.5 * (b[k] + b[k + 1])
        self.counts(k)
        levels = ef.uptake(self.d, t)
        return np.array([(self._render(self.truth(t), t, levels * np.eye(len(levels))[c]) * self.scale[k]).ravel()
                         for c in range(len(levels))])


def fisher(frames: Frames, k: int, uptake_unknown: bool = False) -> np.ndarray:
    """Frame k's 6 x 6 Fisher information about its pose numbers, from its Poisson counts; with uptake_unknown, what
    is left of it when each tissue's level in the frame is unknown too (the pose block of the information's inverse,
    inverted: the Schur complement)."""
    lam, g = frames.counts(k), frames.jacobian(k)
    if uptake_unknown:
        g = np.concatenate([g, frames.tissue_counts(k)])
    info = (g / np.maximum(lam, 1e-12)) @ g.T
    return np.linalg.inv(np.linalg.inv(info)[:6, :6]) if uptake_unknown else info


def point_jacobian(d: ef.Draw) -> np.ndarray:
    """The displacement (mm) per unit pose number at the family's points inside the head."""
    points = hf.head_points(np.random.default_rng([d.seed, 1]), 1000) - np.array(d.pivot)
    jac = np.zeros((len(points), 3, 6))
    jac[:, :, :3] = np.eye(3)
    for i in range(3):
        jac[:, :, 3 + i] = np.deg2rad(1.0) * np.cross(np.eye(3)[i], points)
    return jac


def rms_mm(jac: np.ndarray, cov: np.ndarray) -> float:
    """RMS displacement over the points of a pose error of covariance cov."""
    return float(np.sqrt(np.mean(np.einsum("nai,ij,naj->n", jac, cov, jac))))


def ml_spread(d: ef.Draw, k: int, n: int, seed: int = 12345) -> tuple:
    """The bound's check: frame k's pose by maximum likelihood (Fisher scoring on the Poisson likelihood from the
    truth, the activity known, the derivatives taken at the truth: the poses are tenths of a millimetre off it) on n
    fresh draws of its counts; the RMS displacement of those poses, and the bound's."""
    frames, jac = Frames(d), point_jacobian(d)
    lam0, g = frames.counts(k), frames.jacobian(k)
    bound = rms_mm(jac, np.linalg.inv(fisher(frames, k)))
    rng, est = np.random.default_rng(seed), []
    for _ in range(n):
        y = rng.poisson(lam0).astype(float)
        x = np.zeros(6)
        for _ in range(3):
            lam = np.maximum(frames.counts(k, x), 1e-12)
            x = x + np.linalg.solve((g / lam) @ g.T, g @ (y / lam - 1.0))
        est.append(x)
    e = np.array(est)
    return rms_mm(jac, e.T @ e / n), bound


def floor(d: ef.Draw, trials: int = 400, seed: int = 0, uptake_unknown: bool = False) -> dict:
    frames, jac = Frames(d), point_jacobian(d)
    covs = [np.linalg.inv(fisher(frames, k, uptake_unknown)) for k in range(len(d.bounds) - 1)]
    rng = np.random.default_rng(seed)
    means, worsts = [], []
    for _ in range(trials):
        e = [rng.multivariate_normal(np.zeros(6), c) for c in covs]
        per = [0.0] + [np.linalg.norm(jac @ (e[k] - e[0]), axis=1).mean() for k in range(1, len(e))]
        means.append(np.mean(per))
        worsts.append(np.max(per))
    return {"seed": d.seed, "frames": len(covs), "from_injection": d.start_s == 0.0,
            "counts_per_voxel": d.counts_per_voxel, "frame0_s": d.bounds[1] - d.bounds[0],
            "frame0_rms_mm": rms_mm(jac, covs[0]), "mean_median": float(np.median(means)),
            "mean_p90": float(np.percentile(means, 90)), "worst_median": float(np.median(worsts))}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--draws", help="a family run's draws.jsonl: its seeds, with its petblur and SimpleITK beside")
    p.add_argument("--seed", type=int, action="append", help="a draw to bound (repeatable)")
    p.add_argument("--sitk-from", help="a draws.jsonl whose SimpleITK column to put beside (estimate_family.py "
                   "--sitk-only's)")
    p.add_argument("--check", type=int, nargs=3, metavar=("SEED", "FRAME", "N"),
                   help="the bound's check instead: frame FRAME of draw SEED by maximum likelihood on N count draws")
    p.add_argument("--uptake-unknown", action="store_true",
                   help="each tissue's level in each frame unknown too (the anatomy known, not the tracer's curves)")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    if a.check:
        seed, k, n = a.check
        spread, bound = ml_spread(ef.draw(seed), k, n)
        line = (f"draw {seed} frame {k}: maximum likelihood on {n} draws of its counts {spread:.3f} mm RMS, "
                f"the bound {bound:.3f} mm")
        os.makedirs(a.out, exist_ok=True)
        open(os.path.join(a.out, "check.txt"), "a").write(line + "\n")
        print(line)
        return 0
    rows = [json.loads(line) for line in open(a.draws)] if a.draws else []
    sitk = {}
    if a.sitk_from:
        for line in open(a.sitk_from):
            r = json.loads(line)
            sitk[r["seed"]] = r.get("sitk", {}).get("mean_mm")
    if a.seed:
        rows += [{"seed": s} for s in a.seed]
    if not rows:
        p.error("give --draws or --seed")
    os.makedirs(a.out, exist_ok=True)
    out = []
    with open(os.path.join(a.out, "floor.jsonl"), "w") as f:
        for r in rows:
            b = floor(ef.draw(r["seed"]), uptake_unknown=a.uptake_unknown)
            for who in ("petblur", "sitk", "frame_means"):
                v = sitk.get(r["seed"]) if who == "sitk" and r["seed"] in sitk else r.get(who, {}).get("mean_mm")
                if v is not None and np.isfinite(v):
                    b[who] = v
            f.write(json.dumps(b) + "\n")
            f.flush()
            out.append(b)
            print(json.dumps(b), flush=True)
    lines = ["| draw | frames | from injection | counts a voxel | frame 0 (s) | frame 0's pose, RMS mm | floor: median / "
             "90th mean mm | petblur | SimpleITK | one pose a frame |", "|---|---|---|---|---|---|---|---|---|---|"]
    for b in out:
        cell = lambda k: f"{b[k]:.3f}" if k in b else ""  # noqa: E731
        lines.append(f"| {b['seed']} | {b['frames']} | {'yes' if b['from_injection'] else 'no'} | "
                     f"{b['counts_per_voxel']:.1f} | {b['frame0_s']:.0f} | {b['frame0_rms_mm']:.3f} | "
                     f"{b['mean_median']:.3f} / {b['mean_p90']:.3f} | {cell('petblur')} | {cell('sitk')} | "
                     f"{cell('frame_means')} |")
    with_p = [b for b in out if "petblur" in b]
    if with_p:
        ratio = np.array([b["petblur"] / b["mean_median"] for b in with_p])
        lines += ["", f"petblur over the floor's median, per draw: median {np.median(ratio):.2f}, "
                      f"range {ratio.min():.2f}-{ratio.max():.2f} ({len(ratio)} draws)"]
    open(os.path.join(a.out, "floor.md"), "w").write("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
