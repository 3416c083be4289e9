/* The still frames' poses seen together in time. Each frame's registration
 * sights the head with its own noise: a frame of the first minutes, of few
 * counts or blood-dominated, by millimetres, a late one by hundredths. A
 * head that moves slowly is where its neighbours say it is, weighed by how
 * well each sees it, and a head that jumps is not. So the poses are taken as
 * a random walk seen through each fit's information (J^T J over the
 * residual's variance, register.c), smoothed by Kalman's filter and
 * Rauch-Tung-Striebel's pass back; the walk's rate and the fits' noise
 * scale are those under which the sightings are likeliest (the least scale
 * among the nearly likeliest, so a series of sharp frames keeps its drift).
 * A sighting farther from the walk than noise goes (a jerk between frames,
 * or a frame that holds one) starts the walk anew there. The poses live on a
 * chart about the base frame's pose, x = log(P_base^-1 P_k) (pbe_chart()), the
 * walk's shifts over the radius r and its turns in radians. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"

enum { D = 6 };

/* chi-square of six degrees of freedom at 1e-3: a sighting this far from
 * the walk is not the walk's */
#define JUMP_CHI2 22.46
/* The walk runs in units of the radius r: shifts over r, turns in radians,
 * so that a series on a grid of twice the voxel size smooths the same way.
 * Jumps between frames: one step in JUMP_SHARE, spread over JUMP_SHIFT (of
 * r) and JUMP_TURN (radians) a component. */
#define JUMP_SHARE 0.1
#define JUMP_SHIFT 0.05
#define JUMP_TURN 0.1
/* the rates tried, r^2/s: from a head held still to faster than frames of a
 * second can follow */
#define RATE_LOW 1e-10
#define RATE_HIGH 1e-1
#define RATE_STEPS 55
/* The fits' own spread scaled by 1 to 20 (their residuals are not white), in
 * steps of 10^0.05. On issue 47's family the sightings chose 1 to 14
 * (bench/results/2026-11-30_H200_8b318f4_smooth-scale); a head that moves to
 * and fro between frames looks to a random walk like noise, and a scale of
 * 63 moved frames fitted to 5 um by 0.9 mm (docs/estimate-log.md). */
#define NOISE_STEP 0.05 /* decades of the noise's spread */
#define NOISE_STEPS 27 /* to 10^1.3 */
/* PETBLUR_ESTIMATE_SMOOTH=wide: to 1000, as before, for comparisons */
#define NOISE_STEPS_WIDE 61
/* log-likelihood units: chi-square of two degrees of freedom at 0.95, halved */
#define LIKELIHOOD_SPAN 3.0

/* Cholesky factor of a symmetric positive definite D x D matrix (lower, in
 * place); 0 where it is not. */
static int cholesky(double *a)
{
    for (int j = 0; j < D; j++) {
        double s = a[j * D + j];
        for (int k = 0; k < j; k++)
            s -= a[j * D + k] * a[j * D + k];
        if (!(s > 0.0) || !isfinite(s))
            return 0;
        a[j * D + j] = sqrt(s);
        for (int i = j + 1; i < D; i++) {
            double v = a[i * D + j];
            for (int k = 0; k < j; k++)
                v -= a[i * D + k] * a[j * D + k];
            a[i * D + j] = v / a[j * D + j];
        }
    }
    return 1;
}

/* x = A^-1 b from A's Cholesky factor l. */
static void cholesky_solve(const double *l, double *x)
{
    for (int i = 0; i < D; i++) {
        for (int k = 0; k < i; k++)
            x[i] -= l[i * D + k] * x[k];
        x[i] /= l[i * D + i];
    }
    for (int i = D; i-- > 0;) {
        for (int k = i + 1; k < D; k++)
            x[i] -= l[k * D + i] * x[k];
        x[i] /= l[i * D + i];
    }
}

/* inverse of a symmetric positive definite matrix; 0 where it is not */
static int spd_inverse(const double *a, double *inv, double *logdet)
{
    double l[D * D];
    memcpy(l, a, sizeof l);
    if (!cholesky(l))
        return 0;
    if (logdet) {
        *logdet = 0.0;
        for (int i = 0; i < D; i++)
            *logdet += 2.0 * log(l[i * D + i]);
    }
    for (int j = 0; j < D; j++) {
        double col[D] = {0};
        col[j] = 1.0;
        cholesky_solve(l, col);
        for (int i = 0; i < D; i++)
            inv[i * D + j] = col[i];
    }
    for (int i = 0; i < D; i++) /* symmetric to rounding */
        for (int j = 0; j < i; j++)
            inv[i * D + j] = inv[j * D + i] = 0.5 * (inv[i * D + j] + inv[j * D + i]);
    return 1;
}

/* The grid's rate i and squared noise scale j. */
static double rate(int i)
{
    return RATE_LOW * pow(RATE_HIGH / RATE_LOW, (double)i / (RATE_STEPS - 1));
}

static double noise_scale2(int j)
{
    return pow(10.0, 2.0 * NOISE_STEP * j);
}

static int noise_steps(void)
{
    const char *env = getenv("PETBLUR_ESTIMATE_SMOOTH");
    return env && strcmp(env, "wide") == 0 ? NOISE_STEPS_WIDE : NOISE_STEPS;
}

static void mat_mul(const double *a, const double *b, double *o)
{
    for (int i = 0; i < D; i++)
        for (int j = 0; j < D; j++) {
            double s = 0.0;
            for (int k = 0; k < D; k++)
                s += a[i * D + k] * b[k * D + j];
            o[i * D + j] = s;
        }
}

/* x = log(P_base^-1 P): the translation and rotation vector of H = P_base^-1
 * P. On this chart a step of the head (P' = P g^-1, pb_pose_perturb's) moves
 * x's translation by g's turned by H's rotation, whatever H's translation,
 * and its rotation vector by g's to first order (for the few degrees a head
 * turns, within a few per cent), so that a random walk of the head is about
 * one of x. rot: H's rotation matrix. */
void pbe_chart(const pb_pose *p, const pb_pose *base, double x[6], double rot[9])
{
    pb_pose inv, h;
    pb_pose_invert(base, &inv);
    pb_pose_compose(&inv, p, &h);
    pb_pose_normalized(&h, &h);
    double w = h.rotation[0], v[3] = {h.rotation[1], h.rotation[2], h.rotation[3]};
    if (w < 0.0) { /* the shorter way round */
        w = -w;
        for (int i = 0; i < 3; i++)
            v[i] = -v[i];
    }
    double s = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    double f = s > 1e-12 ? 2.0 * atan2(s, w) / s : 2.0;
    for (int i = 0; i < 3; i++) {
        x[i] = h.translation[i];
        x[3 + i] = f * v[i];
    }
    if (rot)
        pb_quat_to_matrix(h.rotation, rot);
}

/* P = P_base exp(x), the inverse of pbe_chart */
void pbe_unchart(const double x[6], const pb_pose *base, pb_pose *p)
{
    pb_pose h;
    double angle = sqrt(x[3] * x[3] + x[4] * x[4] + x[5] * x[5]);
    for (int i = 0; i < 3; i++) {
        h.translation[i] = x[i];
        h.rotation[i + 1] = angle > 0.0 ? sin(0.5 * angle) / angle * x[3 + i] : 0.5 * x[3 + i];
    }
    h.rotation[0] = cos(0.5 * angle);
    pb_pose_compose(base, &h, p);
    pb_pose_normalized(p, p);
}

/* A fit's covariance on the chart: its perturbations' turned by H's rotation
 * (the sign of a step does not change a covariance). */
static void turn_covariance(const double *cov, const double r[9], double *out)
{
    double m[D * D] = {0}, mt[D * D] = {0}, t[D * D];
    for (int b = 0; b < 2; b++)
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                m[(3 * b + i) * D + 3 * b + j] = mt[(3 * b + j) * D + 3 * b + i] = r[i * 3 + j];
    mat_mul(m, cov, t);
    mat_mul(t, mt, out);
}

/* One filter pass at rate q (r^2/s): the smoothed
 * chart positions into xs (where used), and the log-likelihood of the
 * sightings, each step a mixture of the walk's and a broad jump's; a step
 * past JUMP_CHI2 restarts the walk. cov_r: each sighting's
 * covariance (count x D x D). */
static double filter_smooth(size_t count, const int *use, const double *t, const double *y, const double *cov_r,
                            double q, double *xf, double *pf, double *pp, int *jump, double *xs)
{
    double ll = 0.0, x[D], p[D * D];
    size_t last = SIZE_MAX;
    for (size_t k = 0; k < count; k++) {
        jump[k] = 0;
        if (!use[k])
            continue;
        const double *yk = y + k * D, *rk = cov_r + k * D * D;
        int restart = last == SIZE_MAX;
        if (!restart) {
            const double dt = fmax(t[k] - t[last], 0.0);
            double pred[D * D], s[D * D], si[D * D], e[D], logdet = 0.0;
            memcpy(pred, p, sizeof pred);
            for (int i = 0; i < D; i++)
                pred[i * D + i] += q * dt;
            for (int i = 0; i < D * D; i++)
                s[i] = pred[i] + rk[i];
            for (int i = 0; i < D; i++)
                e[i] = yk[i] - x[i];
            memcpy(pp + k * D * D, pred, sizeof pred);
            if (!spd_inverse(s, si, &logdet)) {
                restart = 1;
            } else {
                double chi = 0.0;
                for (int i = 0; i < D; i++)
                    for (int j = 0; j < D; j++)
                        chi += e[i] * si[i * D + j] * e[j];
                /* a jump's likelihood: its step as one of a broad spread of
                 * jumps (JUMP_SHIFT, JUMP_TURN), however sure the sightings */
                double jl = 0.0;
                for (int i = 0; i < D; i++) {
                    double v = i < 3 ? JUMP_SHIFT * JUMP_SHIFT : JUMP_TURN * JUMP_TURN;
                    jl -= 0.5 * (e[i] * e[i] / v + log(v));
                }
                jl += log(JUMP_SHARE);
                const double wl = log(1.0 - JUMP_SHARE) - 0.5 * (chi + logdet);
                ll += wl > jl ? wl + log1p(exp(jl - wl)) : jl + log1p(exp(wl - jl));
                if (chi > JUMP_CHI2) {
                    restart = 1;
                } else {
                    double gain[D * D], gp[D * D];
                    mat_mul(pred, si, gain);
                    for (int i = 0; i < D; i++)
                        for (int j = 0; j < D; j++)
                            x[i] += gain[i * D + j] * e[j];
                    mat_mul(gain, pred, gp);
                    for (int i = 0; i < D * D; i++)
                        p[i] = pred[i] - gp[i];
                }
            }
        }
        if (restart) { /* the walk starts anew at this sighting */
            memcpy(x, yk, sizeof x);
            memcpy(p, rk, sizeof p);
            jump[k] = 1;
        }
        memcpy(xf + k * D, x, sizeof x);
        memcpy(pf + k * D * D, p, sizeof p);
        last = k;
    }
    if (!xs)
        return ll;
    /* back: each stretch between jumps, from its end */
    size_t next = SIZE_MAX;
    for (size_t k = count; k-- > 0;) {
        if (!use[k])
            continue;
        if (next == SIZE_MAX || jump[next]) {
            memcpy(xs + k * D, xf + k * D, sizeof(double) * D);
        } else {
            double pi[D * D], c[D * D];
            if (!spd_inverse(pp + next * D * D, pi, NULL)) {
                memcpy(xs + k * D, xf + k * D, sizeof(double) * D);
            } else {
                mat_mul(pf + k * D * D, pi, c);
                for (int i = 0; i < D; i++) {
                    double v = xf[k * D + i];
                    for (int j = 0; j < D; j++)
                        v += c[i * D + j] * (xs[next * D + j] - xf[k * D + j]); /* a walk predicts where it was */
                    xs[k * D + i] = v;
                }
            }
        }
        next = k;
    }
    return ll;
}

double pbe_pose_spread(const pbe_fit *fit, double r)
{
    double cov[D * D];
    if (!spd_inverse(fit->information, cov, NULL))
        return (double)INFINITY;
    double v = 0.0;
    for (int i = 0; i < D; i++)
        v += cov[i * D + i] * (i < 3 ? 1.0 : r * r);
    return isfinite(v) && v >= 0.0 ? v : (double)INFINITY;
}

double pbe_smooth_poses(pbe_fit *fits, const int *skip, const double *t, size_t count, size_t base, double r,
                        int *jumped)
{
    for (size_t k = 0; jumped && k < count; k++)
        jumped[k] = 0;
    if (count < 3 || !(r > 0.0))
        return -1.0;
    const pb_pose origin = fits[base].pose;
    int *use = calloc(count, sizeof(int)), *jump = calloc(count, sizeof(int));
    double *y = malloc(sizeof(double) * count * D), *cov = malloc(sizeof(double) * count * D * D);
    double *xf = malloc(sizeof(double) * count * D), *xs = malloc(sizeof(double) * count * D);
    double *pf = malloc(sizeof(double) * count * D * D), *pp = malloc(sizeof(double) * count * D * D);
    double *scaled = malloc(sizeof(double) * count * D * D);
    double best_q = -1.0;
    if (!use || !jump || !y || !cov || !xf || !xs || !pf || !pp || !scaled) {
        best_q = PBE_SMOOTH_NO_MEMORY;
        goto done;
    }
    size_t used = 0;
    for (size_t k = 0; k < count; k++) {
        double own[D * D], rot[9];
        if (skip[k] || !spd_inverse(fits[k].information, own, NULL))
            continue;
        pbe_chart(&fits[k].pose, &origin, y + k * D, rot);
        if (!pb_all_finite(y + k * D, D))
            continue;
        turn_covariance(own, rot, cov + k * D * D);
        for (int i = 0; i < D; i++) { /* shifts in units of r */
            if (i < 3)
                y[k * D + i] /= r;
            for (int j = 0; j < D; j++)
                cov[k * D * D + i * D + j] /= (i < 3 ? r : 1.0) * (j < 3 ? r : 1.0);
        }
        use[k] = 1;
        used++;
    }
    if (used < 3)
        goto done;
    /* the likelihood on a grid of rates and noise scales; where the steps
     * between frames are much larger than the fits' noise the likelihood
     * hardly tells noise scales apart, and the least of those within
     * LIKELIHOOD_SPAN of the best is taken: smoothing that the sightings
     * do not ask for would move sharp frames towards their neighbours */
    double ll[NOISE_STEPS_WIDE][RATE_STEPS], best_ll = -(double)INFINITY, best_s = 1.0;
    const int steps = noise_steps();
    for (int j = 0; j < steps; j++) {
        for (size_t i = 0; i < count * D * D; i++)
            scaled[i] = noise_scale2(j) * cov[i];
        for (int i = 0; i < RATE_STEPS; i++) {
            ll[j][i] = filter_smooth(count, use, t, y, scaled, rate(i), xf, pf, pp, jump, NULL);
            best_ll = fmax(best_ll, ll[j][i]);
        }
    }
    for (int j = 0; j < steps && !(best_q > 0.0); j++) {
        double top = -(double)INFINITY;
        for (int i = 0; i < RATE_STEPS; i++)
            if (ll[j][i] >= best_ll - LIKELIHOOD_SPAN && ll[j][i] > top) {
                top = ll[j][i];
                best_q = rate(i);
                best_s = noise_scale2(j);
            }
    }
    for (size_t i = 0; i < count * D * D; i++)
        cov[i] *= best_s;
    if (!(best_q > 0.0))
        goto done;
    filter_smooth(count, use, t, y, cov, best_q, xf, pf, pp, jump, xs);
    for (size_t k = 0, seen = 0; jumped && k < count; k++)
        if (use[k])
            jumped[k] = seen++ > 0 && jump[k];
    for (size_t k = 0; k < count; k++) {
        double x[D];
        for (int i = 0; i < D; i++)
            x[i] = xs[k * D + i] * (i < 3 ? r : 1.0);
        if (use[k] && pb_all_finite(x, D))
            pbe_unchart(x, &origin, &fits[k].pose);
    }
done:
    free(scaled);
    free(use);
    free(jump);
    free(y);
    free(cov);
    free(xf);
    free(xs);
    free(pf);
    free(pp);
    return best_q;
}
