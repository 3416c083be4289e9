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
    python3 bench/estimate_floor.py --anatomy --seed 123 --out /tmp/floor   # the images learnt from the frames

With --anatomy the estimator is not given the activity: every voxel's image of each tissue is a parameter all
frames share (anatomy_unknown says what it may assume of them), and all frames' poses are bounded together.
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
        if k not in self.scale:  # the frame's scale, as counts sets it
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


def pulled_back(frames: Frames) -> tuple:
    """Every frame's expected counts (K, N) and pose derivatives (K, 6, N) at the truth, carried back onto the head
    as it lay in frame 0 (each frame sampled, trilinearly, where its mid-time truth puts frame 0's voxels); each
    tissue's coefficient in each frame (K, 4): frame k's counts are sum_j a[k, j] B_j moved by its pose, B_j tissue
    j's image after the scanner's blur (which, isotropic in mm, turns with the head); and the B_j (4, N), frame 0's
    counts from each tissue alone."""
    d = frames.d
    b = frames.bounds
    mids = 0.5 * (b[:-1] + b[1:])
    to_index = np.linalg.inv(ef.affine_of(d))
    world, shape = frames.scene.world, d.shape
    back = np.linalg.inv(frames.truth(mids[0]))
    lam, jac, a = [], [], []
    for k in range(len(mids)):
        m = to_index @ frames.truth(mids[k]) @ back
        idx = (world @ m[:3, :3].T + m[:3, 3]).T
        resample = lambda v: ndimage.map_coordinates(v.reshape(shape), idx, order=1, mode="constant")  # noqa: E731
        lam.append(resample(frames.counts(k)))
        jac.append([resample(g) for g in frames.jacobian(k)])
        a.append(frames.scale[k] * ef.uptake(d, mids[k]))
    return np.array(lam), np.array(jac), np.array(a), frames.tissue_counts(0)


def anatomy_information(lam: np.ndarray, jac: np.ndarray, a: np.ndarray, variants: dict, chunk: int = 4096) -> tuple:
    """The Fisher information (6K x 6K) about all K frames' poses together when the tissues' images are unknown, for
    each of variants ({name: (free, prior)}): tissue j's blurred image at voxel n a free parameter where free[n, j]
    (else known), shared by all frames, the curves a (frame k's counts from tissue j at its peak) known. The images
    are eliminated voxel by voxel (a voxel's counts over the frames are independent of the other voxels', and its
    images are its own): the pose block's Schur complement. Each image has a prior of `prior` times its own peak a
    voxel (a Gaussian's spread): else two tissues whose curves differ by a part in 10^5 (a late scan's) make an image
    that only a trend over the frames scales, 10^5 times the tissue's own, free to take up any drift. Also the
    information with the anatomy known, block diagonal (each frame's own). One pass over the voxels serves every
    variant: a tissue held where it is not free drops out of a voxel's cross terms and of its images' information."""
    k_n, n = lam.shape
    w = np.where(lam > 1e-9 * lam.max(), 1.0 / np.maximum(lam, 1e-300), 0.0)  # Poisson: 1 / variance
    known = np.zeros((6 * k_n, 6 * k_n))
    lost = {name: np.zeros_like(known) for name in variants}
    for lo in range(0, n, chunk):
        ww, g = w[:, lo:lo + chunk], jac[:, :, lo:lo + chunk]
        wg = g * ww[:, None, :]                                          # K, 6, n
        for k in range(k_n):
            known[6 * k:6 * k + 6, 6 * k:6 * k + 6] += wg[k] @ g[k].T
        cross = np.einsum("kr,kin->nrki", a, wg).reshape(ww.shape[1], a.shape[1], 6 * k_n)
        images = np.einsum("kn,kr,ks->nrs", ww, a, a)
        for name, (free, prior) in variants.items():
            f = free[lo:lo + chunk]
            c = cross * f[:, :, None]
            amat = images * f[:, :, None] * f[:, None, :] + np.eye(a.shape[1]) / prior ** 2
            # pinv: where no frame sees a voxel, tissues of one curve leave amat singular beside the data's weights
            lost[name] += np.einsum("nrk,nrl->kl", c, np.linalg.pinv(amat, rcond=1e-13, hermitian=True) @ c)
    return {name: known - lost[name] for name in variants}, known


# What an estimator may assume of the tissues' images, as a prior's spread a voxel in units of each image's peak:
# unconstrained (any image an estimator that projects frames onto images learnt from other frames could take), and
# of about its own size (a zero-mean prior of one peak covers every image a tissue can have; the floor is a van Trees
# bound then, the data's information taken at the truth)
FREE, RANGE = 100.0, 1.0


def anatomy_unknown(d: ef.Draw, trials: int = 400, seed: int = 0, support: float = 0.01) -> dict:
    """The floor when the estimator must learn the anatomy from the frames (the tissues' images unknown, their curves
    known: a lower bound for one that knows neither), all frames' poses together and relative to frame 0's: with the
    images unconstrained ("free"), each of about its own size ("range"), free only where each tissue lies (its image
    in frame 0 above `support` of its peak: "support", a prior that knows where each tissue is, not its image), and
    known ("known", the oracle of floor() on the same pulled-back frames, frame 0 held)."""
    frames, pj = Frames(d), point_jacobian(d)
    lam, jac, a, tissues = pulled_back(frames)
    a = a / a[0] * tissues.max(axis=1)  # each tissue's image in units of its peak
    k_n = len(lam)
    where = (tissues > support * tissues.max(axis=1, keepdims=True)).T.astype(float)
    everywhere = np.ones_like(where)
    unknown, known = anatomy_information(lam, jac, a, {"support": (where, FREE), "range": (everywhere, RANGE),
                                                       "free": (everywhere, FREE)})
    infos = {"known": known, **unknown}
    out = {"seed": d.seed, "frames": k_n, "from_injection": d.start_s == 0.0, "counts_per_voxel": d.counts_per_voxel,
           "contrast_singular_values": [float(x) for x in np.linalg.svd(a / np.linalg.norm(a, axis=0),
                                                                          compute_uv=False)]}
    rng = np.random.default_rng(seed)
    for name, info in infos.items():
        cov = np.linalg.inv(info[6:, 6:])
        out[f"{name}_frame_rms_mm"] = [0.0] + [rms_mm(pj, cov[6 * i:6 * i + 6, 6 * i:6 * i + 6])
                                               for i in range(k_n - 1)]
        e = rng.multivariate_normal(np.zeros(len(cov)), cov, size=trials).reshape(trials, k_n - 1, 6)
        per = np.linalg.norm(np.einsum("nai,tki->tkna", pj, e), axis=-1).mean(axis=-1)  # trials, K - 1
        means = per.sum(axis=1) / k_n
        out[f"{name}_mean_median"] = float(np.median(means))
        out[f"{name}_mean_p90"] = float(np.percentile(means, 90))
        out[f"{name}_worst_median"] = float(np.median(per.max(axis=1)))
    return out


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


def anatomy_table(out: list, path: str) -> int:
    kinds = (("known", "anatomy known"), ("support", "where each tissue lies known"),
             ("range", "images of their own size"), ("free", "images unconstrained"))
    lines = ["| draw | frames | from injection | counts a voxel | " + " | ".join(w for _, w in kinds) +
             " | petblur | SimpleITK | one pose a frame |", "|---" * 11 + "|"]
    cell = lambda b, k: f"{b[k]:.3f}" if k in b else ""  # noqa: E731
    for b in out:
        lines.append(f"| {b['seed']} | {b['frames']} | {'yes' if b['from_injection'] else 'no'} | "
                     f"{b['counts_per_voxel']:.1f} | " + " | ".join(
                         f"{b[m + '_mean_median']:.3f} / {b[m + '_mean_p90']:.3f}" for m, _ in kinds) +
                     f" | {cell(b, 'petblur')} | {cell(b, 'sitk')} | {cell(b, 'frame_means')} |")
    lines += ["", "Each floor: the median / 90th percentile of the draw's mean error (mm) over 400 draws from it.", ""]
    for m, what in kinds:
        v = np.array([b[m + "_mean_median"] for b in out])
        p90 = np.array([b[m + "_mean_p90"] for b in out])
        lines.append(f"- {what}: the floor's median {np.median(v):.3f} mm (range {v.min():.3f}-{v.max():.3f}); "
                     f"draws whose floor's median is above 0.6 mm: {int(np.sum(v > 0.6))}, whose 90th percentile "
                     f"is: {int(np.sum(p90 > 0.6))} of {len(v)}")
        with_p = [b for b in out if "petblur" in b]
        if with_p:
            ratio = np.array([b["petblur"] / b[m + "_mean_median"] for b in with_p])
            lines[-1] += f"; petblur over it {np.median(ratio):.2f} (median; {ratio.min():.2f}-{ratio.max():.2f})"
    open(path, "w").write("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


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
    p.add_argument("--anatomy", action="store_true",
                   help="the floor with the tissues' images learnt from the frames instead (unconstrained, of their "
                   "own size, or free where each tissue lies), all poses together: anatomy.jsonl and anatomy.md")
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
    name = "anatomy" if a.anatomy else "floor"
    path = os.path.join(a.out, name + ".jsonl")
    done = {}
    if a.anatomy and os.path.exists(path):  # hours of CPU: a run taken up again keeps the draws it has
        done = {b["seed"]: b for b in map(json.loads, open(path))}
    with open(path, "a" if done else "w") as f:
        for r in rows:
            if r["seed"] in done:
                out.append(done[r["seed"]])
                continue
            d = ef.draw(r["seed"])
            b = anatomy_unknown(d) if a.anatomy else floor(d, uptake_unknown=a.uptake_unknown)
            for who in ("petblur", "sitk", "frame_means"):
                v = sitk.get(r["seed"]) if who == "sitk" and r["seed"] in sitk else r.get(who, {}).get("mean_mm")
                if v is not None and np.isfinite(v):
                    b[who] = v
            f.write(json.dumps(b) + "\n")
            f.flush()
            out.append(b)
            print(json.dumps(b), flush=True)
    if a.anatomy:
        return anatomy_table(out, os.path.join(a.out, "anatomy.md"))
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
