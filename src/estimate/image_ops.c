/* Host image operations of the estimate: the resolution pyramid, smoothing and
 * the derivative images of a reference. Plain loops: each runs once per frame
 * and level, beside hundreds of blurs on the device. */
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

void pbe_grid_corner(const pb_geometry *g, int corner, double p[3])
{
    for (int a = 0; a < 3; a++)
        p[a] = (corner >> a & 1) ? (double)g->dims[a] * g->voxel_size[a] : 0.0;
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

/* One axis of the Gaussian: stride between neighbours, n along the axis,
 * lines of that axis enumerated by (outer, inner). */
static void smooth_axis(float *v, float *tmp, size_t n, size_t stride, size_t lines_outer, size_t outer_stride,
                        size_t lines_inner, size_t inner_stride, const double *w, int radius)
{
    for (size_t o = 0; o < lines_outer; o++)
        for (size_t l = 0; l < lines_inner; l++) {
            float *line = v + o * outer_stride + l * inner_stride;
            for (size_t i = 0; i < n; i++) {
                double s = 0.0, ws = 0.0;
                for (int d = -radius; d <= radius; d++) {
                    long p = (long)i + d;
                    if (p < 0 || p >= (long)n)
                        continue;
                    s += w[d + radius] * (double)line[(size_t)p * stride];
                    ws += w[d + radius];
                }
                tmp[i] = (float)(s / ws);
            }
            for (size_t i = 0; i < n; i++)
                line[i * stride] = tmp[i];
        }
}

void pbe_smooth(const pb_geometry *g, float *v, double fwhm_mm, float *tmp)
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
        if (a == 0)
            smooth_axis(v, tmp, nx, 1, nz, nx * ny, ny, nx, w, radius);
        else if (a == 1)
            smooth_axis(v, tmp, ny, nx, nz, nx * ny, nx, 1, w, radius);
        else
            smooth_axis(v, tmp, nz, nx * ny, ny, nx, nx, 1, w, radius);
        free(w);
    }
}

void pbe_pose_gradients(const pb_geometry *g, const float *x, const double c[3], float *const out[6])
{
    const size_t nx = g->dims[0], ny = g->dims[1], nz = g->dims[2];
    const size_t step[3] = {1, nx, nx * ny};
    for (size_t k = 0; k < nz; k++)
        for (size_t j = 0; j < ny; j++)
            for (size_t i = 0; i < nx; i++) {
                const size_t idx[3] = {i, j, k}, at = i + nx * (j + ny * k);
                double grad[3], r[3];
                for (int a = 0; a < 3; a++) {
                    double lo = idx[a] > 0 ? (double)x[at - step[a]] : 0.0;
                    double hi = idx[a] + 1 < g->dims[a] ? (double)x[at + step[a]] : 0.0;
                    grad[a] = (hi - lo) / (2.0 * g->voxel_size[a]);
                    r[a] = ((double)idx[a] + 0.5) * g->voxel_size[a] - c[a];
                }
                out[0][at] = (float)grad[0];
                out[1][at] = (float)grad[1];
                out[2][at] = (float)grad[2];
                out[3][at] = (float)(r[1] * grad[2] - r[2] * grad[1]);
                out[4][at] = (float)(r[2] * grad[0] - r[0] * grad[2]);
                out[5][at] = (float)(r[0] * grad[1] - r[1] * grad[0]);
            }
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
        pbe_pose_gradients(geometry, x, center, out);
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
