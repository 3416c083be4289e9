# Issue 46's table's segments a frame under the variants: python3 segments.py, from the repository root, with
# PETBLUR_LIBRARY and VARIANTS as variants.py's. bench/frames_cost.py's drift (seed 46046, 24 frames of 75 s,
# 220x220x110 voxels of 2 mm) and its smooth, 20hz-noisy (0.05 mm) and 20hz-0.2mm logs; planning only, on the host.
import sys, os, numpy as np
sys.path.insert(0, "bench"); sys.path.insert(0, "python"); sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import frames_cost as fc, petblur
from variants import variants, use
shape = (220, 220, 110); frames, fs, seed = 24, 75.0, 46046
seconds = frames * fs; bounds = fs * np.arange(frames + 1)
true_pose, size = fc.drift(np.random.default_rng([seed, 0]), seconds)
center = 0.5 * np.array(shape) * fc.VOXEL_MM + fc.PIVOT_MM
VARIANTS, names = variants()
for name, sets in VARIANTS:
    use(sets, names)
    out = []
    for tname in ("smooth", "20hz-noisy", "20hz-0.2mm"):
        rng = np.random.default_rng([seed, 1 + list(fc.TRACKS).index(tname)])
        times, rot, tr = fc.log_track(tname, true_pose, seconds, rng, 0.03)
        logged = fc._motion(times, rot, tr, center)
        F = petblur.FramesOperator(shape, fc.VOXEL_MM, logged, bounds, method="ab", filter="hardware", device="host")
        s = fc.frame_segments(F, logged, bounds)
        out.append(f"{tname} {np.mean(s):.1f} / {max(s)}")
    print(name, " | ".join(out), flush=True)
