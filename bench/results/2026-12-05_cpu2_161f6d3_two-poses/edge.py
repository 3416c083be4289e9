"""edge.py SEED...: test_jerk_in_the_series_first_or_last_frame's series, the
edge frame's error over its time with the default and with PETBLUR_ESTIMATE_TWO=1,
against one pose."""
import os, sys
sys.path.insert(0, "python"); sys.path.insert(0, "python/tests")
import numpy as np
import petblur
import test_motion_from_frames as t

for seed in map(int, sys.argv[1:]):
    rng = np.random.default_rng(seed)
    nf = 7
    for j in (0, nf - 1):
        s = t.Series(rng, (32, 32, 32), (4.0, 3.5, 4.0), nf, jerk=j, at=float(rng.uniform(0.25, 0.75)))
        ref = int(rng.choice([k for k in range(nf) if abs(k - j) > 1]))
        to_ref = np.linalg.inv(s.maps[ref])
        points = s.phantom.inside(rng) @ s.maps[ref][:3, :3].T + s.maps[ref][:3, 3]
        truth = lambda tt: s.truth(tt) @ to_ref
        tj = s.starts[j] + (np.arange(40) + 0.5) / 40 * s.durations[j]
        mids = s.starts + s.durations / 2
        still = [k for k in range(nf) if k not in (j, ref)]
        out = []
        for two in ("0", "1"):
            os.environ["PETBLUR_ESTIMATE_TWO"] = two
            m = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, reference=ref, device="host",
                                           frame_poses_only=(two == "0" and False))
            e = np.mean([t._displacement(t._map(m, x), truth(x), points) for x in tj])
            es = max(t._displacement(t._map(m, mids[k]), truth(mids[k]), points) for k in still)
            out.append((e, es, m.moving_frames, m.frame_report[j]["motion_inside"]))
        one = petblur.Motion.from_frames(s.frames, s.affine, s.starts, s.durations, reference=ref, device="host",
                                         frame_poses_only=True)
        e1 = np.mean([t._displacement(t._map(one, x), truth(x), points) for x in tj])
        print(f"seed {seed} j {j} at {s.jerk_time:.2f}: one {e1:.3f}; default {out[0][0]:.3f} "
              f"({out[0][0]/e1:.2f}, still max {out[0][1]:.2f}, {out[0][2]} moving {out[0][3]}); "
              f"two {out[1][0]:.3f} ({out[1][0]/e1:.2f}, still max {out[1][1]:.2f}, {out[1][2]} moving {out[1][3]})",
              flush=True)
