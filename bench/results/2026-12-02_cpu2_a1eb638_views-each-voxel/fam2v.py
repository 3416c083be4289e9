import os, sys, numpy as np
sys.path.insert(0, "python/tests")
import petblur
from test_motion_from_frames import Series, _map, _displacement
seeds = [int(x) for x in sys.argv[2:]] if sys.argv[1] == "seeds" else list(np.random.default_rng(int(sys.argv[1])).integers(0, 2**32, int(sys.argv[2])))
for seed in seeds:
    rng = np.random.default_rng(seed)
    s = Series(rng, (32, 32, 32), (4.0, 3.5, 4.0), 7, jerk=4)
    nf, j = len(s.maps), s.jerk
    ref = int(rng.choice([k for k in range(nf) if abs(k - j) > 1]))
    out = []
    for v in os.environ.get("VARIANTS", "sampled,sharpened").split(","):
        os.environ["PETBLUR_ESTIMATE_VIEWS"] = v
        m = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, reference=ref, device="host")
        u = [round(f["unfollowed"], 4) for f in m.frame_report]
        mv = [f["frame"] for f in m.frame_report if f["motion_inside"]]
        tj = s.starts[j] + (np.arange(40) + 0.5) / 40 * s.durations[j]
        to_ref = np.linalg.inv(s.maps[ref])
        pts = s.phantom.inside(np.random.default_rng(1)) @ s.maps[ref][:3, :3].T + s.maps[ref][:3, 3]
        ej = np.mean([_displacement(_map(m, t), s.truth(t) @ to_ref, pts) for t in tj])
        out.append(f"{v}: flags {[(k, x) for k, x in enumerate(u) if x > 0]} moving {mv} jerk {ej:.3f}")
    print("SEED", seed, "ref", ref, " | ".join(out), flush=True)
