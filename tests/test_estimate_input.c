/* pb_motion_estimate at the edges of its input, on fresh random series: voxel
 * sizes far outside a scanner's (refused before any work, by name and value,
 * never a crash), smoothing far wider than the grid, frame times near the
 * largest doubles, a failure's message its own, not an earlier call's, and
 * the report's warnings of a background and of frames of noise alone, and
 * the reference frame the report names, asked for or chosen. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testlib.h"

enum { SIDE = 8, FRAMES = 3 };

/* A blob at a random place per frame over a little noise: a series with
 * something to register. */
static float *random_series(size_t n_frames)
{
    const size_t n = SIDE * SIDE * SIDE;
    float *f = malloc(n * n_frames * sizeof *f);
    double c[3];
    for (int a = 0; a < 3; a++)
        c[a] = pb_rand_range(3.0, 4.0);
    for (size_t k = 0; k < n_frames; k++)
        for (size_t i = 0; i < n; i++) {
            double x = (double)(i % SIDE) - c[0], y = (double)(i / SIDE % SIDE) - c[1],
                   z = (double)(i / SIDE / SIDE) - c[2] - 0.2 * (double)k;
            f[k * n + i] = (float)(100.0 * exp(-(x * x + y * y + z * z) / 5.0) + pb_rand_range(0.0, 2.0));
        }
    return f;
}

static void expect_refused(pb_context *ctx, const pb_geometry *g, const float *f, const double *b, const char *what)
{
    pb_track *t = (pb_track *)1;
    pb_status st = pb_motion_estimate(ctx, g, NULL, f, FRAMES, b, NULL, &t, NULL);
    const char *text = pb_last_error(ctx);
    pb_check(st == PB_ERR_BAD_VOXEL_SIZE && t == NULL && strstr(text, "voxel size") &&
                 strstr(text, "0.0001 to 10000 mm"),
             "%s (%g, %g, %g mm): status %d, '%s'", what, g->voxel_size[0], g->voxel_size[1], g->voxel_size[2], st,
             text);
}

/* Voxel sizes from 1e-300 to 1e300 mm on a random axis: the smoothing's
 * radius was an int of 3 sigma, which overflowed (SIGSEGV). */
static void test_voxel_sizes(pb_context *ctx)
{
    float *f = random_series(FRAMES);
    double b[FRAMES + 1] = {0, 10, 20, 30};
    for (int trial = 0; trial < 6; trial++) {
        pb_geometry g = {{SIDE, SIDE, SIDE}, {2, 2, 2}};
        int axis = (int)(pb_rand_uniform() * 3);
        g.voxel_size[axis] = pow(10.0, pb_rand_range(-300.0, -4.5));
        expect_refused(ctx, &g, f, b, "a tiny voxel");
        g.voxel_size[axis] = pow(10.0, pb_rand_range(4.5, 300.0));
        expect_refused(ctx, &g, f, b, "a huge voxel");
    }
    /* the range's ends, and smoothing of 1000 mm over 0.0001 mm voxels: a
     * Gaussian ten million lines wide, cut to the grid. The middle axis's
     * size drawn over the range in mm and over its decades: between such
     * axes the fits' normal equations are near singular (pbe_within_grid) */
    for (int trial = 0; trial < 4; trial++) {
        const double middle = trial % 2 ? pow(10.0, pb_rand_range(-4.0, 4.0)) : pb_rand_range(1e-4, 1e4);
        pb_geometry g = {{SIDE, SIDE, SIDE}, {1e-4, middle, 1e4}};
        pb_estimate_options o = {0};
        o.fwhm_mm = 1000.0;
        pb_track *t = NULL;
        pb_status st = pb_motion_estimate(ctx, &g, NULL, f, FRAMES, b, &o, &t, NULL);
        pb_check(st == PB_OK && t && pb_track_count(t) >= FRAMES + 2, "voxels of %g, %g, %g mm with fwhm 1000: "
                 "status %d, '%s'", g.voxel_size[0], g.voxel_size[1], g.voxel_size[2], st, pb_last_error(ctx));
        pb_track_free(t);
    }
    /* two levels asked of voxels over half the range's top: the coarser
     * level's would be over it, so there is one level, not a refusal that
     * names a size the caller never gave (found by fuzz_estimate) */
    pb_geometry big = {{SIDE, SIDE, SIDE}, {2, 2, 2}};
    big.voxel_size[(int)(pb_rand_uniform() * 3)] = pb_rand_range(0.5 * PB_MAX_VOXEL_MM, PB_MAX_VOXEL_MM);
    pb_estimate_options two = {0};
    two.levels = 2;
    pb_track *t = NULL;
    pb_status st = pb_motion_estimate(ctx, &big, NULL, f, FRAMES, b, &two, &t, NULL);
    pb_check(st == PB_OK && t, "two levels of %g, %g, %g mm voxels: status %d, '%s'", big.voxel_size[0],
             big.voxel_size[1], big.voxel_size[2], st, pb_last_error(ctx));
    pb_track_free(t);
    free(f);
}

/* Frames near the largest doubles: each mid-time is (a + b) / 2 without the
 * sum's overflow; and the call after a failure tells its own outcome (it
 * once failed with the earlier call's "frame bound 2 is nan"). */
static void test_own_message(pb_context *ctx)
{
    float *f = random_series(FRAMES);
    pb_geometry g = {{SIDE, SIDE, SIDE}, {2, 2, 2}};
    double nan_bounds[FRAMES + 1] = {0, 10, (double)NAN, 30};
    pb_track *t = NULL;
    pb_status st = pb_motion_estimate(ctx, &g, NULL, f, FRAMES, nan_bounds, NULL, &t, NULL);
    pb_check(st != PB_OK && strstr(pb_last_error(ctx), "nan"), "a NaN bound: status %d, '%s'", st,
             pb_last_error(ctx));
    double top = DBL_MAX * pb_rand_range(0.5, 1.0), b[FRAMES + 1];
    for (int k = 0; k <= FRAMES; k++)
        b[k] = top * (1.0 - 0.05 * (double)(FRAMES - k));
    pb_estimate_options o = {0};
    o.frame_poses_only = 1; /* a key at every mid-time */
    st = pb_motion_estimate(ctx, &g, NULL, f, FRAMES, b, &o, &t, NULL);
    pb_check(st == PB_OK && t, "frames from %.17g s: status %d, '%s'", b[0], st, pb_last_error(ctx));
    if (st == PB_OK && t) {
        const double *times = pb_track_times(t);
        int mids = 0;
        for (size_t i = 0; i < pb_track_count(t); i++) {
            pb_check(isfinite(times[i]), "time %zu is %g", i, times[i]);
            for (int k = 0; k < FRAMES; k++)
                mids += times[i] == 0.5 * b[k] + 0.5 * b[k + 1];
        }
        pb_check(times[0] == b[0] && times[pb_track_count(t) - 1] == b[FRAMES] && mids == FRAMES,
                 "the track spans [%.17g, %.17g] with %d mid-times; want [%.17g, %.17g] and %d", times[0],
                 times[pb_track_count(t) - 1], mids, b[0], b[FRAMES], FRAMES);
    }
    pb_track_free(t);
    free(f);
}

/* What the report warns about: a series on a uniform background (subtracted)
 * and one of noise alone (its poses left at the identity). */
static void test_warnings(pb_context *ctx)
{
    const size_t n = SIDE * SIDE * SIDE;
    float *f = random_series(FRAMES);
    double b[FRAMES + 1] = {0, 10, 20, 30}, level = pb_rand_range(20.0, 60.0);
    pb_geometry g = {{SIDE, SIDE, SIDE}, {2, 2, 2}};
    for (size_t i = 0; i < n * FRAMES; i++)
        f[i] += (float)level;
    pb_estimate_report report = {0};
    pb_track *t = NULL;
    pb_status st = pb_motion_estimate(ctx, &g, NULL, f, FRAMES, b, NULL, &t, &report);
    pb_check(st == PB_OK && report.warnings.flags == PB_WARN_BACKGROUND && strstr(report.warnings.text, "subtracted"),
             "a background of %g: status %d, flags %u, '%s'", level, st, report.warnings.flags, report.warnings.text);
    pb_track_free(t);
    for (size_t i = 0; i < n * FRAMES; i++)
        f[i] = (float)pb_rand_range(0.0, 10.0);
    st = pb_motion_estimate(ctx, &g, NULL, f, FRAMES, b, NULL, &t, &report);
    int still = st == PB_OK;
    for (size_t i = 0; still && i < pb_track_count(t); i++)
        still = pb_track_poses(t)[i].rotation[0] == 1.0 && pb_track_poses(t)[i].translation[0] == 0.0;
    pb_check(st == PB_OK && (report.warnings.flags & PB_WARN_NO_STRUCTURE) && still &&
                 strstr(report.warnings.text, "3 of 3 frames (0, 1, 2) show no structure"),
             "frames of noise: status %d, still %d, flags %u, '%s'", st, still, report.warnings.flags,
             report.warnings.text);
    pb_track_free(t);
    free(f);
}

/* The frame the track is relative to: the one asked for, or, under
 * PB_ESTIMATE_REFERENCE_AUTO, one the estimate chooses and names (neither a
 * first frame of a tenth the others' signal, as a scan's first seconds, nor
 * a frame of noise alone); the track is the identity at its middle. A
 * reference out of range is refused, and its message names the automatic
 * choice. */
static void test_reference(pb_context *ctx)
{
    enum { N = 5 };
    const size_t n = SIDE * SIDE * SIDE;
    float *f = random_series(N);
    size_t noise = 1 + (size_t)(pb_rand_uniform() * (N - 1)); /* frames 1 to N - 1 */
    for (size_t i = 0; i < n; i++) {
        f[noise * n + i] = (float)pb_rand_range(0.0, 10.0);
        f[i] = 0.1f * f[i] + (float)pb_rand_range(0.0, 2.0);
    }
    pb_geometry g = {{SIDE, SIDE, SIDE}, {2, 2, 2}};
    double b[N + 1] = {0, 10, 20, 30, 40, 50};
    size_t asked[3] = {PB_ESTIMATE_REFERENCE_AUTO, 0, (size_t)(pb_rand_uniform() * N)};
    for (int c = 0; c < 3; c++) {
        pb_estimate_options o = {0};
        o.reference = asked[c];
        pb_estimate_report report = {0};
        report.reference = 99;
        pb_track *t = NULL;
        pb_status st = pb_motion_estimate(ctx, &g, NULL, f, N, b, &o, &t, &report);
        size_t r = report.reference;
        pb_check(st == PB_OK && t && r < N && (c == 0 ? r != noise && r != 0 : r == asked[c]),
                 "reference %zu asked (noise in frame %zu): status %d, named %zu, '%s'", asked[c], noise, st, r,
                 pb_last_error(ctx));
        for (size_t i = 0; st == PB_OK && t && r < N && i < pb_track_count(t); i++) {
            if (pb_track_times(t)[i] != 0.5 * (b[r] + b[r + 1]))
                continue;
            const pb_pose *p = &pb_track_poses(t)[i];
            double off = fabs(p->rotation[0] - 1.0);
            for (int a = 0; a < 3; a++)
                off = fmax(off, fmax(fabs(p->rotation[a + 1]), fabs(p->translation[a])));
            pb_check(off < 1e-9, "reference %zu asked: frame %zu's pose is %g from the identity", asked[c], r, off);
        }
        pb_track_free(t);
    }
    pb_estimate_options o = {0};
    o.reference = N + (size_t)(pb_rand_uniform() * 100.0);
    pb_track *t = (pb_track *)1;
    pb_status st = pb_motion_estimate(ctx, &g, NULL, f, N, b, &o, &t, NULL);
    pb_check(st == PB_ERR_INVALID_ARGUMENT && t == NULL && strstr(pb_last_error(ctx), "out of range") &&
                 strstr(pb_last_error(ctx), "PB_ESTIMATE_REFERENCE_AUTO"),
             "reference %zu of %d frames: status %d, '%s'", o.reference, N, st, pb_last_error(ctx));
    free(f);
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *ctx = pb_test_context(argc, argv);
    test_voxel_sizes(ctx);
    test_own_message(ctx);
    test_warnings(ctx);
    test_reference(ctx);
    pb_context_destroy(ctx);
    return pb_test_finish();
}
