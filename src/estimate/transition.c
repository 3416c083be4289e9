/* A transition across a frame boundary: the head held at one frame's pose
 * until t0, moving steadily to the next frame's pose by t1, held there after
 * (a jerk that starts in one frame and ends in the next; t0 = t1 is a step).
 * Each frame is then a time average of views along the line between the two
 * poses, so its image is a dwell (intra_frame.c) with weights that the
 * transition fixes, and the two frames' residuals for every candidate follow
 * from each frame's normal equations at once. */
#include <math.h>

#include "estimate.h"

/* How far toward the later frame's pose the head is at time t: a steady
 * move from t0 to t1, or smoothstep's s^2 (3 - 2 s) there (the monotone
 * cubic's shape between two held poses, track_curve.c). */
static double toward_later(const pbe_transition *tr, double t)
{
    if (!(tr->t1 > tr->t0))
        return t >= tr->t0 ? 1.0 : 0.0;
    double s = (t - tr->t0) / (tr->t1 - tr->t0);
    s = s < 0.0 ? 0.0 : s > 1.0 ? 1.0 : s;
    return tr->smooth ? s * s * (3.0 - 2.0 * s) : s;
}

void pbe_transition_weights(const pbe_transition *before, const pbe_transition *after, double start, double end,
                            size_t leg, double *w)
{
    const size_t m = 2 * leg - 1, own = leg - 1;
    const double mid = 0.5 * start + 0.5 * end;
    for (size_t i = 0; i < m; i++)
        w[i] = 0.0;
    /* the frame's time in PBE_TRANSITION_SAMPLES equal parts, each at its
     * middle, shared between the two points about it */
    for (int j = 0; j < PBE_TRANSITION_SAMPLES; j++) {
        double t = start + (end - start) * ((double)j + 0.5) / PBE_TRANSITION_SAMPLES, u = (double)own;
        if (t < mid && before)
            u -= (1.0 - toward_later(before, t)) * (double)own;
        else if (t >= mid && after)
            u += toward_later(after, t) * (double)own;
        size_t i = (size_t)u;
        if (i >= m - 1)
            i = m - 2;
        double f = u - (double)i;
        w[i] += (1.0 - f) / PBE_TRANSITION_SAMPLES;
        w[i + 1] += f / PBE_TRANSITION_SAMPLES;
    }
}

double pbe_fit_given(const double *gram, const double *h, double ff, size_t m, const double *w, double *scale)
{
    const size_t k = m + 1;
    double a = 0.0, b = 0.0, p = 0.0;
    for (size_t i = 0; i < m; i++) {
        double gi = 0.0;
        for (size_t j = 0; j < m; j++)
            gi += gram[i * k + j] * w[j];
        a += w[i] * gi;
        b += w[i] * gram[i * k + m];
        p += w[i] * h[i];
    }
    const double c = gram[m * k + m], q = h[m], det = a * c - b * b;
    double explained = c > 0 ? q * q / c : 0.0, s = 0.0;
    if (det > 1e-12 * a * c) {
        s = (p * c - b * q) / det;
        double o = (a * q - b * p) / det;
        explained = s * p + o * q;
    }
    if (scale)
        *scale = s;
    double r = ff - explained;
    return r > 0 ? r : 0.0;
}

double pbe_given_apart(const double *gram, double scale, size_t m, const double *a, const double *b)
{
    const size_t k = m + 1;
    double d2 = 0.0, dw = 0.0;
    for (size_t i = 0; i < m; i++) {
        double gi = 0.0;
        for (size_t j = 0; j < m; j++)
            gi += gram[i * k + j] * (a[j] - b[j]);
        d2 += (a[i] - b[i]) * gi;
        dw += (a[i] - b[i]) * gram[i * k + m];
    }
    /* less the part an offset takes up */
    const double c = gram[m * k + m];
    if (c > 0)
        d2 -= dw * dw / c;
    return d2 > 0 ? scale * scale * d2 : 0.0;
}
