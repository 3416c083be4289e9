import json, sys, numpy as np
for f in sys.argv[1:]:
    r=[json.loads(l) for l in open(f)]
    rms=np.array([x["rms"] for x in r]); mx=np.array([x["max"] for x in r]); sg=np.array([x["segs"] for x in r])
    print(f, len(r), "rms med/99/max %.3f %.3f %.3f"%(np.median(rms),np.percentile(rms,99),rms.max()), "max med/max %.3f %.3f"%(np.median(mx),mx.max()),
      ">0.3:",(rms>0.3).sum(), ">0.35:",(rms>0.35).sum(), ">1max:",(mx>1).sum(), "segs mean/med/max %.1f %d %d"%(sg.mean(),np.median(sg),sg.max()))
    w=np.argsort(rms)[-3:]; print("  worst", [(r[i]["seed"],r[i]["rms"],r[i]["max"],r[i]["segs"]) for i in w])
