import os, sys, numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
import estimate_family as ef, head_frames as hf
from scipy.spatial.transform import Rotation
seed=int(sys.argv[1]); d=ef.draw(seed); tr=ef.Truth(d); b=np.array(d.bounds)
for csv in sys.argv[2:]:
    tk=hf.track_maps(*hf.read_matrix_csv(csv)); print(csv)
    for k in range(len(b)-1):
        t=0.5*(b[k]+b[k+1]); e=tk(t)@np.linalg.inv(tr(t))
        rv=np.rad2deg(Rotation.from_matrix(e[:3,:3]).as_rotvec()); c=np.array([0,0,5.0]); sh=e[:3,:3]@c+e[:3,3]-c
        print("  %2d t=%6.1f rot deg %s shift@c mm %s" % (k, t, np.array2string(rv, precision=3, suppress_small=True), np.array2string(sh, precision=3, suppress_small=True)))
