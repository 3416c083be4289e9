#!/usr/bin/env python3
"""Markdown tables from the CSVs bench/gpu.sh kernels writes: kernel time per
method and scenario for each backend, the NVIDIA OpenCL / CUDA ratio, and the
issue's targets. Usage: summarize.py OUT_DIR"""
import csv
import os
import sys

ROWS = [("AB", "hardware"), ("AB", "exact"), ("RM", "hardware"), ("RM", "exact"),
        ("CL", "hardware"), ("CL", "exact"), ("REF", "exact")]
LABEL = {"hardware": "HW", "exact": "EX"}


def load(path):
    if not os.path.exists(path):
        return None
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {(r["method"], r["filter"], int(r["scenario"])): r for r in rows}


def name(method, filt):
    return method if method == "REF" else f"{method} {LABEL[filt]}"


def table(title, data, value, fmt):
    scen = sorted({k[2] for k in data})
    out = [f"### {title}", "", "| method | " + " | ".join(str(s) for s in scen) + " |",
           "|---|" + "---|" * len(scen)]
    for m, f in ROWS:
        cells = []
        for s in scen:
            v = value(m, f, s)
            cells.append(fmt % v if v is not None else "")
        if any(cells):
            out.append(f"| {name(m, f)} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def main():
    out = sys.argv[1]
    cuda = load(os.path.join(out, "bench-cuda.csv"))
    ocl = load(os.path.join(out, "bench-nvidia-opencl.csv"))
    print("Kernel time in ms, 256^3 float, median of 20 runs after a warm-up (REF is timed by bench/paper.sh); scenarios as in the paper "
          "(1 (2,2,2), 2 (12,10,-11), 3 (-20,30,15), 4 (-20,30,0) voxels; 5 10 deg, 6 60 deg; "
          "7 (2.5,-3.2,-0.7) and -5 deg; 8 (42,21,12) and 20 deg; rotations about z through the centre).\n")
    for label, data in (("CUDA (CUDA events)", cuda), ("NVIDIA OpenCL (profiling events)", ocl)):
        if data:
            print(table(label, data, lambda m, f, s, d=data: float(d[(m, f, s)]["median_ms"])
                        if (m, f, s) in d else None, "%.3f"))
    if cuda and ocl:
        def ratio(m, f, s):
            k = (m, f, s)
            return float(ocl[k]["median_ms"]) / float(cuda[k]["median_ms"]) if k in ocl and k in cuda else None
        print(table("NVIDIA OpenCL time / CUDA time", cuda, ratio, "%.2f"))
        ratios = [ratio(m, f, s) for (m, f, s) in cuda if ratio(m, f, s) is not None]
        print(f"Largest OpenCL / CUDA ratio: {max(ratios):.2f} (target: at most 1.5)\n")
    for label, data in (("CUDA", cuda), ("NVIDIA OpenCL", ocl)):
        if not data or "device_ms" not in next(iter(data.values())):
            continue
        # One device-to-device copy of the volume: the cheapest input copy of
        # the table (a copy into the 3-D image; layers add a layout to it).
        copy = min(float(r["device_copy_ms"]) for r in data.values())
        def dev(m, f, s, d=data):
            return float(d[(m, f, s)]["device_ms"]) if (m, f, s) in d else None
        def part(m, f, s, d=data):
            return float(d[(m, f, s)]["device_copy_ms"]) if (m, f, s) in d else None
        def over(m, f, s, d=data):
            if (m, f, s) not in d:
                return None
            r = d[(m, f, s)]
            return float(r["device_ms"]) / (float(r["median_ms"]) + copy)
        print(f"Through a plan from device memory to device memory ({label}): the device time of the call "
              "(the input made current in the texture, and the kernel; device events), the input's part, and the "
              f"call's ratio to the kernel time above plus one device-to-device copy of the volume ({copy:.3f} ms, "
              "the cheapest input of the table).\n")
        print(table(f"{label}: device memory in and out, ms", data, dev, "%.3f"))
        print(table(f"{label}: of it the input made current, ms", data, part, "%.3f"))
        print(table(f"{label}: device path / (kernel + one copy)", data, over, "%.3f"))
        ab = {s: over("AB", "hardware", s) for s in range(1, 9) if over("AB", "hardware", s) is not None}
        if ab:
            bad = [s for s, v in ab.items() if v > 1.1]
            print(f"AB HARDWARE (target: at most 1.1): met in {len(ab) - len(bad)} of {len(ab)} scenarios"
                  + (f"; not in {', '.join(map(str, bad))} (largest {max(ab.values()):.3f})" if bad else "") + "\n")
    if cuda:
        print("### Targets (AB HARDWARE on CUDA)\n")
        for s, limit in ((2, 0.5), (3, 1.0)):
            k = ("AB", "hardware", s)
            if k in cuda:
                v = float(cuda[k]["median_ms"])
                print(f"- scenario {s}: {v:.3f} ms (target at most {limit} ms): {'met' if v <= limit else 'NOT met'}")
        print()


if __name__ == "__main__":
    main()
