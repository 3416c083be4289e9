p='src/estimate/contrast_poses.c'
s=open(p).read()
# per-frame energy beyond after energy_beyond computes eigen of gram
old='''    for (size_t c = 0, count = pbe_leading(cv->w, m, cv->rank, lead); c < count; c++)
        top += cv->w[lead[c]];
    return trace - top;'''
new='''    size_t nl = pbe_leading(cv->w, m, cv->rank, lead);
    for (size_t c = 0; c < nl; c++)
        top += cv->w[lead[c]];
    if (cv->trace_out)
        for (size_t k = 0; k < m; k++) {
            double in = 0.0;
            for (size_t c = 0; c < nl; c++)
                in += cv->w[lead[c]] * cv->v[k * m + lead[c]] * cv->v[k * m + lead[c]];
            cv->trace_out[k] = cv->gram[k * m + k] - in;
        }
    return trace - top;'''
assert old in s; s=s.replace(old,new,1)
old='''    void *tick_user;
} collective;'''
new='''    void *tick_user;
    double *trace_out;
} collective;'''
assert old in s; s=s.replace(old,new,1)
old='''    if (st == PB_OK && contrast_weights(&cv, ref) && (st = minimise(&cv, p, e0)) == PB_OK &&'''
new='''    double tr0[MAX_SUM_FRAMES], tr1[MAX_SUM_FRAMES];
    int traced = getenv("PETBLUR_TRACE4") != NULL, cw = 0;
    if (traced && st == PB_OK) { double z[NG] = {0}, e; cv.trace_out = tr0; residual(&cv, z, &e); cv.trace_out = NULL; }
    if (st == PB_OK && (cw = contrast_weights(&cv, ref)) && (st = minimise(&cv, p, e0)) == PB_OK && traced) {
        double e; cv.trace_out = tr1; residual(&cv, p, &e); cv.trace_out = NULL;
        fprintf(stderr, "TRACE4 p %.3f %.3f %.3f %.3f %.3f %.3f e0 %.6g e1 %.6g\\n", p[0], p[1], p[2], p[3], p[4], p[5], e0, e);
        for (size_t i = 0; i < m; i++)
            fprintf(stderr, "TRACE4 frame %zu w %.3f r0 %.6g r1 %.6g\\n", cv.use[i], cv.weight[cv.use[i]], tr0[i], tr1[i]);
    }
    if (traced && !cw) fprintf(stderr, "TRACE4 no contrast\\n");
    if (st == PB_OK && cw &&'''
assert old in s; s=s.replace(old,new,1)
s=s.replace('#include <math.h>\n','#include <math.h>\n#include <stdio.h>\n',1)
open(p,'w').write(s)
