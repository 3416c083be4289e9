import os, sys, dataclasses, numpy as np
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bound import *
for s in [int(x) for x in sys.argv[1:]]:
    d = dataclasses.replace(ef.draw(s), jerks=[]); truth = ef.Truth(d); b = np.array(d.bounds)
    rng = np.random.default_rng([s, 1]); points = hf.head_points(rng)
    times, maps = ef.frame_means(truth, b)
    a = hf.displacement_errors(hf.track_maps(times, maps), truth, b, points)
    v = histo(times, b, np.array([vec(m) for m in maps[1:-1]]))
    h = hf.displacement_errors(hf.track_maps(times, np.array([mat(x) for x in v])), truth, b, points)
    fl = np.diff(b)
    print(f"{s:11d} inj={int(d.start_s==0)} frame {fl.min():.0f}-{fl.max():.0f}s nods {[(round(n[1]),round(n[2],1)) for n in d.nods]} mids {a.mean():.3f}/{a.max():.3f}  histo {h.mean():.3f}/{h.max():.3f}", flush=True)
