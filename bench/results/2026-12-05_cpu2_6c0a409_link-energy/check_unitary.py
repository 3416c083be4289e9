import sys; import os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation
from unitary import move
rng = np.random.default_rng(1)
f = ndimage.gaussian_filter(rng.random((40, 36, 30)), 3.0)
f -= f.mean(); f = ndimage.gaussian_filter(f * (ndimage.distance_transform_edt(np.pad(np.ones((24,20,14)),8)) > 0), 1)
A = np.eye(4); A[:3, :3] = Rotation.from_rotvec([0.1, -0.2, 0.15]).as_matrix() @ np.diag([2.0, 3.1, 2.6]); A[:3, 3] = [-40, -50, -30]
M = np.eye(4); M[:3, :3] = Rotation.from_rotvec(np.deg2rad([3, -2, 4])).as_matrix(); M[:3, 3] = [1.3, -0.7, 2.1]
g1 = move(f, A, M)
full = np.linalg.inv(A) @ M @ A
g2 = ndimage.affine_transform(f, full[:3, :3], full[:3, 3], order=5, mode='constant')
inner = (slice(6, -6),) * 3
print("rel diff", np.linalg.norm((g1 - g2)[inner]) / np.linalg.norm(g2[inner]), "energy", (g1**2).sum() / (f**2).sum())
