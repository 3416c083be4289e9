# python3 compare.py RUN.jsonl ...: each run against the default of ../2026-11-30_cpu2_noise-tails on the same seeds (from the repository root).
import json,sys,numpy as np
base={}
for k in ("still","drift-20hz","nod","seizure"):
    for l in open(f"bench/results/2026-11-30_cpu2_noise-tails/{k}.jsonl"):
        d=json.loads(l); base[(k,d["seed"])]=d
for f in sys.argv[1:]:
    rows=[json.loads(l) for l in open(f)]
    if not rows: continue
    k=rows[0]["kind"]
    b=np.array([base[(k,r["seed"])]["rms"] for r in rows]); a=np.array([r["rms"] for r in rows])
    bm=np.array([base[(k,r["seed"])]["max"] for r in rows]); am=np.array([r["max"] for r in rows])
    bs=np.array([base[(k,r["seed"])]["segs"] for r in rows]); as_=np.array([r["segs"] for r in rows])
    print(f"{f}: n={len(rows)} rms med {np.median(b):.3f}->{np.median(a):.3f} worst {b.max():.3f}->{a.max():.3f} | max med {np.median(bm):.3f}->{np.median(am):.3f} worst {bm.max():.3f}->{am.max():.3f} | better {np.sum(a<b-0.01)} worse {np.sum(a>b+0.01)} | segs {bs.mean():.1f}->{as_.mean():.1f}")
