"""Each frame's pose in a track at its mid-time against a family draw's truth (mm at the head's points).
    python3 poses.py SEED TRACK.csv"""
import os
import sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", ".."))  # bench/
import numpy as np, estimate_family as ef, head_frames as hf
seed=int(sys.argv[1]); csv=sys.argv[2]
d = ef.draw(seed); rng = np.random.default_rng([seed, 1])
frames, affine, bounds, truth = ef.simulate(d, rng)
pts = hf.head_points(rng)[::10]
times, maps = hf.read_matrix_csv(csv)
track = hf.track_maps(times, maps)
def dist(a, b):
    return np.sqrt((((pts @ a[:3,:3].T + a[:3,3]) - (pts @ b[:3,:3].T + b[:3,3]))**2).sum(1)).mean()
for k in range(len(bounds)-1):
    t0, t1 = bounds[k], bounds[k+1]; tm = 0.5*(t0+t1)
    ts = np.linspace(t0, t1, 41)
    # truth's mean pose over the frame (matrix mean, close enough for small spreads)
    print(f"frame {k} {t0:6.1f}-{t1:6.1f}: track(mid) vs truth(mid) {dist(track(tm), truth(tm)):.2f}  truth start->end {dist(truth(t0), truth(t1)):.2f}  track(mid) vs truth(start) {dist(track(tm), truth(t0)):.2f} vs truth(end) {dist(track(tm), truth(t1)):.2f}")
