"""python compare.py NEW.JSONL OLD.JSONL...: per seed in both, petblur's mean and worst frame before (the ramp variant where
an old row has it, else its default) and now, and the frames worse by more than 0.1 mm; then the medians and counts."""
import sys, json, numpy as np
sys.path.insert(0, __import__('os').path.join(__import__('os').path.dirname(__import__('os').path.abspath(__file__)), '..', '..')); import estimate_family as ef
new = {json.loads(l)['seed']: json.loads(l.replace('NaN','null')) for l in open(sys.argv[1])}
old = {}
for f in sys.argv[2:]:
    for l in open(f):
        r = json.loads(l.replace('NaN','null'))
        if r.get('petblur', {}).get('per_frame_mm'):
            old.setdefault(r['seed'], r['variants']['ramp'] if 'ramp' in r.get('variants', {}) else r['petblur'])
a, b = [], []
for s in sorted(new):
    if s not in old: continue
    o, n = old[s], new[s]['petblur']
    a.append(o['mean_mm']); b.append(n['mean_mm'])
    d = np.array(n['per_frame_mm']) - np.array(o['per_frame_mm'])
    print(f"{s:11d} inj={int(new[s]['from_injection'])} {o['mean_mm']:.3f} -> {n['mean_mm']:.3f}  worst {o['max_mm']:.2f} -> {n['max_mm']:.2f}  frames worse by >0.1: {[(i, round(x,2)) for i,x in enumerate(d) if x > 0.1]}")
a, b = np.array(a), np.array(b)
print(len(a), 'median', np.median(a).round(3), '->', np.median(b).round(3), 'better', (b < a - 0.005).sum(), 'worse', (b > a + 0.005).sum(), '>0.6', (a > 0.6).sum(), '->', (b > 0.6).sum())
