"""The bound a track through the frames' middles can reach, on issue 47's family: the truth's mean pose over each
frame at the frame's middle (estimate_family.frame_means), joined by lines (`line`, as the estimate's track was) or by
scipy's PchipInterpolator per component on a chart about the first key (`flat-ends`: with the keys at the series'
ends that hold the first and last frames' poses, as src/estimate/track_curve.c lays it; `held-ends`: through the
middles alone, scipy's own end slopes, held beyond). Errors as bench/estimate_family.py states them (mean over each
frame's time and the head's points), 20 instants a frame and a quarter of the points.

    cd bench && python3 results/2026-12-04_cpu2_curve-bound/bound.py $(cat results/2026-12-04_cpu2_curve-bound/seeds.txt)
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
import estimate_family as ef  # noqa: E402
import head_frames as hf  # noqa: E402
from scipy.interpolate import PchipInterpolator  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402
def interp_track(times, maps, lo, hi):
    """PCHIP per component on a chart about maps[lo], through keys lo..hi, held beyond."""
    base=Rotation.from_matrix(maps[lo,:3,:3])
    c=np.array([np.concatenate([m[:3,3], (base.inv()*Rotation.from_matrix(m[:3,:3])).as_rotvec()]) for m in maps])
    f=PchipInterpolator(times[lo:hi+1],c[lo:hi+1],axis=0)
    def at(t):
        t=np.clip(t,times[lo],times[hi]); v=f(t); m=np.eye(4)
        m[:3,:3]=(base*Rotation.from_rotvec(v[3:])).as_matrix(); m[:3,3]=v[:3]; return m
    return at
seeds = [int(x) for x in sys.argv[1:]]
res={'line':[], 'flat-ends':[], 'held-ends':[]}
inj=[]
for seed in seeds:
    d=ef.draw(seed); truth=ef.Truth(d); b=np.array(d.bounds)
    pts=hf.head_points(np.random.default_rng([seed,1]))[::4]
    times,maps=ef.frame_means(truth,b)
    n=len(times)
    tr={'line':hf.track_maps(times,maps),'flat-ends':interp_track(times,maps,0,n-1),'held-ends':interp_track(times,maps,1,n-2)}
    for k in res:
        e=hf.displacement_errors(tr[k],truth,b,pts,samples=20)
        res[k].append((e.mean(), e.max()))
    inj.append(d.start_s==0.0)
    print(seed, 'inj' if inj[-1] else 'late', ' '.join(f"{k} {res[k][-1][0]:.3f}/{res[k][-1][1]:.3f}" for k in res), flush=True)
inj=np.array(inj)
for k,v in res.items():
    v=np.array(v)
    print(f"{k}: mean, median {np.median(v[:,0]):.3f} (from injection {np.median(v[inj,0]):.3f}, late {np.median(v[~inj,0]):.3f}), 90th {np.percentile(v[:,0],90):.3f}, worst {v[:,0].max():.3f}; worst frame, median {np.median(v[:,1]):.3f}; draws above 0.6 mm {(v[:,0]>0.6).sum()}")
lin=np.array(res['line'])[:,0]
for k in ('flat-ends','held-ends'):
    v=np.array(res[k])[:,0]; print(f"{k} against the line: better {(v<lin-0.005).sum()}, worse {(v>lin+0.005).sum()} of {len(v)} (by 0.005 mm)")
