#!/usr/bin/env python3
"""Issue 31's accuracy case, made without petblur's operators: how far
petblur's blur is from the motion it models, as a user measures it.

The case: hot spheres in an oblique LAS grid (61 x 53 x 37 voxels of
2.0 x 2.5 x 3.0 mm, turned about an oblique axis) under a 30 s frame of a
20 Hz tracked seizure that turns 11.4 degrees and moves 6.3 mm while the head
shakes at 3 Hz, with the tracker's noise; sharp (the spheres as they are) and at PET resolution (smoothed to
4.5 mm FWHM). The reference: the blur as the mean, over `--times` equally
spaced times of the frame, of the activity resampled in world coordinates
by scipy.ndimage.map_coordinates (order 1, zero outside), the track between
its samples interpolated by scipy (LERP, SLERP). Errors: relative RMS and
relative max in percent (100 ||d|| / ||ref||, 100 max |d| / max |ref|).

  accuracy_case.py [--device D] [--bounds 0.25,0.1,0.05,0.02,0.01] [--methods ab,ab-sweep,rm] [--out results.json]
  accuracy_case.py --small ...     (a 31 x 27 x 19 grid of twice the voxels: the tests' version)

The tests (python/tests/test_accuracy.py) import Case, reference and
errors from here; bench/path_cases.py its resampling (track_poses,
mean_resampled)."""

import argparse
import json
import time

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation, Slerp

FULL = dict(shape=(61, 53, 37), voxel=(2.0, 2.5, 3.0))
SMALL = dict(shape=(31, 27, 19), voxel=(4.0, 5.0, 6.0))


class Case:
    """The phantom, its affine and the tracked frame, drawn from rng."""

    def __init__(self, rng, shape, voxel, turn_deg=11.4, move_mm=6.3, seconds=30.0, rate_hz=20.0, fwhm_mm=0.0,
                 shake_deg=0.6, shake_mm=0.4):
        self.shape, self.voxel = tuple(shape), np.asarray(voxel, dtype=np.float64)
        # LAS (x flipped), turned 20 degrees about an oblique axis, centred on the world's origin.
        turn = Rotation.from_rotvec(np.radians(20.0) * np.array([0.4, -0.3, 0.87]) / np.linalg.norm([0.4, -0.3, 0.87]))
        m = turn.as_matrix() @ np.diag([-1.0, 1.0, 1.0]) @ np.diag(self.voxel)
        a = np.eye(4)
        a[:3, :3] = m
        a[:3, 3] = -m @ ((np.array(shape) - 1) / 2.0) + rng.uniform(-5, 5, 3)
        self.affine = a
        # Hot spheres (activity 4-8) on a cold background, in world mm.
        ijk = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), -1).reshape(-1, 3)
        w = ijk @ a[:3, :3].T + a[:3, 3]
        half = 0.5 * np.array(shape) * self.voxel
        x = np.zeros(len(w))
        for _ in range(8):
            centre = rng.uniform(-0.45, 0.45, 3) * half.min()
            radius = rng.uniform(4.0, 10.0)
            x[np.linalg.norm(w - centre, axis=1) <= radius] = rng.uniform(4.0, 8.0)
        x = x.reshape(shape)
        if fwhm_mm > 0:
            x = ndimage.gaussian_filter(x, fwhm_mm / 2.3548 / self.voxel)
        self.x = x.astype(np.float32)
        # The track, a seizure as a tracker logs it: the head turns and moves
        # over the frame (smoothstep) while it shakes at 3 Hz (clonic jerks,
        # 0.6 degrees and 0.4 mm), and the tracker adds its own noise (0.02
        # degrees and 0.02 mm a sample); about a centre below the grid's.
        self.times = np.arange(0.0, seconds + 0.5 / rate_hz, 1.0 / rate_hz)
        n = self.times.size
        u = self.times / seconds
        s = u * u * (3 - 2 * u)
        shake = np.sin(2 * np.pi * 3.0 * self.times) * np.sin(np.pi * u)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        move = rng.normal(size=3)
        move *= move_mm / np.linalg.norm(move)
        other = np.cross(axis, rng.normal(size=3))
        other /= np.linalg.norm(other)
        rotvec = np.outer(np.radians(turn_deg) * s, axis) + np.outer(np.radians(shake_deg) * shake, other)
        rotvec += np.radians(0.02) * rng.normal(size=(n, 3))
        self.rotations = Rotation.from_rotvec(rotvec)
        self.translations = np.outer(s, move) + np.outer(shake_mm * shake, other) + 0.02 * rng.normal(size=(n, 3))
        self.center = np.array([0.0, -20.0, -60.0])

    def quaternions(self):
        """w, x, y, z, petblur's order."""
        q = self.rotations.as_quat()
        return np.column_stack([q[:, 3], q[:, :3]])

    def motion(self):
        import petblur
        return petblur.Motion(self.times, self.translations, self.quaternions(), center=self.center)


def reference(case, times=600):
    """The blur of case.x under the track, dense: the mean over `times` equally
    spaced times of x resampled at M(t)^-1 w, each voxel's world point w."""
    t0, t1 = case.times[0], case.times[-1]
    ts = t0 + (np.arange(times) + 0.5) * (t1 - t0) / times
    rot, tr = track_poses(case.times, case.rotations, case.translations, ts)
    return mean_resampled(case.x, case.affine, case.center, rot, tr)


def track_poses(times, rotations, translations, ts):
    """The track's poses at times ts, between its samples as petblur takes
    them: translations by LERP, rotations by SLERP (a Rotation, (n, 3))."""
    tr = np.column_stack([np.interp(ts, times, translations[:, i]) for i in range(3)])
    return Slerp(times, rotations)(ts), tr


def mean_resampled(x, affine, center, rotations, translations):
    """The mean over the poses (a Rotation of n, translations (n, 3) mm, about
    center, in world mm) of x resampled at M^-1 w, each voxel's world point w:
    scipy's order-1 resampling, zero outside the grid. Each pose is one
    voxel-to-voxel affine map, which scipy's affine_transform applies point by
    point without the arrays of points map_coordinates needs."""
    inv = np.linalg.inv(affine)
    c = np.asarray(center, np.float64)
    out = np.zeros(x.shape)
    for k in range(len(translations)):
        # q = inv (R^T (affine ijk - c - t) + c): linear part and offset in voxels
        rt = rotations[k].inv().as_matrix()
        m = inv[:3, :3] @ rt @ affine[:3, :3]
        b = inv[:3, :3] @ (rt @ (affine[:3, 3] - c - translations[k]) + c) + inv[:3, 3]
        out += ndimage.affine_transform(x, m, b, order=1, mode="grid-constant", cval=0.0)
    return out / len(translations)


def errors(ref, x):
    """Relative RMS and max error, percent."""
    ref, x = np.asarray(ref, np.float64), np.asarray(x, np.float64)
    d = x - ref
    return {"rms_pct": float(100 * np.linalg.norm(d) / np.linalg.norm(ref)),
            "max_pct": float(100 * np.abs(d).max() / np.abs(ref).max())}


def method_options(method):
    """'ab', 'rm', 'cl', 'ref', or 'ab-sweep' (AB reading two points a slice
    where its path sweeps sideways) as BlurOperator's keywords."""
    kind, _, sampling = method.partition("-")
    return dict(method=kind, ab_sampling=sampling or None)


def measure(case, ref, method, bound, device):
    import petblur
    op = petblur.BlurOperator(case.shape, case.voxel, case.motion(), max_path_error=bound, affine=case.affine,
                              device=device, **method_options(method))
    x = np.asfortranarray(case.x)
    op(x)  # warm-up: the plan and, on OpenCL, the kernels' build
    t = time.perf_counter()
    y = op(x)
    seconds = time.perf_counter() - t
    return dict(errors(ref, y), seconds=seconds, segments=getattr(op, "segments", None))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="auto")
    ap.add_argument("--bounds", default="default,0.25,0.1,0.05,0.02,0.01")
    ap.add_argument("--methods", default="ab,rm")
    ap.add_argument("--times", type=int, default=600)
    ap.add_argument("--seed", type=int, default=31)
    ap.add_argument("--small", action="store_true")
    ap.add_argument("--out", default="")
    a = ap.parse_args()
    grid = SMALL if a.small else FULL
    rows = []
    for kind, fwhm in (("sharp", 0.0), ("PET resolution", 4.5)):
        case = Case(np.random.default_rng(a.seed), grid["shape"], grid["voxel"], fwhm_mm=fwhm)
        t = time.perf_counter()
        ref = reference(case, a.times)
        print(f"{kind}: reference from {a.times} times in {time.perf_counter() - t:.1f} s", flush=True)
        for method in a.methods.split(","):
            for b in a.bounds.split(","):
                bound = None if b == "default" else ("paper" if b == "paper" else float(b))
                r = dict(measure(case, ref, method, bound, a.device), phantom=kind, method=method, bound=b)
                rows.append(r)
                print(f"  {method.upper():8s} bound {b:>8s}: {r['rms_pct']:7.3f} % RMS  {r['max_pct']:7.3f} % max  "
                      f"{1e3 * r['seconds']:9.2f} ms", flush=True)
    if a.out:
        with open(a.out, "w") as f:
            json.dump({"grid": grid, "times": a.times, "seed": a.seed, "device": a.device, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
