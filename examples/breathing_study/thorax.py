"""A breathing thorax, analytic: the phantom, its motion and the breath.

Coordinates are the image grid's, in mm about the grid's centre: x across
the patient, y from back (-) to front (+), z from feet (-) to head (+). The
reference state is end-exhale (surrogate s = 0); the motion is given as the
resampling field petblur reads: at amplitude s the voxel at r sees the
object's point r + D(s)(r).

The motion model is the one breathing studies draw (the diaphragm's
cranio-caudal excursion largest at and below the domes, little at the lung
apex; the chest and the belly rising forward; a little lateral spread), with
16 mm of diaphragm motion at s = 1 and a forward rise that grows as s^1.5,
so that a field at one amplitude is not a scaled copy of another. The
breath: cycles of 3.5-5 s with amplitudes 0.75-1.25 drawn for each, the
Lujan shape sin^4 (a longer rest at exhale than at inhale), and a baseline
that drifts by 0.15 over the scan; a belt samples it at 25 Hz with noise.
"""

import dataclasses

import numpy as np

# Tissue values (relative uptake, FDG-like): soft tissue 1.
BODY, LUNG, LIVER, MYOCARDIUM, BLOOD = 1.0, 0.3, 2.0, 3.0, 1.5
# The diaphragm's domes at end-exhale: the top of each (mm) and how far the
# dome falls to the lung's edge (the costophrenic recess).
DOME_TOP = {+1: -25.0, -1: -35.0}
DOME_FALL = 45.0
LUNG_X, LUNG_Y, LUNG_HALF = 80.0, -5.0, (60.0, 85.0)
LUNG_BASE, LUNG_APEX = -75.0, 100.0
HEART_C, HEART_OUT, HEART_WALL = np.array([-25.0, 35.0, -5.0]), np.array([50.0, 42.0, 55.0]), 12.0
# Diaphragm motion (mm at s = 1), the forward rise of the front wall and the lateral spread.
SI_MM, AP_MM, LR_MM = 16.0, 10.0, 3.0
SPINE_Y = -100.0


def dome(side, x, y):
    """The diaphragm's height (mm, z) under the lung of `side` (+1 right, -1 left) at end-exhale."""
    u = ((x - side * LUNG_X) / LUNG_HALF[0]) ** 2 + ((y - LUNG_Y) / LUNG_HALF[1]) ** 2
    return DOME_TOP[side] - DOME_FALL * u


def lesion_centres():
    """Four lesions at end-exhale: (name, centre mm, radius mm, value, tissue around it)."""
    return [
        ("right lung base", np.array([80.0, -10.0, dome(+1, 80.0, -10.0) + 14.0]), 6.0, 6.0, "lung"),
        ("left lung base", np.array([-85.0, 10.0, dome(-1, -85.0, 10.0) + 12.0]), 5.0, 6.0, "lung"),
        ("liver dome", np.array([55.0, 10.0, dome(+1, 55.0, 10.0) - 16.0]), 8.0, 5.0, "liver"),
        ("right lung apex", np.array([70.0, 10.0, 70.0]), 6.0, 6.0, "lung"),
    ]


def tissue(p):
    """Each point's value and label (0 outside, 1 body, 2 lung, 3 liver, 4 heart, 5+ lesion k) at end-exhale.
    p: (..., 3) mm."""
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    val = np.zeros(x.shape, np.float32)
    lab = np.zeros(x.shape, np.int8)
    body = (x / 170.0) ** 2 + (y / 115.0) ** 2 <= 1.0
    val[body], lab[body] = BODY, 1
    for side in (+1, -1):
        e = ((x - side * LUNG_X) / LUNG_HALF[0]) ** 2 + ((y - LUNG_Y) / LUNG_HALF[1]) ** 2 + \
            (np.maximum(z - LUNG_BASE, 0.0) / (LUNG_APEX - LUNG_BASE)) ** 2
        lung = body & (e <= 1.0) & (z >= dome(side, x, y)) & (z >= LUNG_BASE)
        val[lung], lab[lung] = LUNG, 2
    liver = body & (((x - 60.0) / 95.0) ** 2 + (y / 90.0) ** 2 <= 1.0) & (z <= dome(+1, x, y)) & (z >= -150.0)
    val[liver], lab[liver] = LIVER, 3
    q = (np.stack([x, y, z], -1) - HEART_C)
    outer = ((q / HEART_OUT) ** 2).sum(-1) <= 1.0
    inner = ((q / (HEART_OUT - HEART_WALL)) ** 2).sum(-1) <= 1.0
    val[outer], lab[outer] = MYOCARDIUM, 4
    val[inner] = BLOOD
    for k, (_, c, r, v, _) in enumerate(lesion_centres()):
        les = ((np.stack([x, y, z], -1) - c) ** 2).sum(-1) <= r * r
        val[les], lab[les] = v, 5 + k
    return val, lab


def smoothstep(u):
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def displacement(p, s):
    """D(s)(p), mm, (..., 3): where the voxel at p looks in the end-exhale object at amplitude s."""
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    top = max(DOME_TOP.values())
    w_z = 1.0 - 0.9 * smoothstep((z - top) / (LUNG_APEX + 10.0 - top))
    w_xy = 0.35 + 0.65 * np.exp(-((x / 110.0) ** 2 + (y / 80.0) ** 2))
    rise = s ** 1.5 if s > 0 else 0.0
    d = np.empty(p.shape, np.float64)
    # inhale: the diaphragm moves down, so a voxel sees tissue from above it
    d[..., 2] = SI_MM * s * w_z * w_xy
    # the front wall moves forward (the back rests on the bed): a voxel sees tissue from behind it
    d[..., 1] = -AP_MM * rise * (y - SPINE_Y) / (115.0 - SPINE_Y)
    d[..., 0] = -LR_MM * rise * x / 170.0
    return d


def grid_points(shape, voxel, sub=1):
    """Voxel centres (sub = 1) or a sub x sub x sub lattice inside each voxel, mm about the grid's centre:
    (nx, ny, nz, sub^3, 3)."""
    v = np.asarray(voxel, dtype=np.float64)
    axes = [(np.arange(n) - (n - 1) / 2.0) * d for n, d in zip(shape, v)]
    c = np.stack(np.meshgrid(*axes, indexing="ij"), -1)
    o = (np.arange(sub) + 0.5) / sub - 0.5
    offs = np.stack(np.meshgrid(o, o, o, indexing="ij"), -1).reshape(-1, 3) * v
    return c[..., None, :] + offs


def image(shape, voxel, s=0.0, sub=2):
    """The activity seen by each voxel at amplitude s: the phantom at p + D(s)(p), averaged over a sub^3 lattice
    inside the voxel (no interpolation: the phantom is analytic), slab by slab to bound memory."""
    out = np.empty(shape, np.float32)
    for i in range(shape[0]):
        p = grid_points((1,) + tuple(shape[1:]), voxel, sub)
        p[..., 0] += (i - (shape[0] - 1) / 2.0) * voxel[0]
        q = p + displacement(p, s) if s != 0 else p
        out[i] = tissue(q)[0].mean(-1)[0]
    return out


def fields(shape, voxel, values):
    """petblur's fields at the surrogate values: (K, nx, ny, nz, 3) mm at the voxel centres."""
    p = grid_points(shape, voxel)[..., 0, :]
    return np.stack([displacement(p, float(s)) for s in values]).astype(np.float32)


@dataclasses.dataclass
class Breath:
    """The true amplitude s(t) and the belt's samples of it."""
    seconds: float
    rng: np.random.Generator
    period: tuple = (3.5, 5.0)
    amplitude: tuple = (0.75, 1.25)
    drift: float = 0.15
    belt_hz: float = 25.0
    belt_noise: float = 0.01

    def __post_init__(self):
        starts, amps = [0.0], []
        while starts[-1] < self.seconds:
            starts.append(starts[-1] + self.rng.uniform(*self.period))
            amps.append(self.rng.uniform(*self.amplitude))
        self.starts, self.amps = np.array(starts), np.array(amps)
        self.belt_t = np.arange(0.0, self.seconds + 0.5 / self.belt_hz, 1.0 / self.belt_hz)
        self.belt_s = self(self.belt_t) + self.rng.normal(0.0, self.belt_noise, self.belt_t.size)

    def __call__(self, t):
        t = np.asarray(t, dtype=np.float64)
        k = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, self.amps.size - 1)
        u = (t - self.starts[k]) / (self.starts[k + 1] - self.starts[k])
        return self.drift * t / self.seconds + self.amps[k] * np.sin(np.pi * u) ** 4
