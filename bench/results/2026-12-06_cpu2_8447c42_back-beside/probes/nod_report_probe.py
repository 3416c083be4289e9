"""The nod test's series at a seed (test_a_nod_that_turns_back_inside_a_frame):
each frame's reported unfollowed share, with every frame and with one left out.
  PETBLUR_LIBRARY=build/src/libpetblur.so python3 THIS_FILE SEED"""
import os, sys
import numpy as np
sys.path[:0] = ["python", "python/tests"]  # run from the repository root
import petblur
import test_motion_from_frames as T
seed = int(sys.argv[1])
rng = np.random.default_rng(seed)
nf, seconds = 7, 10.0
k = int(rng.integers(2, nf - 1))
nod = T._rigid(rng, float(rng.uniform(6.0, 10.0)), 0.0)
v = rng.normal(size=3)
nod[:3, 3] = rng.uniform(4.0, 8.0) * v / np.linalg.norm(v)
out, back = (k + rng.uniform(0.2, 0.35)) * seconds, (k + rng.uniform(0.65, 0.8)) * seconds
def truth(t):
    return nod if out <= t < back else np.eye(4)
frames, affine, starts, durations, phantom = T._moving_series(rng, nf, truth, seconds=seconds, steps=40)
print("k", k, "frames", frames.shape)
os.environ["PETBLUR_ESTIMATE_TWO"] = "2"
def rep(sel, label):
    d = np.asarray(durations)[sel]
    st = np.concatenate([[starts[0]], starts[0] + np.cumsum(d)[:-1]])
    m = petblur.Motion.from_frames(frames[..., sel], affine, st, d, reference=0, device="host")
    print(label, [(sel[f["frame"]], round(f["unfollowed"], 4), bool(f["motion_inside"])) for f in m.frame_report])
rep(list(range(nf)), "all")
rep([i for i in range(nf) if i != k], "without the nod's frame")
rep([i for i in range(nf) if i != k + 1], "without the frame after")
rep([i for i in range(nf) if i != 0], "without frame 0")
