/* A transition across a frame boundary (src/estimate/transition.c), on
 * fresh random frames and transitions each run:
 * - the time a frame spends about the points of its two legs adds up to the
 *   frame, and where the head is (the shares' mean point) is the time
 *   average of where the transition puts it, worked out here in closed form:
 *   held, a steady move, a step, or smoothstep's s^2 (3 - 2 s);
 * - a frame held still spends all its time at its own pose, and one whose
 *   transition lies wholly after it (or before) does too;
 * - the residual of a mixture with its weights given, and the distance
 *   between two mixtures' images, from the normal equations, equal those
 *   summed directly over random views and a random frame (least squares of
 *   the scale and offset solved here on the voxels). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "estimate.h"
#include "testlib.h"

enum { LEG = 7, M = 2 * LEG - 1, K = M + 1, CASES = 400, VOXELS = 3000 };

/* The time average over [s, e] of how far toward the later pose the head
 * is: 0 before t0, 1 after t1, between them (t - t0) / (t1 - t0) or its
 * smoothstep; a step where t1 <= t0. Closed forms of each piece. */
static double mean_toward(const pbe_transition *tr, double s, double e)
{
    double sum = 0.0;
    if (!(tr->t1 > tr->t0))
        return fmax(0.0, e - fmax(s, tr->t0)) / (e - s);
    const double a = fmax(s, tr->t0), b = fmin(e, tr->t1), d = tr->t1 - tr->t0;
    if (b > a) {
        /* the integral of the ramp's shape over [a, b], in u = (t - t0) / d */
        const double ua = (a - tr->t0) / d, ub = (b - tr->t0) / d;
        if (tr->smooth)
            sum += d * ((ub * ub * ub - 0.5 * ub * ub * ub * ub) - (ua * ua * ua - 0.5 * ua * ua * ua * ua));
        else
            sum += d * 0.5 * (ub * ub - ua * ua);
    }
    sum += fmax(0.0, e - fmax(s, tr->t1));
    return sum / (e - s);
}

static pbe_transition random_transition(double lo, double hi)
{
    pbe_transition tr;
    tr.t0 = pb_rand_range(lo, hi);
    tr.t1 = pb_rand_uniform() < 0.2 ? tr.t0 : pb_rand_range(tr.t0, hi);
    tr.smooth = pb_rand_uniform() < 0.5;
    return tr;
}

/* Least squares of frame f on scale * (views w) + offset, summed over the voxels: the residual, and the scale. */
static double direct_fit(const double *views, const double *f, const double *w, double *scale)
{
    double x[VOXELS], sxx = 0, sx = 0, sf = 0, sxf = 0, n = VOXELS;
    for (int v = 0; v < VOXELS; v++) {
        x[v] = 0.0;
        for (int i = 0; i < M; i++)
            x[v] += w[i] * views[i * VOXELS + v];
        sxx += x[v] * x[v];
        sx += x[v];
        sf += f[v];
        sxf += x[v] * f[v];
    }
    const double det = sxx * n - sx * sx, s = (sxf * n - sx * sf) / det, o = (sxx * sf - sx * sxf) / det;
    double r = 0.0;
    for (int v = 0; v < VOXELS; v++)
        r += (s * x[v] + o - f[v]) * (s * x[v] + o - f[v]);
    *scale = s;
    return r;
}

int main(void)
{
    pb_test_seed();
    double worst_sum = 0.0, worst_mean = 0.0, worst_held = 0.0;
    for (int c = 0; c < CASES; c++) {
        /* a frame [s, e] between its neighbours' middles */
        const double s = pb_rand_range(0.0, 300.0), e = s + pb_rand_range(2.0, 60.0);
        const double before_mid = s - pb_rand_range(1.0, 30.0), after_mid = e + pb_rand_range(1.0, 30.0);
        const double mid = 0.5 * (s + e);
        pbe_transition before = random_transition(before_mid, mid), after = random_transition(mid, after_mid);
        const int use_before = pb_rand_uniform() < 0.8, use_after = pb_rand_uniform() < 0.8;
        double w[M];
        pbe_transition_weights(use_before ? &before : NULL, use_after ? &after : NULL, s, e, LEG, w);
        double total = 0.0, at = 0.0;
        for (int i = 0; i < M; i++) {
            total += w[i];
            at += w[i] * ((double)i - (LEG - 1)) / (LEG - 1);
        }
        /* where the head is on average: -(1 - toward) before the middle, toward after it, each half's share */
        double expect = 0.0;
        if (use_before)
            expect -= 0.5 * (1.0 - mean_toward(&before, s, mid));
        if (use_after)
            expect += 0.5 * mean_toward(&after, mid, e);
        worst_sum = fmax(worst_sum, fabs(total - 1.0));
        worst_mean = fmax(worst_mean, fabs(at - expect));
        /* held: no transition, or one wholly beyond the frame */
        pbe_transition late = {e + 1.0, e + 5.0, pb_rand_uniform() < 0.5}, early = {s - 5.0, s - 1.0, 0};
        pbe_transition_weights(&early, &late, s, e, LEG, w);
        worst_held = fmax(worst_held, fabs(w[LEG - 1] - 1.0));
    }
    /* the shares are 512 samples' hat weights: the mean point to within a sample's share */
    pb_check(worst_sum < 1e-12, "the shares add up to %.3g off one", worst_sum);
    pb_check(worst_mean < 2.0 / PBE_TRANSITION_SAMPLES, "the shares' mean point %.3g off the time average",
             worst_mean);
    pb_check(worst_held < 1e-12, "a frame held still is %.3g off its own pose's share", worst_held);

    /* the normal equations against the direct sums */
    static double views[M * VOXELS], f[VOXELS];
    double worst_fit = 0.0, worst_apart = 0.0;
    for (int r = 0; r < 20; r++) {
        for (int i = 0; i < M * VOXELS; i++)
            views[i] = pb_rand_range(0.0, 10.0);
        for (int v = 0; v < VOXELS; v++)
            f[v] = pb_rand_range(0.0, 10.0) + 0.3 * views[(r % M) * VOXELS + v];
        double gram[K * K] = {0}, h[K] = {0}, ff = 0.0;
        for (int v = 0; v < VOXELS; v++) {
            double x[K];
            for (int i = 0; i < M; i++)
                x[i] = views[i * VOXELS + v];
            x[M] = 1.0;
            for (int i = 0; i < K; i++) {
                for (int j = 0; j < K; j++)
                    gram[i * K + j] += x[i] * x[j];
                h[i] += x[i] * f[v];
            }
            ff += f[v] * f[v];
        }
        double a[M], b[M], sa = 0.0, sb = 0.0;
        for (int i = 0; i < M; i++) {
            a[i] = pb_rand_uniform();
            b[i] = pb_rand_uniform();
            sa += a[i];
            sb += b[i];
        }
        for (int i = 0; i < M; i++) {
            a[i] /= sa;
            b[i] /= sb;
        }
        double scale, direct_scale;
        const double given = pbe_fit_given(gram, h, ff, M, a, &scale), direct = direct_fit(views, f, a, &direct_scale);
        worst_fit = fmax(worst_fit, fabs(given - direct) / direct);
        /* |scale V (a - b)|^2 less its mean's share, directly */
        double d[VOXELS], mean = 0.0, apart = 0.0;
        for (int v = 0; v < VOXELS; v++) {
            d[v] = 0.0;
            for (int i = 0; i < M; i++)
                d[v] += scale * (a[i] - b[i]) * views[i * VOXELS + v];
            mean += d[v] / VOXELS;
        }
        for (int v = 0; v < VOXELS; v++)
            apart += (d[v] - mean) * (d[v] - mean);
        worst_apart = fmax(worst_apart, fabs(pbe_given_apart(gram, scale, M, a, b) - apart) / apart);
        pb_check(fabs(scale - direct_scale) <= 1e-9 * fabs(direct_scale), "the scale %.12g against %.12g", scale,
                 direct_scale);
    }
    pb_check(worst_fit < 1e-9, "the residual from the normal equations %.3g off the direct sum", worst_fit);
    pb_check(worst_apart < 1e-9, "the mixtures' distance %.3g off the direct sum", worst_apart);
    printf("shares: sum %.2g, mean point %.2g, held %.2g; fit %.2g, apart %.2g\n", worst_sum, worst_mean, worst_held,
           worst_fit, worst_apart);
    return pb_test_finish();
}
