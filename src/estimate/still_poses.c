/* One pose for frames that held still together. A frame with few counts
 * (the first seconds after injection: under a count a head voxel) registers
 * with a millimetre or more of noise, and the reference frame's noise moves
 * every other frame with it. Where neighbouring frames agree within that
 * noise, the head held still across them and their poses measure one pose
 * several times: each still frame takes the count-weighted mean of the
 * widest run of neighbours around it whose scatter is that of noise alone
 * (a chi-square test at 99 %). A frame's weight is its counts (the Fisher
 * information of a Poisson image grows with them); the noise's scale is the
 * series' own, from its consecutive differences, a robust estimate that
 * leaves out the pairs that moved. Poses are compared as six numbers in mm:
 * the displacement of the centre and the rotation vector times the
 * activity's RMS radius about it (a turn's displacement of an average point).
 * Frames that follow a path, or show no structure, neither pool nor join a
 * run. Measured on issue 47's family (docs/motion.md). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"

/* chi-square with 6 degrees: its 25 % quantile, its 99 % quantile, and its
 * mean below that (scipy.stats.chi2) */
#define CHI2_6_Q25 3.4545988357
#define CHI2_6_Q99 16.8118938298
#define CHI2_6_MEAN_BELOW_Q99 5.8658877730
/* at least this many pairs of still-looking neighbours to measure the noise */
#define MIN_PAIRS 4

/* The 99 % quantile of chi-square with k degrees (Wilson-Hilferty: within
 * 0.2 % of the exact from 6 degrees on). */
static double chi2_q99(double k)
{
    double a = 2.0 / (9.0 * k), c = 1.0 - a + 2.3263478740 * sqrt(a);
    return k * c * c * c;
}

static void to_vector(const pb_pose *p, double radius, double v[6])
{
    double w = p->rotation[0], x = p->rotation[1], y = p->rotation[2], z = p->rotation[3];
    if (w < 0.0)
        w = -w, x = -x, y = -y, z = -z;
    double s = sqrt(x * x + y * y + z * z), f = s > 1e-12 ? 2.0 * atan2(s, w) / s : 2.0;
    v[0] = radius * f * x;
    v[1] = radius * f * y;
    v[2] = radius * f * z;
    for (int i = 0; i < 3; i++)
        v[3 + i] = p->translation[i];
}

static void from_vector(const double v[6], double radius, pb_pose *p)
{
    double r[3] = {v[0] / radius, v[1] / radius, v[2] / radius};
    double a = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    double f = a > 1e-12 ? sin(0.5 * a) / a : 0.5;
    p->rotation[0] = cos(0.5 * a);
    for (int i = 0; i < 3; i++) {
        p->rotation[1 + i] = f * r[i];
        p->translation[i] = v[3 + i];
    }
}

static double distance2(const double *a, const double *b)
{
    double s = 0.0;
    for (int i = 0; i < 6; i++)
        s += (a[i] - b[i]) * (a[i] - b[i]);
    return s;
}

/* The frames' counts (their positive activity times their length) and the
 * activity's RMS radius about c, mm. */
static double counts_and_radius(const pb_geometry *g, const float *raw, size_t count, const double *bounds,
                                const double c[3], double *counts)
{
    const size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    double mass = 0.0, moment = 0.0;
    for (size_t k = 0; k < count; k++) {
        const float *f = raw + k * n;
        double sum = 0.0;
        for (size_t z = 0, v = 0; z < g->dims[2]; z++)
            for (size_t y = 0; y < g->dims[1]; y++)
                for (size_t x = 0; x < g->dims[0]; x++, v++) {
                    if (!(f[v] > 0.0f))
                        continue;
                    double dx = ((double)x + 0.5) * g->voxel_size[0] - c[0];
                    double dy = ((double)y + 0.5) * g->voxel_size[1] - c[1];
                    double dz = ((double)z + 0.5) * g->voxel_size[2] - c[2];
                    sum += (double)f[v];
                    moment += (double)f[v] * (dx * dx + dy * dy + dz * dz);
                }
        mass += sum;
        counts[k] = sum * (bounds[k + 1] - bounds[k]);
    }
    return mass > 0.0 ? sqrt(moment / mass) : 0.0;
}

/* The noise's scale s2: a frame of weight w scatters by s2 / w in each of
 * the six numbers. From the pairs of neighbours, |d|^2 / (1 / w_a + 1 / w_b)
 * is s2 times a chi-square of 6 degrees where the head held still; the pairs
 * that moved lie above. A start from the lower quartile, then the mean of
 * the pairs under the 99 % quantile, to a fixed point. 0 where too few pairs. */
static double noise_scale(size_t count, const double *vec, const double *w, const int *skip, double *z)
{
    size_t m = 0;
    for (size_t k = 0; k + 1 < count; k++)
        if (!skip[k] && !skip[k + 1] && w[k] > 0.0 && w[k + 1] > 0.0)
            z[m++] = distance2(vec + 6 * k, vec + 6 * (k + 1)) / (1.0 / w[k] + 1.0 / w[k + 1]);
    if (m < MIN_PAIRS)
        return 0.0;
    double *sorted = malloc(sizeof(double) * m);
    if (!sorted)
        return 0.0;
    memcpy(sorted, z, sizeof(double) * m);
    for (size_t i = 1; i < m; i++)
        for (size_t j = i; j > 0 && sorted[j - 1] > sorted[j]; j--) {
            double t = sorted[j];
            sorted[j] = sorted[j - 1];
            sorted[j - 1] = t;
        }
    double s2 = sorted[(m - 1) / 4] / CHI2_6_Q25;
    free(sorted);
    for (int it = 0; it < 20 && s2 > 0.0; it++) {
        double sum = 0.0;
        size_t kept = 0;
        for (size_t i = 0; i < m; i++)
            if (z[i] < CHI2_6_Q99 * s2) {
                sum += z[i];
                kept++;
            }
        if (kept < MIN_PAIRS)
            return 0.0;
        double next = sum / (double)kept / CHI2_6_MEAN_BELOW_Q99;
        if (fabs(next - s2) <= 1e-9 * s2) {
            s2 = next;
            break;
        }
        s2 = next;
    }
    return s2;
}

/* Is frames [lo, hi)'s scatter about their weighted mean that of noise? The
 * mean goes to mean. */
static int one_pose(const double *vec, const double *w, size_t lo, size_t hi, double s2, double mean[6])
{
    double total = 0.0;
    for (int i = 0; i < 6; i++)
        mean[i] = 0.0;
    for (size_t j = lo; j < hi; j++) {
        total += w[j];
        for (int i = 0; i < 6; i++)
            mean[i] += w[j] * vec[6 * j + i];
    }
    for (int i = 0; i < 6; i++)
        mean[i] /= total;
    double stat = 0.0;
    for (size_t j = lo; j < hi; j++)
        stat += w[j] * distance2(vec + 6 * j, mean) / s2;
    return stat < chi2_q99(6.0 * (double)(hi - lo - 1));
}

pb_status pbe_pool_still(const pb_geometry *g, const float *raw, size_t count, const double *bounds,
                         const double c[3], const int *skip, pbe_fit *fits, size_t *pooled)
{
    *pooled = 0;
    double *w = malloc(sizeof(double) * count), *vec = malloc(sizeof(double) * 6 * count);
    double *z = malloc(sizeof(double) * count);
    if (!w || !vec || !z) {
        free(w), free(vec), free(z);
        return PB_ERR_OUT_OF_MEMORY;
    }
    double radius = counts_and_radius(g, raw, count, bounds, c, w);
    double s2 = 0.0;
    if (radius > 0.0) {
        for (size_t k = 0; k < count; k++)
            to_vector(&fits[k].pose, radius, vec + 6 * k);
        s2 = noise_scale(count, vec, w, skip, z);
    }
    for (size_t k = 0; k < count && s2 > 0.0; k++) {
        if (skip[k] || !(w[k] > 0.0))
            continue;
        size_t lo = k, hi = k + 1;
        double mean[6];
        for (int grew = 1; grew;) {
            grew = 0;
            if (lo > 0 && !skip[lo - 1] && w[lo - 1] > 0.0 && one_pose(vec, w, lo - 1, hi, s2, mean)) {
                lo--;
                grew = 1;
            } else if (hi < count && !skip[hi] && w[hi] > 0.0 && one_pose(vec, w, lo, hi + 1, s2, mean)) {
                hi++;
                grew = 1;
            }
        }
        if (hi - lo < 2)
            continue;
        one_pose(vec, w, lo, hi, s2, mean);
        from_vector(mean, radius, &fits[k].pose);
        (*pooled)++;
    }
    free(w), free(vec), free(z);
    return PB_OK;
}
