"""Pass 4's per-frame shares of its residual's decrease on one family draw:
runs the probe build with PETBLUR_TRACE4=1 and CONTRAST=0, prints per-frame errors."""
import json, os, subprocess, sys, tempfile
import numpy as np
sys.path.insert(0, "bench")
import estimate_family as fam, head_frames as hf
seed, prog = int(sys.argv[1]), sys.argv[2]
d = fam.draw(seed)
rng = np.random.default_rng([seed, 1])
frames, affine, bounds, truth = fam.simulate(d, rng)
points = hf.head_points(rng)
out = {"seed": seed, "from_injection": d.start_s == 0.0, "bounds": [round(float(b), 1) for b in bounds],
       "nods": [(round(a, 1), round(n, 1), round(g, 1)) for a, n, g, _ in d.nods],
       "jerks": [(round(a, 1), round(n, 2), round(g, 1), round(m, 1)) for a, n, g, _, m, _ in d.jerks],
       "voxel": list(d.voxel)}
with tempfile.TemporaryDirectory() as tmp:
    nii, side = hf.write_series(tmp, frames, affine, bounds, "f")
    for name, env in (("default", {"PETBLUR_TRACE4": "1"}), ("nop4", {"PETBLUR_ESTIMATE_CONTRAST": "0"})):
        csv = os.path.join(tmp, name + ".csv")
        r = subprocess.run([prog, "motion", "estimate", nii, "--frames-from", side, "-o", csv, "-q", "--device", "host"],
                           capture_output=True, text=True, env=dict(os.environ, **env))
        assert r.returncode == 0, r.stderr[-2000:]
        e = hf.displacement_errors(hf.track_maps(*hf.read_matrix_csv(csv)), truth, bounds, points)
        out[name] = {"mean": round(float(e.mean()), 3), "per_frame": [round(float(x), 3) for x in e]}
        if name == "default":
            out["trace"] = [l for l in r.stderr.splitlines() if l.startswith("TRACE4")]
print(json.dumps(out))
