#!/usr/bin/env python3
"""The motion study's reconstruction (e), petblur's blur on the whole track,
with the frames shared out across processes by torch.distributed: one rank
per GPU (NCCL), or per CPU process (gloo).

    torchrun --standalone --nproc-per-node 2 mlem_distributed.py --device cuda --out DIR   # NCCL, a GPU a rank
    torchrun --standalone --nproc-per-node 2 mlem_distributed.py --device host --out DIR   # gloo (or opencl)
    torchrun --nnodes 2 --node-rank R --rdzv-endpoint HOST:PORT ...                         # across hosts, alike

Each rank takes the frames np.array_split gives it (a contiguous run) and
holds only their data, simulated as study.py simulates it (scipy's trilinear
resampling at many poses a frame, ASTRA's strip projector, Poisson noise),
each frame from a seed of its own, so that every split of the frames sees the
same data. It plans one petblur.FramesOperator over its frames' bounds on its
device (``device="cuda"`` is the rank's current GPU, set from LOCAL_RANK) and
holds ASTRA's matrix as a torch sparse tensor there. MLEM, one image from
all frames:

    x <- x / S * sum_k s B_k^T A^T (y_k / (s A B_k x + r_k)),   S = sum_k s B_k^T A^T 1

Each sum over k is the rank's FramesOperator.adjoint (the sum over its
frames, in one call) followed by one all_reduce of a volume; every rank then
holds the same x, so nothing else travels. Rank 0 writes image.npy and
results.json: NRMSE against the truth at every iteration, and each rank's
seconds in the blur, the projector and the all_reduce."""

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
import warnings

import numpy as np
import torch
import torch.distributed as dist

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import head_motion  # noqa: E402
import study  # noqa: E402

import petblur  # noqa: E402

PRESETS = {
    # grid, voxel mm, angles, frames of frame_s seconds, MLEM iterations, poses a frame in the data, counts a frame
    "small": dict(dims=(48, 48, 24), voxel=(5.87, 5.87, 7.47), angles=60, frames=8, frame_s=30.0, iterations=10,
                  poses=30, counts=1e6),
    "full": dict(dims=(128, 128, 64), voxel=(2.2, 2.2, 2.8), angles=180, frames=24, frame_s=10.0, iterations=20,
                 poses=20, counts=1e7),
}


class Setup:
    """What every rank computes alike: the truth, the motion and its track,
    the frames, the projector's matrix and the data's scale."""

    def __init__(self, p, matrix, work):
        self.p = p
        self.truth, self.affine = study.phantom(study.find_cli(), p["dims"], p["voxel"], work)
        self.voxel = np.array(p["voxel"])
        pivot = (np.linalg.inv(self.affine) @ np.array([0.0, -20.0, -75.0, 1.0]))[:3]
        self.pivot = (pivot + 0.5) * self.voxel  # near the neck, as study.py places it
        T = p["frame_s"] * p["frames"]
        self.motion = head_motion.HeadMotion(T, nod_at=0.3 * T, jerk_at=0.6 * T, pivot=self.pivot)
        self.track = self.motion.track()
        self.bounds = p["frame_s"] * np.arange(p["frames"] + 1)
        self.W = study.projector_matrix(self.truth.shape[0], p["angles"], matrix)
        nx, ny, nz = self.truth.shape
        still = self.W @ self.truth.reshape(nx * ny, nz)
        self.scale = p["counts"] / float(still.sum())   # one scale for every frame
        self.background = 0.2 * self.scale * float(still.mean())

    def frame_data(self, k, seed):
        """Frame k's sinogram (rays, nz): its activity at p['poses'] times
        moved and averaged, projected, scaled, plus the background, Poisson
        noise from the seed (seed, k)."""
        t0, t1 = self.bounds[k], self.bounds[k + 1]
        n = self.p["poses"]
        times = t0 + (np.arange(n) + 0.5) * (t1 - t0) / n
        rots, shifts = self.motion.poses(times)
        mean = np.zeros_like(self.truth, dtype=np.float64)
        for j in range(n):
            mean += study.moved(self.truth, rots[j], shifts[j], self.pivot, self.voxel)
        nx, ny, nz = self.truth.shape
        proj = self.W @ (mean / n).astype(np.float32).reshape(nx * ny, nz)
        rng = np.random.default_rng([seed, k])
        return rng.poisson(self.scale * proj + self.background).astype(np.float32)

    def motion_model(self):
        t, tr, q = self.track
        return petblur.Motion(t, tr, q, center=self.pivot)


def my_frames(frames, rank, world):
    """The contiguous run of frames rank holds: np.array_split's."""
    part = np.array_split(np.arange(frames), world)[rank]
    return int(part[0]), int(part[-1]) + 1


class Timer:
    """Seconds per step, the device synchronised around each (CUDA events
    would time the device alone; here the wall time of each step is what
    the parallel efficiency is made of)."""

    def __init__(self, dev):
        self.dev, self.seconds = dev, {}

    def __call__(self, name, fn, *a, **k):
        if self.dev.type == "cuda":
            torch.cuda.synchronize(self.dev)
        t = time.perf_counter()
        out = fn(*a, **k)
        if self.dev.type == "cuda":
            torch.cuda.synchronize(self.dev)
        self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t
        return out


def sparse(M, dev):
    """A scipy matrix as a torch CSR tensor on dev (its invariants checked)."""
    M = M.tocsr()
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "Sparse CSR tensor support is in beta", UserWarning)
        return torch.sparse_csr_tensor(torch.from_numpy(M.indptr.astype(np.int64)),
                                       torch.from_numpy(M.indices.astype(np.int64)),
                                       torch.from_numpy(M.data.astype(np.float32)), size=M.shape,
                                       check_invariants=True).to(dev)


def run(args):
    if args.device.startswith("cuda"):
        dev = torch.device("cuda", int(os.environ.get("LOCAL_RANK", 0)))
        torch.cuda.set_device(dev)
        dist.init_process_group("nccl", device_id=dev)
    else:
        dev = torch.device("cpu")
        dist.init_process_group("gloo")
    rank, world = dist.get_rank(), dist.get_world_size()
    p = dict(PRESETS[args.preset])
    if args.iterations:
        p["iterations"] = args.iterations
    if args.frames:
        p["frames"] = args.frames
    if p["frames"] < world:
        raise SystemExit(f"mlem_distributed.py: {p['frames']} frames cannot be shared by {world} ranks")
    # Rank 0 first: it writes --matrix where that is missing, which the others then read.
    work = tempfile.mkdtemp(prefix=f"mlem-rank{rank}-")
    if rank == 0:
        s = Setup(p, args.matrix or None, work)
    dist.barrier()
    if rank != 0:
        s = Setup(p, args.matrix or None, work)
    shutil.rmtree(work, ignore_errors=True)
    first, end = my_frames(p["frames"], rank, world)
    nx, ny, nz = s.truth.shape
    f = end - first

    clock = Timer(dev)
    t = time.perf_counter()
    data = np.stack([s.frame_data(k, args.seed) for k in range(first, end)], axis=1)  # (rays, f, nz)
    simulate_s = time.perf_counter() - t
    y = torch.from_numpy(data).to(dev)
    # "cuda": the rank's current device, set above; the frames' own bounds.
    B = petblur.FramesOperator(s.truth.shape, s.voxel, s.motion_model(), s.bounds[first:end + 1],
                               device=args.device)
    W, WT = sparse(s.W, dev), sparse(s.W.T, dev)
    rays = s.W.shape[0]

    def project(v):      # (f, nx, ny, nz) -> (rays, f, nz)
        return (W @ v.reshape(f, nx * ny, nz).permute(1, 0, 2).reshape(nx * ny, f * nz)).reshape(rays, f, nz)

    def back(q):         # (rays, f, nz) -> (f, nx, ny, nz)
        return (WT @ q.reshape(rays, f * nz)).reshape(nx * ny, f, nz).permute(1, 0, 2).reshape(f, nx, ny, nz)

    def summed(v):       # the sum over every rank's frames of B_k^T v_k
        u = clock("blur", B.adjoint, v.contiguous(), sum=True)
        clock("all_reduce", dist.all_reduce, u)
        return u

    ones = torch.ones((rays, f, nz), device=dev)
    sens = summed(s.scale * clock("projector", back, ones))
    sens = sens + 1e-6 * float(sens.max())
    x = torch.ones((nx, ny, nz), device=dev)
    metrics = study.Metrics(s.truth, s.affine, s.voxel)
    history = []
    t = time.perf_counter()
    for _ in range(p["iterations"]):
        bx = clock("blur", B.apply, x)
        ratio = y / (s.scale * clock("projector", project, bx) + s.background)
        x = x * summed(s.scale * clock("projector", back, ratio)) / sens
        if rank == 0:  # timed apart: the image copied to the host and compared with the truth
            history.append(clock("metrics", lambda: metrics(x.cpu().numpy())))
    if dev.type == "cuda":
        torch.cuda.synchronize(dev)
    mlem_s = time.perf_counter() - t - clock.seconds.get("metrics", 0.0)
    mine = dict(rank=rank, frames=[first, end], device=B.device, simulate_s=simulate_s, mlem_s=mlem_s,
                **{k + "_s": v for k, v in clock.seconds.items()})
    ranks = [None] * world
    dist.all_gather_object(ranks, mine)
    if rank == 0:
        os.makedirs(args.out, exist_ok=True)
        np.save(os.path.join(args.out, "image.npy"), x.cpu().numpy())
        settings = dict(p, preset=args.preset, device=args.device, seed=args.seed, world=world,
                        backend=dist.get_backend(), affine=s.affine.tolist())
        with open(os.path.join(args.out, "results.json"), "w") as fh:
            json.dump({"settings": settings, "ranks": ranks, "history": history}, fh, indent=1)
        print(f"{world} ranks ({dist.get_backend()}), {p['frames']} frames, {p['iterations']} iterations: "
              f"NRMSE {history[-1]['nrmse']:.4f}; MLEM {mlem_s:.2f} s on rank 0", flush=True)
        for r in ranks:
            print("  rank {rank} frames {frames} on {device}: ".format(**r) +
                  ", ".join(f"{k[:-2]} {v:.3f} s" for k, v in r.items() if k.endswith("_s")), flush=True)
    dist.barrier()
    dist.destroy_process_group()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(PRESETS), default="small")
    ap.add_argument("--device", default="host", help="host, opencl or cuda (each rank's own GPU)")
    ap.add_argument("--out", default="mlem-distributed")
    ap.add_argument("--iterations", type=int, default=0)
    ap.add_argument("--frames", type=int, default=0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--matrix", default="", help="the projector's matrix as .npz: read when there, else made by "
                    "ASTRA and written (the GPU machine cannot load ASTRA)")
    run(ap.parse_args())


if __name__ == "__main__":
    main()
