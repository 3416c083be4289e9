import sys, os, json, numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..'))
import head_frames as hf, estimate_validation as ev
d = sys.argv[1]; track = sys.argv[2]; anchor = int(sys.argv[3])
meta = json.load(open(os.path.join(d, "meta.json")))
import dataclasses
s = ev.SETUPS[meta["setup"]]
if meta.get("ovr"): s = dataclasses.replace(s, **meta["ovr"])
truth = hf.Truth(s)
bounds = np.arange(s.frames + 1) * s.frame_seconds
pts = np.load(os.path.join(d, "points.npy"))
tr = hf.track_maps(*hf.read_matrix_csv(track))
mids = 0.5*(bounds[:-1]+bounds[1:])
A = tr(mids[anchor]); B = truth(mids[anchor])
out=[]
for k in range(s.frames):
    e = tr(mids[k]) @ np.linalg.inv(A); t = truth(mids[k]) @ np.linalg.inv(B)
    D = e - t
    dp = pts @ D[:3,:3].T + D[:3,3]
    out.append(np.mean(np.linalg.norm(dp,axis=1)))
    if k in (0,2,4,8,16,23): print(k, "mean disp vec", np.round(dp.mean(0),3))
print(" ".join("%.2f"%x for x in out))
