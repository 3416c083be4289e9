"""Noise-free tremors and noisy stills/drifts at 20 Hz: AB at the defaults against CL of the logged track (1200+ steps)
and, for the noisy ones, against CL of the true motion."""
import numpy as np, petblur, sys, time
sys.path.insert(0,"bench")
from path_cases import path_segments
from scipy.spatial.transform import Rotation as R
rng=np.random.default_rng(int(sys.argv[1]) if len(sys.argv)>1 else 7)
shape=(26,24,22); vox=(2.0,2.0,2.0)
x=np.zeros(shape,np.float32,order="F"); g=np.indices(shape).astype(float)
for _ in range(6):
    c=rng.uniform(5,18,3); r=rng.uniform(1.5,4)
    x[((g[0]-c[0])**2+(g[1]-c[1])**2+(g[2]-c[2])**2)<r*r]+=rng.uniform(1,3)
T=30.0; t=np.arange(0,T+1e-9,0.05); n=len(t)
def motion(tr, rv):
    q=R.from_rotvec(rv).as_quat(); return petblur.Motion(t,tr,np.column_stack([q[:,3],q[:,:3]]))
def err(a,b): return "%.3f / %.3f %%"%(100*np.linalg.norm(a-b)/np.linalg.norm(b),100*abs(a-b).max()/abs(b).max())
def op_(m, method="ab", steps=0):
    return petblur.BlurOperator(shape,vox,m,frame=(0.01,T-0.01),method=method,filter="exact",device="host",steps=steps)
def blur(m, method="ab", steps=0):
    return np.asarray(op_(m,method,steps)(x))
ax=rng.normal(size=3); ax/=np.linalg.norm(ax)
cases=[]
for f in (4.0,6.0,7.8,8.3,10.0):
    A=0.5  # mm
    s=np.sin(2*np.pi*f*t+rng.uniform(0,6.3))
    cases.append(("tremor %.1f Hz 0.5 mm"%f, np.outer(s,ax)*A, np.outer(s,ax)*A/80, None))
drift=np.outer(t/T,[0.6,-0.4,0.3])
for sg in ():
    cases.append(("still noise %.2f"%sg, rng.normal(scale=sg,size=(n,3)), rng.normal(scale=sg/80,size=(n,3)), (np.zeros((n,3)),np.zeros((n,3)))))
    cases.append(("drift noise %.2f"%sg, drift+rng.normal(scale=sg,size=(n,3)), rng.normal(scale=sg/80,size=(n,3)), (drift,np.zeros((n,3)))))
for name,tr,rv,true in cases:
    m=motion(tr,rv); t0=time.time(); y=blur(m); dt=time.time()-t0
    ref=blur(m,"cl",20)
    line="%-22s segs %5d  vs logged %s" % (name, path_segments(op_(m)), err(y,ref))
    segs=None
    try:
        from petblur import _lib
    except Exception: pass
    if true is not None:
        line+="  vs true %s (logged's own %s)"%(err(y,blur(motion(*true),"cl",3)), err(ref,blur(motion(*true),"cl",3)))
    print(line, "%.2fs"%dt, flush=True)
