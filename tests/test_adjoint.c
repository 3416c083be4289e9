/* pb_blur_adjoint is the transpose of pb_blur: <B x, y> = <x, B^T y> on fresh
 * random x and y, for every method, filter and kind of motion, on the backend
 * named on the command line.
 *
 * Tolerances. Both sides are sums of the same products computed in float (the
 * device kernels) or double (the host), stored as float: the relative
 * mismatch is a few float roundings, ~1e-6, so 1e-5 is asserted.
 *
 * HARDWARE: the forward's weights are the texture unit's. PoCL interpolates in
 * float, so there the adjoint (float weights) is the exact transpose and 1e-5
 * holds. NVIDIA's unit rounds each axis's fraction to 1/256, ties up
 * (bench/texture_rounding.cu: exact on 4 M one-axis fetches), and the adjoint
 * rounds alike; but its 3-D blend is not the exact product of those weights:
 * a single trilinear fetch of values in [0, 1) was measured up to 0.0070 from
 * the float-weight value (mean 8e-4, unbiased), so no scatter reproduces it
 * bit for bit. The tolerance there is derived from that: each tomograph
 * voxel's blur is an average of fetches (weights summing to 1), so it differs
 * from the float-weight blur by d_W with |d_W| <= e max|x|, e = 1/128 (above
 * the 0.0070 measured); with fresh random x these differences have zero mean
 * and sum_W y_W d_W has a standard deviation of at most
 * e max|x| sqrt(sum_W y_W^2). Six of those is the bound (hw_tolerance).
 * Under a motion of translations only the adjoint is a gather whose reads go
 * through the unit as well (cl/pb_shift.cl), each voxel an average of fetches
 * of y, which adds the same term with x and y swapped.
 *
 * A check of the check: the same dot product against the adjoint of a motion
 * 0.05 voxel off must miss by far more than the tolerance. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testlib.h"

#define EXACT_TOL 1e-5
#define FLOAT_HW_TOL 1e-5  /* PoCL and the host: float weights */
#define NVIDIA_FETCH_ERROR (1.0 / 128.0) /* a 3-D fetch's largest error, values in [0, 1) */

static const char *method_names[] = {"AB", "RM", "CL", "REF"};

typedef struct motion_case {
    const char *name;
    double times[5];
    pb_pose poses[5];
    size_t count;
    double frame[2];
} motion_case;

/* The kinds of motion: none (AB's walk degenerates to a point), translations
 * of several voxels on a slant, most along z, y or x (these four are
 * translations only: the shift-invariant kernels, the adjoint a gather; AB
 * HARDWARE reads layers along the translation's axis, along x 8 to 11 voxels
 * so that its forward's walks are long enough for them,
 * PB_X_LAYERS_MIN_SLICES, while its gather reads the 3-D image there,
 * src/devices/kernel_choice.c), a large turn (cut into several segments by the
 * default path bound), a track of several poses with the frame inside it, and
 * a long translation with a turn too small to cut it, whose one long segment
 * the scatter walks or reads as a chord. */
#define GATHER_CASES 4
#define CASES 7
static void make_cases(motion_case *c)
{
    double tilt[3] = {pb_rand_range(-0.5, 0.5), 1.0, pb_rand_range(-0.5, 0.5)};
    double axis2[3] = {1.0, pb_rand_range(-0.3, 0.3), 0.4};
    pb_pose still = pb_test_pose(0, 0, 0, NULL, 0);
    c[0] = (motion_case){"static", {0, 1}, {still, still}, 2, {0, 1}};
    c[1] = (motion_case){"translation", {0, 1},
                         {still, pb_test_pose(pb_rand_range(2, 5), pb_rand_range(-4, -1), pb_rand_range(6.5, 8), NULL, 0)},
                         2, {0, 1}};
    c[2] = (motion_case){"translation along y", {0, 1},
                         {still, pb_test_pose(pb_rand_range(-3, 3), pb_rand_range(6, 8), pb_rand_range(-3, 3), NULL, 0)},
                         2, {0, 1}};
    c[3] = (motion_case){"translation along x", {0, 1},
                         {still, pb_test_pose(pb_rand_range(9.6, 13.2), pb_rand_range(-3, 3), pb_rand_range(-3, 3), NULL,
                                              0)},
                         2, {0, 1}};
    c[4] = (motion_case){"rotation", {0, 1},
                         {still, pb_test_pose(pb_rand_range(-1, 1), 0.5, 0, tilt, pb_rand_range(30, 50))},
                         2, {0, 1}};
    c[5] = (motion_case){"track", {0, 0.3, 0.45, 0.8, 1.2}, {still}, 5, {0.1, 1.1}};
    for (int k = 1; k < 5; k++)
        c[5].poses[k] = pb_test_pose(pb_rand_range(-2, 2), pb_rand_range(-2, 2), pb_rand_range(-2, 2), axis2,
                                     pb_rand_range(-8, 8));
    c[6] = (motion_case){"translation and a small turn", {0, 1},
                         {still, pb_test_pose(pb_rand_range(7.5, 11), pb_rand_range(-4, -2), pb_rand_range(2, 4), tilt,
                                              pb_rand_range(0.5, 1.0))},
                         2, {0, 1}};
}

/* The relative HARDWARE tolerance on NVIDIA for these x and y (both in
 * [0, 1)), derived above; gather: the motion is translations only. */
static double hw_tolerance(const float *x, const float *y, size_t n, int gather, double lhs)
{
    double xx = 0.0, yy = 0.0;
    for (size_t i = 0; i < n; i++) {
        xx += (double)x[i] * (double)x[i];
        yy += (double)y[i] * (double)y[i];
    }
    return 6.0 * NVIDIA_FETCH_ERROR * (sqrt(yy) + (gather ? sqrt(xx) : 0.0)) / fabs(lhs);
}

static pb_motion motion_of(const motion_case *c)
{
    pb_motion m = {c->times, c->poses, c->count, c->frame[0], c->frame[1], 0, {0, 0, 0}};
    return m;
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *ctx = pb_test_context(argc, argv);
    int nvidia = pb_test_nvidia(ctx);
    pb_geometry g = {{17, 14, 11}, {1.2, 1.0, 1.5}};
    size_t n = 17 * 14 * 11;
    motion_case cases[CASES];
    make_cases(cases);
    float *x = pb_random_volume(n), *y = pb_random_volume(n);
    float *bx = malloc(n * sizeof *bx), *bty = malloc(n * sizeof *bty);

    /* Options: the paper's defaults, explicit sub-segments or steps, AB
     * read at two points a slice where its path sweeps sideways, and AB
     * reading every segment exactly (chord). */
    struct {
        pb_method method;
        unsigned steps;
        pb_ab_sampling sampling;
    } runs[] = {{PB_METHOD_AB, 0, 0}, {PB_METHOD_AB, 3, 0}, {PB_METHOD_AB, 0, PB_AB_SAMPLING_SWEEP},
                {PB_METHOD_AB, 2, PB_AB_SAMPLING_SWEEP}, {PB_METHOD_AB, 0, PB_AB_SAMPLING_CHORD},
                {PB_METHOD_RM, 0, 0}, {PB_METHOD_RM, 5, 0},
                {PB_METHOD_CL, 0, 0}, {PB_METHOD_REF, 0, 0}};
    double worst[2] = {0.0, 0.0};
    for (size_t r = 0; r < sizeof runs / sizeof runs[0]; r++)
        for (int filter = 0; filter < 2; filter++) {
            if (runs[r].method == PB_METHOD_REF && filter == PB_FILTER_HARDWARE)
                continue; /* REF reads nearest voxels with either */
            for (int c = 0; c < CASES; c++) {
                pb_motion m = motion_of(&cases[c]);
                pb_blur_options opt = {runs[r].method, (pb_filter)filter, runs[r].steps, 24, 0, 7, PB_PATH_DEFAULT, 0.0,
                                       runs[r].sampling, 0};
                if (!pb_check(pb_test_blur(ctx, &g, x, &m, &opt, bx) == PB_OK &&
                                  pb_test_adjoint(ctx, &g, y, &m, &opt, bty) == PB_OK,
                              "%s steps %u sampling %s %s: blur or adjoint failed", method_names[runs[r].method],
                              runs[r].steps, pb_ab_sampling_name(runs[r].sampling), cases[c].name))
                    continue;
                double lhs = pb_dot(bx, y, n), rhs = pb_dot(x, bty, n);
                double rel = fabs(lhs - rhs) / fabs(lhs);
                double tol = filter == PB_FILTER_EXACT ? EXACT_TOL
                             : nvidia                    ? hw_tolerance(x, y, n, c < GATHER_CASES, lhs)
                                                         : FLOAT_HW_TOL;
                worst[filter] = fmax(worst[filter], rel);
                pb_check(rel <= tol && isfinite(rel), "%s steps %u sampling %s %s %s: <Bx,y> = %.9g, <x,B^T y> = %.9g, "
                         "relative mismatch %.3g > %.3g", method_names[runs[r].method], runs[r].steps,
                         pb_ab_sampling_name(runs[r].sampling), filter ? "EXACT" : "HARDWARE", cases[c].name, lhs, rhs,
                         rel, tol);
            }
        }
    printf("largest relative mismatch: HARDWARE %.3g (tolerance %s), EXACT %.3g\n", worst[0],
           nvidia ? "6 sigma of NVIDIA's fetch error, about 2.6e-3" : "1e-5", worst[1]);

    /* The check of the check: the adjoint of a motion 0.05 voxel off. */
    motion_case off = cases[1];
    off.poses[1].translation[0] += 0.05 * g.voxel_size[0];
    pb_motion m = motion_of(&cases[1]), m_off = motion_of(&off);
    pb_blur_options opt = {PB_METHOD_AB, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    if (pb_check(pb_test_blur(ctx, &g, x, &m, &opt, bx) == PB_OK &&
                     pb_test_adjoint(ctx, &g, y, &m_off, &opt, bty) == PB_OK,
                 "check of the check: blur or adjoint failed")) {
        double lhs = pb_dot(bx, y, n), rhs = pb_dot(x, bty, n), rel = fabs(lhs - rhs) / fabs(lhs);
        printf("a motion 0.05 voxel off: relative mismatch %.3g\n", rel);
        pb_check(rel > 20.0 * EXACT_TOL, "the adjoint of a motion 0.05 voxel off matches within %.3g: the dot "
                 "product cannot tell a wrong adjoint", rel);
    }

    free(x);
    free(y);
    free(bx);
    free(bty);
    pb_context_destroy(ctx);
    return pb_test_finish();
}
