"""A nod alone (sin^2 down and back up, 2-6 degrees over 60-200 s, as bench/estimate_family.py draws them) seen as
its frames' mean angles at their middles, on the family's protocols (a late scan's equal frames of 2-60 s, or frames
from injection), with keys at the series' ends that hold the first and last frames' values: the mean error over the
scan of scipy's PchipInterpolator through those keys over that of lines through them, on 2000 nods.

    python3 nods.py
"""
import numpy as np
from scipy.interpolate import PchipInterpolator
rng=np.random.default_rng(7)
def proto(rng):
    if rng.random()<0.5:
        L=rng.uniform(2,60); n=rng.integers(12,25); return np.arange(n+1)*L
    b=[0.0]
    for lo,hi,a,c in ((2,10,4,8),(30,30,3,5),(60,60,3,8)):
        for _ in range(rng.integers(a,c+1)): b.append(b[-1]+round(rng.uniform(lo,hi)))
    return np.array(b)
res=[]
for r in range(2000):
    b=proto(rng); deg=rng.uniform(2,6); ln=rng.uniform(60,200); at=rng.uniform(b[1],max(b[1],b[-1]-ln))
    nod=lambda t: deg*np.sin(np.pi*np.clip((t-at)/ln,0,1))**2
    means=np.array([nod(np.linspace(b[k],b[k+1],401)[:-1]+ (b[k+1]-b[k])/800).mean() for k in range(len(b)-1)])
    mids=(b[:-1]+b[1:])/2
    T=np.concatenate([[b[0]],mids,[b[-1]]]); Y=np.concatenate([[means[0]],means,[means[-1]]])
    t=np.linspace(b[0],b[-1],20000); tr=nod(t)
    el=np.abs(np.interp(t,T,Y)-tr).mean(); ep=np.abs(PchipInterpolator(T,Y)(t)-tr).mean()
    if el>0: res.append(ep/el)
res=np.array(res)
print('flat ends: pchip/line mean %.3f worst %.3f frac>1 %.4f n %d'%(res.mean(),res.max(),(res>1+1e-9).mean(),len(res)))
