#!/usr/bin/env python3
"""The better of two rounds, side by side: petblur bench's results.csv of two
runs A and B (two trees, or one tree two ways), each run twice, read from
DIR/A-1.csv, DIR/B-1.csv, DIR/A-2.csv and DIR/B-2.csv; for every scenario,
method and filter, each column's least time of the two rounds for A and B and
their ratio B / A, as a Markdown table. A row one run lacks (a method only
one tree has) reads nan. REF, whose time is the reference's, is left out.

  best_of.py DIR [--runs old,new] [--columns adjoint_ms,kernel_ms] [--rms]

--rms adds each run's rms_pct (first round) beside the times: where A and B
compute the same operator two ways, they agree to rounding."""
import argparse
import csv
import math

NAMES = {"kernel_ms": "forward", "adjoint_ms": "adjoint"}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--runs", default="old,new")
    ap.add_argument("--columns", default="kernel_ms,adjoint_ms")
    ap.add_argument("--rms", action="store_true")
    args = ap.parse_args()
    runs, cols = args.runs.split(","), args.columns.split(",")
    best, rms = {}, {}
    for which in runs:
        for r in (1, 2):
            for row in csv.DictReader(open(f"{args.dir}/{which}-{r}.csv")):
                if row["method"] == "REF":
                    continue
                key = (row["scenario"], row["method"], row["filter"])
                for col in cols:
                    v = float(row[col]) if row[col] else math.nan
                    best[(which, col) + key] = min(best.get((which, col) + key, v), v)
                if r == 1:
                    rms[(which,) + key] = row["rms_pct"]
    keys = sorted({k[2:] for k in best}, key=lambda k: (int(k[0]), k[1], k[2]))
    a, b = runs
    head = ["scenario", "method", "filter"]
    for col in cols:
        head += [f"{NAMES.get(col, col)} {a} ms", f"{NAMES.get(col, col)} {b} ms", f"{b} / {a}"]
    if args.rms:
        head += [f"rms % {a}", f"rms % {b}"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for k in keys:
        cells = list(k)
        for col in cols:
            va, vb = best.get((a, col) + k, math.nan), best.get((b, col) + k, math.nan)
            cells += [f"{va:.4f}", f"{vb:.4f}", f"{vb / va:.3f}" if va > 0 else "nan"]
        if args.rms:
            cells += [rms.get((a,) + k, "nan"), rms.get((b,) + k, "nan")]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
