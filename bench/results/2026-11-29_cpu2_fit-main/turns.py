import numpy as np, petblur, sys, time
from scipy.spatial.transform import Rotation as R
shape=(24,24,24); vox=(2.0,2.0,2.0)
x=np.zeros(shape,np.float32,order="F"); x[6:18,8:16,10:14]=1
for deg in (90, 200, 350, 720):
    t=np.linspace(0,10,101)
    q=R.from_rotvec(np.outer(np.radians(deg)*t/10,[0.3,0.2,1.0]/np.linalg.norm([0.3,0.2,1.0]))).as_quat()
    m=petblur.Motion(t, np.zeros((len(t),3)), np.column_stack([q[:,3],q[:,:3]]))
    out={}
    for method in ("ab","cl"):
        op=petblur.BlurOperator(shape,vox,m,frame=(0.05,9.95),method=method,filter="exact",device="host")
        t0=time.time(); out[method]=np.asarray(op(x)); dt=time.time()-t0
    d=np.abs(out["ab"]-out["cl"]).max()/out["cl"].max()*100
    print(deg, "deg: AB vs CL max %.3f %%" % d, flush=True)
