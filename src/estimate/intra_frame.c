/* Motion inside a frame. A frame is the time average of its poses' views of
 * the object, so along a known path from pose s to pose e it is a
 * non-negative mixture of the views at points of the path, each weighted by
 * how long the head dwells there. The weights follow from non-negative least
 * squares, and their order along the path gives the times: a jerk inside a
 * frame is a frame that dwells at both ends. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"

void pbe_nnls(const double *gram, const double *h, size_t n, size_t n_nonneg, double *u)
{
    /* Coordinate descent on 1/2 u'Gu - h'u with the bounds: the problems here
     * are a dozen unknowns, so thousands of sweeps cost nothing. */
    for (size_t j = 0; j < n; j++)
        u[j] = 0.0;
    for (int sweep = 0; sweep < 20000; sweep++) {
        double change = 0.0, size = 0.0;
        for (size_t j = 0; j < n; j++) {
            double d = gram[j * n + j];
            if (!(d > 0))
                continue;
            double r = h[j];
            for (size_t k = 0; k < n; k++)
                r -= gram[j * n + k] * u[k];
            double v = u[j] + r / d;
            if (j < n_nonneg && v < 0)
                v = 0;
            change += fabs(v - u[j]) * sqrt(d);
            size += fabs(v) * sqrt(d);
            u[j] = v;
        }
        if (change <= 1e-12 * size)
            break;
    }
}

pb_status pbe_dwell(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], const pb_pose *s,
                    const pb_pose *e, size_t m, double *u, double *sse)
{
    const size_t n = level->n, k = m + 1; /* the views, and the offset */
    double *gram = calloc(k * k, sizeof(double)), *h = calloc(k, sizeof(double));
    float **views = calloc(m, sizeof(float *));
    pb_status st = gram && h && views ? PB_OK : PB_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; i < m && st == PB_OK; i++) {
        pb_pose p;
        double times[2];
        pb_pose poses[2];
        pb_motion mo;
        pb_pose_interpolate(s, e, (double)i / (double)(m - 1), &p);
        pbe_static_motion(&p, c, times, poses, &mo);
        st = pbe_blur_reference(ctx, level, &mo);
        if (st == PB_OK && !(views[i] = malloc(sizeof(float) * n)))
            st = PB_ERR_OUT_OF_MEMORY;
        if (st == PB_OK)
            memcpy(views[i], level->host[0], sizeof(float) * n);
    }
    if (st == PB_OK) {
        for (size_t v = 0; v < n; v++) {
            double f = (double)frame[v];
            for (size_t i = 0; i < m; i++) {
                double a = (double)views[i][v];
                h[i] += a * f;
                for (size_t j = i; j < m; j++)
                    gram[i * k + j] += a * (double)views[j][v];
                gram[i * k + m] += a;
            }
            h[m] += f;
        }
        gram[m * k + m] = (double)n;
        for (size_t i = 0; i < k; i++)
            for (size_t j = 0; j < i; j++)
                gram[i * k + j] = gram[j * k + i];
        pbe_nnls(gram, h, k, m, u);
        /* the residual summed directly: u'Gu - 2 h'u + f'f cancels badly */
        double r = 0.0;
        for (size_t v = 0; v < n; v++) {
            double model = u[m];
            for (size_t i = 0; i < m; i++)
                model += u[i] * (double)views[i][v];
            r += (model - (double)frame[v]) * (model - (double)frame[v]);
        }
        *sse = r > 0 ? r : 0.0;
    }
    for (size_t i = 0; views && i < m; i++)
        free(views[i]);
    free(views);
    free(gram);
    free(h);
    return st;
}
