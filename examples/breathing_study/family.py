#!/usr/bin/env python3
"""The breathing study over fresh draws: each seed a new breath (periods,
depths, drift, the belt's noise) and new Poisson noise, everything else as
study.py. Prints and writes (family.json, family.md) each model's best NRMSE
and last-iteration lesion contrast per seed, and the differences that the
study's claims rest on, petblur inside each gate (c) against one field per
gate (b) and on time frames (c') against (b'), as median and range over the
seeds.

  family.py --preset full --device cuda --seeds 2,3,4,5 --out DIR [--matrix M]"""

import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import study  # noqa: E402


def summary(results):
    out = {}
    for key, v in results.items():
        h = v["history"]
        out[key] = {"best_nrmse": min(e["nrmse"] for e in h), "contrast_recovery": h[-1]["contrast_recovery"],
                    "liver_variability": h[-1]["liver_variability"]}
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(study.PRESETS), default="small")
    ap.add_argument("--device", default="auto")
    ap.add_argument("--seeds", default="2,3,4,5")
    ap.add_argument("--gates", default="")
    ap.add_argument("--methods", default="bcBC")
    ap.add_argument("--out", default="breathing-family")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--matrix", default="")
    args = ap.parse_args()
    per_seed = {}
    for seed in [int(s) for s in args.seeds.split(",")]:
        run_args = argparse.Namespace(preset=args.preset, device=args.device, out=os.path.join(args.out, f"seed{seed}"),
                                      iterations=0, methods=args.methods, seed=seed, workers=args.workers,
                                      matrix=args.matrix, gates=args.gates)
        metrics, _, results, settings = study.run(run_args)
        os.remove(os.path.join(run_args.out, "images.npz"))
        per_seed[seed] = summary(results)
        lesions = settings["lesions"]
    keys = list(next(iter(per_seed.values())))
    pairs = [(k, "c" + k[1:]) for k in keys if k.startswith("b")] + [("B", "C")] * ("B" in keys and "C" in keys)
    lines = [f"| difference | seeds | best NRMSE | lesion CR ({' / '.join(lesions)}) |", "|---|---|---|---|"]

    def fmt(d):
        return f"{np.median(d):+.4f} [{np.min(d):+.4f}, {np.max(d):+.4f}]"

    for b, c in pairs:
        dn = [per_seed[s][c]["best_nrmse"] - per_seed[s][b]["best_nrmse"] for s in per_seed]
        dcr = np.array([np.subtract(per_seed[s][c]["contrast_recovery"], per_seed[s][b]["contrast_recovery"])
                        for s in per_seed])
        lines.append(f"| {c} - {b} | {len(per_seed)} | {fmt(dn)} | " +
                     " / ".join(f"{np.median(dcr[:, j]):+.2f} [{dcr[:, j].min():+.2f}, {dcr[:, j].max():+.2f}]"
                                for j in range(dcr.shape[1])) + " |")
    table = "\n".join(lines) + "\n\nmedian [min, max] over the seeds; negative NRMSE and positive CR favour the first\n"
    print(table)
    with open(os.path.join(args.out, "family.md"), "w") as f:
        f.write(table)
    with open(os.path.join(args.out, "family.json"), "w") as f:
        json.dump({"per_seed": per_seed, "lesions": lesions, "preset": args.preset}, f, indent=1)


if __name__ == "__main__":
    main()
