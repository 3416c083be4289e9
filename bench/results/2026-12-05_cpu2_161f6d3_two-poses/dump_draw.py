import sys, os, json
sys.path.insert(0, "bench"); sys.path.insert(0, "python")
import numpy as np
import estimate_family as ef
import head_frames as hf
seed, out = int(sys.argv[1]), sys.argv[2]
os.makedirs(out, exist_ok=True)
d = ef.draw(seed)
rng = np.random.default_rng([seed, 1])
frames, affine, bounds, truth = ef.simulate(d, rng)
nii, side = hf.write_series(out, frames, affine, bounds, "f")
print(nii, side, frames.shape if hasattr(frames,'shape') else len(frames))
