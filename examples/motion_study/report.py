#!/usr/bin/env python3
"""The study's outputs from a run folder (study.py's results.json and
images.npz): table.md, curves.png (NRMSE and lesion contrast against
iteration) and slices.png (slices: truth, (a), (b), (e), (f), (g); axial through the first lesion).

  report.py DIR"""

import json
import os
import sys

import numpy as np


def table(res):
    s = res["settings"]
    lines = [f"MLEM, {s['iterations']} iterations, {s['frames']} frames of {s['frame_s']:g} s, grid "
             f"{'x'.join(map(str, s['dims']))} of {'x'.join(f'{v:g}' for v in s['voxel'])} mm, {s['angles']} angles "
             f"(ASTRA strip, slice by slice), {s['counts']:.3g} counts per frame, data from {s['poses']} poses per "
             f"frame; petblur on {s['petblur_device']}.", "",
             "| model | NRMSE in brain | lesion CR (8 / 10 / 6 mm) | background variability | projector s | blur s |",
             "|---|---|---|---|---|---|"]
    for m, r in res["results"].items():
        last = r["history"][-1]
        cr = " / ".join(f"{v:.2f}" for v in last["contrast_recovery"])
        lines.append(f"| {r['label']} | {last['nrmse']:.4f} | {cr} | {last['background_variability']:.3f} | "
                     f"{r['projector_s']:.1f} | {r['blur_s']:.1f} |")
    e = res.get("estimate")
    if e:
        lines += ["", f"(g)'s track: {e['short_frames']} frames of {e['short_s']:g} s, each reconstructed by "
                  f"{s.get('short_iterations', '?')} MLEM iterations without a motion model ({e['reconstruction_s']:.1f} "
                  f"s), then petblur.Motion.from_frames ({e['estimate_s']:.1f} s, {e['keys']} keys, "
                  f"{e['moving_frames']} frames with motion inside). Its displacement error inside the brain against "
                  f"the true track, averaged over each frame: {e['mean_mm']:.2f} mm mean over frames, "
                  f"{e['max_mm']:.2f} mm at the worst (frame {e['worst_frame']})."]
    return "\n".join(lines) + "\n"


def curves(res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 4, figsize=(16, 3.6))
    for m, r in res["results"].items():
        it = np.arange(1, len(r["history"]) + 1)
        ax[0].plot(it, [h["nrmse"] for h in r["history"]], label=r["label"])
        for j in range(3):
            ax[j + 1].plot(it, [h["contrast_recovery"][j] for h in r["history"]], label=r["label"])
    ax[0].set_title("NRMSE inside the brain")
    for j, name in enumerate(["lesion 1 (8 mm)", "lesion 2 (10 mm)", "lesion 3 (6 mm)"]):
        ax[j + 1].set_title(f"contrast recovery, {name}")
    for a in ax:
        a.set_xlabel("MLEM iteration")
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def slices(res, images, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    show = [("truth", "truth")] + [(m, res["results"][m]["label"]) for m in "abefg" if m in res["results"]]
    truth = images["truth"]
    vmax = float(truth.max())
    nx, ny, nz = truth.shape
    dx, dy, dz = res["settings"]["voxel"]
    # The phantom's array runs right to left, front to back, top to bottom:
    # origin "upper" shows the head's top up, its front up in the axial row,
    # and the patient's right on the left (radiological). The axial slice goes
    # through the first lesion.
    affine = np.array(res["settings"]["affine"])
    lesion = np.linalg.inv(affine) @ np.array([*res["settings"]["lesions"][0][0], 1.0])
    k = int(np.clip(round(lesion[2]), 0, nz - 1))
    fig, ax = plt.subplots(3, len(show), figsize=(2.6 * len(show), 7.4))
    for c, (key, label) in enumerate(show):
        v = images[key]
        ax[0, c].imshow(v[:, :, k].T, origin="upper", cmap="gray_r", vmin=0, vmax=vmax, aspect=dy / dx)
        ax[1, c].imshow(v[:, ny // 2, :].T, origin="upper", cmap="gray_r", vmin=0, vmax=vmax, aspect=dz / dx)
        ax[2, c].imshow(v[nx // 2, :, :].T, origin="upper", cmap="gray_r", vmin=0, vmax=vmax, aspect=dz / dy)
        nrmse = "" if key == "truth" else f"\nNRMSE {res['results'][key]['history'][-1]['nrmse']:.3f}"
        ax[0, c].set_title(label + nrmse, fontsize=8)
        for r in range(3):
            ax[r, c].axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    d = sys.argv[1]
    res = json.load(open(os.path.join(d, "results.json")))
    images = dict(np.load(os.path.join(d, "images.npz")))
    with open(os.path.join(d, "table.md"), "w") as f:
        f.write(table(res))
    curves(res, os.path.join(d, "curves.png"))
    slices(res, images, os.path.join(d, "slices.png"))
    print(open(os.path.join(d, "table.md")).read())


if __name__ == "__main__":
    main()
