"""A series of bench/head_frames.py, written as petblur motion estimate reads it.

    python3 bench/head_series.py SEED DIR [SETUP [COUNTS]]     OVR='{"nod_deg": 0, ...}' overrides Setup's fields

DIR gets frames.nii.gz and its BIDS-PET sidecar frames.json, the points the error is measured on (drawn after the
frames, as bench/estimate_validation.py draws them) and meta.json (seed, setup, overrides)."""
import dataclasses
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import estimate_validation as ev  # noqa: E402
import head_frames as hf  # noqa: E402

seed, out = int(sys.argv[1]), sys.argv[2]
setup = sys.argv[3] if len(sys.argv) > 3 else "axial"
override = json.loads(os.environ.get("OVR", "{}"))
s = ev.SETUPS[setup]
if len(sys.argv) > 4:
    s = dataclasses.replace(s, counts=float(sys.argv[4]))
s = dataclasses.replace(s, **override)
rng = np.random.default_rng(seed)
frames, affine, bounds, truth = hf.simulate(s, rng)
os.makedirs(out, exist_ok=True)
hf.write_series(out, frames, affine, bounds)
np.save(os.path.join(out, "points.npy"), hf.head_points(rng))
with open(os.path.join(out, "meta.json"), "w") as f:
    json.dump({"seed": seed, "setup": setup, "ovr": override}, f)
