/* One frame registered rigidly to a reference: Levenberg-Marquardt on the
 * pose, the residual f - (a B(T) x + b) with a and b refitted at every step
 * (the least-squares form of normalised cross-correlation, which tolerates
 * tracer uptake that changes from frame to frame). The Jacobian comes from
 * the blurs of the reference's derivative images (pbe_pose_gradients), so
 * a step taken is seven blurs on the device (a step refused, one) and a pass
 * over the voxels here, on the estimate's threads. */
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
    for (int i = 0; i < 7; i++) {
        pb_status st = pb_volume_create(ctx, g, &level->in[i]);
        if (st == PB_OK)
            st = pb_volume_create(ctx, g, &level->out[i]);
        if (st != PB_OK)
            return st;
        if (!(level->host[i] = malloc(sizeof(float) * level->n)))
            return PB_ERR_OUT_OF_MEMORY;
    }
    return PB_OK;
}

void pbe_level_free(pbe_level *level)
{
    for (int i = 0; i < 7; i++) {
        pb_volume_destroy(level->in[i]);
        pb_volume_destroy(level->out[i]);
        free(level->host[i]);
    }
    free(level->views);
    memset(level, 0, sizeof *level);
}

pb_status pbe_level_set_reference(pbe_level *level, const float *x, const double c[3], float *scratch)
{
    float *d[6];
    for (int j = 0; j < 6; j++)
        d[j] = scratch + (size_t)j * level->n;
    pbe_pose_gradients(level->pool, &level->g, x, c, d);
    pb_status st = pb_volume_upload(level->in[0], x);
    for (int j = 0; j < 6 && st == PB_OK; j++)
        st = pb_volume_upload(level->in[1 + j], d[j]);
    return st;
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
    const float *a, *f;
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

void pbe_fit_scale(pb_pool *pool, const float *a, const float *f, size_t n, double *scale, double *offset,
                   double *sse)
{
    scale_job j = {a, f};
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

/* Solves the n x n system (row-major a, destroyed) for x by Gaussian
 * elimination with partial pivoting; 0 when singular. */
static int solve(double *a, double *b, int n, double *x)
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

enum { NP = 8, NORMAL_SUMS = NP * (NP + 1) / 2 + NP };

/* The normal equations' sums at scale a and offset b: A's upper triangle
 * row by row, then g. */
typedef struct normal_job {
    const float *const *h;
    const float *frame;
    double a, b;
} normal_job;

static void normal_sums(void *arg, size_t begin, size_t end, double *s)
{
    const normal_job *j = arg;
    const float *const *h = j->h;
    for (size_t i = begin; i < end; i++) {
        double J[NP];
        for (int k = 0; k < 6; k++)
            J[k] = j->a * (double)h[1 + k][i];
        J[6] = (double)h[0][i];
        J[7] = 1.0;
        double r = j->a * (double)h[0][i] + j->b - (double)j->frame[i];
        double *up = s;
        for (int p = 0; p < NP; p++)
            for (int q = p; q < NP; q++)
                *up++ += J[p] * J[q];
        for (int p = 0; p < NP; p++)
            up[p] += J[p] * r;
    }
}

/* The pose's information from the normal equations A (NP x NP, the last two
 * rows scale and offset) at the fit's end: the Schur complement of the scale
 * and offset, over the residual's variance sse / (n - NP). Zero where A was
 * never set or the residual is zero. */
static void information(const double *A, double sse, size_t n, double *info)
{
    memset(info, 0, sizeof(double) * 36);
    const double a = A[6 * NP + 6], b = A[6 * NP + 7], d = A[7 * NP + 7], det = a * d - b * b;
    if (!(sse > 0.0) || n <= NP || !(det > 0.0) || !isfinite(sse))
        return;
    const double var = sse / (double)(n - NP);
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
    double lambda = 1e-3, best_sse = (double)INFINITY;
    double best_a[NP * NP] = {0}, best_g[NP] = {0};
    pb_pose best_pose = fit->pose, trial = fit->pose;
    double best_scale = 1, best_offset = 0;
    double times[2];
    pb_pose poses[2];
    pb_motion m;
    fit->iterations = 0;
    for (unsigned it = 0; it <= iterations; it++) {
        pbe_static_motion(&trial, c, times, poses, &m);
        /* the derivative images only for a step that is taken */
        pb_status st = blur_images(ctx, level, &m, 0, 1);
        if (st != PB_OK)
            return st;
        double a, b, sse;
        pbe_fit_scale(level->pool, level->host[0], frame, n, &a, &b, &sse);
        if (sse < best_sse) {
            /* accepted: the normal equations at this pose */
            if ((st = blur_images(ctx, level, &m, 1, 7)) != PB_OK)
                return st;
            double A[NP * NP], g[NP], sums[NORMAL_SUMS];
            normal_job job = {(const float *const *)level->host, frame, a, b};
            pb_pool_sums(level->pool, n, NORMAL_SUMS, normal_sums, &job, sums);
            const double *up = sums;
            for (int p = 0; p < NP; p++)
                for (int q = p; q < NP; q++)
                    A[p * NP + q] = A[q * NP + p] = *up++;
            memcpy(g, up, sizeof g);
            double gain = best_sse - sse;
            best_sse = sse;
            best_pose = trial;
            best_scale = a;
            best_offset = b;
            memcpy(best_a, A, sizeof A);
            memcpy(best_g, g, sizeof g);
            lambda = fmax(lambda / 3.0, 1e-7);
            if (it > 0 && gain < 1e-7 * sse)
                break;
        } else {
            lambda *= 8.0;
            if (lambda > 1e6)
                break;
        }
        if (it == iterations)
            break;
        double A[NP * NP], g[NP], step[NP];
        memcpy(A, best_a, sizeof A);
        for (int p = 0; p < NP; p++) {
            A[p * NP + p] *= 1.0 + lambda;
            g[p] = -best_g[p];
        }
        /* A singular or overflowing system ends the fit at the best pose so far
         * (checked here: a refusal of pb_pose_perturb would write an error text). */
        if (!solve(A, g, NP, step) || !pb_all_finite(step, 6))
            break;
        pb_pose_perturb(&best_pose, step, &trial);
        fit->iterations = it + 1;
        double move = sqrt(step[0] * step[0] + step[1] * step[1] + step[2] * step[2]);
        double turn = sqrt(step[3] * step[3] + step[4] * step[4] + step[5] * step[5]);
        if (move < 1e-3 && turn < 1e-5) {
            best_pose = trial;
            break;
        }
    }
    fit->pose = best_pose;
    fit->scale = best_scale;
    fit->offset = best_offset;
    fit->sse = best_sse;
    information(best_a, best_sse, n, fit->information);
    return PB_OK;
}
