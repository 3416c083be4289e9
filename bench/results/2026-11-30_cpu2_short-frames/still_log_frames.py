import sys, numpy as np
sys.path.insert(0, "python"); sys.path.insert(0, "bench")
import petblur
from path_cases import _motion
from scipy.spatial.transform import Rotation
shape, vox = (64, 64, 48), (2.0, 2.0, 2.0)
center = 0.5 * np.array(shape) * np.array(vox)
bounds = [0.0, 2.0, 4.0, 7.0, 10.0, 30.0, 57.0, 60.0]
for noise in (0.02, 0.05, 0.1, 0.2):
    segs = {}; nz = []
    for seed in range(10):
        rng = np.random.default_rng(seed)
        n = 60 * 20 + 1; t = np.arange(n) / 20.0
        tr = rng.normal(0, noise, (n, 3)); rot = Rotation.from_rotvec(rng.normal(0, noise / 80.0, (n, 3)))
        m = _motion(t, rot, tr, center)
        for i, f in enumerate(m.summary(bounds, shape, vox)["frames"]):
            segs.setdefault(i, []).append(f["segments"]); nz.append(f["noise_mm"])
    print(noise, " ".join("%g-%gs: %.1f" % (bounds[i], bounds[i+1], np.mean(v)) for i, v in segs.items()), "noise_mm mean %.3f" % np.mean(nz))
