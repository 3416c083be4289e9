"""Per-frame error of a track csv against a family draw's truth: eval_draw.py SEED CSV STDOUT"""
import sys
sys.path.insert(0, "bench"); sys.path.insert(0, "python")
import numpy as np
import estimate_family as ef
import head_frames as hf
seed, csv, out = int(sys.argv[1]), sys.argv[2], sys.argv[3]
d = ef.draw(seed)
rng = np.random.default_rng([seed, 1])
frames, affine, bounds, truth = ef.simulate(d, rng)
points = hf.head_points(rng)
means = ef.frame_means(truth, bounds)
ref = ef.reference_said(open(out).read())
times, maps = hf.read_matrix_csv(csv)
track, anchor = hf.track_maps(times, maps), means[1][1 + ref]
e = hf.displacement_errors(lambda t: track(t) @ anchor, truth, bounds, points)
print("mean %.3f max %.3f" % (e.mean(), e.max()), " ".join("%.2f" % x for x in e))
