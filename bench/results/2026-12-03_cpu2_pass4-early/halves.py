import os, subprocess, sys, tempfile
import numpy as np
sys.path.insert(0, "bench")
import estimate_family as fam, pass4_family as p4, head_frames as hf
kind, seed, prog = sys.argv[1], int(sys.argv[2]), sys.argv[3]
if kind == "family":
    d = fam.draw(seed); rng = np.random.default_rng([seed, 1]); frames, affine, bounds, truth = fam.simulate(d, rng)
else:
    rng = np.random.default_rng(seed); frames, affine, bounds, truth = hf.simulate(p4.SETUP, rng, steps=4, jerk_steps=40)
with tempfile.TemporaryDirectory() as t:
    nii, side = hf.write_series(t, frames, affine, bounds, "f")
    r = subprocess.run([prog, "motion", "estimate", nii, "--frames-from", side, "-o", os.path.join(t, "t.csv"), "-q", "--device", "host"],
                       env=dict(os.environ, PETBLUR_TRACE4="1"), capture_output=True, text=True)
    for l in r.stderr.splitlines():
        if "part" in l or "no contrast" in l:
            print(kind, seed, l)
