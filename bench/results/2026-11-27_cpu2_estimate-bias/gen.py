import sys, os, json, numpy as np, nibabel as nib
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..'))
import head_frames as hf
seed = int(sys.argv[1]); out = sys.argv[2]; setup = sys.argv[3] if len(sys.argv) > 3 else 'axial'
import estimate_validation as ev
import dataclasses
s = ev.SETUPS[setup]
if len(sys.argv) > 4: s = dataclasses.replace(s, counts=float(sys.argv[4]))
if os.environ.get("OVR"): s = dataclasses.replace(s, **json.loads(os.environ["OVR"]))
rng = np.random.default_rng(seed)
frames, affine, bounds, truth = hf.simulate(s, rng)
os.makedirs(out, exist_ok=True)
nib.save(nib.Nifti1Image(frames, affine), os.path.join(out, "frames.nii.gz"))
json.dump({"FrameTimesStart": bounds[:-1].tolist(), "FrameDuration": np.diff(bounds).tolist()}, open(os.path.join(out, "frames.json"), "w"))
np.save(os.path.join(out, "points.npy"), hf.head_points(rng))
json.dump({"seed": seed, "setup": setup, "ovr": json.loads(os.environ.get("OVR","{}"))}, open(os.path.join(out, "meta.json"), "w"))
