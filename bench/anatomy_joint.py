#!/usr/bin/env python3
"""A probe for issue 47: the shared-anatomy model of bench/anatomy_probe.py fitted where the frames are, with every
unknown at once.

anatomy_probe.py fits the tissue images to the frames moved back onto frame 0's head, and scores the poses by the
frames against those images moved forward: two criteria, so its joint steps are not steps on the objective they are
judged by (from the truth's mean poses on 4208755960 not even a step of damping 333 lowered it). Here one weighted
sum of squares, on each frame's own voxels, is all there is: frame k is modelled as sum_r c[k, r] T_k b[r], b the r
tissue images on frame 0's grid, c the curves and T_k the trilinear map of frame 0's grid to frame k's voxels under
its pose (one pose a frame, frame 0 held). The weights are fixed, a frame's length over its smoothed activity (the
counts' variance), so that every objective compared is the same function. Levenberg-Marquardt steps on images, curves
and poses together, each solved by LSQR on the whole Jacobian (columns scaled to unit norm); a step is kept only
where it lowers the objective: first --image-rounds with the poses held, then --rounds on every unknown. Those
steps leave the images far from fitted (LSQR stops at its iteration limit, and free curves crawl), so the objectives
they reach do not compare poses. --evaluate does: at petblur's track, the truth's mean poses and where an earlier
run's refinements ended, the images fitted by conjugate gradients with the curves' shapes known (fit_images).
--stepwise holds the head still inside every frame, so that one pose a frame describes the series exactly.
--alternate descends on that objective from each --start (the images fitted, then each frame's pose).
--known-curves gives each frame's scale as well (the curves known, as the floor has them), so that the images are
one linear least-squares problem, which conjugate gradients preconditioned by each voxel's block solve (400 and
1 600 iterations give the same objective to 6e-11 of it on 4208755960); with the scales free and a diagonal preconditioner they had not
converged, and a descent's objective mixed the images' progress with the poses'. --prior and --blur constrain the
images (a prior of each tissue's own size, as the floor's "range"; the images blurred). With trilinear maps the
objective has a cusp wherever a frame's map crosses the grid on noisy frames (--profile shows one frame's squares
along a line); --smooth compares the frames and the model after one Gaussian, which removes it
(bench/results/2026-12-01_cpu2_anatomy-prior).

    python3 bench/anatomy_joint.py --petblur build/src/cli/petblur --seed 4208755960 --start truth --start petblur
    python3 bench/anatomy_joint.py --petblur build/src/cli/petblur --seed 4208755960 --stepwise --out DIR
    python3 bench/anatomy_joint.py --petblur build/src/cli/petblur --seed 4208755960 --stepwise \
        --evaluate DIR/joint.jsonl --out DIR
    python3 bench/anatomy_joint.py --petblur build/src/cli/petblur --seed 4208755960 --stepwise --start truth \
        --known-curves --alternate 8 --out DIR
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse import linalg as splinalg

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import anatomy_probe as ap  # noqa: E402
import estimate_family as ef  # noqa: E402
import estimate_floor as ef_floor  # noqa: E402
import head_frames as hf  # noqa: E402


class FrameSpace:
    """The series, its fixed weights and the trilinear maps of frame 0's grid to each frame's voxels."""

    def __init__(self, model: ap.Model, smooth=None):
        self.m = model
        self.shape = model.shape
        self.n = int(np.prod(self.shape))
        self.k = model.f.shape[0]
        self.f = model.f.reshape(self.k, -1)
        self.smooth = smooth
        activity = np.array([ndimage.gaussian_filter(fk, 1.0) for fk in model.f]).reshape(self.k, -1)
        mean = np.average(activity, axis=0, weights=model.len)
        floor = 0.02 * mean.max()
        self.s = np.sqrt(model.len[:, None] / np.maximum(activity, floor))        # K x N
        self.r = model.world - model.centre                                        # N x 3
        if smooth is not None:  # the frames and the model compared after the same smoothing (Smoothed)
            self.f = np.array([smooth(fk) for fk in self.f])

    def warp(self, m):
        """T (N x N) and its derivatives along frame 0's index axes, for a frame whose map is m; and the chain
        from frame 0's index to the frame's world (3 x 3)."""
        inv = self.m.inv @ np.linalg.inv(m)
        x = (self.m.world @ inv[:3, :3].T + inv[:3, 3])                           # N x 3, frame 0's index
        dims = np.array(self.shape)
        inside = np.all((x >= 0) & (x <= dims - 1), axis=1)
        x = np.clip(x, 0, dims - 1)
        i0 = np.minimum(np.floor(x).astype(np.int64), dims - 2)
        fr = x - i0
        rows, cols, w, dw = [], [], [], [[], [], []]
        strides = np.array([self.shape[1] * self.shape[2], self.shape[2], 1])
        for corner in range(8):
            o = np.array([(corner >> 2) & 1, (corner >> 1) & 1, corner & 1])
            f1 = np.where(o, fr, 1 - fr)                                            # N x 3
            sign = np.where(o, 1.0, -1.0)
            rows.append(np.arange(self.n))
            cols.append((i0 + o) @ strides)
            w.append(f1.prod(axis=1))
            for a in range(3):
                others = np.prod(np.delete(f1, a, axis=1), axis=1)
                dw[a].append(sign[a] * others * inside)
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        t = sparse.csr_matrix((np.concatenate(w), (rows, cols)), shape=(self.n, self.n))
        d = [sparse.csr_matrix((np.concatenate(v), (rows, cols)), shape=(self.n, self.n)) for v in dw]
        if self.smooth is not None:
            t, d = Smoothed(t, self.smooth), [Smoothed(v, self.smooth) for v in d]
        return t, d, inv[:3, :3]

    def state(self, maps, b, c):
        """What every evaluation needs: each frame's warp, model image and residual (weighted)."""
        warps = [self.warp(m) for m in maps]
        model = np.array([warps[k][0] @ (c[k] @ b) for k in range(self.k)])
        return warps, model, self.s * (self.f - model)

    def frame_squares(self, k, t, image) -> float:
        """Frame k's weighted squares against image moved by its map t."""
        return float(np.sum((self.s[k] * (self.f[k] - t @ image)) ** 2))

    def objective(self, maps, b, c) -> float:
        return float(np.sum(self.state(maps, b, c)[2] ** 2))

    def squared_columns(self, ts):
        """Each frame's weighted squared norm of every column of its T (N a frame): the images' columns' scales
        (lm) and the images' Jacobi preconditioner (fit_images)."""
        if self.smooth is not None:  # for preconditioners only: the smoothing's effect on a column taken as its shrink
            return [self.smooth.shrink * (t.raw.multiply(t.raw).T @ self.s[k] ** 2) for k, t in enumerate(ts)]
        return [t.multiply(t).T @ self.s[k] ** 2 for k, t in enumerate(ts)]

    def pose_columns(self, warps, b, c):
        """d(model)/d(pose) of every frame but 0, unweighted: K x N x 6 (frame 0's zero)."""
        out = np.zeros((self.k, self.n, 6))
        for k in range(1, self.k):
            t, d, chain = warps[k]
            image = c[k] @ b
            raw = [getattr(dk, "raw", dk) for dk in d]
            g_idx = np.stack([dk @ image for dk in raw], axis=1)                    # N x 3, along frame 0's index
            g = g_idx @ chain                                                        # along the frame's world
            out[k] = -np.concatenate([g, np.cross(self.r, g)], axis=1)
            if self.smooth is not None:
                out[k] = np.stack([self.smooth(col) for col in out[k].T], axis=1)
        return out


class Smoothed:
    """A frame's map followed by a smoothing (Blur): the model compared with the frames smoothed alike, so that the
    map's own averaging at a fractional offset, which on noisy frames gives the objective a cusp wherever a map
    crosses the grid (bench/results/2026-12-01_cpu2_anatomy-prior), is small beside the smoothing's."""

    def __init__(self, raw, smooth):
        self.raw, self.smooth = raw, smooth

    def __matmul__(self, x):
        return self.smooth(self.raw @ x)

    @property
    def T(self):
        outer = self

        class Transposed:
            def __matmul__(self, y):
                return outer.raw.T @ outer.smooth(y)
        return Transposed()


class Stepwise(ef.Truth):
    """The draw's motion held at its pose at each frame's middle over the whole frame: a series that one pose a frame
    describes exactly, so that what the model cannot hold (motion inside frames) is out of the comparison."""

    def __call__(self, t: float) -> np.ndarray:
        b = np.asarray(self.d.bounds)
        k = int(np.clip(np.searchsorted(b, t, side="right") - 1, 0, len(b) - 2))
        return super().__call__(0.5 * (b[k] + b[k + 1]))

    def changes(self, t0: float, t1: float) -> bool:
        return False


def fit_images(fs: FrameSpace, warps, x, shapes, outer=6, iterations=400, log=print, prior=None, blur=None,
               scales=None):
    """The images that fit the frames best with the poses held (warps: each frame's T), the curves' shapes given
    (shapes: K x r, each frame's mean level of each tissue) and each frame's scale free: alternating, the images by
    conjugate gradients on their normal equations (preconditioned by each voxel's block, at most `iterations` a
    round) and the scales exactly. With the curves' shapes known the images
    are a linear least-squares problem, which a rank-r factorisation with free curves (the Levenberg-Marquardt steps)
    only crawls towards. What the objective at a set of poses is, compared fairly: as bench/estimate_floor.py
    --anatomy bounds it (curves known, images free). prior (r x r, or None): a Gaussian prior on the images, the
    term b[:, n]' prior b[:, n] a voxel added to the objective; the scales are then held at median 1, the images
    taking the factor, since a prior on the images alone would trade them for ever larger scales. blur (a symmetric
    linear map of one image, or None): the images are blur(u), u free (the scanner's resolution known), where
    else they may hold detail finer than it, and with it the frames' noise. x: the unknowns to start from (b, or u
    with a blur); returns the images, the curves, the objective and the unknowns. scales (K, or None): each
    frame's scale known (the curves known, as the floor has them): the images then a linear least-squares problem
    with nothing to alternate with."""
    rank = x.shape[0]
    w2 = fs.s ** 2
    sq = fs.squared_columns(warps)
    back = np.array([warps[k].T @ (w2[k] * fs.f[k]) for k in range(fs.k)])        # K x N
    scale = np.ones(fs.k) if scales is None else np.asarray(scales, float)
    g = (lambda v: np.array([blur(vr) for vr in v])) if blur else (lambda v: v)
    shrink = blur.shrink if blur else 1.0  # the blur's effect on the diagonal, for the preconditioner
    for it in range(outer):
        c = shapes * scale[:, None]
        # block Jacobi: each voxel's r x r block of the normal matrix, whose curves the frames' weights make
        # ill-conditioned voxel by voxel (the early frames' counts are the blood's) where a diagonal left conjugate
        # gradients at their iteration cap
        block = np.einsum("kn,kr,ks->nrs", np.array(sq), c, c)
        if prior is not None:
            block = block + prior[None]
        block = block * shrink
        ridge = 1e-9 * np.trace(block, axis1=1, axis2=2).mean() / rank
        inverse = np.linalg.inv(block + ridge * np.eye(rank)[None])

        def normal(v):
            b = g(v.reshape(rank, fs.n))
            out = np.zeros((rank, fs.n))
            for k in range(fs.k):
                out += c[k][:, None] * (warps[k].T @ (w2[k] * (warps[k] @ (c[k] @ b))))[None]
            if prior is not None:
                out += prior @ b
            return g(out).ravel() + ridge * v

        rhs = g(c.T @ back).ravel()
        op = splinalg.LinearOperator((rank * fs.n,) * 2, matvec=normal)
        pre = splinalg.LinearOperator((rank * fs.n,) * 2, matvec=lambda v: np.einsum(
            "nrs,sn->rn", inverse, v.reshape(rank, fs.n)).ravel())
        x, info = splinalg.cg(op, rhs, x0=x.ravel(), rtol=1e-7, maxiter=iterations, M=pre)
        x = x.reshape(rank, fs.n)
        b = g(x)
        model = np.array([warps[k] @ (shapes[k] @ b) for k in range(fs.k)])
        if scales is not None:
            new = scale
        else:
            new = np.sum(w2 * model * fs.f, axis=1) / np.sum(w2 * model * model, axis=1)
        obj = float(np.sum(w2 * (fs.f - new[:, None] * model) ** 2))
        if scales is None and prior is not None:
            norm = np.median(new)
            new, b, x = new / norm, b * norm, x * norm
        if prior is not None:
            obj += float(np.sum(b * (prior @ b)))
        log(f"    images and scales {it}: {obj:.1f} (cg {'converged' if info == 0 else info}; scales moved "
            f"{np.abs(new / scale - 1).max():.1e})")
        scale = new
    return b, shapes * scale[:, None], obj, x


class Blur:
    """The scanner's blur (a Gaussian, sigma in voxels a axis) on one flat image: symmetric, as zero padding keeps
    it. shrink: the sum of the kernel's squares, what it scales a column's squared norm by."""

    def __init__(self, shape, sigma):
        self.shape, self.sigma = shape, np.asarray(sigma, float)
        self.shrink = float(np.prod([np.sum(ndimage.gaussian_filter1d(np.eye(1, 41, 20)[0], s) ** 2)
                                     for s in self.sigma]))

    def __call__(self, v):
        return ndimage.gaussian_filter(v.reshape(self.shape), self.sigma, mode="constant").ravel()


def alternate(fs: FrameSpace, maps, x, shapes, rounds, pose_errors, log=print, prior=None, blur=None, scales=None,
              outer=2, iterations=400):
    """Descent on the one objective with the curves' shapes known: the images and scales fitted (fit_images, warm),
    then each frame's pose by Gauss-Newton against its own model image, kept where its frame's squares fall."""
    for rnd in range(rounds):
        warps = [fs.warp(m) for m in maps]
        b, c, obj, x = fit_images(fs, [w[0] for w in warps], x, shapes, outer, iterations, lambda *_: None, prior,
                                  blur, scales)
        res = fs.s * (fs.f - np.array([warps[k][0] @ (c[k] @ b) for k in range(fs.k)]))
        pose = fs.pose_columns(warps, b, c)
        new = list(maps)
        for k in range(1, fs.k):
            j = pose[k] * fs.s[k][:, None]
            step = np.linalg.solve(j.T @ j, j.T @ res[k])
            for scale in (1.0, 0.5, 0.25):
                trial = fs.m.moved([maps[0], maps[k]], scale * step)[1]
                t = fs.warp(trial)[0]
                if fs.frame_squares(k, t, c[k] @ b) < np.sum(res[k] ** 2):
                    new[k] = trial
                    break
        maps = new
        log(f"    round {rnd}: objective {obj:.1f} before the poses; poses {pose_errors(maps).mean():.3f} mm")
    obj = fit_images(fs, [fs.warp(m)[0] for m in maps], x, shapes, outer, iterations, lambda *_: None, prior, blur,
                     scales)[2]
    return maps, obj


def lm(fs: FrameSpace, maps, b, c, rounds, images_only=False, log=print, iterations=200):
    """Levenberg-Marquardt on images, curves and (unless images_only) poses; each step by LSQR."""
    rank = b.shape[0]
    nb, nc, npz = rank * fs.n, fs.k * rank, 0 if images_only else 6 * (fs.k - 1)
    damp = 1e-2
    warps, model, res = fs.state(maps, b, c)
    obj = float(np.sum(res ** 2))
    log(f"    start {obj:.1f}")
    for rnd in range(rounds):
        pose = None if images_only else fs.pose_columns(warps, b, c)
        tb = np.array([[warps[k][0] @ b[r] for r in range(rank)] for k in range(fs.k)])  # K x r x N
        # column scales: unit norm of each weighted column
        sq = fs.squared_columns([w[0] for w in warps])
        sb = sum((c[k] ** 2)[:, None] * sq[k][None] for k in range(fs.k))
        sb = 1.0 / np.sqrt(np.maximum(sb, 1e-30))
        sc = 1.0 / np.sqrt(np.maximum(np.einsum("krn,kn->kr", tb ** 2, fs.s ** 2), 1e-30))
        sp = None if images_only else 1.0 / np.sqrt(np.maximum(np.einsum("knp,kn->kp", pose ** 2, fs.s ** 2)[1:],
                                                                  1e-30))

        def matvec(x):
            xb = x[:nb].reshape(rank, fs.n) * sb
            xc = x[nb:nb + nc].reshape(fs.k, rank) * sc
            y = np.empty((fs.k, fs.n))
            for k in range(fs.k):
                y[k] = warps[k][0] @ (c[k] @ xb) + xc[k] @ tb[k]
                if not images_only and k:
                    y[k] += pose[k] @ (x[nb + nc + 6 * (k - 1):nb + nc + 6 * k] * sp[k - 1])
            return (fs.s * y).ravel()

        def rmatvec(y):
            y = y.reshape(fs.k, fs.n) * fs.s
            xb = np.zeros((rank, fs.n))
            xc = np.zeros((fs.k, rank))
            xp = np.zeros((max(fs.k - 1, 0), 6))
            for k in range(fs.k):
                back = warps[k][0].T @ y[k]
                xb += c[k][:, None] * back[None]
                xc[k] = tb[k] @ y[k]
                if not images_only and k:
                    xp[k - 1] = pose[k].T @ y[k]
            out = [(xb * sb).ravel(), (xc * sc).ravel()]
            if not images_only:
                out.append((xp * sp).ravel())
            return np.concatenate(out)

        op = splinalg.LinearOperator((fs.k * fs.n, nb + nc + npz), matvec=matvec, rmatvec=rmatvec)
        for attempt in range(6):
            t0 = time.time()
            x = splinalg.lsqr(op, res.ravel(), damp=damp, iter_lim=iterations, atol=1e-8, btol=1e-8)[0]
            nb_ = b + x[:nb].reshape(rank, fs.n) * sb
            nc_ = c + x[nb:nb + nc].reshape(fs.k, rank) * sc
            nm = maps if images_only else fs.m.moved(maps, (x[nb + nc:].reshape(fs.k - 1, 6) * sp).ravel())
            new = fs.objective(nm, nb_, nc_)
            log(f"    round {rnd} damp {damp:g}: {obj:.1f} -> {new:.1f} ({time.time() - t0:.0f} s)")
            if new < obj:
                maps, b, c, damp = nm, nb_, nc_, damp / 3
                warps, model, res = fs.state(maps, b, c)
                obj = float(np.sum(res ** 2))
                break
            damp *= 10
        else:
            break
    return maps, b, c, obj


def profile(fs: FrameSpace, maps, b, c, spec: str) -> list:
    """One frame's weighted squares along a line of translations through its pose, the images and curves held: how
    the objective looks to that frame's pose alone (spec: 'K:x,y,z', mm in the world)."""
    k, v = spec.split(":")
    k, v = int(k), np.array([float(x) for x in v.split(",")])
    out = []
    for step in np.linspace(-1.5, 1.5, 13):
        m = maps[k].copy()
        m[:3, 3] += step * v
        t = fs.warp(m)[0]
        out.append([round(float(step), 3), round(fs.frame_squares(k, t, c[k] @ b), 2)])
    return out


def frame_scales(d: ef.Draw, bounds, truth) -> np.ndarray:
    """Each frame's scale as simulate sets it (its counts as its length over its activity's sum), in the units
    where frame k is scale[k] times sum_r levels[k, r] times tissue r's image at unit level: with the curves' shapes,
    the curves known (what the floor assumes), at the instants simulate renders."""
    scene, lens = ef.Scene(d), np.diff(bounds)
    out = []
    for k in range(len(lens)):
        acc = np.mean([scene.sample(truth(t), t) for t in ef.instants(truth, bounds[k], bounds[k + 1])], axis=0)
        total = ndimage.gaussian_filter(acc.astype(np.float64), scene.sigma, mode="constant").sum()
        out.append(d.counts_per_voxel * scene.head / lens.mean() / total)
    return np.array(out)


def tissue_peaks(d: ef.Draw, bounds, unit=False) -> np.ndarray:
    """Each tissue's peak a voxel, what a prior of an image's own size is measured against (only its order of
    magnitude matters). With unit, its image's peak at unit level (frame_scales' units); else in the units its image
    takes when the frames' scales have median 1 (fit_images with a prior and free scales): frame k's noise-free rate
    from it at its peak voxel over its level is the peak times frame k's scale, so the median over frames is the peak
    at the median scale."""
    if unit:
        scene = ef.Scene(d)
        t = 0.5 * (bounds[0] + bounds[1])
        m = ef.Truth(d)(t)
        return np.array([ndimage.gaussian_filter(scene.sample(m, t, np.eye(len(ef.uptake(d, t)))[r]).astype(
            np.float64), scene.sigma, mode="constant").max() for r in range(len(ef.uptake(d, t)))])
    frames = ef_floor.Frames(d)
    lens = np.diff(bounds)
    per = []
    for k in range(len(lens)):
        tc = frames.tissue_counts(k)                                          # r x N, frame k's counts
        levels = ef.uptake(d, 0.5 * (bounds[k] + bounds[k + 1]))
        rate = tc.max(axis=1) / lens[k]
        per.append(np.where(levels > 1e-3 * levels.max(), rate / np.maximum(levels, 1e-300), np.nan))
    per = np.array(per)
    return np.nanmedian(per, axis=0)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--petblur", required=True)
    p.add_argument("--seed", type=int, action="append", required=True)
    p.add_argument("--start", choices=("petblur", "truth"), action="append")
    p.add_argument("--rank", type=int, default=4)
    p.add_argument("--image-rounds", type=int, default=6, help="rounds with the poses held, at each start")
    p.add_argument("--rounds", type=int, default=10, help="rounds on every unknown")
    p.add_argument("--stepwise", action="store_true", help="the head held still inside every frame (Stepwise)")
    p.add_argument("--counts", type=float, help="counts a voxel in an average frame instead of the draw's")
    p.add_argument("--evaluate", help="a joint.jsonl of an earlier run: the objective with the images fitted "
                   "exactly (fit_images) at petblur's track, the truth and where each start's refinement ended")
    p.add_argument("--alternate", type=int,
                   help="instead of --evaluate: this many rounds of alternate() from each --start")
    p.add_argument("--prior", type=float,
                   help="with --evaluate or --alternate: a Gaussian prior on each tissue's image, this many times "
                   "its peak a voxel (bench/estimate_floor.py's 'range' is 1)")
    p.add_argument("--blur", type=float,
                   help="with --evaluate or --alternate: the images blurred (Blur) by a Gaussian of this sigma in "
                   "voxels; 0: the scanner's own")
    p.add_argument("--known-curves", action="store_true",
                   help="with --evaluate or --alternate: each frame's scale known as well (frame_scales)")
    p.add_argument("--cg", type=int, default=400, help="conjugate gradients' iterations a fit")
    p.add_argument("--profile", help="with --evaluate: K:x,y,z (mm), frame K's weighted squares with the images "
                   "held as fitted, its pose moved by s times that translation, s from -1.5 to 1.5 (profile)")
    p.add_argument("--smooth", type=float, help="the frames and the model compared after a Gaussian of this sigma "
                   "in voxels (Smoothed)")
    p.add_argument("--out")
    a = p.parse_args()
    for seed in a.seed:
        d = ef.draw(seed)
        if a.counts:
            d = dataclasses.replace(d, counts_per_voxel=a.counts)
        rng = np.random.default_rng([seed, 1])
        frames, affine, bounds, truth = ef.simulate(d, rng, truth=Stepwise(d) if a.stepwise else None)
        points = hf.head_points(rng)

        def score(maps):
            return hf.displacement_errors(hf.track_maps(*ap.one_pose_track(bounds, maps)), truth, bounds, points)

        truth_maps = ef.frame_means(truth, bounds)[1][1:-1]

        def pose_errors(maps):
            """Each frame's pose against the truth's mean pose over it: the error of one pose a frame, which the
            track's interpolation between frames (score) adds to where the head moves inside or between frames."""
            return np.array([np.linalg.norm((points @ (m - t)[:3, :3].T + (m - t)[:3, 3]), axis=1).mean()
                             for m, t in zip(maps, truth_maps)])

        model = ap.Model(frames, affine, bounds)
        fs = FrameSpace(model, Blur(model.shape, a.smooth * np.ones(3)) if a.smooth else None)
        row = {"seed": seed, "from_injection": d.start_s == 0.0, "stepwise": a.stepwise,
               "counts_per_voxel": d.counts_per_voxel, "smooth": a.smooth}
        starts = {}
        if "petblur" in (a.start or ["petblur", "truth"]):
            times, tmaps = ap.petblur_track(a.petblur, frames, affine, bounds)
            at = hf.track_maps(times, tmaps)
            starts["petblur"] = [at(t) for t in 0.5 * (bounds[:-1] + bounds[1:])]
            row["petblur"] = float(hf.displacement_errors(at, truth, bounds, points).mean())
        if "truth" in (a.start or ["petblur", "truth"]):
            starts["truth"] = list(truth_maps)
        if a.evaluate or a.alternate:
            for line in open(a.evaluate) if a.evaluate else []:
                old = json.loads(line)
                if old["seed"] == seed and old.get("stepwise", False) == a.stepwise:
                    for name in ("petblur", "truth"):
                        if f"from {name} maps" in old:
                            starts[f"{name} refined"] = [np.array(m) for m in old[f"from {name} maps"]]

            def mean_uptake(k):  # at the instants simulate renders the frame at
                return np.mean([ef.uptake(d, t) for t in ef.instants(truth, bounds[k], bounds[k + 1])], axis=0)

            shapes = np.array([mean_uptake(k) for k in range(len(bounds) - 1)])
            # the same span with orthonormal columns, weighted by the frames' lengths (the counts' weights): the
            # curves' fourth singular value is 1e-4 of the first, which conjugate gradients on the tissues' own
            # images do not converge under
            root = np.sqrt(model.len)[:, None]
            q, rmat = np.linalg.qr(shapes * root)
            shapes = q / root
            prior, scales, outer = None, None, 2
            if a.known_curves:
                scales, outer = frame_scales(d, bounds, truth), 1
                row["known curves"] = True
            blur = None
            if a.blur is not None:
                blur = Blur(model.shape, a.blur * np.ones(3) if a.blur else ef.Scene(d).sigma)
                row["blur"] = [float(v) for v in blur.sigma]
            if a.prior:
                # the images in the orthonormal span are rmat times the tissues' own: the prior on those
                spread = a.prior * tissue_peaks(d, bounds, scales is not None)
                inv = np.linalg.inv(rmat)
                prior = inv.T @ np.diag(1.0 / spread ** 2) @ inv
                row["prior"] = a.prior
                row["tissue peaks"] = [float(v) for v in spread / a.prior]
            for name, maps in starts.items():
                fit = model.factorise(model.pulled_back(maps), a.rank, 0.0)
                b0 = np.linalg.lstsq(shapes, fit.c @ fit.b, rcond=None)[0]             # a start near the images
                if a.alternate:
                    maps, obj = alternate(fs, maps, b0, shapes, a.alternate, pose_errors, prior=prior, blur=blur,
                                          scales=scales, outer=outer, iterations=a.cg)
                    name = f"{name} alternated"
                else:
                    b, c, obj, _ = fit_images(fs, [fs.warp(m)[0] for m in maps], b0, shapes,
                                              6 if scales is None else 1, a.cg, prior=prior, blur=blur, scales=scales)
                    if a.profile:
                        row[f"{name} profile"] = profile(fs, maps, b, c, a.profile)
                        print(f"{seed} {name} profile of frame {a.profile}: {row[f'{name} profile']}", flush=True)
                row[f"{name} profiled"] = obj
                row[f"{name} poses"] = float(pose_errors(maps).mean())
                row[f"{name} poses per frame"] = " ".join(f"{v:.2f}" for v in pose_errors(maps))
                row[f"{name} maps"] = np.round(np.array(maps), 6).tolist()
                print(f"{seed} {name}: poses {row[f'{name} poses']:.3f} mm, objective {obj:.1f}", flush=True)
            print(json.dumps(row), flush=True)
            if a.out:
                os.makedirs(a.out, exist_ok=True)
                with open(os.path.join(a.out, "evaluate.jsonl"), "a") as f:
                    f.write(json.dumps(row) + "\n")
            continue
        for name, maps in starts.items():
            fit = model.factorise(model.pulled_back(maps), a.rank, 0.0)
            print(f"{seed} from {name}: {score(maps).mean():.3f} mm, poses {pose_errors(maps).mean():.3f} mm",
                  flush=True)
            maps, b, c, obj = lm(fs, maps, fit.b, fit.c, a.image_rounds, images_only=True)
            row[f"{name} images fitted"] = obj
            print(f"  images fitted: {obj:.1f}", flush=True)
            maps, b, c, obj = lm(fs, maps, b, c, a.rounds)
            e, pe = score(maps), pose_errors(maps)
            row[f"from {name}"] = float(e.mean())
            row[f"from {name} poses"] = float(pe.mean())
            row[f"from {name} poses per frame"] = " ".join(f"{v:.2f}" for v in pe)
            row[f"from {name} maps"] = np.round(np.array(maps), 6).tolist()
            row[f"from {name} objective"] = obj
            row[f"from {name} per frame"] = " ".join(f"{v:.2f}" for v in e)
            print(f"  joint: {e.mean():.3f} mm (poses {pe.mean():.3f}), {obj:.1f}; per frame "
                  f"{row[f'from {name} per frame']}; poses {row[f'from {name} poses per frame']}", flush=True)
        print(json.dumps(row), flush=True)
        if a.out:
            os.makedirs(a.out, exist_ok=True)
            with open(os.path.join(a.out, "joint.jsonl"), "a") as f:
                f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
