/* Motion inside a frame. A frame is the time average of its poses' views of
 * the object, so along a known path from pose s to pose e it is a
 * non-negative mixture of the views at points of the path, each weighted by
 * how long the head dwells there. The weights follow from non-negative least
 * squares, and their order along the path gives the times: a jerk inside a
 * frame is a frame that dwells at both ends. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
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

/* The dwell's sums, each voxel by its weight: the views' Gram matrix with
 * the offset's column (upper triangle, row by row), their products with the
 * frame, and the weights' sum. */
typedef struct dwell_job {
    const float *views; /* m of them, n voxels each, one after another */
    const float *frame;
    const float *w;
    size_t n, m;
    const double *u; /* for the residual */
} dwell_job;

static void dwell_sums(void *arg, size_t begin, size_t end, double *s)
{
    const dwell_job *j = arg;
    const size_t m = j->m;
    for (size_t v = begin; v < end; v++) {
        const double w = (double)j->w[v];
        if (!(w > 0.0))
            continue;
        double f = w * (double)j->frame[v];
        double *up = s;
        for (size_t i = 0; i < m; i++) {
            double a = w * (double)j->views[i * j->n + v];
            for (size_t k = i; k < m; k++)
                *up++ += a * (double)j->views[k * j->n + v];
            *up++ += a;
        }
        for (size_t i = 0; i < m; i++)
            up[i] += (double)j->views[i * j->n + v] * f;
        up[m] += f;
        up[m + 1] += w;
    }
}

/* The residual summed directly: u'Gu - 2 h'u + f'f cancels badly. */
static void dwell_residual(void *arg, size_t begin, size_t end, double *s)
{
    const dwell_job *j = arg;
    for (size_t v = begin; v < end; v++) {
        double model = j->u[j->m];
        for (size_t i = 0; i < j->m; i++)
            model += j->u[i] * (double)j->views[i * j->n + v];
        s[0] += (double)j->w[v] * (model - (double)j->frame[v]) * (model - (double)j->frame[v]);
    }
}

/* in sharpened along each axis by the smoothing trilinear sampling gave each
 * voxel, f (1 - f) for its own f, into out: in + sum over the axes of
 * f (1 - f) (in - the mean of its two neighbours along the axis), the
 * grid's edge voxels repeated beyond it. (One pass of the three axes' taps
 * (-s/2, 1 + s, -s/2) together; in turn they would differ by their
 * products, at most 1/16 of a second difference, for three passes' time.)
 * Where a voxel is read is affine in its index (pb_pose_texel_map), so each
 * axis's offset in voxels is its value at the first voxel plus a step an
 * index. */
typedef struct sharpen_job {
    const pb_geometry *g;
    const float *in;
    float *out;
    double first[3], step[3][3]; /* each axis's offset at voxel 0; its change a step along each index */
} sharpen_job;

/* floor(x): libm's is a call on x86-64 without SSE4.1, a fifth of the
 * sharpening's time at 128^3; a conversion is inline. */
static inline double whole_below(double x)
{
    if (!(fabs(x) < 0x1p52))
        return floor(x);
    const double t = (double)(long long)x;
    return t > x ? t - 1.0 : t;
}

static void sharpen_slice(void *arg, size_t k)
{
    const sharpen_job *job = arg;
    const pb_geometry *g = job->g;
    const size_t n[3] = {g->dims[0], g->dims[1], g->dims[2]}, stride[3] = {1, n[0], n[0] * n[1]};
    for (size_t j = 0; j < n[1]; j++) {
        double d[3];
        for (int a = 0; a < 3; a++)
            d[a] = job->first[a] + (double)j * job->step[a][1] + (double)k * job->step[a][2];
        for (size_t i = 0; i < n[0]; i++) {
            const size_t at[3] = {i, j, k}, idx = i + n[0] * (j + n[1] * k);
            const double here = (double)job->in[idx];
            double out = here;
            for (int a = 0; a < 3; a++) {
                const double f = d[a] - whole_below(d[a]), sm = f * (1.0 - f);
                d[a] += job->step[a][0];
                if (n[a] < 2 || sm == 0.0)
                    continue;
                const size_t lo = at[a] > 0 ? idx - stride[a] : idx, hi = at[a] + 1 < n[a] ? idx + stride[a] : idx;
                out += sm * (here - 0.5 * ((double)job->in[lo] + (double)job->in[hi]));
            }
            job->out[idx] = (float)out;
        }
    }
}

static void sharpen_each_voxel(pb_pool *pool, const pb_geometry *g, const pb_pose *pose, const double c[3],
                               const float *in, float *out)
{
    double m[12]; /* object texel = m[:, 0:3] tomograph texel + m[:, 3], texel i's centre at i + 0.5 */
    pb_pose_texel_map(pose, c, g->voxel_size, m);
    sharpen_job job = {g, in, out, {0.0, 0.0, 0.0}, {{0.0}}};
    for (int a = 0; a < 3; a++) {
        job.first[a] = m[4 * a + 3] - 0.5;
        for (int b = 0; b < 3; b++) {
            job.step[a][b] = m[4 * a + b] - (a == b);
            job.first[a] += 0.5 * m[4 * a + b];
        }
    }
    pb_pool_for(pool, g->dims[2], sharpen_slice, &job);
}

pb_status pbe_view(pb_context *ctx, pbe_level *level, const pb_pose *pose, const double c[3], float *out)
{
    double times[2];
    pb_pose held[2];
    pb_motion mo;
    pbe_static_motion(pose, c, times, held, &mo);
    /* PETBLUR_ESTIMATE_VIEWS=sampled leaves each view as sampled, for comparisons */
    const char *env = getenv("PETBLUR_ESTIMATE_VIEWS");
    if (env && strcmp(env, "sampled") == 0)
        return pbe_blur_reference_to(ctx, level, &mo, out);
    pb_status st = pbe_blur_reference(ctx, level, &mo);
    if (st == PB_OK)
        sharpen_each_voxel(level->pool, &level->g, pose, c, level->host[0], out);
    return st;
}

pb_status pbe_dwell(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], const pb_pose *s,
                    const pb_pose *e, size_t m, double *u, double *sse)
{
    pb_pose *poses = malloc(m * sizeof *poses);
    if (!poses)
        return PB_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; i < m; i++)
        pb_pose_interpolate(s, e, (double)i / (double)(m - 1), &poses[i]);
    pb_status st = pbe_dwell_at(ctx, level, frame, c, poses, m, u, sse, NULL);
    free(poses);
    return st;
}

pb_status pbe_dwell_at(pb_context *ctx, pbe_level *level, const float *frame, const double c[3],
                       const pb_pose *poses, size_t m, double *u, double *sse, double *gram_out)
{
    const size_t n = level->n, k = m + 1; /* the views, and the offset */
    const size_t terms = m * (m + 1) / 2 + m + k + 1;
    if (terms > PB_MOST_SUMS)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "a dwell of %zu points has more sums than %d", m,
                        (int)PB_MOST_SUMS);
    double *gram = calloc(k * k, sizeof(double)), *h = calloc(k, sizeof(double));
    float *views = pbe_level_views(level, m);
    pb_status st = gram && h && views ? PB_OK : PB_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; i < m && st == PB_OK; i++)
        st = pbe_view(ctx, level, &poses[i], c, views + i * n);
    if (st == PB_OK) {
        double sums[PB_MOST_SUMS];
        dwell_job job = {views, frame, level->host[PBE_SUPPORT], n, m, u};
        pb_pool_sums(level->pool, n, terms, dwell_sums, &job, sums);
        const double *up = sums;
        for (size_t i = 0; i < m; i++) {
            for (size_t j = i; j < m; j++)
                gram[i * k + j] = *up++;
            gram[i * k + m] = *up++;
        }
        for (size_t i = 0; i < k; i++)
            h[i] = up[i];
        gram[m * k + m] = up[k];
        for (size_t i = 0; i < k; i++)
            for (size_t j = 0; j < i; j++)
                gram[i * k + j] = gram[j * k + i];
        if (gram_out)
            memcpy(gram_out, gram, k * k * sizeof *gram);
        pbe_nnls(gram, h, k, m, u);
        double r;
        pb_pool_sums(level->pool, n, 1, dwell_residual, &job, &r);
        *sse = r > 0 ? r : 0.0;
    }
    free(gram);
    free(h);
    return st;
}
