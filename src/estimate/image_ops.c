/* Host image operations of the estimate: the resolution pyramid, smoothing and
 * the derivative images of a reference, the last two on the estimate's
 * threads (a plane each). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "objects.h"

void pbe_coarser(const pb_geometry *fine, pb_geometry *coarse)
{
    for (int a = 0; a < 3; a++) {
        coarse->dims[a] = (fine->dims[a] + 1) / 2;
        coarse->voxel_size[a] = 2.0 * fine->voxel_size[a];
    }
}

size_t pbe_longest_side(const pb_geometry *g)
{
    size_t n = g->dims[0] > g->dims[1] ? g->dims[0] : g->dims[1];
    return n > g->dims[2] ? n : g->dims[2];
}

void pbe_grid_corner(const pb_geometry *g, int corner, double p[3])
{
    for (int a = 0; a < 3; a++)
        p[a] = (corner >> a & 1) ? (double)g->dims[a] * g->voxel_size[a] : 0.0;
}

double pbe_corner_distance(const pb_geometry *g, const double c[3], const pb_pose *a, const pb_pose *b)
{
    double most = 0.0;
    for (int corner = 0; corner < 8; corner++) {
        double q[3], u[3], v[3], d = 0.0;
        pbe_grid_corner(g, corner, q);
        pb_pose_apply(a, c, q, u);
        pb_pose_apply(b, c, q, v);
        for (int i = 0; i < 3; i++)
            d += (u[i] - v[i]) * (u[i] - v[i]);
        if (isnan(d) || d > most) /* a NaN, once in, stays */
            most = d;
    }
    return sqrt(most);
}

int pbe_within_grid(const pb_geometry *g, const double c[3], const pb_pose *from, const pb_pose *p)
{
    double far[3];
    pbe_grid_corner(g, 7, far);
    return pbe_corner_distance(g, c, from, p) <= sqrt(far[0] * far[0] + far[1] * far[1] + far[2] * far[2]);
}

int pbe_within_extent(const pb_geometry *g, const double c[3], const pb_pose *a, const pb_pose *b)
{
    double ma[12], mb[12];
    pb_pose_texel_map(a, c, g->voxel_size, ma);
    pb_pose_texel_map(b, c, g->voxel_size, mb);
    for (int axis = 0; axis < 3; axis++)
        if (!(pb_texel_map_walk(ma, mb, g->dims, axis) <= (double)g->dims[axis]))
            return 0;
    return 1;
}

void pbe_downsample(const pb_geometry *fine, const float *in, const pb_geometry *coarse, float *out)
{
    const size_t nx = fine->dims[0], ny = fine->dims[1], nz = fine->dims[2];
    const size_t cx = coarse->dims[0], cy = coarse->dims[1], cz = coarse->dims[2];
    for (size_t k = 0; k < cz; k++)
        for (size_t j = 0; j < cy; j++)
            for (size_t i = 0; i < cx; i++) {
                double s = 0.0;
                int count = 0;
                for (size_t dk = 0; dk < 2; dk++)
                    for (size_t dj = 0; dj < 2; dj++)
                        for (size_t di = 0; di < 2; di++) {
                            size_t x = 2 * i + di, y = 2 * j + dj, z = 2 * k + dk;
                            if (x < nx && y < ny && z < nz) {
                                s += (double)in[x + nx * (y + ny * z)];
                                count++;
                            }
                        }
                out[i + cx * (j + cy * k)] = (float)(s / count);
            }
}

/* One axis of the Gaussian: n along the axis, stride between neighbours;
 * its lines are (outer, inner) for outer < lines_outer, inner <
 * lines_inner, and `lines` holds a line for each outer (or one, used by
 * every outer where the caller runs them alone). */
typedef struct smooth_job {
    float *v, *lines;
    size_t n, stride, lines_inner, outer_stride, inner_stride;
    int shared_line;
    const double *w;
    int radius;
} smooth_job;

static void smooth_lines(void *arg, size_t o)
{
    const smooth_job *s = arg;
    float *tmp = s->lines + (s->shared_line ? 0 : o * s->n);
    for (size_t l = 0; l < s->lines_inner; l++) {
        float *line = s->v + o * s->outer_stride + l * s->inner_stride;
        for (size_t i = 0; i < s->n; i++) {
            double sum = 0.0, ws = 0.0;
            for (int d = -s->radius; d <= s->radius; d++) {
                long p = (long)i + d;
                if (p < 0 || p >= (long)s->n)
                    continue;
                sum += s->w[d + s->radius] * (double)line[(size_t)p * s->stride];
                ws += s->w[d + s->radius];
            }
            tmp[i] = (float)(sum / ws);
        }
        for (size_t i = 0; i < s->n; i++)
            line[i * s->stride] = tmp[i];
    }
}

void pbe_smooth(pb_pool *pool, const pb_geometry *g, float *v, double fwhm_mm, float *tmp)
{
    const size_t nx = g->dims[0], ny = g->dims[1], nz = g->dims[2];
    for (int a = 0; a < 3; a++) {
        double sigma = fwhm_mm / (2.0 * sqrt(2.0 * log(2.0))) / g->voxel_size[a];
        if (sigma < 0.2)
            continue;
        /* a weight beyond the line's length meets no voxel: the radius
         * stops there however wide the Gaussian (and fits an int) */
        const size_t n = g->dims[a];
        int radius = 3.0 * sigma < (double)(n - 1) ? (int)ceil(3.0 * sigma) : (int)(n - 1);
        double *w = malloc(sizeof(double) * (size_t)(2 * radius + 1));
        if (!w)
            return;
        for (int d = -radius; d <= radius; d++)
            w[d + radius] = exp(-0.5 * d * d / (sigma * sigma));
        /* x and y: a plane of z each; z: a plane of y */
        const size_t outer = a < 2 ? nz : ny;
        smooth_job s = {v, NULL, n, a == 0 ? 1 : a == 1 ? nx : nx * ny, a == 0 ? ny : nx, a < 2 ? nx * ny : nx,
                        a == 0 ? nx : 1, 0, w, radius};
        s.lines = pool ? malloc(sizeof(float) * n * outer) : NULL;
        if (!s.lines) {
            s.lines = tmp;
            s.shared_line = 1;
        }
        pb_pool_for(s.shared_line ? NULL : pool, outer, smooth_lines, &s);
        if (!s.shared_line)
            free(s.lines);
        free(w);
    }
}

typedef struct gradient_job {
    const pb_geometry *g;
    const float *x;
    const double *c;
    float *const *out;
} gradient_job;

static void gradient_plane(void *arg, size_t k)
{
    const gradient_job *s = arg;
    const pb_geometry *g = s->g;
    const float *x = s->x;
    const size_t nx = g->dims[0], ny = g->dims[1];
    const size_t step[3] = {1, nx, nx * ny};
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            const size_t idx[3] = {i, j, k}, at = i + nx * (j + ny * k);
            double grad[3], r[3];
            for (int a = 0; a < 3; a++) {
                double lo = idx[a] > 0 ? (double)x[at - step[a]] : 0.0;
                double hi = idx[a] + 1 < g->dims[a] ? (double)x[at + step[a]] : 0.0;
                grad[a] = (hi - lo) / (2.0 * g->voxel_size[a]);
                r[a] = ((double)idx[a] + 0.5) * g->voxel_size[a] - s->c[a];
            }
            s->out[0][at] = (float)grad[0];
            s->out[1][at] = (float)grad[1];
            s->out[2][at] = (float)grad[2];
            s->out[3][at] = (float)(r[1] * grad[2] - r[2] * grad[1]);
            s->out[4][at] = (float)(r[2] * grad[0] - r[0] * grad[2]);
            s->out[5][at] = (float)(r[0] * grad[1] - r[1] * grad[0]);
        }
}

void pbe_pose_gradients(pb_pool *pool, const pb_geometry *g, const float *x, const double c[3],
                        float *const out[6])
{
    gradient_job s = {g, x, c, out};
    pb_pool_for(pool, g->dims[2], gradient_plane, &s);
}

pb_status pb_pose_gradient_images(const pb_geometry *geometry, const float *x, const double center[3],
                                  float *const out[6])
{
    size_t count = 0;
    if (!geometry || !x || !center || !out)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the geometry, object, centre and outputs must not be NULL");
    for (int j = 0; j < 6; j++)
        if (!out[j])
            return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "output image %d is NULL", j);
    if (!(isfinite(center[0]) && isfinite(center[1]) && isfinite(center[2])))
        return pb_error(NULL, PB_ERR_NOT_FINITE, "the centre holds NaN or infinity");
    pb_status st = pb_geometry_check(NULL, geometry, &count);
    if (st == PB_OK)
        pbe_pose_gradients(NULL, geometry, x, center, out);
    return st;
}

double pbe_correlation_volume(const pb_geometry *g, const float *a, const float *b)
{
    const size_t nx = g->dims[0], ny = g->dims[1], nz = g->dims[2], n = nx * ny * nz;
    const size_t step[3] = {1, nx, nx * ny};
    double mean = 0.0, var = 0.0, lag[3] = {0}, volume = 1.0;
    for (size_t v = 0; v < n; v++)
        mean += (double)a[v] - (double)b[v];
    mean /= (double)n;
    for (size_t k = 0; k < nz; k++)
        for (size_t j = 0; j < ny; j++)
            for (size_t i = 0; i < nx; i++) {
                const size_t idx[3] = {i, j, k}, at = i + nx * (j + ny * k);
                double r = (double)a[at] - (double)b[at] - mean;
                var += r * r;
                for (int x = 0; x < 3; x++)
                    if (idx[x] + 1 < g->dims[x])
                        lag[x] += r * ((double)a[at + step[x]] - (double)b[at + step[x]] - mean);
            }
    for (int x = 0; x < 3 && var > 0; x++) {
        /* smoothed white noise: rho(1) = exp(-1 / (4 s^2)), its volume
         * 2 sqrt(pi) s a side */
        double rho = fmin(0.99, lag[x] / var);
        if (rho > 0.01)
            volume *= fmax(1.0, 3.5449077018110318 * sqrt(-0.25 / log(rho)));
    }
    return volume;
}
