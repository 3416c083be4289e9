import sys, numpy as np
sys.path.insert(0, "python"); sys.path.insert(0, "bench")
import petblur
from path_cases import _motion
from scipy.spatial.transform import Rotation
shape, vox = (24, 26, 23), (2.0, 2.6, 3.2)
center = 0.5 * np.array(shape) * np.array(vox)
zero = total = 0
for seed in range(100):
    rng = np.random.default_rng([seed, 77])
    n = 60 * 20 + 1; t = np.arange(n) / 20.0
    noise = rng.uniform(0.05, 0.25)
    tr = rng.normal(0, noise, (n, 3)); rot = Rotation.from_rotvec(rng.normal(0, noise / 80.0, (n, 3)))
    m = _motion(t, rot, tr, center)
    b = np.sort(rng.uniform(0, 58, 4)); bounds = sorted(set(np.r_[b, b + 2.0]))
    for lo, hi in zip(b, b + 2.0):
        f = m.summary([lo, hi], shape, vox)["frames"][0]
        zero += f["noise_mm"] == 0; total += 1
print("frames whose noise was not measured:", zero, "of", total)
