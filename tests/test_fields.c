/* Field motions on a backend against the host backend (double precision,
 * independent code), and the transpose's dot test: random smooth fields on
 * the image grid and on a coarser grid of their own, every method, frames
 * that start and end between samples and on them. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

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
    pb_context_destroy(host);
    pb_context_destroy(dev);
    return pb_test_finish();
}
