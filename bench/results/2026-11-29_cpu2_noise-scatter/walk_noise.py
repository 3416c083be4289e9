"""How often the whiteness test takes a 20 Hz random walk of 1 mm steps (motion) for tracker noise: Motion.summary's
noise_mm on 400 walks of 2001 and of 20001 samples, free and held near the grid by a pull of 0.1 % a step (as the
tests of a frame no path walks draw it). From the repository root:
PYTHONPATH=python PETBLUR_LIBRARY=... python3 walk_noise.py"""
import numpy as np
from scipy.signal import lfilter

import petblur

for pull, n in ((0.0, 2001), (0.0, 20001), (0.001, 2001), (0.001, 20001)):
    hits = 0
    for s in range(400):
        rng = np.random.default_rng([s, 7])
        t = np.arange(n) * 0.05
        w = lfilter([1.0], [1.0, pull - 1.0], rng.normal(0, 1.0, (n, 3)), axis=0)
        f = petblur.Motion(t, w, np.tile([1.0, 0, 0, 0], (n, 1))).summary([0, t[-1]], (100, 100, 60),
                                                                          (2, 2, 2))["frames"][0]
        hits += f["noise_mm"] > 0
    print(f"pull {pull}, {n} samples: {hits} of 400 taken for noise", flush=True)
