import json, os, subprocess, sys, tempfile
import numpy as np
sys.path.insert(0, "bench")
import pass4_family as p4, head_frames as hf
seed, prog = int(sys.argv[1]), sys.argv[2]
rng = np.random.default_rng(seed)
frames, affine, bounds, truth = hf.simulate(p4.SETUP, rng, steps=4, jerk_steps=40)
points = hf.head_points(rng)
out = {"seed": seed}
with tempfile.TemporaryDirectory() as d:
    nii, side = hf.write_series(d, frames, affine, bounds, "f")
    for on in ("1", "0"):
        csv = os.path.join(d, f"t{on}.csv")
        r = subprocess.run([prog, "motion", "estimate", nii, "--frames-from", side, "-o", csv, "-q", "--device", "host"],
                           env=dict(os.environ, PETBLUR_ESTIMATE_CONTRAST=on, PETBLUR_TRACE4="1"), capture_output=True, text=True)
        assert r.returncode == 0, r.stderr[-2000:]
        e = hf.displacement_errors(hf.track_maps(*hf.read_matrix_csv(csv)), truth, bounds, points)
        out["on" if on == "1" else "off"] = round(float(e.mean()), 3)
        if on == "1":
            out["trace"] = [l for l in r.stderr.splitlines() if l.startswith("TRACE4")]
print(json.dumps(out))
