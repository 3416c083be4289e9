import os, subprocess, sys, tempfile
import numpy as np
sys.path.insert(0, "bench")
import estimate_validation as ev, head_frames as hf
seed, prog = int(sys.argv[1]), sys.argv[2]
rng = np.random.default_rng(seed)
frames, affine, bounds, truth = hf.simulate(ev.SETUPS["axial"], rng)
with tempfile.TemporaryDirectory() as t:
    nii, side = hf.write_series(t, frames, affine, bounds, "f")
    r = subprocess.run([prog, "motion", "estimate", nii, "--frames-from", side, "-o", os.path.join(t, "t.csv"), "-q", "--device", "host"],
                       env=dict(os.environ, PETBLUR_TRACE4="1"), capture_output=True, text=True)
    for l in r.stderr.splitlines():
        if "part" in l or "no contrast" in l or "TRACE4 p" in l:
            print("axial", seed, l)
