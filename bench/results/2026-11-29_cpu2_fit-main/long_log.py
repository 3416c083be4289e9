import numpy as np, petblur, time, ctypes, importlib.util
spec=importlib.util.spec_from_file_location("pc","bench/path_cases.py"); pc=importlib.util.module_from_spec(spec); spec.loader.exec_module(pc)
rng=np.random.default_rng(5)
shape=(64,64,48); vox=(2.0,2.0,3.0)
for n,noise in ((12000,0.2),(12000,0.0)):
    t=np.arange(n)/20.0
    tr=np.column_stack([np.sin(t/30), 0.5*np.cos(t/20), 0.1*t/60]) + noise*rng.standard_normal((n,3))
    q=np.tile([1.0,0,0,0],(n,1))
    m=petblur.Motion(t,tr,q)
    op=petblur.BlurOperator(shape,vox,m,frame=(0.0,t[-1]),method="ab",device="host")
    t0=time.time(); s=pc.path_segments(op); dt=time.time()-t0
    print(n, "samples noise", noise, "segments", s, "plan s %.3f"%dt, flush=True)
