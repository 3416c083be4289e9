"""The field blur's speed on a GPU against the rigid blur of paths of the
same length and against the best peer a user has, a loop of torch's
grid_sample over the same time samples (issue 45's targets: within 3x the
rigid blur, at least 10x the loop).

The case: a breathing frame on a clinical grid (default 256^3 of 2 mm), 20
field samples inside it (22 fields, the frame's ends between samples), a
region moving up to --amplitude mm along a direction that turns from sample
to sample while the rest barely moves. The rigid motion: 20 tracked poses
whose largest path (a grid corner's) is as long as the field's, turning
about an oblique axis so that the general kernels run. All times are device
events: petblur's from pb_context_last_kernel_ms (numpy in, the upload not
counted), torch's from CUDA events around the whole loop.

    python3 bench/field_speed.py [--size 256] [--runs 10] [--amplitude 15]
prints a markdown table and the memory the fields take."""

import argparse
import time

import numpy as np

import petblur


def breathing(n, samples, amplitude, rng):
    """(samples, nx, ny, nz, 3) float32 mm: a Gaussian region's move."""
    axes = [np.linspace(-1.0, 1.0, m, dtype=np.float32) for m in n]
    gx, gy, gz = np.meshgrid(*axes, indexing="ij", sparse=True)
    profile = np.exp(-((gx - 0.2) ** 2 + gy ** 2 + (gz + 0.3) ** 2) / 0.18).astype(np.float32)
    d = np.empty((samples,) + tuple(n) + (3,), np.float32)
    phase = np.sort(rng.uniform(0, 2 * np.pi, samples))
    for k in range(samples):
        u = np.array([0.3 * np.cos(phase[k]), 0.2 * np.sin(phase[k]), 1.0], np.float32)
        d[k] = (0.5 * amplitude * (1 - np.cos(phase[k])) / np.linalg.norm(u)) * profile[..., None] * u
    return d


def median_ms(op, x, runs, adjoint=False):
    ms = []
    for _ in range(runs + 1):
        op.adjoint(x) if adjoint else op(x)
        ms.append(op.last_device_ms()[0])
    return float(np.median(ms[1:]))


def grid_sample_loop(x, fields, voxel, runs):
    """torch's grid_sample over the same samples: out = mean_k x(r + D_k(r)),
    trilinear, zeros outside; the sampling grids built from the fields on
    the GPU beforehand (not timed)."""
    import torch
    import torch.nn.functional as F
    dev = torch.device("cuda")
    n = x.shape
    xt = torch.from_numpy(x).to(dev)[None, None].permute(0, 1, 4, 3, 2)  # N, C, D=z, H=y, W=x
    base = torch.stack(torch.meshgrid(*[torch.arange(m, device=dev, dtype=torch.float32) for m in n],
                                      indexing="ij"), -1)
    grids = []
    for k in range(fields.shape[0]):
        p = base + torch.from_numpy(fields[k]).to(dev) / torch.tensor(voxel, device=dev, dtype=torch.float32)
        g = (2 * p + 1) / torch.tensor(n, device=dev, dtype=torch.float32) - 1  # align_corners=False
        grids.append(g.permute(2, 1, 0, 3)[None])  # (1, z, y, x, 3) with (x, y, z) last
    ms = []
    for _ in range(runs + 1):
        start, end = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
        start.record()
        out = torch.zeros_like(xt)
        for g in grids:
            out += F.grid_sample(xt, g, mode="bilinear", padding_mode="zeros", align_corners=False)
        out /= len(grids)
        end.record()
        torch.cuda.synchronize()
        ms.append(start.elapsed_time(end))
    return float(np.median(ms[1:])), out[0, 0].permute(2, 1, 0).cpu().numpy()


def belt(rng, seconds, rate=25.0):
    """An irregular respiratory belt at its real rate: the period and depth
    drift, the baseline wanders, the belt's noise on top."""
    t = np.arange(0.0, seconds, 1.0 / rate)
    period = 4.0 * (1 + 0.15 * np.sin(2 * np.pi * t / rng.uniform(20, 40)))
    phase = 2 * np.pi * np.cumsum(1.0 / period) / rate
    depth = 1 + 0.2 * np.sin(2 * np.pi * t / rng.uniform(15, 30) + rng.uniform(0, 6))
    return t, depth * 0.5 * (1 - np.cos(phase)) + 0.1 * np.sin(2 * np.pi * t / 60) + rng.normal(0, 0.01, t.size)


def gate_rows(n, voxel, x, amplitude, seconds, device, rng):
    """The top of five equal-count amplitude gates of a `seconds` scan, a
    25 Hz belt, 8 fields at amplitudes: the default plan (the values the
    breath visits, path_surrogate.c) against the belt walked in time (the
    paper's polyline), forward, AB; and a grid_sample loop over the belt's
    samples in the gate, what a peer does to model the motion inside it."""
    t, s = belt(rng, seconds)
    values = np.linspace(s.min() - 1e-3, s.max() + 1e-3, 8)
    shape = breathing(n, 2, amplitude, rng)[1] / amplitude  # a region's move of 1 mm at its centre
    side = np.roll(shape, 1, axis=-1)
    fields = np.stack([v * amplitude * shape + 0.3 * v * v * amplitude * side for v in values]).astype(np.float32)
    fm = petblur.FieldMotion.from_surrogate(values, fields, t, s)
    edges = np.quantile(s, np.linspace(0, 1, 6))
    gate = petblur.amplitude_gates(t, s, edges)[-1]
    inside = sum(np.count_nonzero((t >= a) & (t < b)) for a, b in gate)
    rows = []
    for label, bound in (("values (default)", None), ("belt in time", "paper")):
        t0 = time.time()
        F = petblur.FramesOperator(n, voxel, fm, [gate], method="ab", max_path_error=bound, device=device)
        plan_s = time.time() - t0
        rows.append((label, median_ms(F, x, 2), plan_s))
    samples = np.concatenate([s[(t >= a) & (t < b)] for a, b in gate])
    k = np.clip(np.searchsorted(values, samples, side="right") - 1, 0, values.size - 2)
    w = (samples - values[k]) / (values[k + 1] - values[k])
    # The loop's time over 40 of the samples (their grids all held on the
    # device), scaled to all of them: a grid_sample costs the same at any.
    loop_ms = None
    try:
        import torch  # noqa: F401
        pick = np.linspace(0, samples.size - 1, 40).astype(int)
        at = (1 - w[pick])[:, None, None, None, None] * fields[k[pick]] + \
            w[pick][:, None, None, None, None] * fields[k[pick] + 1]
        loop_ms = grid_sample_loop(x, at.astype(np.float32), voxel, 2)[0] * samples.size / pick.size
    except ImportError:
        pass
    return rows, len(gate), inside, loop_ms


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--amplitude", type=float, default=15.0)
    ap.add_argument("--device", default="cuda")
    ap.add_argument("--gate-seconds", type=float, default=300.0, help="the gated scan's length")
    args = ap.parse_args()
    rng = np.random.default_rng(45)
    n, voxel = (args.size,) * 3, (2.0, 2.0, 2.0)
    x = rng.random(n, dtype=np.float32)
    samples = 22
    times = np.linspace(0.0, 21.0, samples)
    frame = (0.5, 20.5)  # 20 samples inside
    t = time.time()
    fields = breathing(n, samples, args.amplitude, rng)
    fm = petblur.FieldMotion(times, fields)
    made = time.time() - t
    longest = float(np.sqrt((np.diff(fields, axis=0) ** 2).sum(-1)).sum(0).max())
    # A rigid path as long: a turn about an oblique axis whose corner path
    # adds up to the field's longest, 20 tracked poses.
    half = 0.5 * np.array(n) * voxel
    radius = float(np.linalg.norm(half))
    step = longest / radius / (samples - 1)
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    angles = step * np.cumsum(np.r_[0, rng.choice([-1, 1], samples - 1)])
    quats = np.stack([np.r_[np.cos(a / 2), np.sin(a / 2) * axis] for a in angles])
    track = petblur.Motion(times, np.zeros((samples, 3)), quats)
    rows = []
    for method in ("ab", "rm"):
        t = time.time()
        B = petblur.BlurOperator(n, voxel, fm, frame=frame, method=method, device=args.device)
        plan_s = time.time() - t
        R = petblur.BlurOperator(n, voxel, track, frame=frame, method=method, device=args.device)
        rows.append((method, "forward", median_ms(B, x, args.runs), median_ms(R, x, args.runs), plan_s))
        rows.append((method, "adjoint", median_ms(B, x, args.runs, True), median_ms(R, x, args.runs, True), plan_s))
    J = petblur.BlurOperator(n, voxel, fm, frame=frame, method="ab", device=args.device, jacobian=True)
    jac = (median_ms(J, x, args.runs), median_ms(J, x, args.runs, True))
    torch_ms, torch_out = grid_sample_loop(x, fields[1:-1], voxel, args.runs)
    gb = fields[0].nbytes / 2 ** 30
    print(f"# field blur, {args.size}^3 of 2 mm, {samples - 2} field samples in the frame, {args.device}")
    print(f"\nlongest voxel path {longest:.1f} mm; the rigid turn's corner path {radius * abs(np.diff(angles)).sum():.1f}"
          f" mm; fields made in {made:.1f} s\n")
    print("| method | direction | field ms | rigid ms | field / rigid | grid_sample loop / field | plan s |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for method, direction, f, r, p in rows:
        print(f"| {method} | {direction} | {f:.2f} | {r:.2f} | {f / r:.2f} | {torch_ms / f:.1f} | {p:.1f} |")
    print(f"\nAB mass-preserving (jacobian=True): forward {jac[0]:.2f} ms, adjoint {jac[1]:.2f} ms")
    print(f"\ntorch grid_sample loop over the {samples - 2} samples: {torch_ms:.2f} ms (trilinear, one read a sample, "
          "not the path between them)")
    rows, visits, inside, loop_ms = gate_rows(n, voxel, x, args.amplitude, args.gate_seconds, args.device, rng)
    print(f"\n## a gate: the top of five amplitude gates of a {args.gate_seconds:g} s scan, a 25 Hz belt, 8 fields\n")
    print(f"{visits} visits, {inside} belt samples inside; AB forward\n")
    print("| plan | ms | plan s |")
    print("| --- | --- | --- |")
    for label, ms, plan_s in rows:
        print(f"| {label} | {ms:.2f} | {plan_s:.1f} |")
    if loop_ms is not None:
        print(f"| torch grid_sample loop over the {inside} samples (40 timed, scaled) | {loop_ms:.2f} | |")
    print(f"memory: {gb:.3f} GiB a field ({gb * 2 ** 30 / np.prod(n):.0f} bytes a voxel); a frame's plan holds the "
          f"{samples} fields its time covers, {samples * gb:.2f} GiB on the device")


if __name__ == "__main__":
    main()
