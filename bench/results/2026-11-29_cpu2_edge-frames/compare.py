import json, sys, statistics as st
rec = {json.loads(l)['seed']: json.loads(l) for l in open('/work/main/bench/results/2026-11-29_cpu2_50373c2_heads-replay/draws.jsonl')}
rows = []
for l in open('/tmp/s47/edge_results.txt'):
    p = l.split()
    if len(p) < 6: continue
    s = int(p[0]); mean = float(p[3]); mx = float(p[5])
    r = rec[s]; om, ox = r['petblur']['mean_mm'], r['petblur']['max_mm']
    rows.append((s, r['from_injection'], om, mean, ox, mx, r.get('sitk', {}).get('mean_mm') if isinstance(r.get('sitk'), dict) else None))
for s, inj, om, m, ox, x, sk in rows:
    flag = '' if abs(m - om) <= 0.01 else ('BETTER' if m < om else 'WORSE')
    print(f"{s:>11} {'inj ' if inj else 'late'} mean {om:.3f} -> {m:.3f}  worst {ox:.2f} -> {x:.2f}  sitk {sk} {flag}")
if rows:
    for name, sel in (('all', rows), ('inj', [r for r in rows if r[1]]), ('late', [r for r in rows if not r[1]])):
        if not sel: continue
        om = sorted(r[2] for r in sel); nm = sorted(r[3] for r in sel)
        q = lambda v, f: v[min(len(v) - 1, int(round(f * (len(v) - 1))))]
        print(name, len(sel), 'median', st.median(om), '->', st.median(nm), '90th', q(om, .9), '->', q(nm, .9),
              'worst-frame median', st.median(r[4] for r in sel), '->', st.median(r[5] for r in sel))
