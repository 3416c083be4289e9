"""python drawmod.py SEED MOD DIR [tracks...]: the draw changed by MOD (nojerk, steady, both, still, nonod; anything else: as drawn); without tracks it writes the series, with them their errors"""
import sys, os, json, dataclasses, numpy as np
sys.path.insert(0, "/work/main/bench")
import estimate_family as ef, head_frames as hf
seed, mod, out = int(sys.argv[1]), sys.argv[2], sys.argv[3]
d = ef.draw(seed)
if mod in ("nojerk", "both"):
    d = dataclasses.replace(d, jerks=[])
if mod in ("steady", "both"):
    d = dataclasses.replace(d, curves=[(1.0, 1.0, 1.0)] * 4)
if mod == "still":
    d = dataclasses.replace(d, nods=[], jerks=[], drift_mm=(0.0, 0.0, 0.0), drift_deg=0.0)
if mod.startswith("still") and mod != "still":
    d = dataclasses.replace(d, nods=[], jerks=[], drift_mm=(0.0, 0.0, 0.0), drift_deg=0.0)
    if "clean" in mod:
        d = dataclasses.replace(d, counts_per_voxel=1e6)
    if "steady" in mod:
        d = dataclasses.replace(d, curves=[(1.0, 1.0, 1.0)] * 4)
if mod == "nonod":
    d = dataclasses.replace(d, nods=[], drift_mm=(0.0, 0.0, 0.0), drift_deg=0.0)
rng = np.random.default_rng([seed, 1])
frames, affine, bounds, truth = ef.simulate(d, rng)
points = hf.head_points(rng)
if len(sys.argv) > 4:
    fm = hf.displacement_errors(hf.track_maps(*ef.frame_means(truth, bounds)), truth, bounds, points)
    for t in sys.argv[4:]:
        e = hf.displacement_errors(hf.track_maps(*hf.read_matrix_csv(t)), truth, bounds, points)
        print(os.path.basename(t), "mean %.3f max %.3f" % (e.mean(), e.max()), " ".join("%.2f" % x for x in e))
    print("one-pose", "mean %.3f max %.3f" % (fm.mean(), fm.max()), " ".join("%.2f" % x for x in fm))
else:
    import nibabel as nib
    os.makedirs(out, exist_ok=True)
    nib.save(nib.Nifti1Image(frames, affine), os.path.join(out, "f.nii.gz"))
    json.dump({"FrameTimesStart": bounds[:-1].tolist(), "FrameDuration": np.diff(bounds).tolist()}, open(os.path.join(out, "f.json"), "w"))
