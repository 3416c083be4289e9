"""The slow-jerk test's series at a seed, estimated under each variant: the
jerk frame's error and the series' mean."""
import os, sys
import numpy as np
sys.path.insert(0, "python/tests")
import test_motion_from_frames as T
from scipy.spatial.transform import Rotation
import petblur

def series(seed):
    rng = np.random.default_rng(seed)
    nf, seconds = 7, 10.0
    k = int(rng.integers(2, nf - 2))
    jerk = T._rigid(rng, float(rng.uniform(12.0, 16.0)), 0.0)
    v = rng.normal(size=3)
    jerk[:3, 3] = rng.uniform(10.0, 14.0) * v / np.linalg.norm(v)
    turn = Rotation.from_matrix(jerk[:3, :3]).as_rotvec()
    a, b = (k + rng.uniform(0.3, 0.5)) * seconds, (k + 1 + rng.uniform(0.03, 0.08)) * seconds
    def truth(t):
        s = min(max((t - a) / (b - a), 0.0), 1.0)
        m = np.eye(4); m[:3, :3] = Rotation.from_rotvec(s * turn).as_matrix(); m[:3, 3] = s * jerk[:3, 3]
        return m
    frames, affine, starts, durations, phantom = T._moving_series(rng, nf, truth, seconds=seconds, steps=40)
    points = phantom.inside(rng)
    return k, frames, affine, starts, durations, truth, points

variants = {"two0": {"PETBLUR_ESTIMATE_TWO": "0"}, "default": {}, "line0": {"PETBLUR_ESTIMATE_LINE": "0"}}
def main():
  for seed in map(int, sys.argv[1:]):
      k, frames, affine, starts, durations, truth, points = series(seed)
      out = [f"{seed} k={k}"]
      for name, env in variants.items():
          for key in ("PETBLUR_ESTIMATE_TWO", "PETBLUR_ESTIMATE_LINE"):
              os.environ.pop(key, None)
          os.environ.update(env)
          m = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host")
          e = T._frame_errors(m, truth, points, starts, durations)
          out.append(f"{name} {e[k]:.3f}/{e.mean():.3f}")
      one = petblur.Motion.from_frames(frames, affine, starts, durations, reference=0, device="host", frame_poses_only=True)
      e = T._frame_errors(one, truth, points, starts, durations)
      out.append(f"one {e[k]:.3f}/{e.mean():.3f}")
      print("  ".join(out), flush=True)

if __name__ == "__main__":
    main()
