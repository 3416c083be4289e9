"""A head-motion track as an optical tracker logs it, at 30 Hz: a slow drift
over the whole scan, a nod (a pitch of 8 degrees about the left-right axis and
back over some seconds), and a sudden seizure-like jerk (15 degrees and 10 mm
within 2 s, then held). Poses are in grid mm along the array's axes (axis 0
left-right, 1 front-back, 2 the scanner axis), about a pivot the caller
places (near the neck), as petblur.Motion takes them: p' = R (p - c) + c + t.

The same analytic functions give the pose at any time, which the data
simulation samples on its own (scipy's Rotation, not petblur's SLERP)."""

import numpy as np
from scipy.spatial.transform import Rotation

RATE_HZ = 30.0


def _smoothstep(u):
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def wxyz(rotations):
    """scipy's rotations as unit quaternions w, x, y, z (petblur's order)."""
    xyzw = np.atleast_2d(rotations.as_quat())
    return np.column_stack([xyzw[:, 3], xyzw[:, :3]])


class HeadMotion:
    """duration s; nod_at and jerk_at: when the nod and the jerk start, s."""

    def __init__(self, duration, nod_at, jerk_at, pivot):
        self.duration, self.nod_at, self.jerk_at = float(duration), float(nod_at), float(jerk_at)
        self.pivot = np.asarray(pivot, dtype=np.float64)

    def poses(self, t):
        """Rotations (scipy) and translations (mm, (n, 3)) at times t (s)."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        drift = t / self.duration
        # Drift: 3 degrees of yaw and (2, 3, 1.5) mm over the scan.
        yaw = Rotation.from_rotvec(np.outer(np.radians(3.0) * drift, [0, 0, 1]))
        shift = np.outer(drift, [2.0, 3.0, 1.5])
        # Nod: pitch 8 degrees over 3 s, held 10 s, back over 4 s.
        down = _smoothstep((t - self.nod_at) / 3.0) - _smoothstep((t - self.nod_at - 13.0) / 4.0)
        nod = Rotation.from_rotvec(np.outer(np.radians(8.0) * down, [1, 0, 0]))
        # Jerk: 15 degrees about a tilted axis and 10 mm within 2 s, held.
        j = _smoothstep((t - self.jerk_at) / 2.0)
        axis = np.array([0.35, -0.25, 1.0]) / np.linalg.norm([0.35, -0.25, 1.0])
        jerk = Rotation.from_rotvec(np.outer(np.radians(15.0) * j, axis))
        shift = shift + np.outer(j, [6.0, -4.0, 7.0])  # |(6, -4, 7)| = 10 mm
        return jerk * nod * yaw, shift

    def track(self):
        """The tracker's samples: times (s), translations (mm) and unit
        quaternions (w, x, y, z)."""
        t = np.arange(0.0, self.duration + 0.5 / RATE_HZ, 1.0 / RATE_HZ)
        r, shift = self.poses(t)
        return t, shift, wxyz(r)
