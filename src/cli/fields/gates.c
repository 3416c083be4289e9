/* Amplitude gates of a breathing surrogate, as a gated reconstruction bins
 * its counts (python/petblur/fields.py's amplitude_gates, the same rule):
 * gate g is every interval of [t0, t1] where the signal, linear between its
 * samples, lies in [edges[g], edges[g+1]) (the last gate closed). Pure: no
 * I/O, no allocation. */
#include <float.h>
#include <math.h>
#include <stddef.h>

#include "fields.h"

/* The signal at time t inside [t[0], t[n-1]], linear between samples; *j is a
 * search hint that only moves forward. */
static double signal_at(const double *t, const double *s, size_t n, double x, size_t *j)
{
    while (*j + 2 < n && t[*j + 1] <= x)
        (*j)++;
    double a = (x - t[*j]) / (t[*j + 1] - t[*j]);
    return s[*j] + a * (s[*j + 1] - s[*j]);
}

size_t pbc_amplitude_gates(const double *t, const double *s, size_t n, const double *edges, size_t gates, double t0,
                           double t1, double *intervals, size_t *counts)
{
    size_t total = 0;
    for (size_t g = 0; g < gates; g++) {
        double lo = edges[g], hi = edges[g + 1];
        size_t j = 0, k = 0, here = 0;
        /* The pieces [a, b]: the signal's samples inside the span, cut at its ends. */
        double a = t0, sa = signal_at(t, s, n, t0, &j), last_end = 0.0;
        while (k < n && t[k] <= t0)
            k++;
        while (a < t1) {
            double b = k < n && t[k] < t1 ? t[k] : t1;
            double sb = signal_at(t, s, n, b, &j);
            double p, q;
            if (sa == sb) { /* the top gate is closed: a plateau at its top edge is in it */
                p = a;
                q = (lo <= sa && sa < hi) || (g + 1 == gates && sa == hi) ? b : a;
            } else { /* where s crosses lo and hi in the piece */
                double ta = a + (lo - sa) / (sb - sa) * (b - a), tb = a + (hi - sa) / (sb - sa) * (b - a);
                p = fmax(a, fmin(ta, tb));
                q = fmin(b, fmax(ta, tb));
            }
            if (q > p) {
                /* Continues the one before where the two meet at a sample, up to the crossing's rounding (a
                 * few ulps of the time and of the piece): a wider join would take a dip outside the gate, of
                 * a millisecond in a belt logged in epoch seconds, for part of it. */
                if (here && fabs(last_end - p) <= 8.0 * DBL_EPSILON * (fabs(p) + (b - a))) {
                    if (intervals)
                        intervals[2 * (total - 1) + 1] = q;
                } else {
                    if (intervals) {
                        intervals[2 * total] = p;
                        intervals[2 * total + 1] = q;
                    }
                    total++;
                    here++;
                }
                last_end = q;
            }
            a = b;
            sa = sb;
            if (k < n && t[k] < t1)
                k++;
        }
        if (counts)
            counts[g] = here;
    }
    return total;
}
