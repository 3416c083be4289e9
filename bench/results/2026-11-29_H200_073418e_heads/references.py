"""Does the reference frame drive the injection scans' error? A family draw (bench/estimate_family.py) estimated on
the host with --reference R (-1: the default), each track re-expressed relative to frame 0 by its own pose there.
From the repository root: PETBLUR=build/src/cli/petblur python3 references.py SEED R,R,..."""
import json, os, subprocess, sys, tempfile, time
import numpy as np
sys.path.insert(0, "bench")
import estimate_family as ef, head_frames as hf
import nibabel as nib
petblur = os.environ.get("PETBLUR", "build/src/cli/petblur")
seed = int(sys.argv[1]); refs = [int(x) for x in sys.argv[2].split(",")]
d = ef.draw(seed)
rng = np.random.default_rng([seed, 1])
frames, affine, bounds, truth = ef.simulate(d, rng)
points = hf.head_points(rng)
tmp = tempfile.mkdtemp()
nii, side = os.path.join(tmp, "f.nii.gz"), os.path.join(tmp, "f.json")
nib.save(nib.Nifti1Image(frames, affine), nii)
json.dump({"FrameTimesStart": bounds[:-1].tolist(), "FrameDuration": np.diff(bounds).tolist()}, open(side, "w"))
print(seed, "frames", len(bounds) - 1, "lengths", np.diff(bounds).round(1).tolist(), flush=True)
for r in refs:
    csv = os.path.join(tmp, f"t{r}.csv")
    t = time.time()
    p = subprocess.run([petblur, "motion", "estimate", nii, "--frames-from", side, "-o", csv, "-q", "--device", "host"]
                       + (["--reference", str(r)] if r >= 0 else []), capture_output=True, text=True)
    if p.returncode:
        print("ref", r, "failed", p.stderr[-500:]); continue
    times, maps = hf.read_matrix_csv(csv)
    track = hf.track_maps(times, maps)
    m0 = np.linalg.inv(track(0.5 * (bounds[0] + bounds[1])))
    e = hf.displacement_errors(lambda tt: track(tt) @ m0, truth, bounds, points)
    print("ref", r, "mean %.3f worst %.3f (frame %d) per frame %s  %.0f s" % (e.mean(), e.max(), e.argmax(), np.round(e, 2).tolist(), time.time() - t), flush=True)
