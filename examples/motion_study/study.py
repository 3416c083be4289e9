#!/usr/bin/env python3
"""Motion-compensated reconstruction of a moving head: what intra-frame blur
in the system model buys, against the truth.

Truth: petblur's brain phantom (three hot lesions). Motion: a 30 Hz head
track (head_motion.py: drift, nod, seizure-like jerk). Data, made without
petblur's operator: in each frame the activity at many closely spaced times,
moved by scipy.ndimage.affine_transform (trilinear) and averaged, projected by
the ASTRA toolbox's 2-D parallel-beam strip projector slice by slice (its
sparse matrix), with a uniform background and Poisson noise. Reconstructions:
MLEM over all frames at once (one static image), the same iterations, with the
system model A B_k of frame k for
  (a) no motion model (B = I),
  (b) one pose per frame, the frame's mean pose (STIR's and SIRF's way),
  (c) constant-pose sub-frames, one per tracked interval (CASToR's way;
      petblur CL, one sample per interval),
  (d) petblur AB, the paper's one-segment polyline (frame start to end),
  (e) petblur AB on the whole track, the default path bound,
  (f) data acquired without motion, no model: the ideal,
  (g) petblur AB as (e), on the track estimated from the data alone: the
      acquisition cut into short frames (10 s), each reconstructed by the
      same MLEM without a motion model, and petblur.Motion.from_frames on
      them (no tracker).
Metrics against the truth at every iteration: NRMSE inside the brain, each
lesion's contrast recovery, background variability in white matter, and the
time spent in the projector and in the blur.

  study.py --preset full --device cuda --out DIR     (the GPU machine: torch)
  study.py --preset small --device opencl --out DIR  (CI: numpy, PoCL)
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np
from scipy import ndimage, sparse

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import head_motion  # noqa: E402
import petblur  # noqa: E402

PRESETS = {
    # grid, voxel mm, angles, frames (s), iterations, poses per frame in the data (4 and 2 a second: the
    # 2 s jerk gets 8 and 4), counts per frame; (g): short frames (s) and their MLEM iterations
    "full": dict(dims=(128, 128, 64), voxel=(2.2, 2.2, 2.8), angles=180, frame_s=60.0, frames=4, iterations=40,
                 poses=240, counts=3e7, methods="abcdefg", short_s=10.0, short_iterations=10),
    "small": dict(dims=(48, 48, 24), voxel=(5.87, 5.87, 7.47), angles=60, frame_s=60.0, frames=4, iterations=15,
                  poses=120, counts=3e6, methods="abdefg", short_s=10.0, short_iterations=10),
}
# The phantom's lesions (src/cli/phantoms/phantom_brain.c): world centre mm, radius mm, activity.
LESIONS = [((44.0, 52.0, 30.0), 4.0, 8.0), ((-28.0, -24.0, 4.0), 5.0, 6.0), ((22.0, -56.0, -40.0), 3.0, 7.0)]
LABELS = {"a": "(a) no motion model", "b": "(b) one pose per frame (mean)", "c": "(c) sub-frames, one pose each",
          "d": "(d) petblur, one segment per frame", "e": "(e) petblur, default path bound",
          "f": "(f) no motion (ideal)", "g": "(g) petblur, track estimated from 10 s frames"}


def find_cli():
    env = os.environ.get("PETBLUR_CLI")
    root = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
    for c in [env] + [os.path.join(root, d, "src/cli/petblur") for d in ("build", "build-test", "build-gpu")] + \
            [shutil.which("petblur")]:
        if c and os.access(c, os.X_OK):
            return c
    sys.exit("study.py: the petblur program makes the phantom; build it or set PETBLUR_CLI")


def phantom(cli, dims, voxel, work):
    import nibabel as nib
    path = os.path.join(work, "truth.nii")
    subprocess.run([cli, "phantom", "-q", "--kind", "brain", "--dims", ",".join(map(str, dims)),
                    "--voxel-size", ",".join(map(str, voxel)), "-o", path], check=True)
    img = nib.load(path)
    return np.ascontiguousarray(img.get_fdata(dtype=np.float32)), img.affine


def projector_matrix(n, angles, cache=None):
    """ASTRA's 2-D parallel-beam strip projector on an n x n slice, as a
    sparse matrix (rays x pixels, the pixel of slice[i, j] at i * n + j).
    cache: an .npz that holds it (made here when missing): the GPU machine
    cannot load ASTRA's wheel (it needs CUDA 12's cudart and cuFFT), so the
    matrix ASTRA made travels there as a file."""
    if cache and os.path.exists(cache):
        z = np.load(cache)
        if int(z["n"]) != n or int(z["angles"]) != angles:
            sys.exit(f"study.py: {cache} holds the matrix of {int(z['n'])} pixels and {int(z['angles'])} angles, "
                     f"not {n} and {angles}; delete it to make it anew")
        return sparse.csr_matrix((z["data"], z["indices"], z["indptr"]), shape=tuple(z["shape"]))
    W = _astra_matrix(n, angles)
    if cache:
        np.savez_compressed(cache, data=W.data, indices=W.indices.astype(np.int32),
                            indptr=W.indptr.astype(np.int32), shape=W.shape, n=n, angles=angles)
    return W


def _astra_matrix(n, angles):
    import astra
    vg = astra.create_vol_geom(n, n)
    pg = astra.create_proj_geom("parallel", 1.0, int(np.ceil(n * 1.45)), np.linspace(0, np.pi, angles,
                                                                                      endpoint=False))
    pid = astra.create_projector("strip", pg, vg)
    mid = astra.projector.matrix(pid)
    W = astra.matrix.get(mid).astype(np.float32).tocsr()
    astra.matrix.delete(mid)
    astra.projector.delete(pid)
    return W


class Projector:
    """y = A x slice by slice along z, and its transpose: scipy on the host,
    torch sparse on a GPU. Times itself."""

    def __init__(self, W, dims, xp):
        self.dims, self.xp, self.seconds = dims, xp, 0.0
        if xp == "torch":
            import torch
            self.torch = torch
            W = W.tocsr()
            WT = W.T.tocsr()
            mk = lambda M: torch.sparse_csr_tensor(torch.from_numpy(M.indptr.astype(np.int64)),  # noqa: E731
                                                   torch.from_numpy(M.indices.astype(np.int64)),
                                                   torch.from_numpy(M.data), size=M.shape).cuda()
            self.W, self.WT = mk(W), mk(WT)
        else:
            self.W, self.WT = W, W.T.tocsr()

    def _sync(self):
        if self.xp == "torch":
            self.torch.cuda.synchronize()

    def fwd(self, x):
        t = time.perf_counter()
        nx, ny, nz = self.dims
        y = self.W @ x.reshape(nx * ny, nz)
        self._sync()
        self.seconds += time.perf_counter() - t
        return y

    def back(self, y):
        t = time.perf_counter()
        nx, ny, nz = self.dims
        x = (self.WT @ y).reshape(nx, ny, nz)
        self._sync()
        self.seconds += time.perf_counter() - t
        return x


def moved(x, rot, t, centre, voxel):
    """x moved by the pose (R, t) about centre, in grid mm: y(p) = x(R^T (p -
    c - t) + c), trilinear, zero outside."""
    d = np.asarray(voxel)
    Rt = rot.as_matrix().T
    M = np.diag(1 / d) @ Rt @ np.diag(d)
    off = (Rt @ (0.5 * d - centre - t) + centre) / d - 0.5
    # grid-constant: zero outside, interpolated across the border, as a texture with a zero border
    return ndimage.affine_transform(x, M, offset=off, order=1, mode="grid-constant", cval=0.0)


def simulate(truth, motion, frames, p, rng, W, voxel, still=False, parts=1):
    """Each frame's expected activity (the mean of p['poses'] moved images at
    equally spaced times) projected, scaled to the counts, plus a uniform
    background of 20 % of the mean, with Poisson noise. A frame is acquired
    as `parts` equal short frames, Poisson each, whose sum is its data: the
    short frames that (g) estimates the motion from are the same acquisition.
    Returns the frames' (sinograms, scales, backgrounds) and the short
    frames' (sinograms, scales, backgrounds, bounds)."""
    nx, ny, nz = truth.shape
    short = ([], [], [], [frames[0][0]])
    base = None
    per_part = p["poses"] // parts
    for t0, t1 in frames:
        for j in range(parts):
            a, b = t0 + j * (t1 - t0) / parts, t0 + (j + 1) * (t1 - t0) / parts
            if still:
                mean = truth
            else:
                times = a + (np.arange(per_part) + 0.5) * (b - a) / per_part
                rots, shifts = motion.poses(times)
                mean = np.zeros_like(truth, dtype=np.float64)
                for k in range(len(times)):
                    mean += moved(truth, rots[k], shifts[k], motion.pivot, voxel)
                mean = (mean / len(times)).astype(np.float32)
            proj = W @ mean.reshape(nx * ny, nz)
            if base is None:  # one scale for every frame: the same tracer, the same scanner
                base = p["counts"] / float(proj.sum())
            r = 0.2 * base * float(proj.mean())
            short[0].append(rng.poisson((base * proj + r) / parts).astype(np.float32))
            short[1].append(base / parts)
            short[2].append(r / parts)
            short[3].append(b)
    sinos = [sum(short[0][k * parts:(k + 1) * parts]) for k in range(len(frames))]
    backgrounds = [sum(short[2][k * parts:(k + 1) * parts]) for k in range(len(frames))]
    return (sinos, [base] * len(frames), backgrounds), short


def mean_pose(rots, shifts):
    """A frame's mean pose: the mean translation and the chordal mean rotation."""
    return rots.mean(), shifts.mean(axis=0)


def operators(method, truth_shape, voxel, motion, track, frames, device, estimated=None):
    """The blur of each frame for a method (None: none)."""
    t, tr, q = track
    c = motion.pivot
    out = []
    for t0, t1 in frames:
        if method in ("a", "f"):
            out.append(None)
            continue
        inside = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
        if method == "b":
            rots, shifts = motion.poses(t[inside])
            r, s = mean_pose(rots, shifts)
            q = head_motion.wxyz(r)[0]
            m = petblur.Motion([0.0, 1.0], [s, s], [q, q], center=c)
            out.append(petblur.BlurOperator(truth_shape, voxel, m, device=device))
        elif method == "c":
            m = petblur.Motion(t, tr, q, center=c)
            out.append(petblur.BlurOperator(truth_shape, voxel, m, frame=(t0, t1), method="cl", steps=1,
                                            device=device))
        elif method == "d":
            rots, shifts = motion.poses([t0, t1])
            m = petblur.Motion([t0, t1], shifts, head_motion.wxyz(rots), center=c)
            out.append(petblur.BlurOperator(truth_shape, voxel, m, max_path_error="paper", device=device))
        elif method == "e":
            m = petblur.Motion(t, tr, q, center=c)
            out.append(petblur.BlurOperator(truth_shape, voxel, m, frame=(t0, t1), device=device))
        elif method == "g":
            m, affine = estimated
            out.append(petblur.BlurOperator(truth_shape, voxel, m, frame=(t0, t1), affine=affine, device=device))
    return out


def estimate_motion(short, W, dims, p, affine, device, torch_mode, conv, to_host, xp_ones):
    """(g)'s track from the data alone: each short frame reconstructed by
    MLEM without a motion model, then petblur.Motion.from_frames on the
    series (world coordinates, the phantom's affine). Returns the motion,
    the short frames' images and the seconds spent in each step."""
    sinos, scales, backgrounds, bounds = short
    proj = Projector(W, dims, "torch" if torch_mode else "numpy")
    t = time.perf_counter()
    images = [mlem([conv(y)], [s], [r], [None], proj, p["short_iterations"], lambda x: None, to_host, xp_ones)[0]
              for y, s, r in zip(sinos, scales, backgrounds)]
    recon_s = time.perf_counter() - t
    b = np.asarray(bounds)
    # relative to the first frame, where the phantom lies: the compensated images are compared with it
    m = petblur.Motion.from_frames(np.stack(images, axis=-1), affine, starts=b[:-1], durations=np.diff(b),
                                   reference=0, device=device)
    return m, images, recon_s


def track_error(m, motion, affine, voxel, truth, bounds, samples=20):
    """The estimated track against the truth as bench/estimate_validation.py
    measures it: per short frame, the displacement of points inside the
    brain (mm) averaged over the frame's time (`samples` times) and the
    points; the mean and the max over frames. The estimate's maps (world,
    about the origin) are interpolated here by scipy (LERP, SLERP), the
    truth's taken from head_motion."""
    from scipy.spatial.transform import Rotation, Slerp
    ijk = np.argwhere(truth >= 0.9)[::7].astype(np.float64)
    d = np.asarray(voxel, dtype=np.float64)
    grid_mm = (ijk + 0.5) * d                      # head_motion's frame: grid mm
    world = ijk @ affine[:3, :3].T + affine[:3, 3]
    inv = np.linalg.inv(affine)
    rot = Slerp(m.times, Rotation.from_quat(np.column_stack([m.quaternions[:, 1:], m.quaternions[:, :1]])))
    per_frame = []
    for t0, t1 in zip(bounds[:-1], bounds[1:]):
        times = t0 + (np.arange(samples) + 0.5) * (t1 - t0) / samples
        rots, shifts = motion.poses(times)
        est_rot = rot(times)
        e = 0.0
        for k, t in enumerate(times):
            tr = np.array([np.interp(t, m.times, m.translations[:, i]) for i in range(3)])
            w = est_rot[k].apply(world) + tr
            est = ((w @ inv[:3, :3].T + inv[:3, 3]) + 0.5) * d
            true = rots[k].apply(grid_mm - motion.pivot) + motion.pivot + shifts[k]
            e += np.linalg.norm(est - true, axis=1).mean() / samples
        per_frame.append(e)
    per_frame = np.array(per_frame)
    return {"mean_mm": float(per_frame.mean()), "max_mm": float(per_frame.max()),
            "worst_frame": int(per_frame.argmax()), "per_frame_mm": per_frame.tolist()}


class Metrics:
    def __init__(self, truth, affine, voxel):
        self.truth = truth.astype(np.float64)
        self.brain = truth >= 0.9
        wm = np.isclose(truth, 1.0, atol=0.02)
        self.wm = ndimage.binary_erosion(wm, iterations=1)
        if self.wm.sum() < 20:
            self.wm = wm
        inv = np.linalg.inv(affine)
        grid = np.stack(np.meshgrid(*[np.arange(n) for n in truth.shape], indexing="ij"), -1).reshape(-1, 3)
        world = grid @ affine[:3, :3].T + affine[:3, 3]
        self.lesions = []
        for centre, radius, _ in LESIONS:
            near = np.linalg.norm(world - np.array(centre), axis=1) <= max(radius, 0.6 * min(voxel))
            roi = near.reshape(truth.shape)
            if roi.sum() == 0:
                ijk = np.round(inv[:3, :3] @ np.array(centre) + inv[:3, 3]).astype(int)
                roi = np.zeros(truth.shape, bool)
                roi[tuple(ijk)] = True
            self.lesions.append(roi)
        bg = self.truth[self.wm].mean()
        self.true_contrast = [self.truth[r].mean() / bg - 1.0 for r in self.lesions]

    def __call__(self, x):
        x = np.asarray(x, dtype=np.float64)
        nrmse = float(np.linalg.norm((x - self.truth)[self.brain]) / np.linalg.norm(self.truth[self.brain]))
        bg = x[self.wm].mean()
        cr = [float((x[r].mean() / bg - 1.0) / tc) for r, tc in zip(self.lesions, self.true_contrast)]
        bv = float(x[self.wm].std() / bg)
        return {"nrmse": nrmse, "contrast_recovery": cr, "background_variability": bv}


def mlem(sinos, scales, backgrounds, blurs, proj, iterations, metrics, to_host, xp_ones):
    """One static image from all frames: x <- x / S * sum_k s_k B_k^T A^T (y_k /
    (s_k A B_k x + r_k)), S = sum_k s_k B_k^T A^T 1."""
    blur_s = 0.0

    def timed(fn, *a):
        nonlocal blur_s
        t = time.perf_counter()
        out = fn(*a)
        if proj.xp == "torch":
            proj.torch.cuda.synchronize()
        blur_s += time.perf_counter() - t
        return out

    ones_sino = xp_ones(sinos[0].shape)
    sens = None
    for k, B in enumerate(blurs):
        s = proj.back(ones_sino) * scales[k]
        s = timed(B.adjoint, s) if B is not None else s
        sens = s if sens is None else sens + s
    x = xp_ones(proj.dims)
    history = []
    floor = 1e-6 * float(sens.max())
    sens = sens + floor
    for _ in range(iterations):
        update = None
        for k, B in enumerate(blurs):
            bx = timed(B.apply, x) if B is not None else x
            ratio = sinos[k] / (scales[k] * proj.fwd(bx) + backgrounds[k])
            u = proj.back(ratio) * scales[k]
            u = timed(B.adjoint, u) if B is not None else u
            update = u if update is None else update + u
        x = x * update / sens
        history.append(metrics(to_host(x)))
    return to_host(x), history, blur_s


def run(args):
    p = dict(PRESETS[args.preset])
    if args.iterations:
        p["iterations"] = args.iterations
    methods = args.methods or p["methods"]
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    truth, affine = phantom(find_cli(), p["dims"], p["voxel"], args.out)
    voxel = np.array(p["voxel"])
    dims = truth.shape
    # The pivot near the neck: world (0, -20, -75) mm (RAS+: behind and below
    # the brain's centre), in grid mm through the phantom's placement (whose
    # array axes run right to left, front to back, top to bottom).
    pivot = (np.linalg.inv(affine) @ np.array([0.0, -20.0, -75.0, 1.0]))[:3]
    pivot = (pivot + 0.5) * voxel
    T = p["frame_s"] * p["frames"]
    motion = head_motion.HeadMotion(T, nod_at=0.3 * T, jerk_at=0.6 * T, pivot=pivot)
    track = motion.track()
    frames = [(k * p["frame_s"], (k + 1) * p["frame_s"]) for k in range(p["frames"])]
    t = time.perf_counter()
    W = projector_matrix(dims[0], p["angles"], args.matrix)
    parts = int(round(p["frame_s"] / p["short_s"]))
    data, short = simulate(truth, motion, frames, p, rng, W, voxel, parts=parts)
    still, _ = simulate(truth, motion, frames, p, rng, W, voxel, still=True)
    sim_s = time.perf_counter() - t
    torch_mode = args.device.startswith("cuda")
    if torch_mode:
        import torch
        dev = torch.device(args.device if ":" in args.device else "cuda:0")
        conv = lambda a: torch.from_numpy(np.ascontiguousarray(a)).to(dev)  # noqa: E731
        to_host = lambda a: a.cpu().numpy()  # noqa: E731
        xp_ones = lambda shape: torch.ones(shape, device=dev)  # noqa: E731
    else:
        conv = lambda a: np.ascontiguousarray(a, dtype=np.float32)  # noqa: E731
        to_host = lambda a: a  # noqa: E731
        xp_ones = lambda shape: np.ones(shape, np.float32)  # noqa: E731
    metrics = Metrics(truth, affine, voxel)
    results = {}
    images = {}
    estimated, estimate = None, {}
    if "g" in methods:
        m_est, short_images, recon_s = estimate_motion(short, W, dims, p, affine, args.device, torch_mode, conv,
                                                       to_host, xp_ones)
        estimated = (m_est, affine)
        estimate = dict(track_error(m_est, motion, affine, voxel, truth, short[3]), short_frames=len(short_images),
                        short_s=p["short_s"], reconstruction_s=recon_s, estimate_s=m_est.estimate_seconds,
                        moving_frames=m_est.moving_frames, keys=len(m_est))
        print(f"(g) track from {len(short_images)} frames of {p['short_s']:g} s: displacement error "
              f"{estimate['mean_mm']:.2f} mm mean over frames, {estimate['max_mm']:.2f} at the worst (frame "
              f"{estimate['worst_frame']}); MLEM {recon_s:.1f} s, estimate "
              f"{m_est.estimate_seconds:.1f} s", flush=True)
    for m in methods:
        proj = Projector(W, dims, "torch" if torch_mode else "numpy")
        sinos, scales, backgrounds = still if m == "f" else data
        blurs = operators(m, dims, voxel, motion, track, frames, args.device, estimated)
        t = time.perf_counter()
        x, history, blur_s = mlem([conv(s) for s in sinos], scales, backgrounds, blurs, proj, p["iterations"],
                                  metrics, to_host, xp_ones)
        results[m] = {"label": LABELS[m], "history": history, "projector_s": proj.seconds, "blur_s": blur_s,
                      "total_s": time.perf_counter() - t}
        images[m] = x
        last = history[-1]
        print(f"{LABELS[m]:40s} NRMSE {last['nrmse']:.4f}  CR " +
              " ".join(f"{v:.2f}" for v in last["contrast_recovery"]) +
              f"  BV {last['background_variability']:.3f}  projector {proj.seconds:.1f} s  blur {blur_s:.1f} s",
              flush=True)
    settings = {k: (list(v) if isinstance(v, tuple) else v) for k, v in p.items()}
    settings.update(preset=args.preset, device=args.device, seed=args.seed, simulation_s=sim_s,
                    petblur_device=petblur.BlurOperator(dims, voxel, petblur.Motion.from_axis_angle(),
                                                        device=args.device).device,
                    track_samples=len(track[0]), pivot_mm=list(pivot), affine=affine.tolist(), lesions=LESIONS)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({"settings": settings, "results": results, "estimate": estimate}, f, indent=1)
    np.savez_compressed(os.path.join(args.out, "images.npz"), truth=truth, **images)
    return truth, images, results, dict(settings, estimate=estimate)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(PRESETS), default="small")
    ap.add_argument("--device", default="auto")
    ap.add_argument("--out", default="motion-study")
    ap.add_argument("--iterations", type=int, default=0)
    ap.add_argument("--methods", default="")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--matrix", default="", help="the projector's matrix as .npz: read when there, else made by "
                    "ASTRA and written")
    ap.add_argument("--make-matrix", action="store_true", help="only make --matrix for the preset, and stop")
    args = ap.parse_args()
    if args.make_matrix:
        p = PRESETS[args.preset]
        projector_matrix(p["dims"][0], p["angles"], args.matrix)
        return
    run(args)


if __name__ == "__main__":
    main()
