#!/usr/bin/env python3
"""Issue 46's drifting frames under the profilers (bench/gpu.sh driftprof):
the case of bench/frames_cost.py that stands at 25.9x the memory floor (24
frames of 75 s on 220x220x110 voxels of 2 mm, the SMOOTH 1 Hz log of the slow
drift, seed 46046, the default path bound, AB HARDWARE, a torch CUDA tensor in
C order), built by frames_cost's own functions, so the same motion and object:

  forward        F.apply(x), x the phantom (frames_cost's call)
  adjoint        F.adjoint(y, sum=True), y = F.apply(x) (frames_cost's call:
                 y is zero wherever the blurred phantom is, most of the grid)
  adjoint-dense  the same with y = torch.rand (no voxel of y zero)
  forward-dense  F.apply(x) with x = torch.rand

Subcommands:

  profile_frames.py timing --out timing.json [case options]
      each call's time (CUDA events around the Python call, median of --runs),
      the library's device time (F.last_device_ms), and each kernel, memset and
      copy the call launched, from torch.profiler (CUPTI): name, duration,
      grid, block, registers a thread, the profiler's occupancy estimate; how
      many voxels of x and y are not zero, the segments a frame
      (pb_path_segments), the memory floor (one copy of the frames' volumes,
      frames_cost's). A markdown table on standard output.
  profile_frames.py call KIND [case options]
      one call of KIND (after what it needs: the adjoint first makes y) and
      nothing else, for Nsight Compute to pick launches from.
  profile_frames.py summary DIR
      DIR/timing.json and Nsight Compute's DIR/ncu-KIND-details.csv and
      DIR/ncu-KIND-raw.csv (--page details / raw --csv of its reports) in one
      markdown page: per kernel duration, launch, registers, occupancy
      (theoretical, achieved), L1/TEX and L2 hit rates, DRAM throughput, issue,
      the largest stall reasons, texture and reduction requests a thread.

Case options (frames_cost's): --track smooth --bound default --seed 46046
--shape 220,220,110 --frames 24 --frame-s 75 --method ab --filter hardware
--walk-mm 0.03 --runs 10 --device cuda:0; --cache DIR keeps the phantom as an
.npy so that later calls skip its 5 s."""

import argparse
import csv
import json
import math
import os
import re
import statistics
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from library_time import device_ms  # noqa: E402

CALLS = ("forward", "adjoint", "adjoint-dense", "forward-dense")


def case_args(ap):
    ap.add_argument("--track", default="smooth")
    ap.add_argument("--bound", default="default", help="max_path_error in voxels; 'default': None (0.1)")
    ap.add_argument("--seed", type=int, default=46046)
    ap.add_argument("--shape", default="220,220,110")
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--frame-s", type=float, default=75.0)
    ap.add_argument("--method", default="ab")
    ap.add_argument("--filter", default="hardware")
    ap.add_argument("--walk-mm", type=float, default=0.03)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--cache", default=None, help="a folder for the phantom's .npy")


class Case:
    """frames_cost.py's study: its drift, the logged track, the phantom and
    the FramesOperator, on the torch device."""

    def __init__(self, a):
        import torch

        import petblur
        from frames_cost import PIVOT_MM, TRACKS, VOXEL_MM, drift, log_track, phantom
        from path_cases import _motion
        self.torch = torch
        self.dev = torch.device(a.device)
        if self.dev.index is not None:
            torch.cuda.set_device(self.dev)
        self.shape = tuple(int(v) for v in a.shape.split(","))
        self.frames = a.frames
        seconds = a.frames * a.frame_s
        self.bounds = a.frame_s * np.arange(a.frames + 1)
        true_pose, self.drift = drift(np.random.default_rng([a.seed, 0]), seconds)
        center = 0.5 * np.array(self.shape) * VOXEL_MM + PIVOT_MM
        if a.track not in TRACKS:
            raise SystemExit(f"--track {a.track}: one of {', '.join(TRACKS)}")
        rng = np.random.default_rng([a.seed, 1 + list(TRACKS).index(a.track)])
        times, rot, tr = log_track(a.track, true_pose, seconds, rng, a.walk_mm)
        self.motion = _motion(times, rot, tr, center)
        x = None
        path = None
        if a.cache:
            path = os.path.join(a.cache, f"phantom-{a.seed}-{'x'.join(map(str, self.shape))}.npy")
            if os.path.exists(path):
                x = np.load(path)
        if x is None:
            x = np.ascontiguousarray(phantom(np.random.default_rng([a.seed, 100]), self.shape), dtype=np.float32)
            if path:
                np.save(path, x)
        self.x = torch.from_numpy(x).to(self.dev)
        bound = None if a.bound == "default" else float(a.bound)
        self.F = petblur.FramesOperator(self.shape, VOXEL_MM, self.motion, self.bounds, method=a.method,
                                        filter=a.filter, max_path_error=bound, device=a.device)

    def sync(self):
        self.torch.cuda.synchronize()


def cupti_events(torch, call):
    """The GPU activities of one call through torch.profiler (CUPTI): a list
    of dicts (cat, name, dur us, args), or an error string."""
    try:
        from torch.profiler import ProfilerActivity, profile
        with profile(activities=[ProfilerActivity.CPU, ProfilerActivity.CUDA]) as prof:
            call()
            torch.cuda.synchronize()
        fd, path = tempfile.mkstemp(suffix=".json")
        os.close(fd)
        prof.export_chrome_trace(path)
        with open(path) as f:
            trace = json.load(f)
        os.unlink(path)
    except Exception as e:  # no CUPTI, an old torch
        return f"torch.profiler failed: {e!r}"
    events = trace.get("traceEvents", trace) if isinstance(trace, dict) else trace
    out = []
    for e in events:
        if e.get("ph") != "X" or e.get("cat") not in ("kernel", "gpu_memcpy", "gpu_memset"):
            continue
        out.append({"cat": e["cat"], "name": e.get("name", "?"), "ts": e.get("ts", 0.0), "dur": float(e.get("dur", 0.0)),
                    "args": e.get("args", {})})
    out.sort(key=lambda e: e["ts"])
    return out


def kernel_stats(events):
    """Per kernel name: launches, total / min / median / max us, each
    launch's us in order, and the first launch's configuration."""
    if isinstance(events, str):
        return events
    by = {}
    for e in events:
        key = e["name"] if e["cat"] == "kernel" else e["cat"]
        by.setdefault(key, []).append(e)
    stats = {}
    for name, es in by.items():
        d = [e["dur"] for e in es]
        args = es[0]["args"]
        stats[name] = {"cat": es[0]["cat"], "launches": len(d), "total_us": sum(d), "min_us": min(d),
                       "median_us": statistics.median(d), "max_us": max(d), "each_us": d,
                       "grid": args.get("grid"), "block": args.get("block"),
                       "registers": args.get("registers per thread"), "shared": args.get("shared memory"),
                       "blocks_per_sm": args.get("blocks per SM"), "warps_per_sm": args.get("warps per SM"),
                       "est_occupancy_pct": args.get("est. achieved occupancy %")}
    return stats


def timing(a):
    from frames_cost import frame_segments
    from python_torch import event_ms  # medians of CUDA-event times, calls queued back to back
    c = Case(a)
    torch, F = c.torch, c.F
    y = F.apply(c.x)
    c.sync()
    gen = torch.Generator(device=c.dev).manual_seed(a.seed)
    y_dense = torch.rand(y.shape, device=c.dev, generator=gen)
    x_dense = torch.rand(c.x.shape, device=c.dev, generator=gen)
    calls = {"forward": lambda: F.apply(c.x), "adjoint": lambda: F.adjoint(y, sum=True),
             "adjoint-dense": lambda: F.adjoint(y_dense, sum=True), "forward-dense": lambda: F.apply(x_dense)}
    dst = torch.empty_like(y)
    floor = event_ms(lambda: dst.copy_(y), a.runs)
    del dst
    voxels = int(np.prod(c.shape))
    try:
        seg = frame_segments(F, c.motion, c.bounds)
    except Exception as e:
        print(f"segments not counted: {e}", flush=True)
        seg = None
    res = {"argv": sys.argv[1:], "gpu": torch.cuda.get_device_name(c.dev), "commit": os.environ.get("PB_COMMIT"),
           "shape": list(c.shape), "voxels": voxels, "frames": c.frames, "drift": c.drift, "floor_ms": floor,
           "segments": seg, "segments_mean": float(np.mean(seg)) if seg else None,
           "nonzero_x": float((c.x != 0).float().mean()), "nonzero_y": float((y != 0).float().mean()),
           "nonzero_y_per_frame": [float((y[f] != 0).float().mean()) for f in range(c.frames)], "calls": {}}
    for name, call in calls.items():
        call()  # warm
        c.sync()
        t = time.perf_counter()
        ms = event_ms(call, a.runs)
        kern, inp = device_ms(F, call)
        st = kernel_stats(cupti_events(torch, call))
        names = sorted(k for k, v in st.items() if v["cat"] == "kernel" and k.startswith("pb_")) \
            if isinstance(st, dict) else []
        res["calls"][name] = {"call_ms": ms, "library_kernel_ms": kern, "library_input_ms": inp,
                              "x_floor": ms / floor, "kernel_names": names, "activities": st,
                              "seconds": time.perf_counter() - t}
        print(f"{name}: {ms:.3f} ms a call, library {kern:.3f} ms kernels + {inp:.3f} ms input; "
              f"{ms / floor:.1f}x the floor {floor:.3f} ms", flush=True)
    with open(a.out, "w") as f:
        json.dump(res, f, indent=1)
    print(timing_markdown(res))


def timing_markdown(t):
    lines = [f"# {t['gpu']}, commit {t.get('commit') or '?'}: {t['frames']} frames of "
             f"{'x'.join(map(str, t['shape']))} (library x fastest: the tensor's last axis), "
             f"segments a frame {t['segments_mean'] if t['segments_mean'] is None else round(t['segments_mean'], 2)}; "
             f"x not zero on {100 * t['nonzero_x']:.2f} % of voxels, y = F.apply(x) on {100 * t['nonzero_y']:.2f} %; "
             f"memory floor {t['floor_ms']:.3f} ms", "",
             "| call | call ms (events) | library kernels ms | input copy ms | x floor | kernel | launches | "
             "median / min / max us | grid | block | regs | est. occupancy % (CUPTI) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, r in t["calls"].items():
        head = (f"| {name} | {r['call_ms']:.3f} | {r['library_kernel_ms']:.3f} | {r['library_input_ms']:.3f} | "
                f"{r['x_floor']:.1f} ")
        acts = r["activities"]
        if isinstance(acts, str):
            lines.append(head + f"| {acts} | | | | | | |")
            continue
        for k, s in sorted(acts.items(), key=lambda kv: -kv[1]["total_us"]):
            lines.append(head + f"| {k} | {s['launches']} | {s['median_us']:.1f} / {s['min_us']:.1f} / "
                         f"{s['max_us']:.1f} | {s['grid']} | {s['block']} | {s['registers']} | "
                         f"{s['est_occupancy_pct']} |")
            head = "| | | | | "
    vf = t["voxels"] * t["frames"]
    out = []
    fw, ad, dd = (t["calls"].get(k) for k in ("forward", "adjoint", "adjoint-dense"))
    if fw:
        out.append(f"- forward: {1e6 * fw['library_kernel_ms'] / vf:.4f} ns a voxel-frame ({vf / 1e6:.1f} M)")
    if ad:
        walked = t["nonzero_y"] * vf
        out.append(f"- adjoint: {1e6 * ad['library_kernel_ms'] / walked:.4f} ns a walked voxel-frame "
                   f"(y not zero: {walked / 1e6:.2f} M of {vf / 1e6:.1f} M); "
                   f"{1e6 * ad['library_kernel_ms'] / vf:.4f} ns a voxel-frame")
    if ad and dd:
        out.append(f"- adjoint of a dense y / of F.apply(x): {dd['library_kernel_ms'] / ad['library_kernel_ms']:.2f}x")
    if fw and dd:
        out.append(f"- forward / dense adjoint: {fw['library_kernel_ms'] / dd['library_kernel_ms']:.2f}x; "
                   f"forward / frames_cost's adjoint: {fw['library_kernel_ms'] / ad['library_kernel_ms']:.2f}x")
    return "\n".join(lines + [""] + out) + "\n"


def call(a):
    c = Case(a)
    torch, F = c.torch, c.F
    gen = torch.Generator(device=c.dev).manual_seed(a.seed)
    if a.kind == "forward":
        F.apply(c.x)
    elif a.kind == "forward-dense":
        F.apply(torch.rand(c.x.shape, device=c.dev, generator=gen))
    elif a.kind == "adjoint":
        y = F.apply(c.x)
        F.adjoint(y, sum=True)
    else:
        F.adjoint(torch.rand((c.frames,) + c.shape, device=c.dev, generator=gen), sum=True)
    c.sync()


# ---- summary -----------------------------------------------------------------

UNIT_US = {"ns": 1e-3, "nsecond": 1e-3, "us": 1.0, "usecond": 1.0, "ms": 1e3, "msecond": 1e3, "s": 1e6,
           "second": 1e6}
# (column, details page's metric name)
DETAILS = [("duration us", "Duration"), ("regs", "Registers Per Thread"), ("theor. occ %", "Theoretical Occupancy"),
           ("achieved occ %", "Achieved Occupancy"), ("block limit regs", "Block Limit Registers"),
           ("waves/SM", "Waves Per SM"), ("L1/TEX hit %", "L1/TEX Hit Rate"), ("L2 hit %", "L2 Hit Rate"),
           ("DRAM thr %", "DRAM Throughput"), ("L1/TEX thr %", "L1/TEX Cache Throughput"),
           ("L2 thr %", "L2 Cache Throughput"), ("SM thr %", "Compute (SM) Throughput"),
           ("issue busy %", "Issue Slots Busy"), ("cycles/issue", "Warp Cycles Per Issued Instruction"),
           ("executed inst", "Executed Instructions"), ("threads", "Threads"),
           ("active threads/warp", "Avg. Active Threads Per Warp")]


def number(s):
    try:
        return float(str(s).replace(",", ""))
    except ValueError:
        return None


def read_details(path):
    """ncu --page details --csv: {ID: {"kernel", "block", "grid", metric name: (value, unit)}}."""
    out = {}
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r]
    head = next((i for i, r in enumerate(rows) if "Metric Name" in r), None)
    if head is None:
        return out
    cols = rows[head]
    ix = {n: cols.index(n) for n in cols}
    for r in rows[head + 1:]:
        if len(r) < len(cols):
            continue
        k = out.setdefault(r[ix["ID"]], {"kernel": r[ix["Kernel Name"]], "block": r[ix.get("Block Size", 0)],
                                          "grid": r[ix.get("Grid Size", 0)]})
        k[r[ix["Metric Name"]]] = (r[ix["Metric Value"]], r[ix["Metric Unit"]])
    return out


def read_raw(path):
    """ncu --page raw --csv: a list of {metric: value} per kernel."""
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r]
    head = next((i for i, r in enumerate(rows) if "Kernel Name" in r), None)
    if head is None:
        return []
    cols = rows[head]
    body = rows[head + 1:]
    if body and number(body[0][0]) is None:
        body = body[1:]  # the units row
    return [dict(zip(cols, r)) for r in body]


def summary(a):
    d = a.dir
    parts = []
    tpath = os.path.join(d, "timing.json")
    if os.path.exists(tpath):
        with open(tpath) as f:
            parts.append(timing_markdown(json.load(f)))
    else:
        parts.append("(no timing.json)\n")
    table = ["| call | kernel | launch | block | grid | " + " | ".join(c for c, _ in DETAILS) + " |",
             "|---|---|---|---|---|" + "---|" * len(DETAILS)]
    notes = []
    found = False
    for kind in CALLS:
        dp = os.path.join(d, f"ncu-{kind}-details.csv")
        if not os.path.exists(dp):
            continue
        det = read_details(dp)
        raw = []
        rp = os.path.join(d, f"ncu-{kind}-raw.csv")
        if os.path.exists(rp):
            try:
                raw = read_raw(rp)
            except Exception as e:
                notes.append(f"- {kind}: raw page unreadable ({e!r})")
        for n, (kid, k) in enumerate(sorted(det.items(), key=lambda kv: int(kv[0]) if kv[0].isdigit() else 0)):
            found = True
            cells = []
            for _, m in DETAILS:
                v, unit = k.get(m, ("", ""))
                x = number(v)
                if m == "Duration" and x is not None:
                    x *= UNIT_US.get(unit.strip().lower(), 1.0)
                    v = f"{x:.1f}"
                elif m == "Executed Instructions" and x is not None:
                    thr = number(k.get("Threads", ("", ""))[0])
                    v = f"{x:,.0f}" + (f" ({32 * x / thr:.0f}/thread)" if thr else "")
                cells.append(v)
            table.append(f"| {kind} | {k['kernel']} | {kid} | {k['block']} | {k['grid']} | " + " | ".join(cells) + " |")
            r = next((row for row in raw if row.get("ID") == kid), raw[n] if n < len(raw) else {})
            threads = number(k.get("Threads", ("", ""))[0]) or number(r.get("launch__thread_count", "")) or None
            stalls = []
            for pattern in (r"smsp__average_warps?_issue_stalled_(.+?)_per_issue_active\.ratio$",
                            r"smsp__pcsamp_warps_issue_stalled_(.+)$"):
                for col, val in r.items():
                    m = re.match(pattern, col)
                    x = number(val)
                    if m and x and not m.group(1).endswith("not_issued"):
                        stalls.append((x, m.group(1)))
                if stalls:
                    break
            stalls.sort(reverse=True)
            warps = threads / 32.0 if threads else None
            per = []
            for col, val in r.items():
                x = number(val)
                if x is None or not col.endswith(".sum"):
                    continue
                if re.search(r"(pipe_tex|op_texture|op_red|op_atom|mem_local|op_global_red)", col) and \
                        re.search(r"(requests|sectors|inst_executed|wavefronts)", col):
                    per.append(f"{col} {x:,.0f}" + (f" ({x / warps:.2f} a warp)" if warps else ""))
            if stalls:
                notes.append(f"- {kind} launch {kid}: stall reasons (warps stalled per issued instruction, or samples), largest: " +
                             ", ".join(f"{s} {x:.2f}" for x, s in stalls[:6]))
            if per:
                notes.append(f"- {kind} launch {kid}: " + "; ".join(per[:12]))
    if found:
        parts.append("## Nsight Compute\n")
        picked = os.path.join(d, "ncu-picked.txt")
        if os.path.exists(picked):
            with open(picked) as f:
                parts.append(f.read().strip() + "\n")
        parts.append("\n".join(table) + "\n")
        parts.append("\n".join(notes) + "\n")
    else:
        parts.append("(no Nsight Compute results: see ncu-*.log)\n")
    for name in ("resources.txt", "sass-counts.txt"):
        p = os.path.join(d, name)
        if os.path.exists(p):
            with open(p) as f:
                parts.append(f"## {name}\n\n```\n{f.read().strip()}\n```\n")
    print("\n".join(parts))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("timing")
    t.add_argument("--out", default="timing.json")
    case_args(t)
    c = sub.add_parser("call")
    c.add_argument("kind", choices=CALLS)
    case_args(c)
    s = sub.add_parser("summary")
    s.add_argument("dir")
    a = ap.parse_args()
    {"timing": timing, "call": call, "summary": summary}[a.cmd](a)


if __name__ == "__main__":
    main()
