import json,sys,statistics as st
rows=[json.loads(l) for l in open(sys.argv[1])]
b=w=0; worse=[]
for r in sorted(rows,key=lambda r:r['seed']):
    c=r['petblur']['mean_mm']; l=r['variants']['line']['mean_mm']
    cw=r['petblur']['max_mm']; lw=r['variants']['line']['max_mm']
    tag = 'better' if c<l-0.005 else 'worse' if c>l+0.005 else 'same'
    b+=tag=='better'; w+=tag=='worse'
    print(r['seed'], 'inj' if r['from_injection'] else 'late', f"{l:.3f} -> {c:.3f}  worst {lw:.3f} -> {cw:.3f}  oracle {r['frame_means']['mean_mm']:.3f}", tag)
n=len(rows)
print('better',b,'worse',w,'of',n, '| above 0.6:', sum(r['petblur']['mean_mm']>0.6 for r in rows), 'line', sum(r['variants']['line']['mean_mm']>0.6 for r in rows),
  '| from injection', sum(r['from_injection'] for r in rows))
print('largest gain %.3f, median gain %.3f' % (max(r['variants']['line']['mean_mm']-r['petblur']['mean_mm'] for r in rows), st.median(r['variants']['line']['mean_mm']-r['petblur']['mean_mm'] for r in rows)))
