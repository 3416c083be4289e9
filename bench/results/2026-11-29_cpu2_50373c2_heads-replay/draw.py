"""python draw.py SEED DIR: write the draw; python draw.py SEED DIR TRACK.csv: its errors"""
import sys, os, json, numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
import estimate_family as ef, head_frames as hf
seed, out = int(sys.argv[1]), sys.argv[2]
d = ef.draw(seed)
rng = np.random.default_rng([seed, 1])
frames, affine, bounds, truth = ef.simulate(d, rng)
points = hf.head_points(rng)
def errors(times, maps):
    e = hf.displacement_errors(hf.track_maps(times, maps), truth, bounds, points)
    return e
if len(sys.argv) > 3:
    fm = errors(*ef.frame_means(truth, bounds))
    for t in sys.argv[3:]:
        e = errors(*hf.read_matrix_csv(t))
        print(os.path.basename(t), "mean %.3f max %.3f" % (e.mean(), e.max()), " ".join("%.2f" % x for x in e))
    print("one-pose", "mean %.3f max %.3f" % (fm.mean(), fm.max()), " ".join("%.2f" % x for x in fm))
    print("bounds", " ".join("%.1f" % b for b in bounds))
    print("jerks", [(round(a, 1), round(n, 2), round(g, 1), round(m, 1)) for a, n, g, _, m, _ in d.jerks], "nods", [(round(a, 1), round(n, 1), round(g, 1)) for a, n, g, _ in d.nods])
else:
    import nibabel as nib
    os.makedirs(out, exist_ok=True)
    nib.save(nib.Nifti1Image(frames, affine), os.path.join(out, "f.nii.gz"))
    json.dump({"FrameTimesStart": bounds[:-1].tolist(), "FrameDuration": np.diff(bounds).tolist()}, open(os.path.join(out, "f.json"), "w"))
