#!/usr/bin/env python3
"""How long `petblur blur --fields --signal --gates` takes to plan long belts: two builds of the program on the
same inputs, each run timed whole (the blur itself is milliseconds on this 16^3 grid). The inputs: a 16^3 image of 2
mm, fields at the surrogate values 0 and 1 (a still one and a smooth 3 mm one), and 25 Hz belts of a 4.1 s breath
with 0.01 of noise, clipped to the fields' values.

    python3 gate_planning.py OLD_PETBLUR NEW_PETBLUR [TIMEOUT_S]
"""
import os
import subprocess
import sys
import tempfile
import time

import nibabel as nib
import numpy as np
from scipy.ndimage import gaussian_filter


def inputs(folder, rng):
    affine = np.diag([2.0, 2.0, 2.0, 1.0])
    nib.save(nib.Nifti1Image(gaussian_filter(rng.random((16, 16, 16)), 1.5).astype(np.float32), affine),
             os.path.join(folder, "in.nii"))
    for name, amp in (("v0.nii", 0.0), ("v1.nii", 3.0)):
        d = np.stack([gaussian_filter(rng.standard_normal((16, 16, 16)), 2.0) for _ in range(3)], axis=-1)
        d = d / np.abs(d).max() * amp
        img = nib.Nifti1Image(d.astype(np.float32)[:, :, :, None, :], affine)
        img.header["intent_code"] = 1006
        nib.save(img, os.path.join(folder, name))
    with open(os.path.join(folder, "values.csv"), "w") as f:
        f.write("value,path\n0,v0.nii\n1,v1.nii\n")


def belt(path, minutes, rng):
    t = np.arange(0.0, minutes * 60.0, 0.04)
    s = np.clip(0.5 - 0.5 * np.cos(2 * np.pi * t / 4.1) + 0.01 * rng.standard_normal(t.size), 0.0, 1.0)
    with open(path, "w") as f:
        f.write("time,value\n" + "".join(f"{a:.3f},{b:.5f}\n" for a, b in zip(t, s)))


def timed(petblur, folder, signal, edges, timeout):
    t0 = time.perf_counter()
    try:
        p = subprocess.run([petblur, "blur", "-i", "in.nii", "-o", "out.nii", "--fields", "values.csv", "--signal",
                            signal, "--gates", edges, "--device", "host", "-q"], cwd=folder, capture_output=True,
                           text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return f"> {timeout} s (stopped)"
    dt = time.perf_counter() - t0
    return f"{dt:.2f} s" if p.returncode == 0 else f"exit {p.returncode} after {dt:.2f} s: {p.stderr.strip()[:160]}"


def main(old, new, timeout):
    rng = np.random.default_rng(20261202)
    with tempfile.TemporaryDirectory() as folder:
        inputs(folder, rng)
        four = "0.1,0.3,0.5,0.7,0.9"
        ten = ",".join(f"{x:.2f}" for x in np.linspace(0.05, 0.95, 11))
        print("| belt | gates | old | new |\n|---|---|---|---|")
        for minutes, edges, label in ((20, four, "4"), (60, four, "4"), (240, ten, "10")):
            name = f"belt{minutes}.csv"
            belt(os.path.join(folder, name), minutes, rng)
            print(f"| {minutes} min at 25 Hz | {label} | {timed(old, folder, name, edges, timeout)} | "
                  f"{timed(new, folder, name, edges, timeout)} |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], float(sys.argv[3]) if len(sys.argv) > 3 else 120.0)
