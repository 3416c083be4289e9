# How far the noise measured from lag 1 of the chord offsets (path_fit.c's tracker_noise, one corner, equally spaced
# samples) scatters, beside the mean square of the samples about their mean: white noise of sigma 1 on 3 axes, 4000
# logs of each length. python3 noise_measure.py
import numpy as np
rng = np.random.default_rng(1)
for n in (64, 128, 323, 600):
    est, ms = [], []
    for _ in range(4000):
        x = rng.normal(size=(n, 3))
        u = x[1:-1] - 0.5 * (x[:-2] + x[2:])
        est.append(-np.mean(np.sum(u[:-1] * u[1:], 1)))
        r = x - x.mean(0)
        ms.append(np.mean(np.sum(r * r, 1)))
    est, ms = np.array(est), np.array(ms)
    print(f"n {n}: measured / 3 sigma^2 {est.mean() / 3:.3f}, its relative SD {est.std() / est.mean():.3f}; the mean "
          f"square's {ms.std() / ms.mean():.3f} (path_fit.c's model sqrt(2 / (3 n)) {np.sqrt(2 / (3 * n)):.3f}); "
          f"SD of their ratio {np.std(ms / est):.3f}")
