/* The track between the still frames' middles. Each still frame's pose is
 * about the head's mean pose over the frame, kept at the frame's middle. A
 * line from middle to middle cuts every turn of a nod short, and a nod of
 * one or two minutes spans frames of 30-60 s. A monotone cubic through the
 * same poses (Fritsch and Carlson's, as scipy's PchipInterpolator) follows
 * the turn and never overshoots the poses about it: a drift stays the line,
 * a pose held on both sides stays flat, and a jump between two middles stays
 * between their poses. On the truth's mean poses of 40 fresh draws of issue
 * 47's family it took the mean error from 0.502 to 0.428 mm (median) and was
 * better on all 40 (docs/estimate-log.md, "The track through the middles").
 * Each run of consecutive middles is curved on one chart about its first
 * pose, component by component; the keys about a run (a step's, a moving
 * frame's, the series' ends) shape the slopes at its ends and stay as they
 * are, with lines to them. A key that holds a frame's pose to a step or to
 * the series' end gives the curve a level end there, which the track then
 * keeps. */
#include <stdlib.h>

#include "estimate.h"

enum { D = 6 };

/* The monotone cubic's slope at the middle of three points: 0 at an
 * extremum, else the weighted harmonic mean of the secants on each side. */
static double slope(double h0, double h1, double s0, double s1)
{
    if (!(s0 * s1 > 0.0))
        return 0.0;
    double w1 = 2.0 * h1 + h0, w2 = h1 + 2.0 * h0;
    return (w1 + w2) / (w1 / s0 + w2 / s1);
}

size_t pbe_curve_keys(const double *t, const pb_pose *p, const unsigned char *middle, size_t n, double *t_out,
                      pb_pose *p_out)
{
    double *x = malloc(sizeof(double) * D * n), *d = malloc(sizeof(double) * D * n);
    size_t out = 0;
    if (!x || !d) {
        free(x);
        free(d);
        return 0;
    }
    for (size_t i = 0; i < n;) {
        if (!(middle[i] && i + 1 < n && middle[i + 1])) {
            t_out[out] = t[i];
            p_out[out++] = p[i];
            i++;
            continue;
        }
        size_t a = i, m = i + 1;
        while (m + 1 < n && middle[m + 1])
            m++;
        /* the run and a key on each side shape the slopes (one always
         * precedes a middle and one follows: the series' ends hold the
         * first and last frames' poses, so the curve meets them flat) */
        size_t lo = a > 0 ? a - 1 : a, hi = m + 1 < n ? m + 1 : m;
        for (size_t k = lo; k <= hi; k++)
            pbe_chart(&p[k], &p[a], x + D * k, NULL);
        for (size_t k = a; k <= m; k++)
            for (int c = 0; c < D; c++) {
                double s0 = k > lo ? (x[D * k + c] - x[D * (k - 1) + c]) / (t[k] - t[k - 1]) : 0.0;
                double s1 = k < hi ? (x[D * (k + 1) + c] - x[D * k + c]) / (t[k + 1] - t[k]) : 0.0;
                d[D * k + c] = k > lo && k < hi ? slope(t[k] - t[k - 1], t[k + 1] - t[k], s0, s1) : 0.0;
            }
        for (size_t k = a; k < m; k++) {
            double h = t[k + 1] - t[k];
            t_out[out] = t[k];
            p_out[out++] = p[k];
            for (int s = 1; s < PBE_CURVE_KEYS; s++) {
                double u = (double)s / PBE_CURVE_KEYS, u2 = u * u, u3 = u2 * u, y[D];
                double h00 = 2.0 * u3 - 3.0 * u2 + 1.0, h10 = u3 - 2.0 * u2 + u, h01 = 3.0 * u2 - 2.0 * u3,
                       h11 = u3 - u2;
                for (int c = 0; c < D; c++)
                    y[c] = h00 * x[D * k + c] + h10 * h * d[D * k + c] + h01 * x[D * (k + 1) + c] +
                           h11 * h * d[D * (k + 1) + c];
                double ts = t[k] + u * h;
                if (!(ts > t_out[out - 1] && ts < t[k + 1]))
                    continue; /* frames too short for the doubles about them */
                t_out[out] = ts;
                pbe_unchart(y, &p[a], &p_out[out++]);
            }
        }
        t_out[out] = t[m];
        p_out[out++] = p[m];
        i = m + 1;
    }
    free(x);
    free(d);
    return out;
}
