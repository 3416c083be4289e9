/* Field motions on a backend against the host backend (double precision,
 * independent code), and the transpose's dot test: random smooth fields on
 * the image grid and on a coarser grid of their own, every method, frames
 * that start and end between samples and on them. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testlib.h"

/* Relative to the largest value: float positions against double ones, and
 * the texture unit's weights for HARDWARE (testlib.h). */
#define TOL_EXACT 2e-4
#define TOL_HARDWARE 2e-2

/* count smooth fields on dims: a sum of a few random waves a field, mm. */
static float *random_fields(const size_t *dims, size_t count, double amplitude)
{
    size_t n = dims[0] * dims[1] * dims[2];
    float *f = malloc(count * n * 3 * sizeof *f);
    for (size_t k = 0; f && k < count; k++) {
        double w[3][4];
        for (int c = 0; c < 3; c++)
            for (int j = 0; j < 4; j++)
                w[c][j] = pb_rand_range(-1.0, 1.0);
        for (size_t v = 0; v < n; v++) {
            double p[3] = {(double)(v % dims[0]) / dims[0], (double)(v / dims[0] % dims[1]) / dims[1],
                           (double)(v / dims[0] / dims[1]) / dims[2]};
            for (int c = 0; c < 3; c++)
                f[(k * n + v) * 3 + c] = (float)(amplitude * (w[c][3] + sin(3.0 * (w[c][0] * p[0] + w[c][1] * p[1] +
                                                                                   w[c][2] * p[2]))));
        }
    }
    return f;
}

static pb_status run(pb_context *ctx, const pb_geometry *g, const pb_field_motion *fm, const pb_blur_options *opt,
                     int adjoint, const float *in, float *out)
{
    pb_plan *plan = NULL;
    pb_volume *a = NULL, *b = NULL;
    pb_status st = pb_plan_create_field(ctx, g, fm, opt, &plan);
    if (st == PB_OK)
        st = pb_volume_create(ctx, g, &a);
    if (st == PB_OK)
        st = pb_volume_create(ctx, g, &b);
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    float *poison = malloc(n * sizeof *poison);
    for (size_t i = 0; poison && i < n; i++)
        poison[i] = -1e30f;
    if (st == PB_OK)
        st = pb_volume_upload(a, in);
    if (st == PB_OK && poison)
        st = pb_volume_upload(b, poison);
    if (st == PB_OK)
        st = adjoint ? pb_plan_adjoint(plan, 0, a, b, 0) : pb_plan_forward(plan, 0, a, b);
    if (st == PB_OK)
        st = pb_volume_download(b, out);
    free(poison);
    pb_volume_destroy(a);
    pb_volume_destroy(b);
    pb_plan_destroy(plan);
    return st;
}

/* Every frame of a plan of three, forward and adjoint, into outs (3 x 2 x n). */
static pb_status run_frames(pb_context *ctx, const pb_geometry *g, const pb_field_motion *fm, const double *bounds,
                            const float *x, const float *y, float *outs)
{
    pb_plan *plan = NULL;
    pb_volume *a = NULL, *b = NULL;
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    pb_blur_options opt = {0};
    pb_status st = pb_plan_create_field_frames(ctx, g, fm, bounds, 3, &opt, &plan);
    if (st == PB_OK)
        st = pb_volume_create(ctx, g, &a);
    if (st == PB_OK)
        st = pb_volume_create(ctx, g, &b);
    for (size_t k = 0; k < 3 && st == PB_OK; k++)
        for (int adjoint = 0; adjoint < 2 && st == PB_OK; adjoint++) {
            st = pb_volume_upload(a, adjoint ? y : x);
            if (st == PB_OK)
                st = adjoint ? pb_plan_adjoint(plan, k, a, b, 0) : pb_plan_forward(plan, k, a, b);
            if (st == PB_OK)
                st = pb_volume_download(b, outs + (2 * k + (size_t)adjoint) * n);
        }
    pb_volume_destroy(a);
    pb_volume_destroy(b);
    pb_plan_destroy(plan);
    return st;
}

/* Frames whose fields pass the device's budget for resident fields stay on
 * the host and are uploaded for each launch (PETBLUR_FIELD_MEMORY_MIB=0
 * streams them all): the same kernels on the same data, the same numbers. */
static void check_streamed(pb_context *dev)
{
    pb_geometry g = {{11, 9, 10}, {2.0, 2.5, 1.8}};
    size_t n = g.dims[0] * g.dims[1] * g.dims[2];
    double times[6] = {0.0, 0.7, 1.5, 2.1, 3.0, 3.8}, bounds[4] = {0.2, 1.6, 2.5, 3.6};
    float *fields = random_fields(g.dims, 6, 4.0);
    pb_field_motion fm = {0};
    fm.times = times;
    fm.displacements = fields;
    fm.count = 6;
    for (int d = 0; d < 3; d++)
        fm.dims[d] = g.dims[d];
    fm.frame_start = times[0];
    fm.frame_end = times[5];
    float *x = pb_random_volume(n), *y = pb_random_volume(n);
    float *resident = malloc(6 * n * sizeof *resident), *streamed = malloc(6 * n * sizeof *streamed);
    char *before = getenv("PETBLUR_FIELD_MEMORY_MIB") ? strdup(getenv("PETBLUR_FIELD_MEMORY_MIB")) : NULL;
    pb_status s1 = run_frames(dev, &g, &fm, bounds, x, y, resident);
    setenv("PETBLUR_FIELD_MEMORY_MIB", "0", 1);
    pb_status s2 = run_frames(dev, &g, &fm, bounds, x, y, streamed);
    if (before)
        setenv("PETBLUR_FIELD_MEMORY_MIB", before, 1);
    else
        unsetenv("PETBLUR_FIELD_MEMORY_MIB");
    free(before);
    if (pb_check(s1 == PB_OK && s2 == PB_OK, "streamed frames: %s", pb_last_error(dev))) {
        /* The forward gathers, the same bits; the adjoint's scatter adds in
         * whatever order its threads meet. */
        size_t differ = 0;
        double scale = pb_max_abs(resident, 6 * n);
        for (size_t i = 0; i < 6 * n; i++) {
            int adjoint = (i / n) % 2;
            double e = fabs((double)resident[i] - (double)streamed[i]);
            differ += adjoint ? e > 1e-5 * scale : e != 0.0;
        }
        pb_check(differ == 0 && scale > 0.0, "streamed frames: %zu of %zu values differ from the resident plan's",
                 differ, 6 * n);
    }
    free(x);
    free(y);
    free(resident);
    free(streamed);
    free(fields);
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *dev = pb_test_context(argc, argv);
    pb_context *host = NULL;
    pb_context_options ho = {PB_BACKEND_HOST, 0, NULL};
    if (pb_context_create(&ho, &host) != PB_OK)
        return 1;
    const pb_method methods[] = {PB_METHOD_AB, PB_METHOD_RM, PB_METHOD_CL, PB_METHOD_REF};
    for (int round = 0; round < 4; round++) {
        pb_geometry g = {{(size_t)pb_rand_range(6, 14), (size_t)pb_rand_range(6, 14), (size_t)pb_rand_range(6, 14)},
                         {pb_rand_range(1.0, 3.0), pb_rand_range(1.0, 3.0), pb_rand_range(1.0, 3.0)}};
        size_t n = g.dims[0] * g.dims[1] * g.dims[2];
        pb_field_motion fm = {0};
        double times[5];
        size_t count = 3 + (size_t)(pb_rand_uniform() * 3);
        times[0] = pb_rand_range(-1.0, 0.0);
        for (size_t k = 1; k < count; k++)
            times[k] = times[k - 1] + pb_rand_range(0.2, 1.0);
        int mapped = round % 2;
        double coarse = mapped ? pb_rand_range(1.5, 2.5) : 1.0;
        for (int d = 0; d < 3; d++)
            fm.dims[d] = mapped ? (size_t)ceil((double)g.dims[d] / coarse) + 1 : g.dims[d];
        fm.has_map = mapped;
        for (int r = 0; r < 3; r++) {
            fm.field_from_grid[4 * r + r] = 1.0 / coarse;
            fm.field_from_grid[4 * r + 3] = mapped ? pb_rand_range(-0.3, 0.3) : 0.0;
        }
        float *fields = random_fields(fm.dims, count, pb_rand_range(1.0, 6.0));
        fm.times = times;
        fm.displacements = fields;
        fm.count = count;
        /* Between samples, or on them (the frame's last sample is its run's end). */
        fm.frame_start = round < 2 ? pb_rand_range(times[0], times[1]) : times[1];
        fm.frame_end = round < 2 ? pb_rand_range(times[count - 2], times[count - 1]) : times[count - 1];
        float *x = pb_random_volume(n), *y = pb_random_volume(n);
        float *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), *bt = malloc(n * sizeof *bt);
        for (int mi = 0; mi < 4; mi++)
            for (int filter = 0; filter < 2; filter++) {
                pb_blur_options opt = {0};
                opt.method = methods[mi];
                opt.filter = filter ? PB_FILTER_EXACT : PB_FILTER_HARDWARE;
                opt.ref_points = 16;
                opt.jacobian = round >= 2; /* the mass-preserving weights in half the rounds */
                if (opt.method == PB_METHOD_REF && filter)
                    continue;
                pb_status s1 = run(dev, &g, &fm, &opt, 0, x, a), s2 = run(host, &g, &fm, &opt, 0, x, b);
                if (!pb_check(s1 == PB_OK && s2 == PB_OK, "round %d method %d: %s", round, mi, pb_last_error(dev)))
                    continue;
                double tol = opt.filter == PB_FILTER_EXACT || opt.method == PB_METHOD_REF ? TOL_EXACT : TOL_HARDWARE;
                /* REF's points read the voxel that holds them: a point within
                 * rounding of a face may read the neighbour; count those. */
                size_t off = 0;
                double scale = pb_max_abs(b, n), worst = 0.0;
                for (size_t i = 0; i < n; i++) {
                    double e = fabs((double)a[i] - (double)b[i]);
                    worst = fmax(worst, e);
                    off += e > tol * scale;
                }
                pb_check(opt.method == PB_METHOD_REF ? off <= n / 50 : off == 0,
                         "round %d (%s fields) method %d filter %d: %zu voxels differ from the host's beyond %g of "
                         "%g (worst %g)", round, mapped ? "mapped" : "image-grid", mi, filter, off, tol, scale, worst);
                /* The dot test on this backend. */
                if (run(dev, &g, &fm, &opt, 1, y, bt) == PB_OK) {
                    double l = pb_dot(a, y, n), r = pb_dot(x, bt, n);
                    double rel = fabs(l - r) / fmax(fabs(l), fabs(r));
                    /* NVIDIA's texture unit blends HARDWARE's weights as the
                     * scatter cannot reproduce bit for bit (petblur.h). */
                    double dot_tol = opt.filter == PB_FILTER_HARDWARE && opt.method != PB_METHOD_REF ? 1e-3 : 1e-5;
                    pb_check(rel <= dot_tol,
                             "round %d method %d filter %d: <Bx, y> = %.9g, <x, B^T y> = %.9g (%.2g)", round, mi,
                             filter, l, r, rel);
                } else {
                    pb_check(0, "adjoint: %s", pb_last_error(dev));
                }
            }
        free(x);
        free(y);
        free(a);
        free(b);
        free(bt);
        free(fields);
    }
    check_streamed(dev);
    pb_context_destroy(host);
    pb_context_destroy(dev);
    return pb_test_finish();
}
