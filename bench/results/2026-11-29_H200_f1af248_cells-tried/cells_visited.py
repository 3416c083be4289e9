"""How many trilinear cells a voxel's path visits in a frame of frames_cost's smooth drift (seed 46046):
20000 voxels of the grid's middle, the true drift sampled 301 times a frame. Run from the repository root:
  python3 bench/results/2026-11-29_H200_f1af248_cells-tried/cells_visited.py > cells_visited.txt"""
import numpy as np, sys
sys.path.insert(0, 'bench')  # from the repository root
from frames_cost import drift, PIVOT_MM, VOXEL_MM
shape=(220,220,110); seconds=24*75
pose,size=drift(np.random.default_rng([46046,0]),seconds)
print(size)
center=0.5*np.array(shape)*VOXEL_MM+PIVOT_MM
rng=np.random.default_rng(0)
# sample voxels in the central region
u=(rng.uniform([40,40,20],[180,180,90],(20000,3))).astype(int)+0.5
for f in [0,5,11,17,23]:
    t=np.linspace(f*75,(f+1)*75,301)
    R,tr=pose(t)
    # object = R^T (u*vox - center - t) + center ?  direction doesn't matter for counting
    X=u*VOXEL_MM-center
    P=np.stack([ (R[k].inv().apply(X - tr[k]) + center)/VOXEL_MM for k in range(len(t))])  # (T, N, 3)
    cells=np.floor(P-0.5).astype(int)
    key=cells[...,0]*1000000+cells[...,1]*1000+cells[...,2]
    changes=(np.diff(key,axis=0)!=0).sum(0)+1
    ext=(P.max(0)-P.min(0))
    print(f, 'cells visited per voxel mean', changes.mean(), 'max', changes.max(), 'path extent mean', ext.mean(0))
