/* Every method and filter on a device backend against the host backend (double
 * precision, independent code) on small random volumes and random motions. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "path.h"
#include "testlib.h"

/* Relative to the largest value: float arithmetic on positions of a few tens of
 * voxels (ulp ~ 4e-6) times gradients of order one. */
#define TOL_EXACT 2e-5
/* HARDWARE: the texture unit's weights, PB_TEX_TRILINEAR_ERROR (derived in
 * testlib.h) times the largest input value, on top of float arithmetic. */

static void random_volume(const pb_geometry *g, float *v)
{
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    for (size_t i = 0; i < n; i++)
        v[i] = (float)pb_rand_uniform();
}

/* Up to 4 tracked poses; the frame lies inside the track. With translations
 * only, the device runs its shift-invariant kernels. With along_x, at least
 * 3 poses of translations only that swing 16 to 24 voxels along x and little
 * else: a whole middle segment is long enough for AB HARDWARE's layers along
 * x (src/devices/kernel_choice.c). */
static void random_motion(const pb_geometry *g, int translations, int along_x, pb_test_motion *tm, double *times,
                          pb_pose *poses, int *count)
{
    int n = (along_x ? 3 : 2) + (int)(pb_rand_uniform() * (along_x ? 2 : 3));
    double t = pb_rand_range(-1.0, 0.0);
    for (int i = 0; i < n; i++) {
        double axis[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), pb_rand_range(-1, 1)};
        double deg = translations || pb_rand_uniform() < 0.3 ? 0.0 : pb_rand_range(-25, 25);
        double x = along_x ? (i % 2 ? 1.0 : -1.0) * pb_rand_range(8, 12) : pb_rand_range(-4, 4), r = along_x ? 1.5 : 4;
        poses[i] = pb_test_pose(x * g->voxel_size[0], pb_rand_range(-r, r) * g->voxel_size[1],
                                pb_rand_range(-r, r) * g->voxel_size[2], axis, deg);
        times[i] = t;
        t += pb_rand_range(0.2, 1.0);
    }
    pb_test_motion_init(tm, &poses[0], &poses[1]);
    tm->motion.times = times;
    tm->motion.poses = poses;
    tm->motion.count = (size_t)n;
    tm->motion.frame_start = pb_rand_range(times[0], 0.5 * (times[0] + times[1]));
    tm->motion.frame_end = pb_rand_range(0.5 * (times[n - 2] + times[n - 1]), times[n - 1]);
    if (pb_rand_uniform() < 0.5) {
        tm->motion.has_center = 1;
        for (int d = 0; d < 3; d++)
            tm->motion.center[d] = pb_rand_range(0.2, 0.8) * (double)g->dims[d] * g->voxel_size[d];
    }
    *count = n;
}

/* Two discrete choices make a blur jump where a voxel's mapped path crosses a
 * threshold: the major axis (AB walks its slices along it; it switches where
 * two axes' extents tie), and RM's and CL's default step count (AB's slice
 * count, which grows where an end point crosses a slice boundary). The device
 * maps in float and the host in double, so a voxel within rounding of such an
 * edge may take the other choice on one side: a different sum, and an equally
 * right one. This marks those voxels from the plan both backends walk, with a
 * margin far above float rounding of coordinates below 100 voxels (~1e-5), and
 * returns how many there are. */
#define EDGE_MARGIN 1e-4
static size_t mark_edges(const pb_geometry *g, const pb_motion *m, const pb_blur_options *opt, unsigned char *edge)
{
    pb_path plan;
    if (!pb_check(pb_path_create(NULL, g, m, opt, &plan) == PB_OK, "plan for the edges"))
        return 0;
    size_t count = 0, idx = 0;
    for (size_t k = 0; k < g->dims[2]; k++)
        for (size_t j = 0; j < g->dims[1]; j++)
            for (size_t i = 0; i < g->dims[0]; i++, idx++) {
                double u[3] = {i + 0.5, j + 0.5, k + 0.5};
                edge[idx] = 0;
                for (size_t s = 0; s + 1 < plan.count && !edge[idx]; s++) {
                    double a[3], b[3], longest = 0.0;
                    for (int r = 0; r < 3; r++) {
                        const double *ma = plan.poses[s].map + 4 * r, *mb = plan.poses[s + 1].map + 4 * r;
                        a[r] = ma[0] * u[0] + ma[1] * u[1] + ma[2] * u[2] + ma[3];
                        b[r] = mb[0] * u[0] + mb[1] * u[1] + mb[2] * u[2] + mb[3];
                        longest = fmax(longest, fabs(b[r] - a[r]));
                    }
                    /* Over the axes that may be the major one: how many, and the
                     * fewest and most slices each gives with its end points moved
                     * by the margin. */
                    int majors = 0;
                    long fewest = -1, most = -1;
                    for (int r = 0; r < 3; r++) {
                        if (fabs(b[r] - a[r]) < longest - 2.0 * EDGE_MARGIN)
                            continue;
                        majors++;
                        double lo = fmin(a[r], b[r]) - 0.5, hi = fmax(a[r], b[r]) - 0.5;
                        long lo_n = (long)ceil(hi - EDGE_MARGIN) - (long)floor(lo + EDGE_MARGIN) + 1;
                        long hi_n = (long)ceil(hi + EDGE_MARGIN) - (long)floor(lo - EDGE_MARGIN) + 1;
                        fewest = fewest < 0 ? lo_n : (lo_n < fewest ? lo_n : fewest);
                        most = hi_n > most ? hi_n : most;
                    }
                    if (opt->method == PB_METHOD_AB)
                        edge[idx] = majors > 1;
                    else if (opt->steps == 0)
                        edge[idx] = fewest != most;
                }
                count += edge[idx];
            }
    pb_path_destroy(&plan);
    return count;
}

/* How many voxels are on an edge for AB, or for RM and CL, whichever more. */
static size_t edges(const pb_geometry *g, const pb_motion *m, unsigned char *edge)
{
    pb_blur_options ab = {PB_METHOD_AB, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    pb_blur_options rm = {PB_METHOD_RM, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    size_t a = mark_edges(g, m, &ab, edge), r = mark_edges(g, m, &rm, edge);
    return a > r ? a : r;
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *dev = pb_test_context(argc, argv);
    pb_context *host = NULL;
    pb_context_options ho = {PB_BACKEND_HOST, 0, NULL};
    if (!pb_check(pb_context_create(&ho, &host) == PB_OK, "host context"))
        return pb_test_finish();

    static const char *names[] = {"AB", "RM", "CL", "REF"};
    double worst[4][2] = {{0}};
    for (int trial = 0; trial < 6; trial++) {
        pb_geometry g = {{0}, {0}};
        for (int d = 0; d < 3; d++) {
            g.dims[d] = 6 + (size_t)(pb_rand_uniform() * 14);
            g.voxel_size[d] = pb_rand_range(0.8, 2.5);
        }
        if (trial == 3) /* more than one run of voxels along x (PB_X_RUN) */
            g.dims[0] = 12 + (size_t)(pb_rand_uniform() * 8);
        size_t n = g.dims[0] * g.dims[1] * g.dims[2];
        float *in = malloc(n * sizeof *in), *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
        unsigned char *edge = malloc(n);
        random_volume(&g, in);
        pb_test_motion tm;
        double times[4];
        pb_pose poses[4];
        int count;
        /* Every third trial translations only, the second such mostly along
         * x. Their voxels all walk alike, so an edge there would be every
         * voxel's: such a draw is redrawn. So is a turn so slight that more
         * than 1 % of the voxels lie within the margin of a tie (its
         * displacements vary little across the grid); the check below fails
         * if 50 draws find none, as when edges are marked wrongly. */
        int translations = trial % 3 == 0, draws = 0;
        do
            random_motion(&g, translations, trial == 3, &tm, times, poses, &count);
        while (++draws < 50 && edges(&g, &tm.motion, edge) > (translations ? 0 : n / 100));
        for (int method = 0; method < 4; method++) {
            for (int filter = 0; filter < 2; filter++) {
                pb_blur_options opt = {(pb_method)method, (pb_filter)filter, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
                if (method == PB_METHOD_REF) {
                    opt.ref_points = 24;
                    opt.ref_time_steps = 4;
                    opt.seed = (uint32_t)(pb_rand_uniform() * 4e9);
                }
                if (method == PB_METHOD_AB && pb_rand_uniform() < 0.3)
                    opt.steps = 2;
                /* AB's samplings in turn: each on both filters, on
                 * translations (trials 0 and 3) and on general motions. */
                static const pb_ab_sampling turn[3] = {PB_AB_SAMPLING_DEFAULT, PB_AB_SAMPLING_SWEEP,
                                                       PB_AB_SAMPLING_CHORD};
                if (method == PB_METHOD_AB)
                    opt.ab_sampling = turn[(trial / 3 + trial + filter) % 3];
                if (pb_test_blur(host, &g, in, &tm.motion, &opt, a) != PB_OK ||
                    pb_test_blur(dev, &g, in, &tm.motion, &opt, b) != PB_OK) {
                    pb_check(0, "blur %s failed", names[method]);
                    continue;
                }
                if (method != PB_METHOD_REF) {
                    /* Off the edges both backends sum the same samples; on them
                     * the device's value must still be a blur, an average of
                     * inputs (all in [0, 1)), and the edges must be few. */
                    size_t marked = mark_edges(&g, &tm.motion, &opt, edge), outside = 0;
                    for (size_t i = 0; i < n; i++)
                        if (edge[i]) {
                            outside += !(b[i] >= 0.0f && b[i] <= 1.0f);
                            b[i] = a[i];
                        }
                    pb_check(marked <= n / 100 && outside == 0,
                             "trial %d %s: %zu of %zu voxels on an edge, %zu of them outside [0, 1]", trial,
                             names[method], marked, n, outside);
                }
                double rel = pb_max_abs_diff(a, b, n) / pb_max_abs(a, n);
                if (isnan(rel) || rel > worst[method][filter])
                    worst[method][filter] = rel;
                double tol = TOL_EXACT;
                if (filter == PB_FILTER_HARDWARE && method != PB_METHOD_REF)
                    tol += PB_TEX_TRILINEAR_ERROR * pb_max_abs(in, n) / pb_max_abs(a, n);
                if (method == PB_METHOD_REF) {
                    /* REF's points are the same on both sides, but a point within
                     * float rounding of a voxel face may land in the neighbour:
                     * one such flip moves a voxel by 1 / (points x steps) of a
                     * value. Allow two in the worst voxel, and flips in at most
                     * 1% of the voxels. */
                    tol = 2.0 / (opt.ref_points * opt.ref_time_steps);
                    size_t flipped = 0;
                    for (size_t i = 0; i < n; i++)
                        flipped += fabs((double)a[i] - (double)b[i]) > 1e-5;
                    pb_check(flipped <= n / 100, "trial %d REF: %zu of %zu voxels differ by more than 1e-5", trial,
                             flipped, n);
                }
                pb_check(rel <= tol, "trial %d %s (sampling %s) %s: %zux%zux%zu, %d poses: max rel diff %.3g > %.3g",
                         trial, names[method], pb_ab_sampling_name(opt.ab_sampling),
                         filter ? "EXACT" : "HARDWARE", g.dims[0], g.dims[1], g.dims[2], count, rel, tol);
            }
        }
        free(in);
        free(a);
        free(b);
        free(edge);
    }
    for (int m = 0; m < 4; m++)
        printf("%-3s largest relative difference: HARDWARE %.3g, EXACT %.3g\n", names[m], worst[m][0], worst[m][1]);
    pb_context_destroy(host);
    pb_context_destroy(dev);
    return pb_test_finish();
}
