# The table of variants.py's JSON lines: python3 summarize.py FILE.jsonl... [--base NAME]; per file and variant RMS %
# median / 90th / worst, max % median / worst, segments median / max, and draws better / worse than the base (the
# first variant unless --base) by more than 1e-4 % RMS.
import sys, json, numpy as np
args = sys.argv[1:]
base = args[args.index("--base") + 1] if "--base" in args else None
files = [a for a in args if a.endswith(".jsonl")]
print("| file (draws) | variant | RMS % median / 90th / worst | max % median / worst | segments median / max | better / worse |")
print("|---|---|---|---|---|---|")
for f in files:
    rows = [json.loads(l) for l in open(f)]
    names = [k for k, v in rows[0].items() if isinstance(v, list)]
    b = base or names[0]
    for n in names:
        r = np.array([row[n][0] for row in rows]); m = np.array([row[n][1] for row in rows])
        s = np.array([row[n][2] for row in rows]); rb = np.array([row[b][0] for row in rows])
        bw = "-" if n == b else f"{int(np.sum(r < rb - 1e-4))} / {int(np.sum(r > rb + 1e-4))}"
        print(f"| {f} ({len(rows)}, {rows[0]['seed']}-{rows[-1]['seed']}) | {n} | {np.median(r):.3f} / "
              f"{np.percentile(r, 90):.3f} / {r.max():.3f} | {np.median(m):.3f} / {m.max():.3f} | "
              f"{np.median(s):.0f} / {s.max()} | {bw} |")
