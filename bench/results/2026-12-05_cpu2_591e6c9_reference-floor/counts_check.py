"""For each family draw: each frame's sum x duration (most_counts' measure, on the series as written), and whether
the reference petblur chose holds at least a quarter of the most among the frames held still."""
import sys, json
sys.path.insert(0, "bench"); sys.path.insert(0, "python")  # run from the repository root
import numpy as np
import estimate_family as ef
for path in sys.argv[1:]:
    for line in open(path):
        r = json.loads(line)
        d = ef.draw(r["seed"])
        frames, affine, bounds, truth = ef.simulate(d, np.random.default_rng([r["seed"], 1]))
        f = np.asarray(frames, dtype=np.float64)
        sums = f.reshape(-1, f.shape[-1]).sum(axis=0) * np.diff(bounds)
        ref = r["petblur"]["reference"]
        mv = r["petblur"]["frames"]["moving"]
        still = [k for k in range(len(sums)) if not mv[k]]
        top = max(sums[k] for k in still)
        print(r["seed"], "ref", ref, "share of the most %.3f" % (sums[ref] / top),
              "min share of still frames %.3f" % min(sums[k] / top for k in still), flush=True)
