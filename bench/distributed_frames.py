#!/usr/bin/env python3
"""A dynamic study's blur across GPUs (issue 34): the frames of a slow head
drift shared out across torch.distributed ranks, one GPU each (NCCL), each
rank one petblur.FramesOperator over its run of frames on a CUDA tensor. One
step is what an MLEM iteration asks of the blur: every frame's forward of
one activity, the adjoint summed over the rank's frames, and one all_reduce
of that volume across ranks.

Each rank times its forward, adjoint and all_reduce with CUDA events on the
current stream (median of --runs); the step's wall time is taken on rank 0
between barriers (the slowest rank sets it). Run once per world size and
compare:  efficiency(N) = step(1) / (N * step(N)).

  torchrun --standalone --nproc-per-node N distributed_frames.py --out run-N.json
  distributed_frames.py --table run-1.json run-2.json   (a markdown table)"""

import argparse
import json
import os
import statistics
import time

import numpy as np


def track(frames, frame_s, rate=10.0):
    """A slow drift: 3 degrees of yaw and (2, 3, 1.5) mm over the study, a
    tracker's samples at rate Hz (times s, translations mm, quaternions)."""
    import petblur
    t = np.arange(0.0, frames * frame_s + 0.5 / rate, 1.0 / rate)
    u = t / t[-1]
    half = np.radians(3.0) * u / 2
    q = np.c_[np.cos(half), np.zeros_like(u), np.zeros_like(u), np.sin(half)]
    return petblur.Motion(t, np.outer(u, [2.0, 3.0, 1.5]), q)


def run(args):
    import torch
    import torch.distributed as dist

    import petblur
    from python_torch import event_ms  # imports torch and petblur: not for --table
    local = int(os.environ.get("LOCAL_RANK", 0))
    torch.cuda.set_device(local)
    dev = torch.device("cuda", local)
    dist.init_process_group("nccl", device_id=dev)
    rank, world = dist.get_rank(), dist.get_world_size()
    n = args.size
    part = np.array_split(np.arange(args.frames), world)[rank]
    first, end = int(part[0]), int(part[-1]) + 1
    bounds = args.frame_s * np.arange(args.frames + 1)
    F = petblur.FramesOperator((n, n, n), (2.0, 2.0, 2.0), track(args.frames, args.frame_s), bounds[first:end + 1],
                               device="cuda")
    g = torch.Generator(device=dev).manual_seed(1)
    x = torch.rand((n, n, n), device=dev, generator=g)
    held = dict(y=F.apply(x), s=F.adjoint(F.apply(x), sum=True))  # outputs from torch's caching allocator

    def forward():
        held["y"] = F.apply(x)

    def adjoint():
        held["s"] = F.adjoint(held["y"], sum=True)

    def reduce():
        dist.all_reduce(held["s"])

    def step():
        u = F.adjoint(F.apply(x), sum=True)
        dist.all_reduce(u)
        return u

    # Each part alone, then the step as a whole, back to back.
    fwd = event_ms(forward, args.runs)
    adj = event_ms(adjoint, args.runs)
    dist.barrier()
    red = event_ms(reduce, args.runs)
    walls = []
    for _ in range(args.runs + 1):
        dist.barrier()
        torch.cuda.synchronize()
        t = time.perf_counter()
        step()
        torch.cuda.synchronize()
        dist.barrier()
        walls.append(1e3 * (time.perf_counter() - t))
    mine = dict(rank=rank, device=F.device, gpu=torch.cuda.get_device_name(dev), frames=[first, end],
                forward_ms=fwd, adjoint_ms=adj, all_reduce_ms=red)
    ranks = [None] * world
    dist.all_gather_object(ranks, mine)
    if rank == 0:
        out = dict(world=world, size=n, frames=args.frames, frame_s=args.frame_s, runs=args.runs,
                   step_wall_ms=statistics.median(walls[1:]), ranks=ranks)
        with open(args.out, "w") as f:
            json.dump(out, f, indent=1)
        print(json.dumps(out), flush=True)
    dist.destroy_process_group()


def table(paths):
    runs = sorted((json.load(open(p)) for p in paths), key=lambda r: r["world"])
    base = next((r for r in runs if r["world"] == 1), None)
    print(f"{runs[0]['frames']} frames of {runs[0]['size']}^3; per rank, CUDA events (median of {runs[0]['runs']}); "
          "step: forward + summed adjoint + all_reduce, wall time between barriers on rank 0\n")
    print("| GPUs | frames a rank | forward ms | adjoint ms | all_reduce ms | step ms | efficiency |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in runs:
        worst = lambda k: max(x[k] for x in r["ranks"])  # noqa: E731
        eff = base["step_wall_ms"] / (r["world"] * r["step_wall_ms"]) if base else float("nan")
        frames = "/".join(str(x["frames"][1] - x["frames"][0]) for x in r["ranks"])
        print(f"| {r['world']} | {frames} | {worst('forward_ms'):.2f} | {worst('adjoint_ms'):.2f} | "
              f"{worst('all_reduce_ms'):.2f} | {r['step_wall_ms']:.2f} | {100 * eff:.1f} % |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--frame-s", type=float, default=10.0)
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--out", default="distributed_frames.json")
    ap.add_argument("--table", nargs="+", help="the runs' JSON files: print their table and stop")
    args = ap.parse_args()
    if args.table:
        table(args.table)
    else:
        run(args)


if __name__ == "__main__":
    main()
