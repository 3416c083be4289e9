#!/usr/bin/env python3
"""What the estimated track's curve costs a reconstruction's blur (issue 47): the track that
`petblur motion estimate` writes runs as a monotone cubic between still frames' middles, seven poses between each
two, where it ran as a line (PETBLUR_ESTIMATE_CURVE=line). AB's default path follows the track, so a bend takes more
segments. This measures it as a user pays it: the forward and summed adjoint of every frame through
petblur.FramesOperator, with each of the two tracks.

For each family draw (bench/estimate_family.py's draws: a head series with its protocol, from injection or late,
its motion and its counts), the series is simulated as the family does and estimated twice in this process
(Motion.from_frames on --device, the curve and the line). Each track then drives a FramesOperator over the draw's
frames on two grids: the series' own (2-4 mm voxels, oblique) and a clinical one (--shape voxels of --voxel-mm,
axis-aligned, about the same world origin as the head). On each: the segments AB walks per frame
(pb_path_segments), the forward of one activity into every frame and the adjoint summed over the frames (median of
--runs calls, CUDA events around the Python call on cuda, wall clock on the host), and how far the curve's forward
lies from the line's (relative RMS and max, %), which says how much the reconstruction's model changes.

  curve_cost.py [--device cuda:0] [--seeds S,S,..] [--draws N] [--shape 220,220,110] [--voxel-mm 2] [--runs 10]
  curve_cost.py --device host --draws 1 --shape 60,60,40 --runs 2        (a quick look on a CPU)
"""
import argparse
import json
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import estimate_family as ef  # noqa: E402
from frames_cost import Device, Errors, frame_segments, phantom  # noqa: E402

VARIANTS = (("curve", None), ("line", "line"))


def clinical_affine(shape, voxel_mm):
    """An axis-aligned scanner grid of `shape` voxels of voxel_mm, centred on the world's origin (where the family's
    heads sit)."""
    a = np.diag([voxel_mm, voxel_mm, voxel_mm, 1.0])
    a[:3, 3] = -voxel_mm * (np.array(shape) - 1) / 2.0
    return a


def estimate(petblur, frames, affine, bounds, device, curve):
    """Motion.from_frames with PETBLUR_ESTIMATE_CURVE set for the call (None: the default)."""
    old = os.environ.pop("PETBLUR_ESTIMATE_CURVE", None)
    try:
        if curve:
            os.environ["PETBLUR_ESTIMATE_CURVE"] = curve
        return petblur.Motion.from_frames(frames, affine=affine, bounds=bounds, device=device)
    finally:
        os.environ.pop("PETBLUR_ESTIMATE_CURVE", None)
        if old is not None:
            os.environ["PETBLUR_ESTIMATE_CURVE"] = old


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cuda:0", help="cuda[:N] (torch tensors) or host (numpy arrays)")
    ap.add_argument("--seeds", default="", help="family seeds, comma separated (bench/estimate_family.py --seed)")
    ap.add_argument("--draws", type=int, default=6, help="fresh draws where --seeds names none")
    ap.add_argument("--shape", default="220,220,110", help="the clinical grid")
    ap.add_argument("--voxel-mm", type=float, default=2.0)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--out", default="curve_cost.json")
    a = ap.parse_args()
    import petblur
    seeds = [int(s) for s in a.seeds.split(",") if s] or \
        [int.from_bytes(os.urandom(4), "little") for _ in range(a.draws)]
    clinical = tuple(int(v) for v in a.shape.split(","))
    dev = Device(a.device, a.runs)
    est_device = "cuda" if dev.cuda else "host"
    gpu = dev.torch.cuda.get_device_name(dev.dev) if dev.cuda else "host"
    print(f"# {gpu}, petblur {getattr(petblur, '__version__', '?')}; seeds {','.join(map(str, seeds))} "
          f"(--seeds replays them); median of {a.runs} calls", flush=True)
    rows = []
    for seed in seeds:
        d = ef.draw(seed)
        frames, affine, bounds, _ = ef.simulate(d, np.random.default_rng([seed, 1]))
        tracks = {}
        for name, env in VARIANTS:
            t = time.perf_counter()
            tracks[name] = estimate(petblur, frames, affine, bounds, est_device, env)
            print(f"seed {seed}: {len(bounds) - 1} frames of {np.diff(bounds).min():.0f}-{np.diff(bounds).max():.0f}"
                  f" s ({'from injection' if d.start_s == 0 else 'late'}), {name} estimated in "
                  f"{time.perf_counter() - t:.1f} s, {len(tracks[name].times)} poses", flush=True)
        del frames
        grids = (("series", tuple(d.shape), tuple(d.voxel), affine),
                 ("clinical", clinical, (a.voxel_mm,) * 3, clinical_affine(clinical, a.voxel_mm)))
        for grid, shape, vox, aff in grids:
            # the object in the grid's own frame: its placement does not matter to the cost
            x = dev.array(phantom(np.random.default_rng([seed, 7]), shape, vox))
            out, floor = {}, None
            for name, _ in VARIANTS:
                F = petblur.FramesOperator(shape, vox, tracks[name], bounds, affine=aff, device=a.device)
                y = F.apply(x)
                dev.sync()
                if floor is None:
                    floor = dev.floor(y)
                fwd = dev.time(F, lambda: F.apply(x))
                adj = dev.time(F, lambda: F.adjoint(y, sum=True))
                seg = frame_segments(F, tracks[name], bounds)
                out[name] = {"segments": seg, "segments_mean": float(np.mean(seg)), "segments_max": int(max(seg)),
                             "forward_ms": fwd[0], "adjoint_ms": adj[0], "y": y}
                F = None
            e = Errors()
            for f in range(len(bounds) - 1):
                e.add(out["line"]["y"][f], out["curve"]["y"][f])
            for name in out:
                del out[name]["y"]
            dev.release()
            row = {"seed": seed, "grid": grid, "shape": list(shape), "voxel_mm": list(vox),
                   "frames": len(bounds) - 1, "from_injection": d.start_s == 0.0, "floor_ms": floor,
                   "curve_vs_line": e.result(), **out}
            rows.append(row)
            c, l = out["curve"], out["line"]
            print(f"  {grid:8s} {'x'.join(map(str, shape))}: segments a frame {c['segments_mean']:.1f} (max "
                  f"{c['segments_max']}) against {l['segments_mean']:.1f} ({l['segments_max']}); forward "
                  f"{c['forward_ms']:.2f} against {l['forward_ms']:.2f} ms ({c['forward_ms'] / l['forward_ms']:.2f}x), "
                  f"adjoint {c['adjoint_ms']:.2f} against {l['adjoint_ms']:.2f} ms "
                  f"({c['adjoint_ms'] / l['adjoint_ms']:.2f}x); the floor {floor:.3f} ms; the curve's forward "
                  f"{row['curve_vs_line']['rms_pct']:.2f} % RMS / {row['curve_vs_line']['max_pct']:.2f} % max from "
                  f"the line's", flush=True)
    print()
    print("| grid | draws | segments a frame, curve / line (median) | forward, curve / line (median ratio, worst) "
          "| adjoint, curve / line (median ratio, worst) |")
    print("|---|---|---|---|---|")
    for grid in ("series", "clinical"):
        g = [r for r in rows if r["grid"] == grid]
        fr = [r["curve"]["forward_ms"] / r["line"]["forward_ms"] for r in g]
        ar = [r["curve"]["adjoint_ms"] / r["line"]["adjoint_ms"] for r in g]
        print(f"| {grid} | {len(g)} | {statistics.median(r['curve']['segments_mean'] for r in g):.1f} / "
              f"{statistics.median(r['line']['segments_mean'] for r in g):.1f} | {statistics.median(fr):.2f}x, "
              f"{max(fr):.2f}x | {statistics.median(ar):.2f}x, {max(ar):.2f}x |")
    with open(a.out, "w") as f:
        json.dump({"device": gpu, "seeds": seeds, "rows": rows}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
