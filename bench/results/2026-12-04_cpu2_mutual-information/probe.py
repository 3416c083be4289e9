"""Still heads from injection (issue 47's family draws with their motion taken out): each frame registered alone to
a late reference frame (the third last) by SimpleITK with correlation and with Mattes mutual information (three
levels, bench/estimate_validation.py's sitk_track), and petblur's estimate with --reference at that frame; the truth
is the identity, so the error is the displacement inside the head.

    cd bench && PETBLUR_CLI=../build/src/cli/petblur python3 results/2026-12-04_cpu2_mutual-information/probe.py SEED MOD

MOD: still (as drawn: Poisson counts, uptake changing) or stillclean (1e6 counts a voxel). Prints a line a method and
writes SEED_MOD.json beside this file."""
import dataclasses, json, os, subprocess, sys, tempfile
import numpy as np
here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(here, "..", ".."))
import estimate_family as ef, head_frames as hf, estimate_validation as ev

seed, mod = int(sys.argv[1]), sys.argv[2]
d = ef.draw(seed)
d = dataclasses.replace(d, nods=[], jerks=[], drift_mm=(0.0, 0.0, 0.0), drift_deg=0.0)
if mod == "stillclean":
    d = dataclasses.replace(d, counts_per_voxel=1e6)
rng = np.random.default_rng([seed, 1])
frames, affine, bounds, truth = ef.simulate(d, rng)
points = hf.head_points(rng)
n = len(bounds) - 1
ref = n - 3
out = {"seed": seed, "mod": mod, "frames": n, "ref": ref, "lengths": np.diff(bounds).round(1).tolist()}
for metric in ("correlation", "mattes"):
    times, maps = ev.sitk_track(frames, affine, bounds, 2, metric, ref)
    e = hf.displacement_errors(hf.track_maps(times, maps), truth, bounds, points)
    out[metric] = [round(float(x), 3) for x in e]
with tempfile.TemporaryDirectory() as tmp:
    nii, side = hf.write_series(tmp, frames, affine, bounds, "f")
    csv = os.path.join(tmp, "t.csv")
    subprocess.run([os.environ.get("PETBLUR_CLI", "petblur"), "motion", "estimate", nii, "--frames-from", side, "-o", csv,
                    "--device", "host", "--reference", str(ref), "-q"], check=True, capture_output=True)
    e = hf.displacement_errors(hf.track_maps(*hf.read_matrix_csv(csv)), truth, bounds, points)
    out["petblur"] = [round(float(x), 3) for x in e]
for k in ("correlation", "mattes", "petblur"):
    v = np.array(out[k])
    print(f"{seed} {mod} {k:12s} mean {v.mean():.3f} first-half {v[: n // 2].mean():.3f} max {v.max():.3f}: "
          + " ".join(f"{x:.2f}" for x in v), flush=True)
with open(os.path.join(here, f"{seed}_{mod}.json"), "w") as f:
    json.dump(out, f)
