"""The same draws with the view's own Jacobian (view/) and with the blurs of the derivative images (blur/): each
draw's mean and worst-frame error, the largest difference of a frame's error, and the seconds each took."""
import json
import os
import statistics

here = os.path.dirname(os.path.abspath(__file__))
runs = {name: {json.loads(line)["seed"]: json.loads(line) for line in open(os.path.join(here, name, "draws.jsonl"))}
        for name in ("view", "blur")}
rows = []
print("| seed | kind | view mean / worst mm | blur mean / worst mm | largest frame difference mm | view s | blur s |")
print("|---|---|---|---|---|---|---|")
for seed, v in runs["view"].items():
    a, b = v["petblur"], runs["blur"][seed]["petblur"]
    d = max(abs(x - y) for x, y in zip(a["per_frame_mm"], b["per_frame_mm"]))
    rows.append((a["mean_mm"], b["mean_mm"], d, a["seconds"], b["seconds"]))
    print("| %d | %s | %.3f / %.3f | %.3f / %.3f | %.3f | %.1f | %.1f |" % (
        seed, "injection" if v["from_injection"] else "late", a["mean_mm"], a["max_mm"], b["mean_mm"], b["max_mm"], d,
        a["seconds"], b["seconds"]))
print()
print("median draw: view %.3f, blur %.3f mm; mean of the draws' means: view %.4f, blur %.4f mm" % (
    statistics.median(r[0] for r in rows), statistics.median(r[1] for r in rows),
    statistics.mean(r[0] for r in rows), statistics.mean(r[1] for r in rows)))
print("largest difference of any frame's error: %.3f mm" % max(r[2] for r in rows))
print("seconds, all draws: view %.0f, blur %.0f (%.2fx); per draw blur / view: %.2f-%.2fx" % (
    sum(r[3] for r in rows), sum(r[4] for r in rows), sum(r[4] for r in rows) / sum(r[3] for r in rows),
    min(r[4] / r[3] for r in rows), max(r[4] / r[3] for r in rows)))
