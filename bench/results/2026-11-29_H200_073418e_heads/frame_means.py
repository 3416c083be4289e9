"""The truth's mean pose over each frame (bench/estimate_family.py's frame_means, written before it), on 4000
other points inside the head: the best one pose a frame can do, per draw. From the repository root: python3
frame_means.py SEED..."""
import sys, numpy as np
sys.path.insert(0, "bench")
import estimate_family as ef, head_frames as hf
from scipy.spatial.transform import Rotation
for seed in [int(x) for x in sys.argv[1:]]:
    d = ef.draw(seed); truth = ef.Truth(d); b = np.array(d.bounds)
    rng = np.random.default_rng([seed, 1])
    pts = hf.head_points(np.random.default_rng(0))
    # the truth's mean pose in each frame (40 samples), placed at mid-frame, interpolated between
    maps = []
    for k in range(len(b) - 1):
        ts = b[k] + (np.arange(40) + 0.5) / 40 * (b[k + 1] - b[k])
        ms = np.array([truth(t) for t in ts])
        r = Rotation.from_matrix(ms[:, :3, :3]).mean().as_matrix()
        m = np.eye(4); m[:3, :3] = r; m[:3, 3] = ms[:, :3, 3].mean(0)
        maps.append(m)
    mids = 0.5 * (b[:-1] + b[1:])
    times = np.concatenate([[b[0]], mids, [b[-1]]]); maps = np.array([maps[0]] + maps + [maps[-1]])
    e = hf.displacement_errors(hf.track_maps(times, maps), truth, b, pts)
    none = hf.displacement_errors(lambda t: np.eye(4), truth, b, pts)
    print(seed, "inj" if d.start_s == 0 else "late", "oracle one pose a frame: mean %.3f worst %.3f; none %.2f; nods %s" % (e.mean(), e.max(), none.mean(), [(round(a), round(n), round(g, 1)) for a, n, g, _ in d.nods]))
