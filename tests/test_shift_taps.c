/* A short motion of translations runs as the convolution of its taps
 * (cl/pb_taps.cl), measured once per plan from the walk's response to an
 * impulse (src/devices/shift_taps.c). Against the walk itself
 * (PETBLUR_SHIFT_TAPS=0) on fresh random volumes, grids, voxel sizes and
 * translations, for every method, AB's sweep and sub-segments, and both
 * filters, on the device backend named on the command line:
 *   - the plan chose the taps where the limit allows them (PETBLUR_SHIFT_TAPS
 *     set far above it: a check that the comparisons below compare two
 *     different kernels), and the walk where it is set below their number;
 *     by default, the taps exactly where they are at most the count worth
 *     reading for the frame's method, filter and path (pb_shift_taps_limit,
 *     never below PB_SHIFT_TAPS_MAX);
 *   - forward: the same weights summed in another order, so within float
 *     rounding, 2e-5 of the largest input (a tap outside its place, or one
 *     lost, costs far more: a voxel weight is at least 1e-3 here); where the
 *     texture unit rounds its weights (NVIDIA), within its rounding
 *     (PB_TEX_TRILINEAR_ERROR): a sample whose fraction lies within a float
 *     step of a rounding tie may round apart at the impulse's small voxel
 *     coordinates and at a voxel's far out;
 *   - adjoint: the taps' own transpose, <B x, y> = <x, B^T y> to 1e-5; and
 *     against the walk's mirrored gather, within float rounding where the
 *     device filters in float, within the texture unit's rounding
 *     (PB_TEX_TRILINEAR_ERROR) where it rounds its weights (NVIDIA);
 *   - the identity: one tap of weight 1, the input back bit for bit (AB, RM;
 *     CL builds each step's map from the pose in float, an ulp off the
 *     voxel's centre, and reads its neighbours at weights of that size);
 *   - both taps kernels ran: pb_shift_taps_tile, which reads a group's input
 *     from local memory where the taps' window fits it, and pb_shift_taps. */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "objects.h" /* which kernel a plan chose */
#include "testlib.h"

static const char *method_names[] = {"AB", "RM", "CL", "REF"};

/* The forward kernel a plan of one frame chose, under the limit that
 * PETBLUR_SHIFT_TAPS sets, and the limit of taps worth reading for that
 * frame's path by default (pb_shift_taps_limit, without the variable), on
 * this device and on a GPU. */
static pb_kernel_id planned_kernel(pb_context *ctx, const pb_geometry *g, const pb_motion *m,
                                   const pb_blur_options *opt, int *taps, long *worth, long *gpu_worth)
{
    pb_plan *plan = NULL;
    pb_kernel_id k = PB_KERNEL_COUNT;
    if (pb_check(pb_plan_create(ctx, g, m, opt, &plan) == PB_OK, "plan: %s", pb_last_error(ctx))) {
        k = plan->set.frame[0].forward_fresh;
        *taps = plan->set.frame[0].forward_prm.taps;
        char *set = getenv("PETBLUR_SHIFT_TAPS");
        set = set ? strdup(set) : NULL;
        unsetenv("PETBLUR_SHIFT_TAPS");
        *worth = pb_shift_taps_limit(opt, &plan->set.frame[0].path, ctx->dev.info.is_gpu);
        *gpu_worth = pb_shift_taps_limit(opt, &plan->set.frame[0].path, 1);
        if (set)
            setenv("PETBLUR_SHIFT_TAPS", set, 1);
        free(set);
        pb_plan_destroy(plan);
    }
    return k;
}

/* Either taps kernel: the plain one, or the one whose group holds its input
 * in local memory (where the taps' window is small enough). */
static int is_taps(pb_kernel_id k)
{
    return k < PB_KERNEL_COUNT && pb_kernel_table[k].family == PB_FAMILY_TAPS;
}

/* The plan's other paths through the taps kernels, against the one-shot
 * calls' bx = B x and bty = B^T y: the forward in progress slabs (a launch a
 * slab, each from its prm.z0) bit for bit, and the adjoint added into an
 * object volume that holds z (pb_plan_adjoint's accumulate), z + B^T y. */
static void plan_paths(pb_context *ctx, const pb_geometry *g, const pb_motion *m, const pb_blur_options *opt,
                       const float *x, const float *y, const float *bx, const float *bty, const char *what)
{
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    float *z = pb_random_volume(n), *got = malloc(n * sizeof *got);
    pb_volume *object = NULL, *tomograph = NULL;
    pb_plan *plan = NULL;
    pb_status st = pb_volume_create(ctx, g, &object);
    if (st == PB_OK)
        st = pb_volume_create(ctx, g, &tomograph);
    if (st == PB_OK)
        st = pb_plan_create(ctx, g, m, opt, &plan);
    pb_test_progress_log log = {0, 0, 0.0};
    if (st == PB_OK)
        st = pb_volume_upload(object, x);
    if (st == PB_OK)
        st = pb_context_set_progress(ctx, pb_test_record_progress, &log);
    if (st == PB_OK)
        st = pb_plan_forward(plan, 0, object, tomograph);
    pb_context_set_progress(ctx, NULL, NULL);
    if (st == PB_OK)
        st = pb_volume_download(tomograph, got);
    if (pb_check(st == PB_OK, "%s: the plan in slabs: %s", what, pb_last_error(ctx))) {
        pb_check(log.calls >= 3 && log.bad == 0 && memcmp(got, bx, n * sizeof *got) == 0,
                 "%s: in %d progress slabs (%d bad) the forward differs from one launch by %g", what, log.calls,
                 log.bad, pb_max_abs_diff(got, bx, n));
        st = pb_volume_upload(tomograph, y);
        if (st == PB_OK)
            st = pb_volume_upload(object, z);
        if (st == PB_OK)
            st = pb_plan_adjoint(plan, 0, tomograph, object, 1);
        if (st == PB_OK)
            st = pb_volume_download(object, got);
        if (pb_check(st == PB_OK, "%s: the adjoint added: %s", what, pb_last_error(ctx))) {
            for (size_t i = 0; i < n; i++)
                z[i] += bty[i];
            pb_check(pb_max_abs_diff(got, z, n) <= 1e-6 * pb_max_abs(z, n),
                     "%s: the adjoint added into z is %g from z + B^T y", what, pb_max_abs_diff(got, z, n));
        }
    }
    pb_plan_destroy(plan);
    pb_volume_destroy(object);
    pb_volume_destroy(tomograph);
    free(z);
    free(got);
}

/* The taps whatever their number, past the default limit. */
#define FORCED "100000"

static void set_limit(const char *limit)
{
    if (limit)
        setenv("PETBLUR_SHIFT_TAPS", limit, 1);
    else
        unsetenv("PETBLUR_SHIFT_TAPS");
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *ctx = pb_test_context(argc, argv);
    if (pb_context_backend(ctx) == PB_BACKEND_HOST) {
        printf("the host backend walks every path itself\n");
        pb_context_destroy(ctx);
        return PB_TEST_SKIP;
    }
    int rounds = ctx->dev.texture_weight_steps > 0.0f;
    struct {
        pb_method method;
        unsigned steps;
        pb_ab_sampling sampling;
    } runs[] = {{PB_METHOD_AB, 0, 0}, {PB_METHOD_AB, 2, 0}, {PB_METHOD_AB, 0, PB_AB_SAMPLING_SWEEP},
                {PB_METHOD_AB, 0, PB_AB_SAMPLING_CHORD}, {PB_METHOD_RM, 0, 0}, {PB_METHOD_RM, 3, 0},
                {PB_METHOD_CL, 0, 0}};
    int kernels_met[2] = {0, 0}; /* the plain taps kernel's plans, the tile's */
    for (int draw = 0; draw < 3; draw++) {
        pb_geometry g;
        size_t n = 1;
        /* The second draw's grid is large enough that under the short motions
         * below every axis has voxels whose taps all land inside, runs of
         * PB_TAP_RUN along z among them: only there does pb_shift_taps read
         * without its checks at the rim. The third's holds work groups of
         * pb_shift_taps_tile whose whole tile lies inside (at least 72 x 16 x
         * 38 for any window the tile takes), read without checks, and enough
         * slices for three progress slabs; it runs AB and RM. */
        static const double lo[3][3] = {{10, 10, 10}, {26, 26, 26}, {72, 16, 40}};
        static const double hi[3][3] = {{23, 23, 23}, {34, 34, 34}, {80, 24, 48}};
        for (int d = 0; d < 3; d++) {
            g.dims[d] = (size_t)pb_rand_range(lo[draw][d], hi[draw][d]);
            g.voxel_size[d] = pb_rand_range(1.5, 3.0);
            n *= g.dims[d];
        }
        /* Up to 2.5 voxels along each axis, either way, and a track of three
         * translations through the frame; the identity; a still pose far
         * off, half the grid to beyond it along each axis (a short path far
         * from the reference: taps that land partly outside, or nowhere); and
         * 4-5 voxels along y and z, whose taps' window is too large for the
         * kernel that holds a group's input in local memory (PB_TAP_TY),
         * where the identity's one tap always fits it; and 6.5-9 voxels along
         * one axis, which AB and RM walk or sample (the rule by length walks
         * a segment of PB_AB_WALK_FROM voxels or more). */
        double t[3], s[3], far[3], longer[3], along[3];
        int axis = (int)(pb_rand_uniform() * 3.0) % 3;
        for (int d = 0; d < 3; d++) {
            t[d] = pb_rand_range(-2.5, 2.5) * g.voxel_size[d];
            s[d] = pb_rand_range(-1.5, 1.5) * g.voxel_size[d];
            far[d] = (pb_rand_uniform() < 0.5 ? -1.0 : 1.0) * pb_rand_range(0.5, 1.1) * (double)g.dims[d] *
                     g.voxel_size[d];
            longer[d] = d == 0 ? pb_rand_range(-0.5, 0.5) * g.voxel_size[d]
                               : (pb_rand_uniform() < 0.5 ? -1.0 : 1.0) * pb_rand_range(4.0, 5.0) * g.voxel_size[d];
            along[d] = (d == axis ? (pb_rand_uniform() < 0.5 ? -1.0 : 1.0) * pb_rand_range(6.5, 9.0)
                                  : pb_rand_range(-1.5, 1.5)) * g.voxel_size[d];
        }
        pb_pose away = pb_test_pose(far[0], far[1], far[2], NULL, 0);
        pb_pose still = pb_test_pose(0, 0, 0, NULL, 0);
        pb_pose poses[3] = {still, pb_test_pose(t[0], t[1], t[2], NULL, 0), pb_test_pose(s[0], s[1], s[2], NULL, 0)};
        double times[3] = {0.0, pb_rand_range(0.3, 0.7), 1.0}, unit[2] = {0.0, 1.0};
        pb_motion motions[6] = {{times, poses, 2, 0.0, times[1], 0, {0, 0, 0}}, {times, poses, 3, 0.0, 1.0, 0, {0, 0, 0}},
                                {unit, (pb_pose[]){still, still}, 2, 0.0, 1.0, 0, {0, 0, 0}},
                                {unit, (pb_pose[]){away, away}, 2, 0.0, 1.0, 0, {0, 0, 0}},
                                {unit, (pb_pose[]){still, pb_test_pose(longer[0], longer[1], longer[2], NULL, 0)}, 2,
                                 0.0, 1.0, 0, {0, 0, 0}},
                                {unit, (pb_pose[]){still, pb_test_pose(along[0], along[1], along[2], NULL, 0)}, 2,
                                 0.0, 1.0, 0, {0, 0, 0}}};
        const char *motion_names[6] = {"a translation", "a track of translations", "the identity", "a pose far off",
                                       "a longer translation", "a walked translation"};
        for (int c = 0; c < 6; c++) {
            pb_motion m = motions[c];
            for (size_t r = 0; r < sizeof runs / sizeof runs[0]; r++)
                for (int filter = 0;
                     filter < 2 && (draw < 2 || r == 0 || (runs[r].method == PB_METHOD_RM && runs[r].steps == 0));
                     filter++) {
                    pb_blur_options opt = {runs[r].method, (pb_filter)filter, runs[r].steps, 0, 0, 0,
                                           PB_PATH_DEFAULT, 0.0, runs[r].sampling, 0};
                    char what[160];
                    snprintf(what, sizeof what, "draw %d, %s, %s sampling %s steps %u %s", draw, motion_names[c],
                             method_names[runs[r].method], pb_ab_sampling_name(runs[r].sampling), runs[r].steps,
                             filter ? "EXACT" : "HARDWARE");
                    int taps = 0, walk_taps = 0, default_taps = 0;
                    long worth = 0, gpu_worth = 0, unused;
                    set_limit(NULL);
                    pb_kernel_id chosen = planned_kernel(ctx, &g, &m, &opt, &default_taps, &worth, &gpu_worth);
                    set_limit(FORCED);
                    pb_kernel_id k = planned_kernel(ctx, &g, &m, &opt, &taps, &unused, &unused);
                    set_limit("0");
                    pb_kernel_id walk = planned_kernel(ctx, &g, &m, &opt, &walk_taps, &unused, &unused);
                    kernels_met[k == PB_KERNEL_SHIFT_TAPS_TILE] += is_taps(k);
                    if (!pb_check(is_taps(k) && !is_taps(walk),
                                  "%s: kernels %s and %s, not the taps and the walk", what,
                                  k < PB_KERNEL_COUNT ? pb_kernel_table[k].name : "none",
                                  walk < PB_KERNEL_COUNT ? pb_kernel_table[walk].name : "none"))
                        continue;
                    pb_check(is_taps(chosen) == (taps <= worth),
                             "%s: %d taps, %ld worth reading, the default chose %s", what, taps, worth,
                             chosen < PB_KERNEL_COUNT ? pb_kernel_table[chosen].name : "none");
                    /* Independently of the rule's code: every path is worth its taps on a device without a
                     * texture unit; on a GPU every path here through the EXACT filter, AB's chord sampling and
                     * CL, and where the rule by length reads every segment's chord (shorter than
                     * PB_AB_WALK_FROM, AB's sub-segments each); a translation walked or sampled through
                     * HARDWARE 40 + 2.1 L (AB) and 15 + 4.4 S (RM) of them, L its length along its major axis in
                     * voxels, S RM's samples (L by default). The GPU's rule is stated on every device. */
                    if (!ctx->dev.info.is_gpu)
                        pb_check(is_taps(chosen) && worth == LONG_MAX,
                                 "%s: %d taps, %ld worth reading on a device without a texture unit, the default "
                                 "chose %s", what, taps, worth,
                                 chosen < PB_KERNEL_COUNT ? pb_kernel_table[chosen].name : "none");
                    if (c == 0 || c == 5) {
                        const double *d = c == 0 ? t : along;
                        double L = 0.0;
                        for (int a = 0; a < 3; a++)
                            L = fmax(L, fabs(d[a]) / g.voxel_size[a]);
                        int rm = runs[r].method == PB_METHOD_RM, cl = runs[r].method == PB_METHOD_CL;
                        int chord = runs[r].sampling == PB_AB_SAMPLING_CHORD;
                        double sub = !rm && runs[r].steps > 1 ? L / runs[r].steps : L;
                        int by_length = !rm || runs[r].steps == 0;
                        if (filter == PB_FILTER_EXACT || cl || chord || (by_length && sub < (double)PB_AB_WALK_FROM))
                            pb_check(gpu_worth == LONG_MAX && is_taps(chosen),
                                     "%s: %d taps, %ld worth reading on a GPU, the default chose %s", what, taps,
                                     gpu_worth, chosen < PB_KERNEL_COUNT ? pb_kernel_table[chosen].name : "none");
                        else {
                            double S = runs[r].steps ? runs[r].steps : L; /* RM's samples, one segment */
                            double want = fmax(PB_SHIFT_TAPS_MAX, rm ? 15 + 4.4 * S : 40 + 2.1 * L);
                            pb_check(fabs((double)gpu_worth - want) <= 1.0,
                                     "%s: %ld taps worth reading on a GPU, not %g", what, gpu_worth, want);
                        }
                    }
                    char below[16];
                    snprintf(below, sizeof below, "%d", taps - 1);
                    set_limit(below);
                    pb_check(taps == 0 || !is_taps(planned_kernel(ctx, &g, &m, &opt, &walk_taps, &unused, &unused)),
                             "%s: %d taps chosen under a limit of %s", what, taps, below);

                    float *x = pb_random_volume(n), *y = pb_random_volume(n);
                    float *bx = malloc(n * sizeof *bx), *bty = malloc(n * sizeof *bty);
                    float *wx = malloc(n * sizeof *wx), *wty = malloc(n * sizeof *wty);
                    set_limit(FORCED);
                    pb_status st = pb_test_blur(ctx, &g, x, &m, &opt, bx);
                    if (st == PB_OK)
                        st = pb_test_adjoint(ctx, &g, y, &m, &opt, bty);
                    set_limit("0");
                    if (st == PB_OK)
                        st = pb_test_blur(ctx, &g, x, &m, &opt, wx);
                    if (st == PB_OK)
                        st = pb_test_adjoint(ctx, &g, y, &m, &opt, wty);
                    set_limit(NULL);
                    if (pb_check(st == PB_OK, "%s: %s", what, pb_last_error(ctx))) {
                        /* Where the unit rounds, a sample's fraction within a float step of a rounding tie
                         * may round one way for the impulse's small grid and the other at a voxel far out. */
                        double tol = rounds && filter == PB_FILTER_HARDWARE ? 2.0 * PB_TEX_TRILINEAR_ERROR : 2e-5;
                        double fwd = pb_max_abs_diff(bx, wx, n) / pb_max_abs(x, n);
                        pb_check(fwd <= tol, "%s: forward %g of the largest input from the walk's (%d taps, %g)",
                                 what, fwd, taps, tol);
                        double lhs = pb_dot(bx, y, n), rhs = pb_dot(x, bty, n);
                        pb_check(fabs(lhs - rhs) <= 1e-5 * fabs(lhs), "%s: <Bx, y> %.9g, <x, B^T y> %.9g", what,
                                 lhs, rhs);
                        double adj = pb_max_abs_diff(bty, wty, n) / pb_max_abs(y, n);
                        pb_check(adj <= tol, "%s: adjoint %g of the largest input from the walk's gather (%g)",
                                 what, adj, tol);
                        if (c == 2 && runs[r].method != PB_METHOD_CL)
                            pb_check(taps == 1 && memcmp(bx, x, n * sizeof *x) == 0 &&
                                         memcmp(bty, y, n * sizeof *y) == 0,
                                     "%s: %d taps, the input not returned bit for bit", what, taps);
                        if (draw == 2 && c < 2) {
                            set_limit(FORCED);
                            plan_paths(ctx, &g, &m, &opt, x, y, bx, bty, what);
                            set_limit(NULL);
                        }
                    }
                    free(x);
                    free(y);
                    free(bx);
                    free(bty);
                    free(wx);
                    free(wty);
                }
        }
    }
    pb_check(kernels_met[0] > 0 && kernels_met[1] > 0, "the plain taps kernel ran %d plans, the tile's %d: "
             "both should have", kernels_met[0], kernels_met[1]);
    pb_context_destroy(ctx);
    return pb_test_finish();
}
