import os, sys, numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
import head_frames as hf
t, m = hf.read_matrix_csv(sys.argv[1]); b0, b1 = float(sys.argv[3]), float(sys.argv[4])
tk = hf.track_maps(t, m)
# the map at frame 0's middle (frame 0 is still in the truth)
a = np.linalg.inv(tk(0.5 * (b0 + b1)))
out = np.array([x @ a for x in m])
with open(sys.argv[2], "w") as f:
    f.write("t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz\n")
    for ti, x in zip(t, out):
        f.write(",".join(["%.6f" % ti] + ["%.9g" % v for v in x[:3, :].ravel()]) + "\n")
