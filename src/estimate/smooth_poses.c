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
 * chart about the base frame's pose, x = log(P_base^-1 P_k) (chart()), the
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
static void chart(const pb_pose *p, const pb_pose *base, double *x, double rot[9])
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
    pb_quat_to_matrix(h.rotation, rot);
}

/* P = P_base exp(x), the inverse of chart */
static void unchart(const double *x, const pb_pose *base, pb_pose *p)
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

/* A fit's pose seen as a sighting on the chart about origin, in units of
 * r: its position y and covariance (the inverse of its information, turned
 * onto the chart). 0 where the information is not positive definite. */
static int sighting(const pbe_fit *fit, const pb_pose *pose, const pb_pose *origin, double r, double *y, double *cov)
{
    double own[D * D], rot[9];
    if (!spd_inverse(fit->information, own, NULL))
        return 0;
    chart(pose, origin, y, rot);
    if (!pb_all_finite(y, D))
        return 0;
    turn_covariance(own, rot, cov);
    for (int i = 0; i < D; i++) { /* shifts in units of r */
        if (i < 3)
            y[i] /= r;
        for (int j = 0; j < D; j++)
            cov[i * D + j] /= (i < 3 ? r : 1.0) * (j < 3 ? r : 1.0);
    }
    return 1;
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
        use[k] = !skip[k] && sighting(&fits[k], &fits[k].pose, &origin, r, y + k * D, cov + k * D * D);
        used += (size_t)use[k];
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
            unchart(x, &origin, &fits[k].pose);
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

/* ---- the track's knots, each frame's pose its mean over the frame ------------- */

/* The knots' system is banded: a frame's mean ties three knots together. */
enum { BAND = 3 * D - 1 };
#define AT(a, i, j) ((a)[(i) * (BAND + 1) + (j) + BAND - (i)]) /* lower half, i - BAND <= j <= i */

/* Cholesky factor of an n x n banded matrix (lower half, AT) in place, and
 * its log-determinant; 0 where it is not positive definite. */
static int band_cholesky(double *a, size_t n, double *logdet)
{
    *logdet = 0.0;
    for (size_t i = 0; i < n; i++) {
        const size_t lo = i > BAND ? i - BAND : 0;
        for (size_t j = lo; j <= i; j++) {
            double s = AT(a, i, j);
            for (size_t k = j > BAND && j - BAND > lo ? j - BAND : lo; k < j; k++)
                s -= AT(a, i, k) * AT(a, j, k);
            if (j < i) {
                AT(a, i, j) = s / AT(a, j, j);
            } else {
                if (!(s > 0.0) || !isfinite(s))
                    return 0;
                AT(a, i, i) = sqrt(s);
                *logdet += log(s);
            }
        }
    }
    return 1;
}

/* x = L^-1 x (forward), then, where back, x = L^-T x. */
static void band_solve(const double *l, size_t n, double *x, int back)
{
    for (size_t i = 0; i < n; i++) {
        for (size_t k = i > BAND ? i - BAND : 0; k < i; k++)
            x[i] -= AT(l, i, k) * x[k];
        x[i] /= AT(l, i, i);
    }
    for (size_t i = n; back && i-- > 0;) {
        for (size_t k = i + 1; k < n && k <= i + BAND; k++)
            x[i] -= AT(l, k, i) * x[k];
        x[i] /= AT(l, i, i);
    }
}

/* A run's sightings and the walk's knots between them. */
typedef struct knot_run {
    size_t knots, frames;    /* unknown knots: 2 frames + 1, less a tied end's */
    int tied[2];             /* its start, its end: the knot there is its frame's middle's (a ramp beyond) */
    int *jumped;             /* frame k's start: the walk jumped there (run-relative, 0 unused) */
    double *half;            /* each frame's half length, s */
    int *seen;               /* each frame: sighted */
    double *y, *cov;         /* each frame's sighting on the chart, and its covariance (D x D) */
    double *a, *rhs;         /* D knots rows, banded (AT); D knots */
    double constant;         /* the energy's constant part */
} knot_run;

/* The term |sum_a h_a u_knot[a] - y|^2_W of the knots' energy into their
 * normal equations. */
static void add_term(knot_run *s, const size_t *knot, const double *h, int terms, const double *w, const double *y)
{
    double wy[D];
    for (int i = 0; i < D; i++) {
        wy[i] = 0.0;
        for (int j = 0; j < D; j++)
            wy[i] += w[i * D + j] * y[j];
        s->constant += y[i] * wy[i];
    }
    for (int a = 0; a < terms; a++) {
        const size_t ka = knot[a];
        for (int i = 0; i < D; i++)
            s->rhs[ka * D + (size_t)i] += h[a] * wy[i];
        for (int b = 0; b < terms; b++) {
            const size_t kb = knot[b];
            if (kb > ka)
                continue;
            for (int i = 0; i < D; i++)
                for (int j = 0; j < D && (kb < ka || j <= i); j++)
                    AT(s->a, ka * D + (size_t)i, kb * D + (size_t)j) += h[a] * h[b] * w[i * D + j];
        }
    }
}

/* Where knot j of a run (2 k + 0, 1, 2: frame k's start, middle, end) is
 * among its unknowns: a tied end's is its frame's middle's. */
static size_t slot(const knot_run *s, size_t j)
{
    if (s->tied[0] && j == 0)
        j = 1;
    if (s->tied[1] && j == 2 * s->frames)
        j = 2 * s->frames - 1;
    return j - (size_t)s->tied[0];
}

/* The run's knots at walk rate q and noise scale s2: the likelihood of its
 * sightings (less a constant), and, where x, the knots' chart positions.
 * -HUGE_VAL where the system is not positive definite. */
static double knots_at(knot_run *s, double q, double s2, double *x)
{
    const size_t n = D * s->knots;
    memset(s->a, 0, sizeof(double) * n * (BAND + 1));
    memset(s->rhs, 0, sizeof(double) * n);
    s->constant = 0.0;
    double logdet_prior = 0.0, logdet_noise = 0.0;
    /* the walk between knots half a frame apart; where it jumped into a
     * frame, between the two frames' middles by a step of the spread
     * smoothing allows one (JUMP_SHIFT, JUMP_TURN), the knot at their
     * boundary on the line between them as a bridge of the walk is (free
     * on both sides, knots a half frame apart could swing to and fro about
     * the frames' means) */
    for (size_t j = 0; j + 1 < 2 * s->frames + 1; j++) {
        const size_t frame = j / 2, start = j % 2 ? frame + 1 : frame;
        if (start > 0 && start < s->frames && s->jumped[start]) {
            if (j % 2) /* the middle before: both half frames at once */
                continue;
            const double a = s->half[frame - 1], b = s->half[frame], f = a / (a + b);
            const size_t across[2] = {slot(s, j - 1), slot(s, j + 1)},
                         bridge[3] = {slot(s, j - 1), slot(s, j), slot(s, j + 1)};
            const double h2[2] = {-1.0, 1.0}, h3[3] = {-(1.0 - f), 1.0, -f};
            double wj[D * D] = {0}, wb[D * D] = {0}, zero[D] = {0};
            for (int i = 0; i < D; i++) {
                wj[i * D + i] = 1.0 / (q * (a + b) + (i < 3 ? JUMP_SHIFT * JUMP_SHIFT : JUMP_TURN * JUMP_TURN));
                wb[i * D + i] = 1.0 / (q * a * b / (a + b));
                logdet_prior += log(wj[i * D + i]) + log(wb[i * D + i]);
            }
            if (!pb_all_finite(wj, D * D) || !pb_all_finite(wb, D * D))
                return -HUGE_VAL;
            add_term(s, across, h2, 2, wj, zero);
            add_term(s, bridge, h3, 3, wb, zero);
            continue;
        }
        const size_t ks[2] = {slot(s, j), slot(s, j + 1)};
        if (ks[0] == ks[1])
            continue;
        double w[D * D] = {0}, zero[D] = {0}, h[2] = {-1.0, 1.0};
        for (int i = 0; i < D; i++) {
            w[i * D + i] = 1.0 / (q * s->half[frame]);
            logdet_prior += log(w[i * D + i]);
        }
        if (!pb_all_finite(w, D * D))
            return -HUGE_VAL;
        add_term(s, ks, h, 2, w, zero);
    }
    /* each frame sighted: the track's mean over it, (start + 2 middle + end) / 4 */
    for (size_t k = 0; k < s->frames; k++) {
        double cov[D * D], w[D * D], logdet;
        if (!s->seen[k])
            continue;
        for (int i = 0; i < D * D; i++)
            cov[i] = s2 * s->cov[k * D * D + (size_t)i];
        if (!spd_inverse(cov, w, &logdet))
            continue;
        logdet_noise += logdet;
        const size_t ks[3] = {slot(s, 2 * k), slot(s, 2 * k + 1), slot(s, 2 * k + 2)};
        const double h[3] = {0.25, 0.5, 0.25};
        add_term(s, ks, h, 3, w, s->y + k * D);
    }
    double logdet_a;
    if (!band_cholesky(s->a, n, &logdet_a))
        return -HUGE_VAL;
    if (x) {
        memcpy(x, s->rhs, sizeof(double) * n);
        band_solve(s->a, n, x, 1);
    }
    /* the energy's least, c - b' A^-1 b */
    band_solve(s->a, n, s->rhs, 0);
    double fit = s->constant;
    for (size_t i = 0; i < n; i++)
        fit -= s->rhs[i] * s->rhs[i];
    const double ll = -0.5 * (fit + logdet_a - logdet_prior + logdet_noise);
    return isfinite(ll) ? ll : -HUGE_VAL;
}

/* One run's sightings on the chart about its first, set up for knots_at. */
typedef struct run_setup {
    size_t first, last;
    pb_pose origin;
    knot_run s;
    int ok;
} run_setup;

static void run_free(run_setup *u)
{
    free(u->s.jumped);
    free(u->s.half);
    free(u->s.seen);
    free(u->s.y);
    free(u->s.cov);
    free(u->s.a);
    free(u->s.rhs);
}

static int run_setup_make(run_setup *u, const pbe_fit *fits, const pb_pose *seen, const int *observed,
                          const int *jumped, const unsigned char *ramped, const double *bounds, double r)
{
    const int tied[2] = {ramped[u->first] != 0, ramped[u->last + 1] != 0};
    const size_t frames = u->last - u->first + 1, n = 2 * frames + 1 - (size_t)tied[0] - (size_t)tied[1],
                 unknowns = D * n;
    size_t origin_frame = SIZE_MAX;
    for (size_t k = u->first; k <= u->last && origin_frame == SIZE_MAX; k++)
        if (observed[k])
            origin_frame = k;
    int *use = calloc(frames, sizeof(int)), *jump = calloc(frames, sizeof(int));
    double *half = malloc(sizeof(double) * frames), *y = malloc(sizeof(double) * frames * D);
    double *cov = malloc(sizeof(double) * frames * D * D);
    u->s = (knot_run){n, frames, {tied[0], tied[1]}, jump, half, use, y, cov,
                      calloc(unknowns * (BAND + 1), sizeof(double)), calloc(unknowns, sizeof(double)), 0.0};
    u->ok = 0;
    if (!use || !jump || !half || !y || !cov || !u->s.a || !u->s.rhs)
        return 0;
    if (origin_frame == SIZE_MAX)
        return 1; /* nothing sighted: left as it is */
    u->origin = seen[origin_frame];
    for (size_t k = 0; k < frames; k++) {
        half[k] = 0.5 * (bounds[u->first + k + 1] - bounds[u->first + k]);
        jump[k] = k > 0 && jumped[u->first + k];
        use[k] = observed[u->first + k] && sighting(&fits[u->first + k], &seen[u->first + k], &u->origin, r,
                                                     y + k * D, cov + k * D * D);
        u->ok |= use[k];
    }
    return 1;
}

int pbe_frame_mean_knots(const pbe_fit *fits, const pb_pose *seen, const int *observed, const int *jumped,
                         const unsigned char *ramped, const double *bounds, const size_t *run, size_t count, double r,
                         pb_pose *knots)
{
    if (!(r > 0.0) || count == 0)
        return 0;
    size_t runs = 0;
    for (size_t k = 0; k < count; k++)
        runs += run[k] && (k == 0 || run[k - 1] != run[k]);
    run_setup *u = calloc(runs ? runs : 1, sizeof *u);
    double *x = malloc(sizeof(double) * D * (2 * count + 1));
    int solved = 0, made = u && x;
    for (size_t k = 0, i = 0; made && k < count; k++) {
        if (!run[k] || (k > 0 && run[k - 1] == run[k]))
            continue;
        u[i].first = u[i].last = k;
        while (u[i].last + 1 < count && run[u[i].last + 1] == run[k])
            u[i].last++;
        made = run_setup_make(&u[i++], fits, seen, observed, jumped, ramped, bounds, r);
    }
    if (!made)
        goto done;
    /* the walk and noise scale under which the series' sightings, each the
     * track's mean over its frame, are likeliest, every run together: the
     * least scale among the nearly likeliest, as pbe_smooth_poses chooses
     * (a run of two or three frames alone cannot tell noise from motion) */
    double ll[NOISE_STEPS_WIDE][RATE_STEPS], best_ll = -HUGE_VAL, best_q = -1.0, best_s = 1.0;
    const int steps = noise_steps();
    for (int j = 0; j < steps; j++)
        for (int i = 0; i < RATE_STEPS; i++) {
            ll[j][i] = 0.0;
            for (size_t v = 0; v < runs; v++)
                if (u[v].ok)
                    ll[j][i] += knots_at(&u[v].s, rate(i), noise_scale2(j), NULL);
            best_ll = fmax(best_ll, ll[j][i]);
        }
    for (int j = 0; j < steps && !(best_q > 0.0); j++) {
        double top = -HUGE_VAL;
        for (int i = 0; i < RATE_STEPS; i++)
            if (ll[j][i] > -HUGE_VAL && ll[j][i] >= best_ll - LIKELIHOOD_SPAN && ll[j][i] > top) {
                top = ll[j][i];
                best_q = rate(i);
                best_s = noise_scale2(j);
            }
    }
    if (!(best_q > 0.0) || !(best_ll > -HUGE_VAL))
        goto done;
    for (size_t v = 0; v < runs; v++) {
        if (!u[v].ok)
            continue;
        const size_t n = u[v].s.knots;
        if (knots_at(&u[v].s, best_q, best_s, x) == -HUGE_VAL || !pb_all_finite(x, D * n))
            goto done;
    }
    for (size_t v = 0; v < runs; v++) { /* every run solved: written */
        if (!u[v].ok)
            continue;
        knots_at(&u[v].s, best_q, best_s, x);
        for (size_t k = u[v].first; k <= u[v].last; k++)
            for (size_t i = 0; i < 3; i++) {
                double p[D];
                const size_t j = slot(&u[v].s, 2 * (k - u[v].first) + i);
                for (int c = 0; c < D; c++)
                    p[c] = x[j * D + (size_t)c] * (c < 3 ? r : 1.0);
                unchart(p, &u[v].origin, &knots[3 * k + i]);
            }
    }
    solved = 1;
done:
    for (size_t v = 0; u && v < runs; v++)
        run_free(&u[v]);
    free(u);
    free(x);
    return solved;
}
