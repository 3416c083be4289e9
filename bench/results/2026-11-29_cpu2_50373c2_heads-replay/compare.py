"""Issue 47's 36 recorded draws replayed on the host: the estimator before this session (the records: CUDA, nopool /
default rows of bench/results/2026-11-29_H200_e5d8d46_heads and _073418e_heads) against this session's.
    python3 compare.py REPLAY_DIR RERUN_DIR
REPLAY_DIR: estimate_family.py --seed S --device host --sitk-from ... runs of the instrumented binary at 980da5b with
the near-reference check of f75881b's predecessor (each SEED/draws.jsonl, SEED.dbg the passes' lines); RERUN_DIR: the
draws that the later commits change (an own-gain path under 0.15, fewer than six frames near the reference), rerun at
50373c2."""
import json, glob, os, sys
import numpy as np
RECORDS = ['2026-11-29_H200_e5d8d46_heads/draws.jsonl', '2026-11-29_H200_073418e_heads/draws.jsonl']
root = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..')
rec = {}
for f, key in zip(RECORDS, ['nopool', None]):
    for l in open(os.path.join(root, f)):
        d = json.loads(l)
        rec[d['seed']] = d['variants'][key] if key else d['petblur']
def load(p):
    lines = open(p).read().splitlines()
    return json.loads(lines[0]) if lines else None
rows = []
for p in sorted(glob.glob(sys.argv[1] + '/*/draws.jsonl')):
    d = load(p)
    if d is None:
        continue
    dbg = open(os.path.dirname(p) + '.dbg').read() if os.path.exists(os.path.dirname(p) + '.dbg') else ''
    r = os.path.join(sys.argv[2], str(d['seed']), 'draws.jsonl')
    run = 'replay'
    if os.path.exists(r) and load(r):
        d, run = load(r), 'rerun'
    old, new = rec[d['seed']], d['petblur']
    rows.append((d['seed'], d['from_injection'], old['mean_mm'], new['mean_mm'], old['max_mm'], new['max_mm'],
                 d['sitk']['mean_mm'], d['frame_means']['mean_mm'], run, dbg.strip().replace('\n', '; ')))
print("| seed | from injection | mean before | mean after | worst frame before | after | SimpleITK mean | "
      "truth's mean pose a frame | run | passes (replay's lines) |")
print("|---|---|---|---|---|---|---|---|---|---|")
for r in rows:
    print("| %d | %s | %.3f | %.3f | %.2f | %.2f | %.3f | %.3f | %s | %s |" % (r[0], 'yes' if r[1] else 'no', *r[2:8], r[8], r[9]))
a = np.array([r[2:8] for r in rows], float); inj = np.array([r[1] for r in rows])
def s(x): return "%.3f / %.3f / %.3f" % (np.median(x), np.percentile(x, 90), x.max())
print()
print("| | draws | mean before: median / 90th / worst draw | after | worst frame before: median | after | "
      "SimpleITK mean: median | at or below SimpleITK, after (before) |")
print("|---|---|---|---|---|---|---|---|")
for name, m in [("all", np.ones(len(rows), bool)), ("from injection", inj), ("late", ~inj)]:
    if m.sum() == 0:
        continue
    b = a[m]
    print("| %s | %d | %s | %s | %.2f | %.2f | %.3f | %d (%d) |" % (name, m.sum(), s(b[:, 0]), s(b[:, 1]),
          np.median(b[:, 2]), np.median(b[:, 3]), np.median(b[:, 4]), (b[:, 1] <= b[:, 4]).sum(),
          (b[:, 0] <= b[:, 4]).sum()))
