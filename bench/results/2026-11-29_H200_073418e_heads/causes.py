"""Which part of a family draw (bench/estimate_family.py) makes the estimate fail: the same draw with one thing
changed (counts x10, steady uptake in every tissue, pass 4 off), estimated on the host. From the repository root:
PETBLUR=build/src/cli/petblur python3 causes.py SEED WHAT, WHAT one of: default, "counts x10", "steady uptake",
"no pass 4", "frame poses only"."""
import dataclasses, json, os, subprocess, sys, tempfile, time
import numpy as np
sys.path.insert(0, "bench")
import estimate_family as ef, head_frames as hf
import nibabel as nib
petblur = os.environ.get("PETBLUR", "build/src/cli/petblur")
seed, what = int(sys.argv[1]), sys.argv[2]
d = ef.draw(seed)
env = dict(os.environ)
args = []
if what == "counts x10":
    d = dataclasses.replace(d, counts_per_voxel=d.counts_per_voxel * 10)
elif what == "steady uptake":
    d = dataclasses.replace(d, curves=[(1.0, 1.0, 1.0)] * 4)
elif what == "no pass 4":
    env["PETBLUR_ESTIMATE_CONTRAST"] = "0"
elif what == "frame poses only":
    args = ["--frame-poses-only"]
rng = np.random.default_rng([seed, 1])
frames, affine, bounds, truth = ef.simulate(d, rng)
points = hf.head_points(rng)
tmp = tempfile.mkdtemp()
nii, side, csv = (os.path.join(tmp, n) for n in ("f.nii.gz", "f.json", "t.csv"))
nib.save(nib.Nifti1Image(frames, affine), nii)
json.dump({"FrameTimesStart": bounds[:-1].tolist(), "FrameDuration": np.diff(bounds).tolist()}, open(side, "w"))
t = time.time()
subprocess.run([petblur, "motion", "estimate", nii, "--frames-from", side, "-o", csv, "-q", "--device", "host"] + args,
               check=True, env=env)
e = hf.displacement_errors(hf.track_maps(*hf.read_matrix_csv(csv)), truth, bounds, points)
fm = hf.displacement_errors(hf.track_maps(*ef.frame_means(truth, bounds)), truth, bounds, points)
print(f"{seed} {what}: mean {e.mean():.3f} worst {e.max():.3f}; one pose a frame {fm.mean():.3f}; per frame "
      f"{np.round(e, 2).tolist()} ({time.time() - t:.0f} s)", flush=True)
