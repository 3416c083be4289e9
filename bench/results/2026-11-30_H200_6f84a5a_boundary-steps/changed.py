"""python changed.py DRAWS.JSONL: per draw, the boundaries a jerk is centred on (from the draw's seed,
bench/estimate_family.py), petblur's mean and worst frame under the ramp variant and the default, and the frames
whose error changed by more than 0.02 mm."""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
import estimate_family as ef  # noqa: E402

rows = [json.loads(line.replace("NaN", "null")) for line in open(sys.argv[1])]
for r in sorted(rows, key=lambda r: r["seed"]):
    d = ef.draw(r["seed"])
    b = np.array(d.bounds)
    centres = [at + n / 2 for at, n, *_ in d.jerks]
    on = [int(np.argmin(abs(b - c))) for c in centres if abs(b[np.argmin(abs(b - c))] - c) < 1e-6]
    new, old = r["petblur"], r["variants"]["ramp"]
    diff = np.array(new["per_frame_mm"]) - np.array(old["per_frame_mm"])
    changed = [(i, round(float(x), 2)) for i, x in enumerate(diff) if abs(x) > 0.02]
    print(f"{r['seed']:11d} from injection {int(r['from_injection'])} counts {r['counts_per_voxel']:5.1f} "
          f"jerks on boundaries {on}  {old['mean_mm']:.3f} -> {new['mean_mm']:.3f}  worst {old['max_mm']:.2f} -> "
          f"{new['max_mm']:.2f}  frames changed {changed}")
