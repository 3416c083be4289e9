/* Properties every backend must have, on fresh random volumes: zero motion gives
 * the input back, activity is conserved when nothing leaves the volume, and a
 * pure translation matches its analytic blur. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "testlib.h"

static const char *names[] = {"AB", "RM", "CL", "REF"};

static float *random_volume(const pb_geometry *g, size_t margin)
{
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    float *v = malloc(n * sizeof *v);
    for (size_t k = 0; k < g->dims[2]; k++)
        for (size_t j = 0; j < g->dims[1]; j++)
            for (size_t i = 0; i < g->dims[0]; i++) {
                int inside = i >= margin && j >= margin && k >= margin && i + margin < g->dims[0] &&
                             j + margin < g->dims[1] && k + margin < g->dims[2];
                v[i + g->dims[0] * (j + g->dims[1] * k)] = inside ? (float)pb_rand_range(0.1, 1.0) : 0.0f;
            }
    return v;
}

static void test_zero_motion(pb_context *ctx)
{
    pb_geometry g = {{13, 9, 7}, {1.3, 2.0, 2.4}};
    size_t n = 13 * 9 * 7;
    float *in = random_volume(&g, 0), *out = malloc(n * sizeof *out);
    double axis[3] = {0.3, -0.2, 1.0};
    /* The identity pose, once as (1, 0, 0, 0) and once as a 0-degree rotation
     * about an axis; the centre is irrelevant then. */
    pb_pose still = pb_test_pose(0, 0, 0, axis, 0.0);
    pb_test_motion tm;
    pb_test_motion_init(&tm, &still, &still);
    for (int method = 0; method < 4; method++)
        for (int filter = 0; filter < 2; filter++) {
            pb_blur_options opt = {(pb_method)method, (pb_filter)filter, 0, 16, 0, 7, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
            if (pb_test_blur(ctx, &g, in, &tm.motion, &opt, out) != PB_OK) {
                pb_check(0, "zero motion %s blur", names[method]);
                continue;
            }
            double d = pb_max_abs_diff(in, out, n);
            /* AB visits one slice with weight 1 and fetches at texel centres,
             * where every weight is exactly 0 or 1: the input comes back bit for
             * bit. REF's points never leave their voxel; only its float average
             * of equal values rounds. */
            double tol = method == PB_METHOD_AB ? 0.0 : 1e-6;
            pb_check(d <= tol, "zero motion %s %s: max |out - in| = %.3g > %.3g", names[method],
                     filter ? "EXACT" : "HARDWARE", d, tol);
        }
    free(in);
    free(out);
}

/* Total activity that AB and RM gather under a rotation of theta (radians)
 * about z, relative to the input: they follow the chord, not the arc, and at
 * fraction s of the chord the plane is scaled by
 * rho(s) = |(1 - s) + s e^(i theta)|, so they sample the object
 * 1 / rho(s)^2 times as densely. */
static double chord_gain(double theta)
{
    double sum = 0.0;
    int n = 2000;
    for (int i = 0; i < n; i++) {
        double s = (i + 0.5) / n;
        sum += 1.0 / (1.0 - 2.0 * s * (1.0 - s) * (1.0 - cos(theta)));
    }
    return sum / n;
}

static void test_conservation(pb_context *ctx)
{
    pb_geometry g = {{30, 28, 18}, {1.0, 1.0, 1.0}};
    size_t n = 30 * 28 * 18;
    float *in = random_volume(&g, 6), *out = malloc(n * sizeof *out);
    double total = pb_sum(in, n), z[3] = {0, 0, 1};
    /* Translations of up to 4 voxels, rotations of up to 12 degrees about the
     * centre: nothing reaches the 6-voxel empty margin. */
    for (int trial = 0; trial < 4; trial++) {
        int rotate = trial >= 2;
        double deg = rotate ? pb_rand_range(6, 12) * (trial == 2 ? 1 : -1) : 0.0;
        pb_pose a = pb_test_pose(0, 0, 0, NULL, 0);
        pb_pose b = pb_test_pose(pb_rand_range(-4, 4), pb_rand_range(-4, 4), pb_rand_range(-4, 4), z, deg);
        pb_test_motion tm;
        pb_test_motion_init(&tm, &a, &b);
        for (int method = 0; method < 4; method++) {
            /* The paper's one segment (no path cuts): the chord's gain is the check. */
            pb_blur_options opt = {(pb_method)method, PB_FILTER_EXACT, 0, 64, 4, 3, PB_PATH_TRACKED, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
            if (pb_test_blur(ctx, &g, in, &tm.motion, &opt, out) != PB_OK) {
                pb_check(0, "conservation %s blur", names[method]);
                continue;
            }
            /* A translation moves every trilinear footprint alike, so the weights
             * an object voxel hands out sum to 1 exactly; CL and REF follow the
             * arc of a rotation and conserve up to resampling (and REF's
             * sampling noise); AB and RM gather the chord's gain. */
            int chord = rotate && (method == PB_METHOD_AB || method == PB_METHOD_RM);
            double expect = chord ? chord_gain(deg * 3.14159265358979323846 / 180.0) : 1.0;
            double rel = fabs(pb_sum(out, n) / total - expect);
            double tol = method == PB_METHOD_REF ? 5e-3 : (rotate ? 1e-3 : 1e-5);
            pb_check(rel <= tol, "conservation %s, %s %.1f deg: total out / in - %.5f = %.3g > %.3g", names[method],
                     rotate ? "translation and rotation" : "translation", deg, expect, rel, tol);
        }
    }
    free(in);
    free(out);
}

/* Trilinear interpolation (texel coordinates) in double. */
static double trilinear(const float *v, const size_t *dims, const double u[3])
{
    double sum = 0.0;
    long i0[3];
    double f[3];
    for (int d = 0; d < 3; d++) {
        i0[d] = (long)floor(u[d] - 0.5);
        f[d] = u[d] - 0.5 - (double)i0[d];
    }
    for (int c = 0; c < 8; c++) {
        long idx[3];
        double w = 1.0;
        int outside = 0;
        for (int d = 0; d < 3; d++) {
            idx[d] = i0[d] + (c >> d & 1);
            w *= (c >> d & 1) ? f[d] : 1.0 - f[d];
            outside |= idx[d] < 0 || idx[d] >= (long)dims[d];
        }
        if (!outside)
            sum += w * (double)v[idx[0] + (long)dims[0] * (idx[1] + (long)dims[1] * idx[2])];
    }
    return sum;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The exact blur of a translation: for axis-aligned boxes the overlap is the
 * trilinear tent, so it is the time average of trilinear interpolation along
 * the path. Along a line, trilinear interpolation is a cubic between the points
 * where a coordinate crosses a voxel centre; Simpson's rule is exact there. */
static void analytic_translation(const float *v, const size_t *dims, const double shift[3], float *out)
{
    for (size_t k = 0; k < dims[2]; k++)
        for (size_t j = 0; j < dims[1]; j++)
            for (size_t i = 0; i < dims[0]; i++) {
                /* The object-space path of the voxel: u - shift * s, s in [0, 1]. */
                double u[3] = {i + 0.5, j + 0.5, k + 0.5};
                double cuts[512];
                int nc = 0;
                cuts[nc++] = 0.0;
                cuts[nc++] = 1.0;
                for (int d = 0; d < 3; d++) {
                    if (shift[d] == 0.0)
                        continue;
                    double x0 = u[d] - 0.5, x1 = u[d] - 0.5 - shift[d];
                    for (double c = ceil(fmin(x0, x1)); c <= floor(fmax(x0, x1)) && nc < 512; c += 1.0)
                        cuts[nc++] = (x0 - c) / shift[d];
                }
                qsort(cuts, (size_t)nc, sizeof cuts[0], cmp_double);
                double sum = 0.0;
                for (int c = 0; c + 1 < nc; c++) {
                    double s0 = cuts[c], s1 = cuts[c + 1], sm = 0.5 * (s0 + s1);
                    if (s1 <= s0)
                        continue;
                    double p0[3], p1[3], pm[3];
                    for (int d = 0; d < 3; d++) {
                        p0[d] = u[d] - shift[d] * s0;
                        p1[d] = u[d] - shift[d] * s1;
                        pm[d] = u[d] - shift[d] * sm;
                    }
                    sum += (s1 - s0) / 6.0 * (trilinear(v, dims, p0) + 4.0 * trilinear(v, dims, pm) +
                                              trilinear(v, dims, p1));
                }
                out[i + dims[0] * (j + dims[1] * k)] = (float)sum;
            }
}

/* Error of eq. (5) of the paper, in percent. */
static double error_percent(const float *ref, const float *x, size_t n)
{
    double num = 0.0, den = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)x[i] - (double)ref[i];
        num += d * d;
        den += (double)ref[i] * (double)ref[i];
    }
    return 100.0 * num / den;
}

/* Where AB's walk takes over from the exact chord, and up to where the chord
 * reads alone (PB_AB_WALK_FROM and PB_AB_EXACT_TO in cl/pb_kernel_types.h,
 * behind the library's boundary). */
#define AB_WALK_FROM 6.0
#define AB_EXACT_TO 5.0

/* AB under `sampling` against the analytic blur `exact` of the translation
 * by `move` voxels, with both filters: within `tol`, plus the texture unit's
 * 2^-9 of the largest input with HARDWARE where `rounds` (it reads between
 * texel centres). */
static void check_against_analytic(pb_context *ctx, const pb_geometry *g, const float *in, const pb_motion *m,
                                   pb_ab_sampling sampling, const double *move, const float *exact, float *out,
                                   double tol, int rounds)
{
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    for (int filter = 0; filter < 2; filter++) {
        pb_blur_options opt = {PB_METHOD_AB, (pb_filter)filter, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, sampling, 0};
        pb_test_blur(ctx, g, in, m, &opt, out);
        double d = pb_max_abs_diff(exact, out, n);
        double bound = filter == PB_FILTER_HARDWARE && rounds ? tol + pb_max_abs(in, n) / 512.0 : tol;
        pb_check(d <= bound, "AB %s (sampling %s), shift (%.2f, %.2f, %.2f): max |AB - analytic| = %.3g > %.3g",
                 filter ? "EXACT" : "HARDWARE", pb_ab_sampling_name(sampling), move[0], move[1], move[2], d, bound);
    }
}

static void test_analytic_translation(pb_context *ctx)
{
    pb_geometry g = {{14, 12, 10}, {1.5, 1.0, 2.0}};
    size_t n = 14 * 12 * 10;
    float *in = random_volume(&g, 0), *exact = malloc(n * sizeof *exact), *out = malloc(n * sizeof *out);
    pb_pose still = pb_test_pose(0, 0, 0, NULL, 0);

    /* Along one axis AB's slice shares are the exact tent integrals and nothing
     * moves inside a slice: the walk is the analytic blur up to float
     * rounding, and so is the exact chord that reads segments shorter than
     * PB_AB_WALK_FROM (6) voxels. The walk reads slices on their centre
     * planes, where the texture unit's weights are 0 or 1; the chord reads
     * between texel centres, where NVIDIA's unit rounds each weight to 1/256:
     * up to 2^-9 of the largest value there, a HARDWARE filter's own error. */
    double along_x[3] = {pb_rand_range(1.2, 6.0), 0.0, 0.0};
    pb_pose moved = pb_test_pose(along_x[0] * g.voxel_size[0], 0, 0, NULL, 0);
    pb_test_motion tm;
    pb_test_motion_init(&tm, &still, &moved);
    analytic_translation(in, g.dims, along_x, exact);
    check_against_analytic(ctx, &g, in, &tm.motion, PB_AB_SAMPLING_DEFAULT, along_x, exact, out, 2e-6,
                           along_x[0] < AB_WALK_FROM);

    /* A diagonal translation: AB's error falls as its sub-segments shrink the
     * in-slice motion, and REF's as its points grow. */
    double shift[3] = {pb_rand_range(3, 7), pb_rand_range(-6, -2), pb_rand_range(1, 4)};
    moved = pb_test_pose(shift[0] * g.voxel_size[0], shift[1] * g.voxel_size[1], shift[2] * g.voxel_size[2], NULL, 0);
    pb_test_motion_init(&tm, &still, &moved);
    analytic_translation(in, g.dims, shift, exact);
    double prev = (double)INFINITY;
    for (unsigned parts = 1; parts <= 64; parts *= 4) {
        pb_blur_options opt = {PB_METHOD_AB, PB_FILTER_EXACT, parts, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
        pb_test_blur(ctx, &g, in, &tm.motion, &opt, out);
        double e = error_percent(exact, out, n);
        printf("AB, %u sub-segment(s), shift (%.2f, %.2f, %.2f): error %.3g%%\n", parts, shift[0], shift[1],
               shift[2], e);
        /* Pieces of at most PB_AB_EXACT_TO voxels are read exactly: from
         * there on, float rounding. */
        double along = fmax(fabs(shift[0]), fmax(fabs(shift[1]), fabs(shift[2]))) / parts;
        pb_check(e < prev || e < 1e-4, "AB error falls with sub-segments (%u: %.3g%% after %.3g%%)", parts, e, prev);
        if (along <= AB_EXACT_TO)
            pb_check(e < 1e-4, "AB exact on pieces of %.2f voxels (%.3g%% from the analytic blur)", along, e);
        if (parts == 1)
            pb_check(e < 1.0, "AB on a diagonal translation within 1%% of the analytic blur (%.3g%%)", e);
        prev = e;
    }
    pb_check(prev < 1e-3, "AB with 64 sub-segments within 1e-3%% (%.3g%%)", prev);

    /* AB's chord sampling reads a segment exactly whatever its length: a
     * diagonal of 6-10 voxels along x, which the default walks, is the
     * analytic blur up to float rounding (and the texture unit's 1/256
     * weights with HARDWARE, as above). */
    double longer[3] = {pb_rand_range(6, 10), pb_rand_range(-6, -2), pb_rand_range(1, 4)};
    moved = pb_test_pose(longer[0] * g.voxel_size[0], longer[1] * g.voxel_size[1], longer[2] * g.voxel_size[2], NULL,
                         0);
    pb_test_motion_init(&tm, &still, &moved);
    analytic_translation(in, g.dims, longer, exact);
    check_against_analytic(ctx, &g, in, &tm.motion, PB_AB_SAMPLING_CHORD, longer, exact, out, 1e-5, 1);

    prev = (double)INFINITY;
    for (unsigned k = 4; k <= 1024; k *= 16) {
        pb_blur_options opt = {PB_METHOD_REF, PB_FILTER_EXACT, 0, k, 64, 11, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
        pb_test_blur(ctx, &g, in, &tm.motion, &opt, out);
        double e = error_percent(exact, out, n);
        printf("REF, %u points, 64 time steps: error %.3g%%\n", k, e);
        pb_check(e < 0.3 * prev, "REF error falls with points (%u: %.3g%% after %.3g%%)", k, e, prev);
        prev = e;
    }
    pb_check(prev < 0.05, "REF with 1024 points within 0.05%% (%.3g%%)", prev);
    free(in);
    free(exact);
    free(out);
}

/* The premise of PB_TEX_TRILINEAR_ERROR, measured: CL with one step samples
 * once, at the frame's middle pose, so a translation by 2 f voxels along x
 * fetches every voxel at x - f. On a 0, 1, 0, 1, ... row that fetch returns the
 * interpolation weight itself. f is a multiple of 2^-20, so every coordinate is
 * exact in float and only the filter's weights differ from the exact lerp. */
static void test_hardware_weights(pb_context *ctx)
{
    enum { N = 16 };
    pb_geometry g = {{N, 1, 1}, {1.0, 1.0, 1.0}};
    float in[N], out[N];
    for (int i = 0; i < N; i++)
        in[i] = (float)(i & 1);
    double worst = 0.0, off_grid = 0.0;
    for (int trial = 0; trial < 48; trial++) {
        double f = (double)(1 + (long)(pb_rand_uniform() * 1048575.0)) / 1048576.0; /* (0, 1) */
        pb_pose still = pb_test_pose(0, 0, 0, NULL, 0), moved = pb_test_pose(2.0 * f, 0, 0, NULL, 0);
        pb_test_motion tm;
        pb_test_motion_init(&tm, &still, &moved);
        pb_blur_options opt = {PB_METHOD_CL, PB_FILTER_HARDWARE, 1, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
        if (!pb_check(pb_test_blur(ctx, &g, in, &tm.motion, &opt, out) == PB_OK, "hardware weights blur"))
            return;
        for (int i = 1; i < N; i++) {
            /* x - 0.5 = i - f lies between voxels i - 1 and i, weight 1 - f on i. */
            double exact = f * (double)in[i - 1] + (1.0 - f) * (double)in[i];
            double e = fabs((double)out[i] - exact);
            worst = e > worst ? e : worst;
            double steps = (double)out[i] / PB_TEX_WEIGHT_STEP;
            off_grid = fmax(off_grid, fabs(steps - floor(steps + 0.5)));
        }
    }
    printf("hardware weights: largest error %.3g (bound 2^-9 = %.3g); largest distance of a weight from the 1/256 "
           "grid %.3g steps\n",
           worst, PB_TEX_STAGE_ERROR, off_grid);
    pb_check(worst <= PB_TEX_STAGE_ERROR + 1e-6, "a linear fetch's weight is off by %.3g > 2^-9", worst);
}

/* A progress report must not change the result: every backend then runs the
 * volume in slabs of z-slices (src/devices/launch.c), which every voxel must see
 * exactly as in one launch. nz = 70 is not a multiple of the slab (3) nor of
 * the deepest GPU work group (8, cl/pb_kernel_table.h): a group
 * reaching past its slab would scatter the next slab's voxels twice in the
 * adjoint.
 * The adjoint's atomic adds come in any order, hence its small tolerance. */
static void test_progress(pb_context *ctx)
{
    pb_geometry g = {{9, 11, 70}, {1.0, 1.2, 1.1}};
    size_t n = 9 * 11 * 70;
    float *in = random_volume(&g, 0), *plain = malloc(n * sizeof *plain), *sliced = malloc(n * sizeof *sliced);
    double axis[3] = {0.2, 1.0, 0.4};
    pb_pose a = pb_test_pose(0, 0, 0, axis, 0.0), b = pb_test_pose(2.5, -1.5, 6.0, axis, 7.0);
    pb_test_motion tm;
    pb_test_motion_init(&tm, &a, &b);
    for (int run = 0; run < 8; run++) {
        int method = run % 4, adjoint = run / 4;
        const char *what = adjoint ? "adjoint" : "blur";
        pb_blur_options opt = {(pb_method)method, PB_FILTER_HARDWARE, 0, 8, 0, 5, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
        pb_test_progress_log log = {0, 0, 0.0};
        pb_status (*apply)(pb_context *, const pb_geometry *, const float *, const pb_motion *,
                           const pb_blur_options *, float *) = adjoint ? pb_test_adjoint : pb_test_blur;
        pb_context_set_progress(ctx, NULL, NULL);
        pb_status s1 = apply(ctx, &g, in, &tm.motion, &opt, plain);
        pb_context_set_progress(ctx, pb_test_record_progress, &log);
        pb_status s2 = apply(ctx, &g, in, &tm.motion, &opt, sliced);
        pb_context_set_progress(ctx, NULL, NULL);
        if (!pb_check(s1 == PB_OK && s2 == PB_OK, "progress %s %s: failed", what, names[method]))
            continue;
        double d = pb_max_abs_diff(plain, sliced, n), tol = adjoint ? 1e-5 * pb_max_abs(plain, n) : 0.0;
        pb_check(d <= tol, "progress %s %s: slabbed result differs from one launch by %.3g (tolerance %.3g)", what,
                 names[method], d, tol);
        pb_check(log.bad == 0 && log.last == 1.0, "progress %s %s: fractions not increasing to 1 (last %g)", what,
                 names[method], log.last);
        /* A report after each slab of 3 slices, made a whole number of work
         * groups deep (2 or 8): at least 9 calls. */
        pb_check(log.calls >= 9, "progress %s %s: %d calls, expected at least 9", what, names[method], log.calls);
    }
    free(in);
    free(plain);
    free(sliced);
}

/* |v| across the unit axis k. */
static double across_axis(const double v[3], const double k[3])
{
    double along = v[0] * k[0] + v[1] * k[1] + v[2] * k[2], s = 0.0;
    for (int i = 0; i < 3; i++)
        s += (v[i] - along * k[i]) * (v[i] - along * k[i]);
    return sqrt(s);
}

/* The segments pb_path_segments must give, from the derivation in
 * include/petblur.h, computed here on its own: one tracked interval from the
 * identity to pose b (which turns, about a unit axis k) about the grid's
 * centre; distances across k. */
static size_t expected_segments(const pb_geometry *g, const pb_pose *b, const double k[3], double e)
{
    double r = 0.0, vmin = fmin(g->voxel_size[0], fmin(g->voxel_size[1], g->voxel_size[2]));
    for (int c = 0; c < 8; c++) {
        double d[3];
        for (int i = 0; i < 3; i++) /* corner voxel centre */
            d[i] = ((c >> i & 1) ? 0.5 : -0.5) * ((double)g->dims[i] - 1.0) * g->voxel_size[i];
        r = fmax(r, across_axis(d, k));
    }
    const double *q = b->rotation;
    double tn = across_axis(b->translation, k);
    double theta = 2.0 * acos(fmin(1.0, fabs(q[0])));
    double d = (theta * theta * (r + tn) + 2.0 * theta * tn) / vmin;
    return (size_t)fmax(1.0, ceil(sqrt(d / (8.0 * e))));
}

/* p turned by angle a about the unit axis k (Rodrigues), written here on its
 * own rather than through the library's quaternions. */
static void turn_about(const double k[3], double a, const double p[3], double o[3])
{
    double c = cos(a), s = sin(a), kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
    double x[3] = {k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2], k[0] * p[1] - k[1] * p[0]};
    for (int i = 0; i < 3; i++)
        o[i] = p[i] * c + x[i] * s + k[i] * kp * (1.0 - c);
}

/* The bound itself: under random turns (about any axis, the scanner's among
 * them) and translations on random grids, every corner voxel centre (where a
 * voxel strays furthest: its distance from the chord is convex in the voxel's
 * position) stays within E of the chords of the segments pb_path_segments
 * gives, sampled densely in time: the true path o(s) = R(s)^T (p - c - s t) + c
 * against the chord between the pieces' ends. */
static void test_path_bound(void)
{
    double worst = 0.0;
    int trials = 300, failures = 0;
    for (int trial = 0; trial < trials; trial++) {
        pb_geometry g = {{(size_t)pb_rand_range(8, 400), (size_t)pb_rand_range(8, 400), (size_t)pb_rand_range(8, 300)},
                         {pb_rand_range(0.8, 3), pb_rand_range(0.8, 3), pb_rand_range(0.8, 3)}};
        double k[3] = {0.0, 0.0, 1.0};
        if (trial % 3) {
            for (int i = 0; i < 3; i++)
                k[i] = pb_rand_range(-1, 1);
            double kn = sqrt(k[0] * k[0] + k[1] * k[1] + k[2] * k[2]);
            for (int i = 0; i < 3; i++)
                k[i] /= kn;
        }
        double deg = pb_rand_range(0.5, 60) * (pb_rand_uniform() < 0.5 ? -1 : 1), e = pb_rand_range(0.05, 1.0);
        double t[3] = {pb_rand_range(-20, 20), pb_rand_range(-20, 20), pb_rand_range(-20, 20)};
        pb_pose still = pb_test_pose(0, 0, 0, NULL, 0), moved = pb_test_pose(t[0], t[1], t[2], k, deg);
        pb_test_motion tm;
        pb_test_motion_init(&tm, &still, &moved);
        pb_blur_options ab = {PB_METHOD_AB, PB_FILTER_HARDWARE, 0, 0, 0, 0, PB_PATH_BOUNDED, e,
                              PB_AB_SAMPLING_DEFAULT, 0};
        size_t n = 0;
        if (!pb_check(pb_path_segments(&g, &tm.motion, &ab, &n) == PB_OK && n >= 1, "path bound: pb_path_segments"))
            return;
        double vmin = fmin(g.voxel_size[0], fmin(g.voxel_size[1], g.voxel_size[2])), a = deg * 3.14159265358979323846 / 180.0;
        double trial_worst = 0.0;
        for (int c = 0; c < 8; c++) {
            double p[3]; /* the corner voxel centre from the grid's centre */
            for (int i = 0; i < 3; i++)
                p[i] = ((c >> i & 1) ? 0.5 : -0.5) * ((double)g.dims[i] - 1.0) * g.voxel_size[i];
            for (size_t j = 0; j < n; j++) {
                double ends[2][3];
                for (int end = 0; end < 2; end++) {
                    double s = (double)(j + (size_t)end) / (double)n, w[3];
                    for (int i = 0; i < 3; i++)
                        w[i] = p[i] - s * t[i];
                    turn_about(k, -s * a, w, ends[end]); /* R(s)^T w */
                }
                for (int step = 1; step < 64; step++) {
                    double u = step / 64.0, s = ((double)j + u) / (double)n, w[3], o[3], d2 = 0.0;
                    for (int i = 0; i < 3; i++)
                        w[i] = p[i] - s * t[i];
                    turn_about(k, -s * a, w, o);
                    for (int i = 0; i < 3; i++) {
                        double chord = (1.0 - u) * ends[0][i] + u * ends[1][i];
                        d2 += (o[i] - chord) * (o[i] - chord);
                    }
                    trial_worst = fmax(trial_worst, sqrt(d2) / vmin / e);
                }
            }
        }
        worst = fmax(worst, trial_worst);
        if (trial_worst > 1.0 + 1e-9 && failures++ < 5)
            pb_check(0, "path bound: %.1f deg about (%.2f, %.2f, %.2f) on %zux%zux%zu, bound %.3f voxels, %zu "
                        "segments: a corner strays %.3f times the bound", deg, k[0], k[1], k[2], g.dims[0], g.dims[1],
                     g.dims[2], e, n, trial_worst);
    }
    pb_check(failures == 0, "path bound: %d of %d turns stray beyond it", failures, trials);
    printf("path bound: over %d random turns the corners stray at most %.3f times the bound\n", trials, worst);
}

/* Error-bounded paths under a large rotation: RM with many samples per
 * segment against CL with dense steps (both trilinear, EXACT; CL follows the
 * true path): the gap is the polyline's, and it must fall as the bound does,
 * with the split count of the derivation. AB gains the same way. */
static void test_path_error(pb_context *ctx)
{
    pb_geometry g = {{20, 18, 12}, {1.2, 1.0, 1.5}};
    size_t n = 20 * 18 * 12;
    float *in = random_volume(&g, 0), *truth = malloc(n * sizeof *truth), *out = malloc(n * sizeof *out);
    double axis[3] = {0.2, -0.3, 1.0}, an = sqrt(0.04 + 0.09 + 1.0);
    double axis_unit[3] = {axis[0] / an, axis[1] / an, axis[2] / an};
    double deg = pb_rand_range(35, 50) * (pb_rand_uniform() < 0.5 ? -1 : 1);
    pb_pose still = pb_test_pose(0, 0, 0, NULL, 0);
    pb_pose moved = pb_test_pose(pb_rand_range(-3, 3), pb_rand_range(-3, 3), pb_rand_range(-2, 2), axis, deg);
    pb_test_motion tm;
    pb_test_motion_init(&tm, &still, &moved);
    pb_blur_options cl = {PB_METHOD_CL, PB_FILTER_EXACT, 2000, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    pb_test_blur(ctx, &g, in, &tm.motion, &cl, truth);

    double prev = (double)INFINITY;
    size_t prev_segments = 0;
    for (double e = 4.0; e >= 0.06; e /= 4.0) {
        pb_blur_options rm = {PB_METHOD_RM, PB_FILTER_EXACT, 64, 0, 0, 0, PB_PATH_BOUNDED, e, PB_AB_SAMPLING_DEFAULT, 0};
        size_t segments = 0;
        pb_check(pb_path_segments(&g, &tm.motion, &rm, &segments) == PB_OK, "pb_path_segments");
        size_t want = expected_segments(&g, &moved, axis_unit, e);
        pb_check(segments == want, "%.1f deg, bound %g voxels: %zu segments, the derivation gives %zu", deg, e,
                 segments, want);
        pb_test_blur(ctx, &g, in, &tm.motion, &rm, out);
        double err = error_percent(truth, out, n);
        printf("RM against the true path, %.1f deg, bound %g voxels, %zu segments: %.3g%%\n", deg, e, segments, err);
        /* The chord's error goes with the square of the segment length and so
         * linearly with the bound (a quarter of it: at least 2.5x smaller).
         * A small turn can take one segment at both 4 and 1 voxels; the
         * polyline is then the same, and so must the blur be. */
        if (segments == prev_segments)
            pb_check(err == prev, "the same %zu segments at %g voxels, the same blur (%.9g%% after %.9g%%)",
                     segments, e, err, prev);
        else
            pb_check(err < prev / 2.5, "RM's error falls with the bound (%g: %.3g%% after %.3g%%)", e, err, prev);
        prev = err;
        prev_segments = segments;
    }
    pb_check(prev < 0.05, "RM with a bound of 1/16 voxel within 0.05%% of the true path (%.3g%%)", prev);

    /* AB: the default bound against the paper's one segment. */
    double err[2];
    for (int i = 0; i < 2; i++) {
        pb_blur_options ab = {PB_METHOD_AB, PB_FILTER_EXACT, 0, 0, 0, 0, i ? PB_PATH_DEFAULT : PB_PATH_TRACKED, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
        pb_test_blur(ctx, &g, in, &tm.motion, &ab, out);
        err[i] = error_percent(truth, out, n);
    }
    printf("AB against the true path, %.1f deg: one segment %.3g%%, default bound %.3g%%\n", deg, err[0], err[1]);
    pb_check(err[1] < 0.2 * err[0], "AB with the default bound: %.3g%%, not 5x below one segment's %.3g%%", err[1],
             err[0]);
    free(in);
    free(truth);
    free(out);
}

/* A 30 Hz motion log (181 poses over a 6 s frame) merged into chords within
 * the path bound (src/paths/path_split.c). A steady translation is one chord: one
 * segment, and the blur equals the blur between the frame's two end poses. A
 * slow turn keeps fewer segments than the log's 180, and its blur stays
 * within what the bound allows of a blur cut 25 times finer: values of a
 * smooth volume change by at most L per voxel moved (L: the volume's largest
 * step along any axis, times sqrt 3), so two paths within E1 and E2 of the
 * true path give blurs within (E1 + E2) L. */
static void fill_track(pb_pose *poses, double *times, int turn)
{
    double axis[3] = {0.3, 0.2, 1.0}, v[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), pb_rand_range(-1, 1)};
    double rate = turn ? pb_rand_range(1.5, 2.5) : 0.0; /* degrees per second */
    for (int i = 0; i <= 180; i++) {
        times[i] = i / 30.0;
        poses[i] = pb_test_pose(v[0] * times[i], v[1] * times[i], v[2] * times[i], axis, rate * times[i]);
    }
}

static void test_track_merge(pb_context *ctx)
{
    pb_geometry g = {{24, 20, 16}, {1.5, 1.5, 2.0}};
    size_t n = 24 * 20 * 16;
    float *in = malloc(n * sizeof *in), *merged = malloc(n * sizeof *merged), *fine = malloc(n * sizeof *fine);
    double c[3] = {pb_rand_range(9, 14), pb_rand_range(8, 12), pb_rand_range(6, 9)}, step = 0.0;
    for (size_t k = 0; k < n; k++) {
        double x = (double)(k % 24) - c[0], y = (double)(k / 24 % 20) - c[1], z = (double)(k / 480) - c[2];
        in[k] = (float)exp(-(x * x + y * y + z * z) / 18.0);
    }
    for (size_t k = 0; k < n; k++) {
        if (k % 24 + 1 < 24)
            step = fmax(step, fabs((double)(in[k + 1] - in[k])));
        if (k / 24 % 20 + 1 < 20)
            step = fmax(step, fabs((double)(in[k + 24] - in[k])));
        if (k + 480 < n)
            step = fmax(step, fabs((double)(in[k + 480] - in[k])));
    }
    static pb_pose poses[181];
    static double times[181];
    for (int turn = 0; turn < 2; turn++) {
        fill_track(poses, times, turn);
        pb_motion m = {times, poses, 181, 0.0, 6.0, 0, {0, 0, 0}};
        pb_blur_options opt = {PB_METHOD_AB, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
        pb_blur_options raw = opt, finer = opt;
        raw.path = PB_PATH_TRACKED;
        finer.path = PB_PATH_BOUNDED;
        finer.max_path_error = 0.01;
        size_t segs = 0, raw_segs = 0;
        if (!pb_check(pb_path_segments(&g, &m, &opt, &segs) == PB_OK &&
                          pb_path_segments(&g, &m, &raw, &raw_segs) == PB_OK,
                      "track merge: pb_path_segments failed"))
            continue;
        printf("30 Hz track, %s: %zu segments (the log has %zu)\n", turn ? "slow turn" : "steady translation", segs,
               raw_segs);
        pb_check(raw_segs == 180, "track merge: without cuts the log gives %zu segments, expected 180", raw_segs);
        if (!turn) {
            pb_check(segs == 1, "track merge: a steady translation gives %zu segments, expected 1", segs);
            pb_motion ends = {(double[]){0.0, 6.0}, (pb_pose[]){poses[0], poses[180]}, 2, 0.0, 6.0, 0, {0, 0, 0}};
            if (pb_check(pb_test_blur(ctx, &g, in, &m, &opt, merged) == PB_OK &&
                             pb_test_blur(ctx, &g, in, &ends, &opt, fine) == PB_OK,
                         "track merge: blur failed")) {
                double d = pb_max_abs_diff(merged, fine, n);
                pb_check(d <= 1e-6, "track merge: the merged log differs from its two end poses by %.3g", d);
            }
        } else {
            pb_check(segs >= 1 && segs < 180, "track merge: a slow turn keeps %zu segments of 180", segs);
            if (pb_check(pb_test_blur(ctx, &g, in, &m, &opt, merged) == PB_OK &&
                             pb_test_blur(ctx, &g, in, &m, &finer, fine) == PB_OK,
                         "track merge: blur failed")) {
                double d = pb_max_abs_diff(merged, fine, n), bound = (PB_DEFAULT_MAX_PATH_ERROR + 0.01) * step * sqrt(3.0);
                printf("30 Hz slow turn: merged blur against a 25x finer bound: %.3g (bound %.3g)\n", d, bound);
                pb_check(d <= bound, "track merge: merged blur differs by %.3g > %.3g", d, bound);
            }
        }
    }
    free(in);
    free(merged);
    free(fine);
}

/* Walks clipped to the grid (src/paths/path_clip.c): a translation of D along x
 * over the frame averages the object over shifts 0..D, and every shift past
 * the grid reads zeros, so blur(D) = (D0 / D) blur(D0) for any D0 beyond the
 * grid. A D of a million mm must give that, and its adjoint must still be
 * the transpose. AB, exact along one axis, must also give the analytic blur:
 * the integral of the row's linear interpolant (zero outside) up to the
 * voxel, (dx / D) (sum of the values before it + half its own), which a
 * clip that cuts too early misses. */
static void test_clipped_walks(pb_context *ctx)
{
    pb_geometry g = {{20, 10, 8}, {1.5, 1.0, 2.0}};
    size_t n = 20 * 10 * 8;
    float *in = random_volume(&g, 0), *far = malloc(n * sizeof *far), *near = malloc(n * sizeof *near);
    float *y = random_volume(&g, 0), *bty = malloc(n * sizeof *bty);
    double d0 = 3.0 * 20 * 1.5, d = 1e6 * pb_rand_range(1.0, 2.0), axis[3] = {1, 0, 0};
    pb_pose start = pb_test_pose(0, 0, 0, axis, 0.0), end_far = pb_test_pose(d, 0, 0, axis, 0.0),
            end_near = pb_test_pose(d0, 0, 0, axis, 0.0);
    pb_test_motion tf, tn;
    pb_test_motion_init(&tf, &start, &end_far);
    pb_test_motion_init(&tn, &start, &end_near);
    for (int method = 0; method < 3; method++) {
        pb_blur_options opt = {(pb_method)method, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
        if (pb_test_blur(ctx, &g, in, &tf.motion, &opt, far) != PB_OK ||
            pb_test_blur(ctx, &g, in, &tn.motion, &opt, near) != PB_OK) {
            pb_check(0, "%s: %s", names[method], pb_last_error(ctx));
            continue;
        }
        double worst = 0.0, top = pb_max_abs(near, n);
        for (size_t i = 0; i < n; i++)
            worst = fmax(worst, fabs((double)far[i] * (d / d0) - (double)near[i]));
        pb_check(worst <= 1e-4 * top, "%s: a %.3g mm translation is the %.3g mm one scaled by their ratio (off "
                 "%.3g of the largest value)", names[method], d, d0, worst / top);
        double analytic = 0.0, big = 0.0;
        for (size_t row = 0; method == PB_METHOD_AB && row < n / 20; row++)
            for (size_t i = 0; i < 20; i++) {
                double sum = 0.0;
                for (size_t before = 0; before < i; before++)
                    sum += (double)in[row * 20 + before];
                double expect = 1.5 / d * (sum + 0.5 * (double)in[row * 20 + i]);
                analytic = fmax(analytic, fabs((double)far[row * 20 + i] - expect));
                big = fmax(big, expect);
            }
        pb_check(method != PB_METHOD_AB || analytic <= 1e-4 * big, "AB: the %.3g mm translation is the analytic "
                 "blur (off %.3g of the largest value)", d, analytic / big);
        if (pb_test_adjoint(ctx, &g, y, &tf.motion, &opt, bty) != PB_OK) {
            pb_check(0, "%s adjoint: %s", names[method], pb_last_error(ctx));
            continue;
        }
        double lhs = pb_dot(far, y, n), rhs = pb_dot(in, bty, n);
        pb_check(fabs(lhs - rhs) <= 1e-5 * fmax(fabs(lhs), 1e-30), "%s: <B x, y> = <x, B^T y> through a clipped "
                 "walk (%.9g, %.9g)", names[method], lhs, rhs);
    }
    free(in);
    free(far);
    free(near);
    free(y);
    free(bty);
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *ctx = pb_test_context(argc, argv);
    test_hardware_weights(ctx);
    test_zero_motion(ctx);
    test_clipped_walks(ctx);
    test_conservation(ctx);
    test_analytic_translation(ctx);
    test_path_error(ctx);
    test_path_bound();
    test_progress(ctx);
    test_track_merge(ctx);
    pb_context_destroy(ctx);
    return pb_test_finish();
}
