#!/usr/bin/env python3
"""What each launch in an Nsight Compute source page (ncu --page source --csv
--print-source sass, as bench/gpu/driftprof.sh writes it) spent its issue
slots on, per work item: instructions, texture fetches, atomics, and the
hottest instructions with their stall samples. With --voxels N and --duration
US LAUNCH=US..., also the texture unit's floor for those fetches at --tex-rate
(G trilinear fetches/s; 480 on the H200, docs/performance.md).

  python3 bench/ncu_source.py ncu-forward-source.csv --voxels 5324000 --top 12
"""
import argparse
import csv


def num(x):
    try:
        return float(x.replace(",", ""))
    except ValueError:
        return 0.0


def launches(path):
    rows = list(csv.reader(open(path)))
    heads = [i for i, r in enumerate(rows) if r and r[0] == "Address"]
    for n, h in enumerate(heads):
        name = rows[h - 1][1] if h > 0 and len(rows[h - 1]) > 1 else "?"
        end = heads[n + 1] - 1 if n + 1 < len(heads) else len(rows)
        cols = rows[h]
        body = [r for r in rows[h + 1:end] if len(r) == len(cols)]
        yield name, cols, body


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv")
    ap.add_argument("--voxels", type=float, required=True, help="work items that did the work (the grid's voxels)")
    ap.add_argument("--durations", default="", help="comma-separated launch durations in us (ncu's Duration)")
    ap.add_argument("--tex-rate", type=float, default=480.0, help="G trilinear fetches a second")
    ap.add_argument("--top", type=int, default=0)
    a = ap.parse_args()
    durations = [float(d) for d in a.durations.split(",") if d]
    for n, (name, cols, body) in enumerate(launches(a.csv)):
        thr = cols.index("Thread Instructions Executed")
        stall = cols.index("Warp Stall Sampling (All Samples)")
        total = sum(num(r[thr]) for r in body)
        tex = sum(num(r[thr]) for r in body if r[1].strip().split(" ")[0].startswith("TEX") or " TEX" in r[1])
        red = sum(num(r[thr]) for r in body if "RED" in r[1] or "ATOM" in r[1])
        samples = sum(num(r[stall]) for r in body) or 1.0
        line = (f"launch {n} ({name}): {total / a.voxels:.0f} instructions, {tex / a.voxels:.2f} texture fetches, "
                f"{red / a.voxels:.2f} atomic adds a voxel")
        if n < len(durations) and tex:
            floor = tex / (a.tex_rate * 1e3)
            line += f"; fetch floor {floor:.0f} us at {a.tex_rate:g} G/s, the launch {durations[n] / floor:.2f}x it"
        print(line)
        for r in sorted(body, key=lambda r: -num(r[stall]))[:a.top]:
            print(f"  {100 * num(r[stall]) / samples:5.1f} % of stall samples, {num(r[thr]) / a.voxels:6.2f} a voxel: "
                  f"{r[1].strip()}")


if __name__ == "__main__":
    main()
