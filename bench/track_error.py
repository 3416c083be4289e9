"""A track's error against the simulated truth, as bench/estimate_validation.py states it.

    python3 bench/track_error.py DIR TRACK.csv
        mean and worst over frames, then each frame (mm)
    python3 bench/track_error.py DIR TRACK.csv ANCHOR
        each frame with track and truth both re-anchored on frame ANCHOR, and the mean displacement vector of a
        few frames (mm, world axes)
DIR holds bench/head_series.py's meta.json and points.npy."""
import dataclasses
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import estimate_validation as ev  # noqa: E402
import head_frames as hf  # noqa: E402

d, track = sys.argv[1], sys.argv[2]
meta = json.load(open(os.path.join(d, "meta.json")))
s = ev.SETUPS[meta["setup"]]
if meta.get("ovr"):
    s = dataclasses.replace(s, **meta["ovr"])
truth = hf.Truth(s)
bounds = np.arange(s.frames + 1) * s.frame_seconds
pts = np.load(os.path.join(d, "points.npy"))
tr = hf.track_maps(*hf.read_matrix_csv(track))
if len(sys.argv) < 4:
    err = hf.displacement_errors(tr, truth, bounds, pts)
    print("mean %.3f max %.3f (frame %d)" % (err.mean(), err.max(), err.argmax()), " ".join("%.2f" % e for e in err))
    sys.exit(0)
anchor = int(sys.argv[3])
mids = 0.5 * (bounds[:-1] + bounds[1:])
a, b = np.linalg.inv(tr(mids[anchor])), np.linalg.inv(truth(mids[anchor]))
out = []
for k in range(s.frames):
    diff = tr(mids[k]) @ a - truth(mids[k]) @ b
    moved = pts @ diff[:3, :3].T + diff[:3, 3]
    out.append(np.mean(np.linalg.norm(moved, axis=1)))
    if k in (0, 2, 4, 8, 16, 23):
        print(k, "mean displacement", np.round(moved.mean(0), 3))
print(" ".join("%.2f" % x for x in out))
