#!/usr/bin/env python3
"""Motion inside respiratory gates: what petblur's blur along deformation
fields buys a gated thorax reconstruction, against the truth.

Truth: an analytic thorax (thorax.py: lungs, liver, heart, four lesions, two
at the lung bases and one in the liver dome where the diaphragm moves most,
one at a lung apex where it barely moves) breathing irregularly (cycles of
3.5-5 s and amplitudes 0.75-1.25 drawn for each, a drifting baseline), its
motion an analytic field of the breath's amplitude s; a belt samples s at
25 Hz with noise. Data, made without petblur: the analytic phantom at
p + D(s(t))(p) averaged over a lattice inside each voxel, over the true
breath at 100 Hz (through images at finely spaced amplitudes, weighted by
the time the breath spends near each), projected by ASTRA's 2-D strip
projector slice by slice, with a uniform background and Poisson noise. The
acquisition is binned two ways, as gated and dynamic reconstructions bin it:
amplitude gates of equal counts on the belt's signal (each gate every visit
of the breath to its bin), and time frames; each cell (gate x frame) is
drawn once, so both binnings are the same acquisition.

Reconstructions, MLEM over all gates (or frames) at once into the
end-exhale image, the same iterations, the system model A B_g of gate g:
  (a) no motion model (B = I),
  (b) one field per gate, the field at the gate's mean belt amplitude
      (what SIRF and PyTomography do with a registered field per gate),
  (c) petblur's blur along the fields inside each gate (FieldMotion from
      the belt's samples, the gates as unions of intervals),
  (b') and (c') the same on time frames instead of gates,
  (d) a patient who does not breathe (data without motion, no model).
Metrics at every iteration: NRMSE inside the body, each lesion's contrast
recovery against its own tissue around it, the liver's variability (its
standard deviation over its mean, away from its lesion: the noise), and
the time in the blur. Models that blur smooth the image as they go, so a
comparison at one iteration mixes noise and resolution: report.py gives
each model's best NRMSE over the iterations and plots contrast against
noise.

  study.py --preset full --device cuda --out DIR     (the GPU machine)
  study.py --preset small --device opencl --out DIR  (PoCL)
"""

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from scipy import ndimage

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import thorax  # noqa: E402
import petblur  # noqa: E402


def _head_study():
    """The head study's ASTRA projector (examples/motion_study/study.py)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("head_study", os.path.join(HERE, "..", "motion_study", "study.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


_head = _head_study()
Projector, projector_matrix = _head.Projector, _head.projector_matrix

PRESETS = {
    # grid, voxel mm, angles, scan s, gates, time frames, MLEM iterations, counts in the scan, amplitude levels
    # of the data, fields given to petblur (surrogate values), lattice inside a voxel
    "full": dict(dims=(128, 128, 64), voxel=(3.0, 3.0, 3.5), angles=180, seconds=180.0, gates=(3, 5), frames=6,
                 iterations=40, counts=2e8, levels=40, fields=8, sub=2, methods="abcBCd"),
    "small": dict(dims=(64, 64, 32), voxel=(6.0, 6.0, 7.0), angles=64, seconds=60.0, gates=(4,), frames=3,
                  iterations=15, counts=4e6, levels=24, fields=6, sub=2, methods="abcd"),
}
LABELS = {"a": "(a) no motion model", "b": "(b) gates, one field each", "c": "(c) gates, petblur inside each",
          "B": "(b') time frames, one field each", "C": "(c') time frames, petblur inside each",
          "d": "(d) no breathing (ideal)"}
RATE_HZ = 100.0


def _level_image(args):
    shape, voxel, s, sub = args
    return thorax.image(shape, voxel, s, sub)


def acquisition(p, rng, W, workers):
    """The breath, the belt, the binnings and each bin's data (see the module's text). Returns a dict: "gates"
    and "edges" by gate count, "frames" (the time frames), "still" (one bin of the whole scan without breathing)."""
    T, shape, voxel = p["seconds"], p["dims"], p["voxel"]
    breath = thorax.Breath(T, rng)
    t = (np.arange(int(round(T * RATE_HZ))) + 0.5) / RATE_HZ
    s_true = breath(t)
    belt = np.interp(t, breath.belt_t, breath.belt_s)
    # equal-count amplitude gates on the belt (the top bin closed, as petblur.amplitude_gates bins); the
    # acquisition is drawn on the finest partition all gate counts' edges make, so every binning sums the same
    # counts
    edges = {G: np.quantile(breath.belt_s, np.linspace(0.0, 1.0, G + 1)) for G in p["gates"]}
    cuts = np.unique(np.concatenate(list(edges.values())))
    atom = np.clip(np.searchsorted(cuts, belt, side="right") - 1, 0, cuts.size - 2)
    frame = np.minimum((t / (T / p["frames"])).astype(int), p["frames"] - 1)
    # images at amplitudes spaced finely over the true breath; each time sample weighs its two neighbours
    levels = np.linspace(s_true.min(), s_true.max(), p["levels"])
    u = (s_true - levels[0]) / (levels[1] - levels[0])
    lo = np.clip(np.floor(u).astype(int), 0, p["levels"] - 2)
    f = u - lo
    with ProcessPoolExecutor(workers) as ex:
        imgs = list(ex.map(_level_image, [(shape, voxel, float(s), p["sub"]) for s in levels]))
    still = thorax.image(shape, voxel, 0.0, p["sub"])
    nx, ny, nz = shape
    cells = {}
    for a in range(cuts.size - 1):
        for k in range(p["frames"]):
            m = (atom == a) & (frame == k)
            w = np.bincount(lo[m], 1 - f[m], p["levels"]) + np.bincount(lo[m] + 1, f[m], p["levels"])
            mean = sum(wl * im for wl, im in zip(w, imgs) if wl) / RATE_HZ  # activity x seconds
            cells[a, k] = (W @ mean.reshape(nx * ny, nz), np.count_nonzero(m) / RATE_HZ) if m.any() else None
    total = sum(c[0].sum() for c in cells.values() if c is not None)
    scale = p["counts"] / total                 # counts per (activity x second) in the projection
    size = next(c[0].size for c in cells.values() if c is not None)
    bg_rate = 0.2 * scale * total / T / size    # a uniform background: 20 % of the counts
    y = {key: (rng.poisson(scale * c + bg_rate * dur).astype(np.float32), dur)
         for key, (c, dur) in ((k, v) for k, v in cells.items() if v is not None)}

    def binned(members):
        """(data, counts per activity, background) of the bins, each a set of (atom, frame) cells."""
        out = []
        for keys in members:
            parts = [y[k] for k in keys if k in y]
            dur = sum(d for _, d in parts)
            out.append((sum(v for v, _ in parts), scale * dur, bg_rate * dur))
        return out

    frames = p["frames"]
    atoms = range(cuts.size - 1)
    gates = {}
    for G, e in edges.items():
        owner = np.clip(np.searchsorted(e, 0.5 * (cuts[:-1] + cuts[1:]), side="right") - 1, 0, G - 1)
        gates[G] = binned([[(a, k) for a in atoms if owner[a] == g for k in range(frames)] for g in range(G)])
    still_proj = W @ still.reshape(nx * ny, nz)
    still_data = [(rng.poisson(scale * still_proj * T + bg_rate * T).astype(np.float32), scale * T, bg_rate * T)]
    time_frames = binned([[(a, k) for a in atoms] for k in range(frames)])
    return dict(breath=breath, edges=edges, gates=gates, frames=time_frames, still=still_data, levels=levels)


def gate_intervals(acq, G, T):
    """The G gates as petblur bins them from the belt's samples (unions of intervals)."""
    b = acq["breath"]
    return petblur.amplitude_gates(b.belt_t, b.belt_s, acq["edges"][G], span=(0.0, T))


def operators(method, G, p, acq, device):
    """Per bin (G gates, or the time frames), the blur B (None: the identity), as (forward of one image -> list,
    adjoint of a list -> image)."""
    shape, voxel, T = p["dims"], p["voxel"], p["seconds"]
    b = acq["breath"]
    values = np.linspace(b.belt_s.min() - 1e-3, b.belt_s.max() + 1e-3, p["fields"])
    if method in ("a", "d"):
        return None
    gated = method in ("b", "c")
    bins = gate_intervals(acq, G, T) if gated else [[(k * T / p["frames"], (k + 1) * T / p["frames"])]
                                                  for k in range(p["frames"])]
    if method in ("c", "C"):
        motion = petblur.FieldMotion.from_surrogate(values, thorax.fields(shape, voxel, values), b.belt_t,
                                                    b.belt_s)
        if gated:
            op = petblur.FramesOperator(shape, voxel, motion, bins, device=device)
        else:
            op = petblur.FramesOperator(shape, voxel, motion, [iv[0][0] for iv in bins] + [T], device=device)
        return (lambda x: list(op(x))), (lambda ys: op.adjoint(_stack(ys)))
    # (b), (b'): the field at each bin's mean belt amplitude, held still (the same field twice)
    ops = []
    for iv in bins:
        tt = np.concatenate([np.arange(a, c, 1.0 / RATE_HZ) for a, c in iv])
        mean = float(np.interp(tt, b.belt_t, b.belt_s).mean())
        d = thorax.fields(shape, voxel, [mean])[0]
        ops.append(petblur.BlurOperator(shape, voxel, petblur.FieldMotion([0.0, 1.0], np.stack([d, d])),
                                        frame=(0.0, 1.0), device=device))
    return (lambda x: [o(x) for o in ops]), (lambda ys: sum(o.adjoint(y) for o, y in zip(ops, ys)))


def _stack(ys):
    if hasattr(ys[0], "detach"):
        import torch
        return torch.stack(ys)
    return np.stack(ys)


class Metrics:
    def __init__(self, p):
        shape, voxel = p["dims"], p["voxel"]
        self.truth = thorax.image(shape, voxel, 0.0, p["sub"]).astype(np.float64)
        pts = thorax.grid_points(shape, voxel)[..., 0, :]
        _, lab = thorax.tissue(pts)
        self.body = lab > 0
        # noise: the liver away from its lesion and its edges
        inner = ndimage.binary_erosion(lab == 3, iterations=2)
        far = np.linalg.norm(pts - thorax.lesion_centres()[2][1], axis=-1) > 30.0
        self.liver = inner & far
        self.lesions, self.backgrounds, self.true_contrast, self.names = [], [], [], []
        organ = {"lung": 2, "liver": 3}
        for k, (name, c, r, v, around) in enumerate(thorax.lesion_centres()):
            dist = np.linalg.norm(pts - c, axis=-1)
            roi = dist <= max(r, 0.6 * min(voxel))
            bg = (lab == organ[around]) & (dist >= r + 2 * max(voxel)) & (dist <= r + 2 * max(voxel) + 20.0)
            self.lesions.append(roi)
            self.backgrounds.append(bg)
            self.names.append(name)
            self.true_contrast.append(self.truth[roi].mean() / self.truth[bg].mean() - 1.0)

    def __call__(self, x):
        x = np.asarray(x, dtype=np.float64)
        nrmse = float(np.linalg.norm((x - self.truth)[self.body]) / np.linalg.norm(self.truth[self.body]))
        cr = [float((x[r].mean() / x[b].mean() - 1.0) / tc)
              for r, b, tc in zip(self.lesions, self.backgrounds, self.true_contrast)]
        liver = x[self.liver]
        return {"nrmse": nrmse, "contrast_recovery": cr, "liver_variability": float(liver.std() / liver.mean())}


def mlem(data, blur, proj, iterations, metrics, conv, to_host, ones):
    """x <- x / S * sum_g B_g^T (s_g A^T (y_g / (s_g A B_g x + r_g))), S = sum_g s_g B_g^T A^T 1."""
    fwd, adj = blur if blur is not None else ((lambda x: [x] * len(data)), (lambda ys: sum(ys)))
    blur_s = [0.0]

    def timed(fn, a):
        t = time.perf_counter()
        out = fn(a)
        if proj.xp == "torch":
            proj.torch.cuda.synchronize()
        blur_s[0] += time.perf_counter() - t
        return out

    ys = [conv(y) for y, _, _ in data]
    one = proj.back(ones(ys[0].shape))
    sens = timed(adj, [one * s for _, s, _ in data])
    sens = sens + 1e-6 * float(sens.max())
    x = ones(proj.dims)
    history = []
    for _ in range(iterations):
        bx = timed(fwd, x)
        u = [proj.back(y / (s * proj.fwd(b) + r)) * s for y, b, (_, s, r) in zip(ys, bx, data)]
        x = x * timed(adj, u) / sens
        history.append(metrics(to_host(x)))
    return to_host(x), history, blur_s[0]


def run(args):
    p = dict(PRESETS[args.preset])
    if args.iterations:
        p["iterations"] = args.iterations
    if args.gates:
        p["gates"] = [int(g) for g in args.gates.split(",")]
    elif isinstance(p["gates"], int):
        p["gates"] = [p["gates"]]
    methods = args.methods or p["methods"]
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    t = time.perf_counter()
    W = projector_matrix(p["dims"][0], p["angles"], args.matrix)
    acq = acquisition(p, rng, W, args.workers)
    sim_s = time.perf_counter() - t
    visits = {G: [len(g) for g in gate_intervals(acq, G, p["seconds"])] for G in p["gates"]}
    print(f"acquisition: {p['seconds']:g} s, {len(acq['breath'].amps)} breaths, gates' visits {visits}, amplitude "
          f"edges {({G: np.round(e, 3).tolist() for G, e in acq['edges'].items()})}; made in {sim_s:.1f} s",
          flush=True)
    torch_mode = args.device.startswith("cuda")
    if torch_mode:
        import torch
        dev = torch.device(args.device if ":" in args.device else "cuda:0")
        conv = lambda a: torch.from_numpy(np.ascontiguousarray(a)).to(dev)  # noqa: E731
        to_host = lambda a: a.cpu().numpy()  # noqa: E731
        ones = lambda shape: torch.ones(shape, device=dev)  # noqa: E731
    else:
        conv = lambda a: np.ascontiguousarray(a, dtype=np.float32)  # noqa: E731
        to_host = lambda a: a  # noqa: E731
        ones = lambda shape: np.ones(shape, np.float32)  # noqa: E731
    metrics = Metrics(p)
    results, images = {}, {}
    runs = [(m, G) for m in methods for G in (p["gates"] if m in "bc" else [None])]
    for m, G in runs:
        key, label = (m, LABELS[m]) if G is None else (f"{m}{G}", LABELS[m].replace("gates", f"{G} gates"))
        proj = Projector(W, p["dims"], "torch" if torch_mode else "numpy")
        data = acq["still"] if m == "d" else acq["gates"][G] if m in "bc" else acq["frames"]
        t = time.perf_counter()
        blur = operators(m, G, p, acq, args.device)
        plan_s = time.perf_counter() - t
        x, history, blur_s = mlem(data, blur, proj, p["iterations"], metrics, conv, to_host, ones)
        results[key] = {"label": label, "history": history, "projector_s": proj.seconds, "blur_s": blur_s,
                        "plan_s": plan_s, "total_s": time.perf_counter() - t}
        images[key] = x
        last = history[-1]
        print(f"{label:40s} NRMSE {last['nrmse']:.4f}  CR " +
              " ".join(f"{v:.2f}" for v in last["contrast_recovery"]) +
              f"  plan {plan_s:.1f} s  blur {blur_s:.1f} s  projector {proj.seconds:.1f} s", flush=True)
    settings = {k: (list(v) if isinstance(v, tuple) else v) for k, v in p.items()}
    settings.update(preset=args.preset, device=args.device, seed=args.seed, simulation_s=sim_s,
                    breaths=int(len(acq["breath"].amps)),
                    edges={str(G): e.tolist() for G, e in acq["edges"].items()},
                    visits={str(G): v for G, v in visits.items()}, lesions=metrics.names,
                    true_contrast=[float(c) for c in metrics.true_contrast])
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({"settings": settings, "results": results}, f, indent=1)
    np.savez_compressed(os.path.join(args.out, "images.npz"), truth=metrics.truth.astype(np.float32), **images,
                        belt_t=acq["breath"].belt_t, belt_s=acq["breath"].belt_s)
    return metrics, images, results, settings


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(PRESETS), default="small")
    ap.add_argument("--device", default="auto")
    ap.add_argument("--out", default="breathing-study")
    ap.add_argument("--iterations", type=int, default=0)
    ap.add_argument("--methods", default="")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--gates", default="", help="numbers of amplitude gates (equal counts), comma-separated: (b) and "
                    "(c) run for each; default the preset's")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="processes that draw the data")
    ap.add_argument("--matrix", default="", help="the projector's matrix as .npz: read when there, else made by "
                    "ASTRA and written")
    run(ap.parse_args())


if __name__ == "__main__":
    main()
