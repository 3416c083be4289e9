/* One pose for frames that held still together. A frame with few counts
 * (the first seconds after injection: under a count a head voxel) registers
 * with a millimetre or more of noise, and the reference frame's noise moves
 * every other frame with it. Where neighbouring frames agree within that
 * noise, the head held still across them and their poses measure one pose
 * several times, or a slow drift across them the same: each still frame
 * takes, at its mid-time, the count-weighted least-squares line through the
 * widest run of at least three neighbours around it whose scatter about
 * that line is noise alone (a chi-square test at 99 %). A line, not a mean:
 * a mean flattened a slow drift that no pair of frames showed above the
 * noise (issue 47's family, late scans, 0.44 -> 0.52 mm). A frame's weight
 * is its counts (the Fisher information of a Poisson image grows with them);
 * the noise's scale is the series' own, from each frame's distance to the
 * line through its two neighbours (which a drift does not move), a robust
 * estimate that leaves out the frames that moved. Poses are compared as six
 * numbers in mm:
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
/* at least this many frames between still-looking neighbours to measure the noise */
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
 * the six numbers. Frame k's distance from the line through its neighbours
 * at its time, r = v_k - (a v_(k-1) + b v_(k+1)), is s2 (1 / w_k + a^2 /
 * w_(k-1) + b^2 / w_(k+1)) times a chi-square of 6 degrees where the head
 * held still or drifted evenly; the frames that moved otherwise lie above.
 * A start from the lower quartile, then the mean of those under the 99 %
 * quantile, to a fixed point. 0 where too few frames. */
static double noise_scale(size_t count, const double *vec, const double *w, const double *t, const int *skip,
                          double *z)
{
    size_t m = 0;
    for (size_t k = 1; k + 1 < count; k++) {
        if (skip[k - 1] || skip[k] || skip[k + 1] || !(w[k - 1] > 0.0 && w[k] > 0.0 && w[k + 1] > 0.0))
            continue;
        double a = (t[k + 1] - t[k]) / (t[k + 1] - t[k - 1]), b = 1.0 - a, d2 = 0.0;
        for (int i = 0; i < 6; i++) {
            double r = vec[6 * k + i] - a * vec[6 * (k - 1) + i] - b * vec[6 * (k + 1) + i];
            d2 += r * r;
        }
        z[m++] = d2 / (1.0 / w[k] + a * a / w[k - 1] + b * b / w[k + 1]);
    }
    if (m < MIN_PAIRS)
        return 0.0;
    double *sorted = malloc(sizeof(double) * m);
    if (!sorted)
        return 0.0;
    memcpy(sorted, z, sizeof(double) * m);
    for (size_t i = 1; i < m; i++)
        for (size_t j = i; j > 0 && sorted[j - 1] > sorted[j]; j--) {
            double x = sorted[j];
            sorted[j] = sorted[j - 1];
            sorted[j - 1] = x;
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

/* Is frames [lo, hi)'s scatter about their weighted least-squares line in
 * time that of noise (three frames at least)? The line at time at goes to
 * out. */
static int one_line(const double *vec, const double *w, const double *t, size_t lo, size_t hi, double s2,
                    double at, double out[6])
{
    if (hi - lo < 3)
        return 0;
    double total = 0.0, tm = 0.0, stt = 0.0, mean[6] = {0}, slope[6] = {0};
    for (size_t j = lo; j < hi; j++) {
        total += w[j];
        tm += w[j] * t[j];
    }
    tm /= total;
    for (size_t j = lo; j < hi; j++) {
        stt += w[j] * (t[j] - tm) * (t[j] - tm);
        for (int i = 0; i < 6; i++) {
            mean[i] += w[j] * vec[6 * j + i] / total;
            slope[i] += w[j] * (t[j] - tm) * vec[6 * j + i];
        }
    }
    if (!(stt > 0.0))
        return 0;
    double stat = 0.0;
    for (int i = 0; i < 6; i++)
        slope[i] /= stt;
    for (size_t j = lo; j < hi; j++)
        for (int i = 0; i < 6; i++) {
            double r = vec[6 * j + i] - mean[i] - slope[i] * (t[j] - tm);
            stat += w[j] * r * r / s2;
        }
    for (int i = 0; i < 6; i++)
        out[i] = mean[i] + slope[i] * (at - tm);
    return stat < chi2_q99(6.0 * (double)(hi - lo - 2));
}

static int usable(const int *skip, const double *w, size_t count, size_t lo, size_t hi)
{
    if (hi > count)
        return 0;
    for (size_t j = lo; j < hi; j++)
        if (skip[j] || !(w[j] > 0.0))
            return 0;
    return 1;
}

pb_status pbe_pool_still(const pb_geometry *g, const float *raw, size_t count, const double *bounds,
                         const double c[3], const int *skip, pbe_fit *fits, size_t *pooled)
{
    *pooled = 0;
    double *w = malloc(sizeof(double) * count), *vec = malloc(sizeof(double) * 6 * count);
    double *z = malloc(sizeof(double) * count), *t = malloc(sizeof(double) * count);
    if (!w || !vec || !z || !t) {
        free(w), free(vec), free(z), free(t);
        return PB_ERR_OUT_OF_MEMORY;
    }
    double radius = counts_and_radius(g, raw, count, bounds, c, w);
    double s2 = 0.0;
    if (radius > 0.0) {
        for (size_t k = 0; k < count; k++) {
            to_vector(&fits[k].pose, radius, vec + 6 * k);
            t[k] = 0.5 * (bounds[k] + bounds[k + 1]);
        }
        s2 = noise_scale(count, vec, w, t, skip, z);
    }
    for (size_t k = 0; k < count && s2 > 0.0; k++) {
        if (!usable(skip, w, count, k, k + 1))
            continue;
        /* the first three: centred, then before, then after */
        size_t lo = 0, hi = 0;
        double line[6];
        const size_t starts[3] = {k >= 1 ? k - 1 : count, k >= 2 ? k - 2 : count, k};
        for (int s = 0; s < 3 && hi == 0; s++)
            if (starts[s] < count && usable(skip, w, count, starts[s], starts[s] + 3) &&
                one_line(vec, w, t, starts[s], starts[s] + 3, s2, t[k], line)) {
                lo = starts[s];
                hi = lo + 3;
            }
        if (hi == 0)
            continue;
        for (int grew = 1; grew;) {
            grew = 0;
            if (lo > 0 && usable(skip, w, count, lo - 1, lo) && one_line(vec, w, t, lo - 1, hi, s2, t[k], line)) {
                lo--;
                grew = 1;
            } else if (usable(skip, w, count, hi, hi + 1) && one_line(vec, w, t, lo, hi + 1, s2, t[k], line)) {
                hi++;
                grew = 1;
            }
        }
        one_line(vec, w, t, lo, hi, s2, t[k], line);
        from_vector(line, radius, &fits[k].pose);
        (*pooled)++;
    }
    free(w), free(vec), free(z), free(t);
    return PB_OK;
}
