import sys, numpy as np
sys.path.insert(0, "/work/main/python/tests"); sys.path.insert(0, "/work/main/python")
import petblur
from test_fields import _indices
rows = []
for seed in range(int(sys.argv[1]), int(sys.argv[2])):
    rng = np.random.default_rng(seed)
    for case in range(2):
        voxel = rng.uniform(1.5, 3.0, 3)
        n = tuple(int(m) for m in np.ceil(rng.uniform(100.0, 120.0, 3) / voxel))
        r = (_indices(n) + 0.5) * voxel
        centre = 0.5 * np.array(n) * voxel + rng.uniform(-5.0, 5.0, 3)
        w = rng.uniform(4.5, 5.5) * voxel.max()
        x = np.exp(-(((r - centre) / w) ** 2).sum(-1)).astype(np.float32)
        s = rng.uniform(0.8, 0.9, 3) if rng.random() < 0.5 else rng.uniform(1.1, 1.25, 3)
        scale = np.diag(s)
        still = (r - centre) @ (scale - np.eye(3)).T
        times = np.linspace(0.0, 4.0, 17)
        depth = rng.uniform(0.1, 0.25)
        breathing = np.stack([(r - centre) * -(depth * np.sin(np.pi * t / 4.0) ** 2) for t in times])
        for name, fm, frame in (("still", petblur.FieldMotion([0.0, 1.0], np.stack([still, still])), (0.0, 1.0)),
                          ("breath", petblur.FieldMotion(times, breathing), (0.3, 3.7))):
            for method in ("ab", "rm"):
                kept = petblur.BlurOperator(n, voxel, fm, frame=frame, method=method, device="host", jacobian=True)(x).sum() / x.sum()
                print(seed, case, name, method, "voxel", np.round(voxel, 2), "w %.1f" % w, "s", np.round(s, 3), "kept %.4f" % kept, flush=True)
