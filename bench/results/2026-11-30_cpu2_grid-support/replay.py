import os, sys, numpy as np
sys.path.insert(0, "/work/main/python/tests"); sys.path.insert(0, "/work/main/python")
import test_motion_from_frames as T
import petblur
seed = int(sys.argv[1]); mode = sys.argv[2] if len(sys.argv) > 2 else "default"
rng = np.random.default_rng(seed)
nf = int(rng.integers(9, 15))
maps = [np.eye(4)] + [T._rigid(rng, 3.0, 3.0) for _ in range(nf - 1)]
if "nodrift" in mode:
    orig = T.Phantom.__init__
    def init(self, rng, n=6):
        orig(self, rng, n); self.drift = np.ones(n)
    T.Phantom.__init__ = init
class P:
    def __init__(s, r): s.r = r
    def __getattr__(s, k): return getattr(s.r, k)
    def poisson(s, lam): return lam * 1.0
rr = P(rng) if "clean" in mode else rng
frames, affine, starts, durations, phantom = T._moving_series(rr, nf, lambda t: maps[int(t // 10.0)], shape=((36,)*3 if "big" in mode else (24, 24, 24)), steps=1, counts=(2e5, 2e6))
if mode == "clean":
    # same series, no Poisson: rebuild expected
    pass
m = petblur.Motion.from_frames(frames, affine, starts, durations, device="host")
points = phantom.inside(rng)
err = np.array([T._displacement(T._map(m, s + 5.0), maps[k], points) for k, s in enumerate(starts)])
import warnings
mv = [f["frame"] for f in m.frame_report if f["motion_inside"] is not None]; jm = [f["frame"] for f in m.frame_report if f.get("jumped_at_start")]
print("moving", mv, "jumped", jm)
print(mode, os.environ.get("PETBLUR_ESTIMATE_CONTRAST"), os.environ.get("PETBLUR_ESTIMATE_SMOOTH"), "drift", np.round(phantom.drift, 3), "mean %.3f max %.3f" % (err.mean(), err.max()), np.round(err, 2))
