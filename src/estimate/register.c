/* One frame registered rigidly to a reference: Levenberg-Marquardt on the
 * pose, the residual f - (a B(T) x + b) with a and b refitted at every step
 * (the least-squares form of normalised cross-correlation, which tolerates
 * tracer uptake that changes from frame to frame), each voxel weighed by the
 * blur of the reference's support at the fit's starting pose: where its view
 * reads beyond the reference's grid, the grid cut the object and the zeros
 * there are not the object's (a body, or a head at the axial field's edge,
 * moves activity in across the faces). The weights are held through the fit
 * (weights that followed the trial pose would let it lower the residual by
 * moving the voxels it fits worst out of them); the steps are taken on the
 * weighted residual's share of the frame's weighted variance. The Jacobian
 * comes from the view's own differences (view_jacobian.c), so a step is one
 * blur on the device (the weights one a fit) and a pass over the voxels
 * here, on the estimate's threads. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"

static const pb_blur_options blur_options = {.method = PB_METHOD_AB, .filter = PB_FILTER_EXACT};

pb_status pbe_level_init(pb_context *ctx, pbe_level *level, const pb_geometry *g, pb_pool *pool)
{
    memset(level, 0, sizeof *level);
    level->g = *g;
    level->n = g->dims[0] * g->dims[1] * g->dims[2];
    level->pool = level->n >= PBE_THREADS_FROM ? pool : NULL;
    for (int i = 0; i < PBE_IMAGES; i++) {
        pb_status st = pb_volume_create(ctx, g, &level->in[i]);
        if (st == PB_OK)
            st = pb_volume_create(ctx, g, &level->out[i]);
        if (st != PB_OK)
            return st;
        if (!(level->host[i] = malloc(sizeof(float) * level->n)))
            return PB_ERR_OUT_OF_MEMORY;
    }
    /* the support: the outer layer off along every axis with room for it */
    float *support = level->box = malloc(sizeof(float) * level->n);
    if (!support)
        return PB_ERR_OUT_OF_MEMORY;
    const size_t nx = g->dims[0], ny = g->dims[1], nz = g->dims[2];
    for (size_t k = 0; k < nz; k++)
        for (size_t j = 0; j < ny; j++)
            for (size_t i = 0; i < nx; i++) {
                const size_t idx[3] = {i, j, k};
                int inside = 1;
                for (int a = 0; a < 3; a++)
                    if (g->dims[a] >= 4 && (idx[a] == 0 || idx[a] + 1 == g->dims[a]))
                        inside = 0;
                support[i + nx * (j + ny * k)] = (float)inside;
            }
    return pbe_level_set_support(level, NULL);
}

pb_status pbe_level_set_support(pbe_level *level, const float *support)
{
    return pb_volume_upload(level->in[PBE_SUPPORT], support ? support : level->box);
}

void pbe_level_free(pbe_level *level)
{
    for (int i = 0; i < PBE_IMAGES; i++) {
        pb_volume_destroy(level->in[i]);
        pb_volume_destroy(level->out[i]);
        free(level->host[i]);
    }
    free(level->views);
    free(level->box);
    memset(level, 0, sizeof *level);
}

pb_status pbe_level_set_reference(pbe_level *level, const float *x)
{
    pb_status st = pb_volume_upload(level->in[0], x);
    return st == PB_OK ? pbe_level_set_support(level, NULL) : st;
}

void pbe_static_motion(const pb_pose *pose, const double c[3], double times[2], pb_pose poses[2], pb_motion *m)
{
    times[0] = 0.0;
    times[1] = 1.0;
    poses[0] = poses[1] = *pose;
    memset(m, 0, sizeof *m);
    m->times = times;
    m->poses = poses;
    m->count = 2;
    m->frame_start = 0.0;
    m->frame_end = 1.0;
    m->has_center = 1;
    memcpy(m->center, c, sizeof m->center);
}

/* Images [first, end) of the level blurred under m and downloaded. */
static pb_status blur_images(pb_context *ctx, pbe_level *level, const pb_motion *m, int first, int end)
{
    for (int i = first; i < end; i++) {
        pb_status st = pb_blur(ctx, level->in[i], m, &blur_options, level->out[i]);
        if (st == PB_OK)
            st = pb_volume_download(level->out[i], level->host[i]);
        if (st != PB_OK)
            return st;
    }
    return PB_OK;
}

pb_status pbe_blur_reference_to(pb_context *ctx, pbe_level *level, const pb_motion *m, float *out)
{
    pb_status st = pb_blur(ctx, level->in[0], m, &blur_options, level->out[0]);
    return st == PB_OK ? pb_volume_download(level->out[0], out) : st;
}

pb_status pbe_blur_reference(pb_context *ctx, pbe_level *level, const pb_motion *m)
{
    return pbe_blur_reference_to(ctx, level, m, level->host[0]);
}

pb_status pbe_blur_support(pb_context *ctx, pbe_level *level, const pb_motion *m)
{
    return blur_images(ctx, level, m, PBE_SUPPORT, PBE_SUPPORT + 1);
}

float *pbe_level_views(pbe_level *level, size_t m)
{
    if (level->views_held < m) {
        float *more = realloc(level->views, sizeof(float) * level->n * m);
        if (!more)
            return NULL;
        level->views = more;
        level->views_held = m;
    }
    return level->views;
}

typedef struct scale_job {
    const float *a, *f, *w;
} scale_job;

static void scale_sums(void *arg, size_t begin, size_t end, double *s)
{
    const scale_job *j = arg;
    for (size_t i = begin; i < end; i++) {
        double x = (double)j->a[i], y = (double)j->f[i];
        s[0] += x;
        s[1] += y;
        s[2] += x * x;
        s[3] += x * y;
        s[4] += y * y;
    }
}

enum { NP = 8, NORMAL_SUMS = NP * (NP + 1) / 2 + NP };

/* The weighted sums of a and f (W, a, f, aa, af, ff), then the plain ones
 * (a, f, aa, af, ff). */
enum { WEIGHTED_SUMS = 11 };

static void weighted_scale_sums(void *arg, size_t begin, size_t end, double *s)
{
    const scale_job *j = arg;
    for (size_t i = begin; i < end; i++) {
        double x = (double)j->a[i], y = (double)j->f[i], w = (double)j->w[i];
        s[0] += w;
        s[1] += w * x;
        s[2] += w * y;
        s[3] += w * x * x;
        s[4] += w * x * y;
        s[5] += w * y * y;
        s[6] += x;
        s[7] += y;
        s[8] += x * x;
        s[9] += x * y;
        s[10] += y * y;
    }
}

/* The weighted least squares of f on [a, 1] (weights w): the scale, offset,
 * the weighted residual's share of f's weighted variance (infinite where the
 * weights hold no variance of f or of a), the weights' sum and the residual
 * over every voxel. */
typedef struct weighted_fit {
    double scale, offset, share, weight, sse_w, sse;
} weighted_fit;

static weighted_fit fit_scale_weighted(pb_pool *pool, const float *a, const float *f, const float *w, size_t n)
{
    scale_job j = {a, f, w};
    double s[WEIGHTED_SUMS];
    pb_pool_sums(pool, n, WEIGHTED_SUMS, weighted_scale_sums, &j, s);
    weighted_fit out = {0.0, 0.0, (double)INFINITY, s[0], (double)INFINITY, (double)INFINITY};
    const double W = s[0];
    if (!(W > (double)NP))
        return out;
    const double ma = s[1] / W, mf = s[2] / W;
    const double var = s[3] - W * ma * ma, cov = s[4] - W * ma * mf, spread = s[5] - W * mf * mf;
    if (!(var > 0.0) || !(spread > 0.0))
        return out;
    const double a_ = cov / var, b_ = mf - a_ * ma, rest = spread - a_ * cov;
    out.scale = a_;
    out.offset = b_;
    out.sse_w = rest > 0 ? rest : 0.0;
    out.share = out.sse_w / spread;
    const double N = (double)n;
    const double plain = s[10] - 2.0 * a_ * s[9] - 2.0 * b_ * s[7] + a_ * a_ * s[8] + 2.0 * a_ * b_ * s[6] + b_ * b_ * N;
    out.sse = plain > 0 ? plain : 0.0;
    return out;
}

double pbe_weighted_sse(pb_pool *pool, const float *a, const float *f, const float *w, size_t n)
{
    return fit_scale_weighted(pool, a, f, w, n).sse_w;
}

void pbe_fit_scale(pb_pool *pool, const float *a, const float *f, size_t n, double *scale, double *offset,
                   double *sse)
{
    scale_job j = {a, f, NULL};
    double s[5];
    pb_pool_sums(pool, n, 5, scale_sums, &j, s);
    const double sa = s[0], sf = s[1], saa = s[2], saf = s[3], sff = s[4];
    double N = (double)n, var = saa - sa * sa / N, cov = saf - sa * sf / N;
    double sc = var > 0 ? cov / var : 0.0;
    *scale = sc;
    *offset = (sf - sc * sa) / N;
    /* |f - s a - b|^2 at the optimum: the variance of f not explained by a */
    double rest = (sff - sf * sf / N) - sc * cov;
    *sse = rest > 0 ? rest : 0.0;
}

int pbe_solve(double *a, double *b, int n, double *x)
{
    for (int c = 0; c < n; c++) {
        int p = c;
        for (int r = c + 1; r < n; r++)
            if (fabs(a[r * n + c]) > fabs(a[p * n + c]))
                p = r;
        if (!(fabs(a[p * n + c]) > 0))
            return 0;
        if (p != c) {
            for (int k = 0; k < n; k++) {
                double t = a[c * n + k];
                a[c * n + k] = a[p * n + k];
                a[p * n + k] = t;
            }
            double t = b[c];
            b[c] = b[p];
            b[p] = t;
        }
        for (int r = c + 1; r < n; r++) {
            double f = a[r * n + c] / a[c * n + c];
            for (int k = c; k < n; k++)
                a[r * n + k] -= f * a[c * n + k];
            b[r] -= f * b[c];
        }
    }
    for (int r = n - 1; r >= 0; r--) {
        double s = b[r];
        for (int k = r + 1; k < n; k++)
            s -= a[r * n + k] * x[k];
        x[r] = s / a[r * n + r];
    }
    return 1;
}

/* The normal equations' sums at scale a and offset b: A's upper triangle
 * row by row, then g. */
typedef struct normal_job {
    const float *const *h;
    const float *frame;
    const pbe_view_jacobian *jac;
    double a, b;
} normal_job;

/* The weighted normal equations: h[PBE_SUPPORT] holds the weights. */

static void normal_sums(void *arg, size_t begin, size_t end, double *s)
{
    const normal_job *j = arg;
    const float *const *h = j->h;
    for (size_t i = begin; i < end; i++) {
        const double w = (double)h[PBE_SUPPORT][i];
        if (!(w > 0.0))
            continue;
        double J[NP];
        pbe_view_jacobian_at(j->jac, i, J);
        for (int k = 0; k < 6; k++)
            J[k] *= j->a;
        J[6] = (double)h[0][i];
        J[7] = 1.0;
        double r = j->a * (double)h[0][i] + j->b - (double)j->frame[i];
        double *up = s;
        for (int p = 0; p < NP; p++)
            for (int q = p; q < NP; q++)
                *up++ += w * J[p] * J[q];
        for (int p = 0; p < NP; p++)
            up[p] += w * J[p] * r;
    }
}

/* The pose's information from the normal equations A (NP x NP, the last two
 * rows scale and offset) at the fit's end: the Schur complement of the scale
 * and offset, over the residual's variance sse / (weight - NP), sse and A
 * weighted alike. Zero where A was never set or the residual is zero. */
static void information(const double *A, double sse, double weight, double *info)
{
    memset(info, 0, sizeof(double) * 36);
    const double a = A[6 * NP + 6], b = A[6 * NP + 7], d = A[7 * NP + 7], det = a * d - b * b;
    if (!(sse > 0.0) || !(weight > (double)NP) || !(det > 0.0) || !isfinite(sse))
        return;
    const double var = sse / (weight - (double)NP);
    for (int p = 0; p < 6; p++)
        for (int q = 0; q < 6; q++) {
            const double up = A[p * NP + 6], vp = A[p * NP + 7], uq = A[q * NP + 6], vq = A[q * NP + 7];
            const double schur = A[p * NP + q] - (up * (d * uq - b * vq) + vp * (a * vq - b * uq)) / det;
            info[p * 6 + q] = schur / var;
        }
}

pb_status pbe_register(pb_context *ctx, pbe_level *level, const float *frame, const double c[3],
                       unsigned iterations, pbe_fit *fit)
{
    const size_t n = level->n;
    double lambda = 1e-3;
    weighted_fit best = {1.0, 0.0, (double)INFINITY, 0.0, (double)INFINITY, (double)INFINITY};
    double best_a[NP * NP] = {0}, best_g[NP] = {0};
    pb_pose best_pose = fit->pose, trial = fit->pose;
    double times[2];
    pb_pose poses[2];
    pb_motion m;
    fit->iterations = 0;
    /* the weights at the starting pose, kept: weights that followed the
     * trial pose would let a pose lower the residual by moving the voxels it
     * fits worst out of the support */
    pbe_static_motion(&trial, c, times, poses, &m);
    pb_status first = pbe_blur_support(ctx, level, &m);
    if (first != PB_OK)
        return first;
    for (unsigned it = 0; it <= iterations; it++) {
        pbe_static_motion(&trial, c, times, poses, &m);
        pb_status st = blur_images(ctx, level, &m, 0, 1);
        if (st != PB_OK)
            return st;
        weighted_fit now = fit_scale_weighted(level->pool, level->host[0], frame, level->host[PBE_SUPPORT], n);
        if (now.share < best.share) {
            /* accepted: the normal equations at this pose */
            double A[NP * NP], g[NP], sums[NORMAL_SUMS];
            pbe_view_jacobian jac;
            pbe_view_jacobian_init(&jac, &level->g, level->host[0], &trial, c);
            normal_job job = {(const float *const *)level->host, frame, &jac, now.scale, now.offset};
            pb_pool_sums(level->pool, n, NORMAL_SUMS, normal_sums, &job, sums);
            const double *up = sums;
            for (int p = 0; p < NP; p++)
                for (int q = p; q < NP; q++)
                    A[p * NP + q] = A[q * NP + p] = *up++;
            memcpy(g, up, sizeof g);
            double gain = best.share - now.share;
            best = now;
            best_pose = trial;
            memcpy(best_a, A, sizeof A);
            memcpy(best_g, g, sizeof g);
            lambda = fmax(lambda / 3.0, 1e-7);
            if (it > 0 && gain < 1e-7 * now.share)
                break;
        } else {
            lambda *= 8.0;
            if (lambda > 1e6)
                break;
        }
        if (it == iterations)
            break;
        /* A singular or overflowing system ends the fit at the best pose so far
         * (checked here: a refusal of pb_pose_perturb would write an error text);
         * a step beyond the grid (pbe_within_grid) is damped as one that fits worse. */
        double step[NP];
        int solved = 0;
        for (; lambda <= 1e6; lambda *= 8.0) {
            double A[NP * NP], g[NP];
            memcpy(A, best_a, sizeof A);
            for (int p = 0; p < NP; p++) {
                A[p * NP + p] *= 1.0 + lambda;
                g[p] = -best_g[p];
            }
            if (!pbe_solve(A, g, NP, step) || !pb_all_finite(step, 6))
                break;
            pb_pose_perturb(&best_pose, step, &trial);
            if ((solved = pbe_within_grid(&level->g, c, &fit->pose, &trial)))
                break;
        }
        if (!solved)
            break;
        fit->iterations = it + 1;
        double move = sqrt(step[0] * step[0] + step[1] * step[1] + step[2] * step[2]);
        double turn = sqrt(step[3] * step[3] + step[4] * step[4] + step[5] * step[5]);
        if (move < 1e-3 && turn < 1e-5) {
            best_pose = trial;
            break;
        }
    }
    fit->pose = best_pose;
    fit->scale = best.scale;
    fit->offset = best.offset;
    fit->sse = best.sse;
    information(best_a, best.sse_w, best.weight, fit->information);
    return PB_OK;
}
