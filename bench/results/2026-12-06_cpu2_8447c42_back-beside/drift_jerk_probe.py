"""One series of test_a_jerk_inside_a_drift_is_followed by its seed, its
track against the truth second by second about the jerk's frame. From the
repository root: PETBLUR_LIBRARY=build/src/libpetblur.so \
  python3 bench/results/2026-12-06_cpu2_8447c42_back-beside/drift_jerk_probe.py SEED [ENV=VALUE...]"""
import os, sys
import numpy as np
sys.path[:0] = ["python", "python/tests"]
import petblur
import test_motion_from_frames as T
seed = int(sys.argv[1])
rng = np.random.default_rng(seed)
nf, seconds = 7, 10.0
k = int(rng.integers(2, nf - 2))
v = rng.normal(size=3); v /= np.linalg.norm(v)
u = np.cross(v, rng.normal(size=3)); u /= np.linalg.norm(u)
angle = np.radians(rng.uniform(90.0, 105.0))
jump = rng.uniform(10.0, 14.0) * v
drift = rng.uniform(2.0, 3.0) / seconds * (np.cos(angle) * v + np.sin(angle) * u)
at = (k + rng.uniform(0.15, 0.3)) * seconds
def truth(t):
    m = np.eye(4)
    m[:3, 3] = drift * (t - 0.5 * seconds) + min(max((t - at) / 0.5, 0.0), 1.0) * jump
    return m
frames, affine, starts, durations, phantom = T._moving_series(rng, nf, truth, seconds=seconds, steps=40)
points = phantom.inside(rng)
os.environ["PETBLUR_ESTIMATE_SHORT"] = "1"; os.environ["PETBLUR_ESTIMATE_TWO"] = "0"
for extra in sys.argv[2:]:
    a, b = extra.split("="); os.environ[a] = b
m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
print("jerk frame", k, "at", at, "jump", np.round(jump, 2), "drift/s", np.round(drift, 3))
print("errors", np.round(T._frame_errors(m, truth, points, starts, durations), 3))
for f in m.frame_report:
    if f["frame"] in (k - 1, k, k + 1): print(f)
for t in np.arange(starts[k-1], starts[k+1] + durations[k+1] + 0.01, 1.0):
    mm = T._map(m, t)
    print(f"t {t:5.1f} est {np.round(mm[:3,3],2)} true {np.round(truth(t)[:3,3],2)} err {T._displacement(mm, truth(t), points):.2f}")
