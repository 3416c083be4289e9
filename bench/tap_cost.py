#!/usr/bin/env python3
"""What a translation's taps cost against the kernel they replace, on fresh
translations: for translations drawn at random (lengths of 0.5 to 40 voxels
along the major axis, any direction, fractional), every method class (AB's
walk, AB's chord, RM, CL) and both filters, the library's own device time of a
forward on a 256^3 torch CUDA tensor in x-fastest order (the C library's own
layout; on another --device, such as opencl:0 for PoCL, a numpy array in that
order) three ways: as the library chooses, the kernel alone
(PETBLUR_SHIFT_TAPS=0) and the taps forced (PETBLUR_SHIFT_TAPS=100000).
Each time is the kernel's plus the input's copy into the texture, which
the taps do not make. The taps are counted from the kernel's blur of an
impulse (cl/pb_taps.cl: the taps are that response).

src/devices/shift_taps.c's rule was fitted on such draws (seed 1 on the
H200, bench/gpu.sh tapcost); fresh seeds check it: where the chosen time
stands against the better of the two.

  tap_cost.py [--draws 24] [--seed 1] [--size 256] [--device cuda:0] [--longest 40] [--out tap_cost.csv]"""

import argparse
import csv
import os
import statistics
import sys

import numpy as np

import petblur

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from library_time import device_ms  # noqa: E402

VS = 2.0
CLASSES = (("ab", None), ("ab", "chord"), ("rm", None), ("cl", None))
MODES = (("chosen", None), ("kernel", "0"), ("taps", "100000"))


def set_limit(value):
    if value is None:
        os.environ.pop("PETBLUR_SHIFT_TAPS", None)
    else:
        os.environ["PETBLUR_SHIFT_TAPS"] = value


def operator(shape, t, method, sampling, filt, device):
    return petblur.BlurOperator(shape, VS, petblur.Motion.from_axis_angle(translation=np.asarray(t) * VS),
                                method=method, ab_sampling=sampling, filter=filt, device=device)


def tap_count(t, method, sampling, filt, device):
    """Voxels the kernel's blur of an impulse reaches: the convolution's taps."""
    set_limit("0")
    m = int(2 * max(abs(v) for v in t)) + 9
    impulse = np.zeros((m, m, m), dtype=np.float32)
    impulse[m // 2, m // 2, m // 2] = 1.0
    return int(np.count_nonzero(operator((m, m, m), t, method, sampling, filt, device).adjoint(impulse)))


def draw(rng, longest):
    """A translation: its length along the major axis log-uniform in 0.5 to
    longest voxels, its direction uniform on the sphere."""
    d = rng.normal(size=3)
    d /= np.abs(d).max()
    return tuple(float(v) for v in np.round(d * np.exp(rng.uniform(np.log(0.5), np.log(longest))), 2))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--draws", type=int, default=24)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--longest", type=float, default=40.0)
    ap.add_argument("--out", default="tap_cost.csv")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    n = args.size
    if args.device.startswith("cuda"):
        import torch
        x = torch.rand((n, n, n), device=args.device).permute(2, 1, 0)  # x fastest
        name = torch.cuda.get_device_name(0)
    else:
        x = np.asfortranarray(rng.random((n, n, n), dtype=np.float32))
        name = dict(petblur.devices()).get(args.device, args.device)
    print(f"# {name}, {n}^3, seed {args.seed}: device ms (kernel + the input's copy), median of 5 calls")
    print("| translation | class | filter | taps | chosen ms | kernel ms | taps ms | chosen / best |")
    print("|---|---|---|---|---|---|---|---|")
    rows = []
    for _ in range(args.draws):
        t = draw(rng, args.longest)
        for method, sampling in CLASSES:
            for filt in ("hardware", "exact"):
                row = dict(translation=str(t), L=float(np.abs(t).max()), L1=float(np.abs(t).sum()),
                           method=method, sampling=sampling or "default", filter=filt,
                           taps=tap_count(t, method, sampling, filt, args.device))
                for name, limit in MODES:
                    set_limit(limit)
                    op = operator((n, n, n), t, method, sampling, filt, args.device)
                    k, inp = device_ms(op, lambda: op(x))
                    row[f"{name} ms"] = k + inp
                    del op
                set_limit(None)
                best = min(row["kernel ms"], row["taps ms"])
                row["chosen / best"] = row["chosen ms"] / best
                rows.append(row)
                print(f"| {t} | {method}{'-' + sampling if sampling else ''} | {filt} | {row['taps']} | "
                      f"{row['chosen ms']:.3f} | {row['kernel ms']:.3f} | {row['taps ms']:.3f} | "
                      f"{row['chosen / best']:.2f} |", flush=True)
    with open(args.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    ratios = sorted(r["chosen / best"] for r in rows)
    print(f"chosen / best over {len(rows)} rows: median {statistics.median(ratios):.3f}, "
          f"90th {ratios[int(0.9 * (len(ratios) - 1))]:.3f}, worst {ratios[-1]:.3f}")
    # The fixed limit of 24 taps that the library kept before its rule by cost.
    before = sorted((r["taps ms"] if r["taps"] <= 24 else r["kernel ms"]) / r["chosen ms"] for r in rows)
    print(f"a limit of 24 taps / chosen: median {statistics.median(before):.3f}, least {before[0]:.3f}, "
          f"most {before[-1]:.3f}")


if __name__ == "__main__":
    main()
