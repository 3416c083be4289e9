# The scatter path_fit.c's line_holds allows a noisy run, against simulation: white Gaussian noise of sigma 1 on 3 axes,
# n samples, the noise measured as tracker_noise does (lag 1 of the chord offsets, over m = n - 5 products), a run of L
# samples in the middle with its least-squares line removed; 4000 logs each. Per sample and per unit of the noise's
# mean square (3): the run's mean square less the measured noise's (its SD against the model
# sqrt(2 L / 3 + (17/24) L^2 / m) / L, and against the two errors taken as independent, 49/24 in place of 17/24), and
# the sum of the residual's lag-1 products (its SD against sqrt(L - 1) / (sqrt(3) L)). python3 scatter_model.py
import numpy as np
rng = np.random.default_rng(7)
for n, L in ((323, 323), (323, 100), (323, 64), (600, 300), (128, 128), (512, 40)):
    d, a = [], []
    for _ in range(4000):
        x = rng.normal(size=(n, 3))
        u = x[1:-1] - 0.5 * (x[:-2] + x[2:])
        m = n - 5
        est = -np.mean(np.sum(u[:m] * u[1:m + 1], 1))
        s = (n - L) // 2
        t = np.arange(L); A = np.c_[np.ones(L), t]
        res = x[s:s + L] - A @ np.linalg.lstsq(A, x[s:s + L], rcond=None)[0]
        d.append((np.sum(res * res) - L * est) / (L * 3))
        a.append(np.sum(res[1:] * res[:-1]) / (L * 3))
    d, a, m = np.array(d), np.array(a), n - 5
    print(f"n {n}, run {L}: mean square less the measured: mean {d.mean():.4f}, SD {d.std():.4f}, model "
          f"{np.sqrt(2 * L / 3 + 17 / 24 * L * L / m) / L:.4f} (independent {np.sqrt(2 * L / 3 + 49 / 24 * L * L / m) / L:.4f}); "
          f"lag-1 sum: mean {a.mean():.4f}, SD {a.std():.4f}, model {np.sqrt(L - 1) / (np.sqrt(3) * L):.4f}")
