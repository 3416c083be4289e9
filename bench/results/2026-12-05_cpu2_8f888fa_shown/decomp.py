import json,sys,collections
import numpy as np
rows=collections.defaultdict(list)
for l in open(sys.argv[1]):
    f=json.loads(l); rows[f['seed']].append(f)
tot=collections.Counter(); 
print("seed  n | still: pb | unshown<1%: pb floor | shown 1-3%: pb floor n | shown>=3%: pb floor n")
agg=[]
for s,fr in rows.items():
    n=len(fr)
    still=[f for f in fr if f['held_mean_pose_mm']<0.05]
    mov=[f for f in fr if f['held_mean_pose_mm']>=0.05]
    a=[f for f in mov if f['shown_percent']<1]; b=[f for f in mov if 1<=f['shown_percent']<3]; c=[f for f in mov if f['shown_percent']>=3]
    S=lambda L,k: sum(f[k] for f in L)/n
    r=(s, n, S(still,'petblur_mm'), S(a,'petblur_mm'), S(a,'best_mean_poses_mm'), S(b,'petblur_mm'), S(b,'best_mean_poses_mm'), len(b), S(c,'petblur_mm'), S(c,'best_mean_poses_mm'), len(c))
    agg.append(r)
    print("%d %2d | %.3f | %.3f %.3f | %.3f %.3f %d | %.3f %.3f %d"%r)
A=np.array([r[2:] for r in agg]); print('median', ' '.join('%.3f'%x for x in np.median(A,0))); print('mean  ', ' '.join('%.3f'%x for x in A.mean(0)))
# frames shown>=1% : list petblur vs best, moving flag
print('frames shown >=1%:')
for s,fr in rows.items():
    for f in fr:
        if f['shown_percent']>=1 and f['held_mean_pose_mm']>=0.05:
            print(s, f['frame'], '%.1f-%.1f'%(f['t0'],f['t1']), 'shown %.2f%%'%f['shown_percent'], 'held %.3f curved %.3f pb %.3f'%(f['held_mean_pose_mm'],f['curved_mean_poses_mm'],f['petblur_mm']), 'moving' if f['petblur_moving'] else '')
print('frames moving but shown<1%:')
for s,fr in rows.items():
    for f in fr:
        if f['shown_percent']<1 and f['petblur_moving']:
            print(s, f['frame'], '%.1f-%.1f'%(f['t0'],f['t1']), 'shown %.3f%%'%f['shown_percent'], 'held %.3f curved %.3f pb %.3f'%(f['held_mean_pose_mm'],f['curved_mean_poses_mm'],f['petblur_mm']))
