import sys, os, json, numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..'))
import head_frames as hf, estimate_validation as ev
d = sys.argv[1]; track = sys.argv[2]
meta = json.load(open(os.path.join(d, "meta.json")))
import dataclasses
s = ev.SETUPS[meta["setup"]]
if meta.get("ovr"): s = dataclasses.replace(s, **meta["ovr"])
truth = hf.Truth(s)
bounds = np.arange(s.frames + 1) * s.frame_seconds
pts = np.load(os.path.join(d, "points.npy"))
err = hf.displacement_errors(hf.track_maps(*hf.read_matrix_csv(track)), truth, bounds, pts)
print("mean %.3f max %.3f (frame %d)" % (err.mean(), err.max(), err.argmax()), " ".join("%.2f" % e for e in err))
