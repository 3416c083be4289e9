#!/usr/bin/env python3
"""A probe for issue 47: does a model of the series as a few tissue images, shared by every frame and each scaled by
its own curve, take the early-to-late bias out of petblur's track on a family draw (bench/estimate_family.py)?

bench/estimate_floor.py --anatomy bounds what an estimator can do when it learns the tissues' images from the frames:
far above the oracle's floor when the images are unconstrained, nearer it when each image is held to about its own
size. The model: the frames moved back onto frame 0's head by their poses (one a frame), a rank-r factorisation of
them (curves a frame times images a voxel, weighted by the counts' noise; the images with a ridge of `--prior` times
the activity's peak a voxel, 0: none). Its objective: every frame's weighted sum of squares against its model image
moved by its pose. From petblur's track (taken at the frames' middles) and from the truth's mean pose a frame, the
poses are refined by alternating (the images fitted, then every frame but 0 registered to its own by Gauss-Newton),
or (--joint-only) by damped Gauss-Newton steps on all poses at once with the images eliminated voxel by voxel, as the
bound eliminates them, each kept only where it lowers the objective with the images fitted again (alternating is not
a descent on the objective: the images are fitted to the frames moved back, not to the frames). --evaluate-only: the
objective at both starts, nothing refined; --start picks the start refined. The joint steps are linearised on the
frames moved back but judged on the frames, so they are not a descent on that objective: bench/anatomy_joint.py has
one objective. Scored as the family scores (bench/head_frames.py), beside petblur's own
track and the truth's mean pose a frame.

    python3 bench/anatomy_probe.py --petblur build/src/cli/petblur --seed 2128585388 --prior 0     # both, both starts
    python3 bench/anatomy_probe.py --petblur build/src/cli/petblur --seed 2128585388 --prior 0 --joint-only --rounds 8
"""
from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import estimate_family as ef  # noqa: E402
import head_frames as hf  # noqa: E402


def petblur_track(petblur: str, frames, affine, bounds) -> tuple:
    with tempfile.TemporaryDirectory() as tmp:
        nii, side = hf.write_series(tmp, frames, affine, bounds, "f")
        csv = os.path.join(tmp, "t.csv")
        subprocess.run([petblur, "motion", "estimate", nii, "--frames-from", side, "-o", csv, "--device", "host",
                        "-q"], check=True)
        return hf.read_matrix_csv(csv)


def one_pose_track(bounds, maps) -> tuple:
    """A track through one map a frame at its middle, held from the first and last bound."""
    mids = 0.5 * (bounds[:-1] + bounds[1:])
    return np.concatenate([[bounds[0]], mids, [bounds[-1]]]), np.array([maps[0]] + list(maps) + [maps[-1]])


# A factorisation of the moved-back frames: curves (K x r), images (r x N), the noise's weights (K x N) and their
# floor, and the images' ridge
Fit = collections.namedtuple("Fit", "c b w floor ridge")


class Model:
    def __init__(self, frames, affine, bounds):
        self.f = np.moveaxis(frames.astype(np.float64), -1, 0)          # K, x, y, z (counts a second)
        self.len = np.diff(bounds)
        self.affine, self.inv = affine, np.linalg.inv(affine)
        shape = self.f.shape[1:]
        idx = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), axis=-1).reshape(-1, 3)
        self.idx = idx.astype(np.float64)
        self.world = idx @ affine[:3, :3].T + affine[:3, 3]
        self.centre = self.world.mean(axis=0)
        self.shape = shape

    def where(self, m):
        """Frame 0's voxels in the index of a frame whose map is m: 3 x N."""
        w = self.inv @ m
        return (self.world @ w[:3, :3].T + w[:3, 3]).T

    def pulled_back(self, maps):
        """Frame k sampled where its map puts frame 0's voxels: K x N."""
        return np.array([ndimage.map_coordinates(self.f[k], self.where(m), order=1, mode="nearest")
                         for k, m in enumerate(maps)])

    def factorise(self, g, rank, prior, iterations=30) -> Fit:
        """Curves (K x r) and images (r x N) of the moved-back frames, weighted by the counts' noise (a frame's
        variance is its activity over its length), the images with a ridge of prior times the peak."""
        mean = np.maximum(np.average(g, axis=0, weights=self.len), 0.0)
        floor = 0.02 * mean.max()
        w = self.len[:, None] / np.maximum(mean, floor)[None]               # K x N
        u, s, vt = np.linalg.svd(g * np.sqrt(self.len)[:, None], full_matrices=False)
        c = u[:, :rank] * s[:rank] / np.sqrt(self.len)[:, None]
        b = vt[:rank]
        ridge = 0.0 if prior == 0 else 1.0 / (prior * mean.max()) ** 2
        for _ in range(iterations):
            scale = np.abs(c).max(axis=0)
            c, b = c / scale, b * scale[:, None]
            a = np.einsum("kn,kr,ks->nrs", w, c, c) + ridge * np.eye(rank)
            b = np.linalg.solve(a, np.einsum("kn,kr,kn->nr", w, c, g)[..., None])[..., 0].T
            a = np.einsum("kn,rn,sn->krs", w, b, b)
            c = np.linalg.solve(a, np.einsum("kn,rn,kn->kr", w, b, g)[..., None])[..., 0]
        return Fit(c, b, w, floor, ridge)

    def profile(self, maps, rank, prior) -> tuple:
        """The objective where the maps lie, the images fitted there; and that fit."""
        fit = self.factorise(self.pulled_back(maps), rank, prior)
        return self.objective(maps, fit), fit

    def register(self, k, m, image, floor, steps=3):
        """Frame k's map refined against image (frame 0's voxels), Gauss-Newton on a turn about the grid's centre
        and a shift, left of m."""
        r = self.world - self.centre
        for _ in range(steps):
            model, grad = self.frame_gradient(k, m, image)
            jac = -np.concatenate([grad, np.cross(r, grad)], axis=1)
            weight = self.len[k] / np.maximum(model.ravel(), floor)
            res = self.f[k].ravel() - model.ravel()
            step = np.linalg.solve((jac * weight[:, None]).T @ jac, (jac * weight[:, None]).T @ res)
            m = self.moved([m, m], step)[1]
        return m

    def frame_gradient(self, k, m, image):
        """Frame k's model (image moved by m) and its gradient in world mm, on frame k's voxels."""
        back = np.linalg.inv(m)
        w = self.inv @ back @ self.affine
        coords = (self.idx @ w[:3, :3].T + w[:3, 3]).T
        model = ndimage.map_coordinates(image.reshape(self.shape), coords, order=1, mode="nearest").reshape(
            self.shape)
        return model, np.stack(np.gradient(model), axis=-1).reshape(-1, 3) @ self.inv[:3, :3]

    def joint_system(self, maps, g, fit: Fit):
        """One Gauss-Newton step on every frame's pose at once (frame 0 held), the images eliminated voxel by voxel
        (as bench/estimate_floor.py's bound): moves along the directions where alternating the images and the poses
        crawls, a shift shared by frames of one contrast that their images take up."""
        c, w = fit.c, fit.w
        k_n, rank = c.shape
        res = g - c @ fit.b
        jac = []
        for k, m in enumerate(maps):
            _, grad = self.frame_gradient(k, m, c[k] @ fit.b)
            x = self.where(m)
            pulled = np.array([ndimage.map_coordinates(gr.reshape(self.shape), x, order=1, mode="nearest")
                               for gr in grad.T]).T                          # N x 3
            r = (self.world @ m[:3, :3].T + m[:3, 3]) - self.centre
            jac.append(np.concatenate([pulled, np.cross(r, pulled)], axis=1).T)  # 6 x N
        jac = np.array(jac)                                                   # K x 6 x N
        h = np.zeros((6 * k_n, 6 * k_n))
        rhs = np.zeros(6 * k_n)
        for lo in range(0, g.shape[1], 4096):
            sl = slice(lo, lo + 4096)
            ww, jj, rr = w[:, sl], jac[:, :, sl], res[:, sl]
            wj = jj * ww[:, None, :]
            for k in range(k_n):
                h[6 * k:6 * k + 6, 6 * k:6 * k + 6] += wj[k] @ jj[k].T
                rhs[6 * k:6 * k + 6] -= wj[k] @ rr[k]
            cc = np.einsum("kr,kin->nrki", c, wj).reshape(ww.shape[1], rank, 6 * k_n)
            a = np.einsum("kn,kr,ks->nrs", ww, c, c) + fit.ridge * np.eye(rank)
            h -= np.einsum("nrk,nrl->kl", cc, np.linalg.solve(a, cc))
            rhs += np.einsum("nrk,nr->k", cc, np.linalg.solve(a, np.einsum("kn,kr,kn->nr", ww, c, rr)[..., None])[
                ..., 0])
        return h[6:, 6:], rhs[6:]

    def moved(self, maps, step):
        """Every frame's map but frame 0's moved by its six numbers (a shift, a turn about the grid's centre)."""
        step = np.concatenate([np.zeros(6), step])
        k_n = len(maps)
        out = [maps[0]]
        for k in range(1, k_n):
            d = step[6 * k:6 * k + 6]
            e = np.eye(4)
            e[:3, :3] = Rotation.from_rotvec(d[3:]).as_matrix()
            e[:3, 3] = self.centre - e[:3, :3] @ self.centre + d[:3]
            out.append(e @ maps[k])
        return out

    def objective(self, maps, fit: Fit):
        """The frames' weighted sum of squares against their model images moved by their maps."""
        total = 0.0
        for k, m in enumerate(maps):
            model, _ = self.frame_gradient(k, m, fit.c[k] @ fit.b)
            total += np.sum(self.len[k] * (self.f[k] - model) ** 2 / np.maximum(model, fit.floor))
        return total


def refine(model: Model, maps, rank, prior, rounds=5, joint=False, extrapolate=False):
    """Alternating (each frame registered to its model image), or joint: damped Gauss-Newton steps on all poses
    at once, each kept only where it lowers the objective."""
    maps = [m.copy() for m in maps]
    damping = 1e-3
    for _ in range(rounds):
        g = model.pulled_back(maps)
        fit = model.factorise(g, rank, prior)
        if not joint:
            for k in range(1, len(maps)):
                maps[k] = model.register(k, maps[k], fit.c[k] @ fit.b, fit.floor)
            continue
        h, rhs = model.joint_system(maps, g, fit)
        before = model.objective(maps, fit)
        if extrapolate:  # the step's direction, taken 1, 2, 4 and 8 times: the best of them
            step = np.linalg.solve(h + damping * np.diag(np.diag(h)), rhs)
            best = (before, None)
            for scale in (1.0, 2.0, 4.0, 8.0):
                trial = model.moved(maps, scale * step)
                after, _ = model.profile(trial, rank, prior)  # the images follow
                print(f"    joint x{scale:g}: {before:.1f} -> {after:.1f}", flush=True)
                if after < best[0]:
                    best = (after, trial)
                else:
                    break
            if best[1] is None:
                break
            maps = best[1]
            continue
        for _ in range(6):
            trial = model.moved(maps, np.linalg.solve(h + damping * np.diag(np.diag(h)), rhs))
            after, _ = model.profile(trial, rank, prior)  # the images follow
            print(f"    joint: {before:.1f} -> {after:.1f} (damping {damping:g})", flush=True)
            if after < before:
                maps, damping = trial, damping / 3
                break
            damping *= 10
        else:
            break
    return maps, model.profile(maps, rank, prior)[0]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--petblur", required=True)
    p.add_argument("--seed", type=int, action="append", required=True)
    p.add_argument("--prior", type=float, action="append", help="the images' ridge, times the peak; 0: none")
    p.add_argument("--rank", type=int, default=4)
    p.add_argument("--joint-only", action="store_true", help="the joint steps alone")
    p.add_argument("--start", choices=("petblur", "truth", "both"), default=None,
                   help="where refinement starts: petblur's track, the truth's mean poses, or both (the default; "
                   "petblur alone with --joint-only)")
    p.add_argument("--alternating-only", action="store_true", help="from petblur's track and the truth's, "
                   "alternating alone: which the objective prefers")
    p.add_argument("--evaluate-only", action="store_true", help="the objective at both starts, nothing refined")
    p.add_argument("--rounds", type=int, default=5, help="joint rounds")
    p.add_argument("--extrapolate", action="store_true", help="each joint step taken up to 8 times as far")
    p.add_argument("--out")
    a = p.parse_args()
    lines = []
    for seed in a.seed:
        d = ef.draw(seed)
        rng = np.random.default_rng([seed, 1])
        frames, affine, bounds, truth = ef.simulate(d, rng)
        points = hf.head_points(rng)

        def score(times, maps):
            return hf.displacement_errors(hf.track_maps(times, maps), truth, bounds, points)

        times, maps = petblur_track(a.petblur, frames, affine, bounds)
        at = hf.track_maps(times, maps)
        mids = 0.5 * (bounds[:-1] + bounds[1:])
        start = [at(t) for t in mids]
        truth_times, truth_maps = ef.frame_means(truth, bounds)
        row = {"seed": seed, "from_injection": d.start_s == 0.0, "petblur": score(times, maps),
               "petblur_one_pose": score(*one_pose_track(bounds, start)),
               "truth_one_pose": score(truth_times, truth_maps)}
        model = Model(frames, affine, bounds)
        truth_start = list(truth_maps[1:-1])  # one map a frame, without the bounds' copies
        for prior in a.prior or [1.0]:
            if a.evaluate_only:  # the objective where each start lies, before any refinement
                for start_name, s0 in (("petblur", start), ("truth", truth_start)):
                    row[f"prior {prior:g} at {start_name} objective"] = model.profile(s0, a.rank, prior)[0]
                    print(start_name, row[f"prior {prior:g} at {start_name} objective"], flush=True)
                continue
            which = a.start or ("petblur" if a.joint_only else "both")
            for start_name, s0 in (("petblur", start), ("truth", truth_start)):
                if which not in (start_name, "both"):
                    continue
                for joint in (True,) if a.joint_only else (False,) if a.alternating_only else (False, True):
                    name = f"prior {prior:g} from {start_name}{' joint' if joint else ''}"
                    maps_out, obj = refine(model, s0, a.rank, prior, rounds=a.rounds if joint else 5, joint=joint,
                                           extrapolate=a.extrapolate)
                    row[name] = score(*one_pose_track(bounds, maps_out))
                    row[name + " objective"] = obj
                    print(name, round(float(row[name].mean()), 3), obj, flush=True)
        line = {k: (round(float(v.mean()), 3) if isinstance(v, np.ndarray) else v) for k, v in row.items()}
        print(json.dumps(line), flush=True)
        print("  per frame:", {k: " ".join(f"{x:.2f}" for x in v) for k, v in row.items()
                               if isinstance(v, np.ndarray)}, flush=True)
        lines.append(line)
    if a.out:
        os.makedirs(a.out, exist_ok=True)
        with open(os.path.join(a.out, "probe.jsonl"), "a") as f:
            for line in lines:
                f.write(json.dumps(line) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
