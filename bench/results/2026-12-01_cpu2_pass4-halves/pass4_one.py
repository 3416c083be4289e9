import sys, os, json, numpy as np
sys.path.insert(0, "/work/main/bench")
import head_frames as hf, pass4_family as pf
import nibabel as nib
seed, out = int(sys.argv[1]), sys.argv[2]
rng = np.random.default_rng(seed)
frames, affine, bounds, truth = hf.simulate(pf.SETUP, rng, steps=4, jerk_steps=40)
points = hf.head_points(rng)
if len(sys.argv) > 3:
    for t in sys.argv[3:]:
        e = hf.displacement_errors(hf.track_maps(*hf.read_matrix_csv(t)), truth, bounds, points)
        print(os.path.basename(t), "mean %.3f max %.3f" % (e.mean(), e.max()))
else:
    os.makedirs(out, exist_ok=True)
    nib.save(nib.Nifti1Image(frames, affine), os.path.join(out, "f.nii.gz"))
    json.dump({"FrameTimesStart": bounds[:-1].tolist(), "FrameDuration": np.diff(bounds).tolist()}, open(os.path.join(out, "f.json"), "w"))
