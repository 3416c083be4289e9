/* Motion from deformation fields: validation of a field series against the
 * image grid, where a time falls between its samples, the field's value at a
 * point (the host reference's and the planner's), and where it folds. */
#include "motion.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "error.h"
#include "numbers.h"

/* mm: a field that moves a voxel farther than a kilometre is no body's. */
#define PB_MAX_DISPLACEMENT 1e6

static double det3(const double m[12])
{
    return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
           m[2] * (m[4] * m[9] - m[5] * m[8]);
}

size_t pb_field_voxels(const pb_field_motion *f)
{
    return f->dims[0] * f->dims[1] * f->dims[2];
}

/* A displacement longer than the image grid's diagonal takes every voxel out
 * of the grid (any two points of it lie closer), so no field a body's motion
 * makes holds one; twice that is refused, naming the likely cause (a field
 * in micrometres, or in the wrong convention). It also bounds the time a
 * blur takes: a field's walk is not clipped to the grid as a track's is, so
 * a chord's slices, and REF's steps, follow the displacement's length. */
#define PB_FIELD_REACH 2.0

void pb_field_reach_box(const pb_geometry *g, const pb_field_motion *f, double margin, size_t lo[3], size_t hi[3])
{
    for (int a = 0; a < 3; a++) {
        lo[a] = 0;
        hi[a] = f->dims[a] - 1;
    }
    if (!f->has_map)
        return;
    double mn[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, mx[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (int c = 0; c < 8; c++) {
        const double u[3] = {c & 1 ? (double)g->dims[0] - 1.0 + margin : -margin,
                             c & 2 ? (double)g->dims[1] - 1.0 + margin : -margin,
                             c & 4 ? (double)g->dims[2] - 1.0 + margin : -margin};
        for (int a = 0; a < 3; a++) {
            const double *m = f->field_from_grid + 4 * a, q = m[0] * u[0] + m[1] * u[1] + m[2] * u[2] + m[3];
            mn[a] = fmin(mn[a], q);
            mx[a] = fmax(mx[a], q);
        }
    }
    for (int a = 0; a < 3; a++) {
        const double top = (double)f->dims[a] - 1.0;
        lo[a] = (size_t)fmin(top, fmax(0.0, floor(mn[a]) - 1.0));
        hi[a] = (size_t)fmin(top, fmax(0.0, ceil(mx[a]) + 1.0));
    }
}

pb_status pb_field_check_reach(struct pb_context *ctx, const pb_geometry *g, const pb_field_motion *f)
{
    size_t n = pb_field_voxels(f), lo[3], hi[3];
    double diagonal = 0.0;
    for (int c = 0; c < 3; c++)
        diagonal += ((double)g->dims[c] * g->voxel_size[c]) * ((double)g->dims[c] * g->voxel_size[c]);
    diagonal = sqrt(diagonal);
    pb_field_reach_box(g, f, 0.0, lo, hi);
    for (size_t k = 0; k < f->count; k++) {
        const float *d = f->displacements + k * n * 3;
        for (size_t l = lo[2]; l <= hi[2]; l++)
            for (size_t j = lo[1]; j <= hi[1]; j++)
                for (size_t i = lo[0]; i <= hi[0]; i++) {
                    const size_t v = i + f->dims[0] * (j + f->dims[1] * l);
                    const double x = (double)d[3 * v], y = (double)d[3 * v + 1], z = (double)d[3 * v + 2];
                    const double len = sqrt(x * x + y * y + z * z);
                    if (len > PB_FIELD_REACH * diagonal)
                        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "field %zu moves voxel (%zu, %zu, %zu) by %g "
                                        "mm, more than twice the image grid's diagonal (%g mm), out of the grid "
                                        "wherever it starts; displacements are mm: check the field's units "
                                        "(micrometres?) and its convention", k, i, j, l, len, diagonal);
                }
    }
    return PB_OK;
}

static pb_status check_values(struct pb_context *ctx, const pb_field_motion *f)
{
    size_t n = pb_field_voxels(f);
    for (size_t k = 0; k < f->count; k++) {
        const float *d = f->displacements + k * n * 3;
        for (size_t v = 0; v < n; v++)
            for (int c = 0; c < 3; c++) {
                float x = d[3 * v + c];
                if (isfinite(x) && fabs((double)x) <= PB_MAX_DISPLACEMENT)
                    continue;
                size_t i = v % f->dims[0], j = v / f->dims[0] % f->dims[1], l = v / f->dims[0] / f->dims[1];
                if (!isfinite(x))
                    return pb_error(ctx, PB_ERR_NOT_FINITE, "field %zu holds %s in component %c of voxel (%zu, %zu, "
                                    "%zu); a displacement field must be finite everywhere (fill what a registration "
                                    "left undefined, e.g. outside its mask, with 0)", k, isnan(x) ? "NaN" : "infinity",
                                    "xyz"[c], i, j, l);
                return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "field %zu moves voxel (%zu, %zu, %zu) by %g mm along %c, "
                                "beyond a kilometre; displacements are mm", k, i, j, l, (double)x, "xyz"[c]);
            }
    }
    return PB_OK;
}

pb_status pb_field_validate(struct pb_context *ctx, const pb_geometry *g, const pb_field_motion *f)
{
    if (!f || !f->times || !f->displacements)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "the field motion, its times and its displacements must not be "
                        "NULL");
    if (f->count < 2)
        return pb_error(ctx, PB_ERR_TRACK_ORDER, "the field motion has %zu field%s; give at least two, at or before "
                        "the frame's start and at or after its end (the same field twice for a still deformation)",
                        f->count, f->count == 1 ? "" : "s");
    if (f->dims[0] == 0 || f->dims[1] == 0 || f->dims[2] == 0)
        return pb_error(ctx, PB_ERR_ZERO_DIMS, "the field grid is %zu x %zu x %zu; every dimension must be at least 1",
                        f->dims[0], f->dims[1], f->dims[2]);
    if (f->dims[0] > (1u << 20) || f->dims[1] > (1u << 20) || f->dims[2] > (1u << 20) ||
        pb_field_voxels(f) > ((size_t)1 << 31) / 3 || f->count > ((size_t)1 << 40) / (pb_field_voxels(f) * 3))
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "%zu fields of %zu x %zu x %zu voxels are more than petblur "
                        "indexes; use coarser fields or fewer samples", f->count, f->dims[0], f->dims[1], f->dims[2]);
    if (!f->has_map) {
        for (int i = 0; i < 3; i++)
            if (f->dims[i] != g->dims[i])
                return pb_error(ctx, PB_ERR_SIZE_MISMATCH, "the field grid (%zu x %zu x %zu) is not the image grid "
                                "(%zu x %zu x %zu); resample the field, or give the map from image to field voxels "
                                "(has_map; the Python and command-line readers make it from the files' affines)",
                                f->dims[0], f->dims[1], f->dims[2], g->dims[0], g->dims[1], g->dims[2]);
    } else {
        if (!pb_all_finite(f->field_from_grid, 12))
            return pb_error(ctx, PB_ERR_NOT_FINITE, "the map from image to field voxels is NaN or infinite; give a "
                            "finite 3x4 matrix");
        double scale = 0.0;
        for (int i = 0; i < 12; i++)
            if (i % 4 != 3)
                scale = fmax(scale, fabs(f->field_from_grid[i]));
        if (!(scale > 0.0) || fabs(det3(f->field_from_grid)) <= 1e-9 * scale * scale * scale)
            return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "the map from image to field voxels is singular: the field's "
                            "affine collapses an axis; check the field file's affine (sform or qform)");
    }
    for (size_t i = 0; i < f->count; i++) {
        if (!isfinite(f->times[i]))
            return pb_error(ctx, PB_ERR_NOT_FINITE, "field time %zu is NaN or infinite; give finite seconds", i);
        if (i > 0 && !(f->times[i] > f->times[i - 1]))
            return pb_error(ctx, PB_ERR_TRACK_ORDER, "field time %zu (%s s) is not after time %zu (%s s); sort the "
                            "fields by time and drop repeated times", i, PB_NUM(f->times[i]), i - 1,
                            PB_NUM(f->times[i - 1]));
        if (i > 0 && !isfinite(f->times[i] - f->times[i - 1]))
            return pb_error(ctx, PB_ERR_NOT_FINITE, "field times %zu and %zu (%s and %s s) are too far apart to "
                            "subtract; give seconds of a scan", i - 1, i, PB_NUM(f->times[i - 1]),
                            PB_NUM(f->times[i]));
    }
    if (f->signal_count == 1 || (f->signal_count && (!f->signal_times || !f->signal)))
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "the surrogate signal has %zu sample%s%s; give at least two "
                        "(times and values), or none for fields at times", f->signal_count,
                        f->signal_count == 1 ? "" : "s", f->signal_count > 1 ? " and a NULL array" : "");
    for (size_t i = 0; i < f->signal_count; i++) {
        if (!isfinite(f->signal_times[i]) || !isfinite(f->signal[i]))
            return pb_error(ctx, PB_ERR_NOT_FINITE, "surrogate sample %zu (%g s, value %g) is NaN or infinite; give "
                            "finite times (s) and values, dropping the belt's dropouts", i, f->signal_times[i],
                            f->signal[i]);
        if (i > 0 && !(f->signal_times[i] > f->signal_times[i - 1]))
            return pb_error(ctx, PB_ERR_TRACK_ORDER, "surrogate time %zu (%s s) is not after time %zu (%s s); sort "
                            "the signal by time and drop repeated times", i, PB_NUM(f->signal_times[i]), i - 1,
                            PB_NUM(f->signal_times[i - 1]));
    }
    return check_values(ctx, f);
}

/* The times the motion covers: the fields' or the surrogate's. */
static void span(const pb_field_motion *f, double *lo, double *hi)
{
    *lo = f->signal_count ? f->signal_times[0] : f->times[0];
    *hi = f->signal_count ? f->signal_times[f->signal_count - 1] : f->times[f->count - 1];
}

pb_status pb_field_frame_check(struct pb_context *ctx, const pb_field_motion *f, double t0, double t1)
{
    double lo, hi;
    span(f, &lo, &hi);
    if (!isfinite(t0) || !isfinite(t1))
        return pb_error(ctx, PB_ERR_NOT_FINITE, "the frame [%g, %g] is not finite; give finite times in seconds", t0,
                        t1);
    if (!(t1 > t0))
        return pb_error(ctx, PB_ERR_BAD_FRAME, "the frame ends at %s s, not after its start at %s s; give end > "
                        "start", PB_NUM(t1), PB_NUM(t0));
    if (!isfinite(t1 - t0))
        return pb_error(ctx, PB_ERR_NOT_FINITE, "the frame [%s, %s] s is too long to measure in double precision; "
                        "give seconds of a scan", PB_NUM(t0), PB_NUM(t1));
    if (lo > t0 || hi < t1)
        return pb_error(ctx, PB_ERR_TRACK_GAP, "the %s cover [%s, %s] s but the frame is [%s, %s] s; %s",
                        f->signal_count ? "surrogate signal's samples" : "fields",
                        PB_NUM(lo), PB_NUM(hi), PB_NUM(t0), PB_NUM(t1),
                        f->signal_count ? "record the signal over the whole frame, or pick a frame inside it"
                                        : "add fields at or beyond the frame's ends or pick a frame inside them");
    return PB_OK;
}

/* Where v lies among n increasing samples: index j and fraction a in [0, 1]
 * of samples j and j + 1. */
static void bracket(const double *x, size_t n, double v, size_t *j, double *a)
{
    size_t lo = pb_sample_before(x, n, v);
    if (lo > n - 2)
        lo = n - 2;
    double s = (v - x[lo]) / (x[lo + 1] - x[lo]);
    *j = lo;
    *a = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
}

pb_status pb_field_locate(struct pb_context *ctx, const pb_field_motion *f, double t, size_t *f0, size_t *f1,
                          double *alpha)
{
    double v = t;
    if (f->signal_count) {
        size_t j;
        double a;
        bracket(f->signal_times, f->signal_count, t, &j, &a);
        double s0 = f->signal[j], s1 = f->signal[j + 1];
        /* Kept between its two samples: a flat stretch at a field's value
         * must not round an ulp past it. */
        v = s0 == s1 ? s0 : fmin(fmax((1.0 - a) * s0 + a * s1, fmin(s0, s1)), fmax(s0, s1));
        /* A gate's interval ends where the signal crosses an edge, and the
         * value there, found again from that time, may round past a field's
         * value at the edge (-8.6e-15 for an edge at 0): within a billionth
         * of the fields' span, and the slope times the time's own rounding (a
         * belt logged in epoch seconds), it is that value; never beyond a
         * millionth of the span, which moves no voxel a nanometre. */
        const double lo = f->times[0], hi = f->times[f->count - 1];
        const double slope = (s1 - s0) / (f->signal_times[j + 1] - f->signal_times[j]);
        const double near = fmin(1e-9 * (hi - lo) + 8.0 * DBL_EPSILON * fabs(t) * fabs(slope), 1e-6 * (hi - lo));
        if (v >= lo - near && v <= hi + near)
            v = fmin(fmax(v, lo), hi);
        if (v < lo || v > hi)
            return pb_error(ctx, PB_ERR_TRACK_GAP, "the surrogate is %s at %s s, outside the fields' values [%s, %s]; "
                            "add a field for that amplitude, or leave that time out of the frames", PB_NUM(v),
                            PB_NUM(t), PB_NUM(f->times[0]), PB_NUM(f->times[f->count - 1]));
    }
    bracket(f->times, f->count, v, f0, alpha);
    *f1 = *f0 + 1;
    return PB_OK;
}

/* Trilinear interpolation of field k at field voxel coordinates q (voxel i's
 * centre at i), held at the edge values beyond the outer centres. */
void pb_field_sample(const float *field, const size_t dims[3], const double q[3], double out[3])
{
    long i0[3];
    double w[3];
    for (int d = 0; d < 3; d++) {
        double c = fmin(fmax(q[d], 0.0), (double)dims[d] - 1.0);
        i0[d] = (long)floor(c);
        if (i0[d] > (long)dims[d] - 2)
            i0[d] = dims[d] >= 2 ? (long)dims[d] - 2 : 0;
        w[d] = dims[d] >= 2 ? c - (double)i0[d] : 0.0;
    }
    out[0] = out[1] = out[2] = 0.0;
    for (int corner = 0; corner < 8; corner++) {
        double wc = 1.0;
        size_t idx = 0, stride = 1;
        for (int d = 0; d < 3; d++) {
            int up = corner >> d & 1;
            wc *= up ? w[d] : 1.0 - w[d];
            long at = i0[d] + (up && dims[d] >= 2);
            idx += (size_t)at * stride;
            stride *= dims[d];
        }
        if (wc == 0.0)
            continue;
        for (int c = 0; c < 3; c++)
            out[c] += wc * (double)field[3 * idx + c];
    }
}

/* The 3x3 derivative of field k at field voxel v, per mm of the image grid:
 * differences along the field's axes, chained through the map to image
 * voxels and their sizes. */
static void field_gradient(const pb_geometry *g, const pb_field_motion *f, const float *field, size_t v,
                           double grad[9])
{
    const size_t *n = f->dims;
    size_t at[3] = {v % n[0], v / n[0] % n[1], v / n[0] / n[1]}, stride[3] = {1, n[0], n[0] * n[1]};
    double per_index[9] = {0}; /* per_index[3 * c + a]: d D_c / d (field index a) */
    for (int a = 0; a < 3; a++) {
        if (n[a] < 2)
            continue;
        size_t lo = at[a] > 0 ? v - stride[a] : v, hi = at[a] + 1 < n[a] ? v + stride[a] : v;
        double span = (double)((at[a] + 1 < n[a]) + (at[a] > 0));
        for (int c = 0; c < 3; c++)
            per_index[3 * c + a] = ((double)field[3 * hi + c] - (double)field[3 * lo + c]) / span;
    }
    /* d(field index a) / d(image mm b) = map[a][b] / voxel[b]. */
    for (int c = 0; c < 3; c++)
        for (int b = 0; b < 3; b++) {
            double s = 0.0;
            for (int a = 0; a < 3; a++) {
                double m = f->has_map ? f->field_from_grid[4 * a + b] : (a == b ? 1.0 : 0.0);
                s += per_index[3 * c + a] * m;
            }
            grad[3 * c + b] = s / g->voxel_size[b];
        }
}

pb_status pb_field_check_folds(const pb_geometry *geometry, const pb_field_motion *field, pb_field_folds *folds)
{
    if (!geometry || !folds)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "geometry and folds must not be NULL");
    for (int i = 0; i < 3; i++)
        if (geometry->dims[i] == 0 || !(geometry->voxel_size[i] >= PB_MIN_VOXEL_MM) ||
            !(geometry->voxel_size[i] <= PB_MAX_VOXEL_MM))
            return pb_error(NULL, PB_ERR_BAD_VOXEL_SIZE, "the geometry's dimension %d (%zu voxels of %g mm) is not "
                            "a grid; give dims of at least 1 and voxel sizes of %g to %g mm", i, geometry->dims[i],
                            geometry->voxel_size[i], PB_MIN_VOXEL_MM, PB_MAX_VOXEL_MM);
    pb_status st = pb_field_validate(NULL, geometry, field);
    if (st != PB_OK)
        return st;
    *folds = (pb_field_folds){0, -1, -1, (double)INFINITY};
    size_t n = pb_field_voxels(field);
    for (size_t k = 0; k < field->count; k++) {
        const float *d = field->displacements + k * n * 3;
        for (size_t v = 0; v < n; v++) {
            double j[9];
            field_gradient(geometry, field, d, v, j);
            j[0] += 1.0;
            j[4] += 1.0;
            j[8] += 1.0;
            double det = j[0] * (j[4] * j[8] - j[5] * j[7]) - j[1] * (j[3] * j[8] - j[5] * j[6]) +
                         j[2] * (j[3] * j[7] - j[4] * j[6]);
            folds->worst_determinant = fmin(folds->worst_determinant, det);
            if (det <= 0.0) {
                if (folds->voxels++ == 0) {
                    folds->field = (long)k;
                    folds->voxel = (long)v;
                }
            }
        }
    }
    return PB_OK;
}
