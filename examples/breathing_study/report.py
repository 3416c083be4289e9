#!/usr/bin/env python3
"""The breathing study's table and figures from a run's folder (study.py
--out DIR): table.md, curves.png (each lesion's contrast recovery against
the liver's variability, the noise, over the iterations), slices.png (a coronal slice through the right
lung base's lesion and the belt's trace).

  report.py DIR"""

import json
import os
import sys

import numpy as np


def table(res):
    s, r = res["settings"], res["results"]
    names = s["lesions"]
    lines = [f"| model | best NRMSE in body (iteration) | at the last iteration: lesion CR ({' / '.join(names)}) "
             "| liver variability | blur s | plan s |", "|---|---|---|---|---|---|"]
    for m, v in r.items():
        h = v["history"]
        best = int(np.argmin([e["nrmse"] for e in h]))
        last = h[-1]
        lines.append(f"| {v['label']} | {h[best]['nrmse']:.4f} ({best + 1}) | " +
                     " / ".join(f"{c:.2f}" for c in last["contrast_recovery"]) +
                     f" | {last['liver_variability']:.3f} | {v['blur_s']:.1f} | {v['plan_s']:.1f} |")
    return "\n".join(lines) + "\n"


def main():
    out = sys.argv[1]
    with open(os.path.join(out, "results.json")) as f:
        res = json.load(f)
    with open(os.path.join(out, "table.md"), "w") as f:
        f.write(table(res))
    print(table(res))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = res["settings"]["lesions"]
    fig, axes = plt.subplots(1, len(names), figsize=(4 * len(names), 3.6))
    for j, ax in enumerate(axes):
        for m, v in res["results"].items():
            h = v["history"]
            ax.plot([e["liver_variability"] for e in h], [e["contrast_recovery"][j] for e in h], label=v["label"])
        ax.set_title(names[j])
        ax.set_xlabel("liver variability (noise)")
        ax.set_ylabel("contrast recovery")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "curves.png"), dpi=110)
    z = np.load(os.path.join(out, "images.npz"))
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import thorax
    shape, voxel = tuple(res["settings"]["dims"]), res["settings"]["voxel"]
    centre = thorax.lesion_centres()[0][1]
    j = int(round(centre[1] / voxel[1] + (shape[1] - 1) / 2))
    keys = ["truth"] + [m for m in res["results"]]
    fig, axes = plt.subplots(1, len(keys) + 1, figsize=(2.6 * (len(keys) + 1), 3.2))
    vmax = float(np.percentile(z["truth"], 99.9))
    for ax, k in zip(axes, keys):
        ax.imshow(z[k][:, j, :].T, origin="lower", cmap="gray_r", vmin=0, vmax=vmax,
                  aspect=voxel[2] / voxel[0])
        ax.set_title("truth" if k == "truth" else res["results"][k]["label"], fontsize=7)
        ax.axis("off")
    ax = axes[-1]
    ax.plot(z["belt_t"], z["belt_s"], lw=0.5)
    for e in next(iter(res["settings"]["edges"].values())):
        ax.axhline(e, color="k", lw=0.4, ls=":")
    ax.set_xlim(0, min(60.0, float(z["belt_t"][-1])))
    ax.set_title("belt (first 60 s) and gate edges", fontsize=7)
    ax.set_xlabel("s")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "slices.png"), dpi=110)


if __name__ == "__main__":
    main()
