/* The estimator's fit of a frame as a dwell along a line with fitted ends
 * (src/estimate/line_dwell.c), on fresh heads each run (the late contrast,
 * Gaussian noise of 1 % of the peak): a frame that holds pose A for 0.3-0.5
 * of its time and ramps evenly to B, a jerk of 6-9 mm and 6-9 degrees away,
 * over the rest (a slow jerk), and a frame that holds A and then B with a
 * transit of a twentieth (a quick jerk). Fitted from two poses 0.5-1.5 mm off
 * where two poses fitted to such a frame lie (the ramp's: a tenth and six
 * tenths of the way; the jerk's: A and B), the line a quarter beyond either,
 * as two_pose_frames starts it.
 *
 * Asserted: the line leaves less than one pose does, and at least 0.85 of
 * its dwell lies within a voxel of the truth's path from A to B (measured
 * while writing this test, 36 fits: 0.915-1.000). Not asserted, because it
 * does not hold: where along that path the frame dwelt. Views a voxel apart
 * mix into views between them, so at jumps of 3-4 voxels the quick jerk's
 * ends came out 0.4-3.5 mm off A and B and its dwell spread over the points
 * beside them as the ramp's did (docs/estimate-log.md, "A line with fitted
 * ends"). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "heads.h"
#include "motion.h"
#include "testlib.h"

enum { NX = 40, NY = 36, NZ = 30, CASES = 3, RAMP_VIEWS = 24, POINTS = 9 };
/* the least share of the line's dwell within a voxel of the truth's path */
#define ALONG 0.85

static pb_status view_of(pb_context *ctx, const pb_geometry *g, const float *x, const pb_pose *p, const double c[3],
                         float *out)
{
    double times[2];
    pb_pose poses[2];
    pb_motion m;
    pbe_static_motion(p, c, times, poses, &m);
    return pb_test_blur(ctx, g, x, &m, NULL, out);
}

/* The line fitted from near lo and hi of the way from A to B: the share of
 * its dwell within a voxel of the path from A to B, its ends and residual,
 * and the one pose's residual for comparison. */
static pb_status fit(pb_context *ctx, pbe_level *level, const float *frame, const double c[3], const pb_pose *at,
                     const pb_pose *bt, double lo, double hi, double *along, pb_pose *s, pb_pose *t, double *sse, double *one_sse)
{
    pb_pose q1, q3, mean;
    pb_pose_interpolate(at, bt, lo, &q1);
    pb_pose_interpolate(at, bt, hi, &q3);
    pb_pose_interpolate(at, bt, 0.5, &mean);
    pb_pose_normalized(&mean, &mean);
    q1 = pbt_jittered(&q1, pb_rand_range(0.5, 1.5));
    q3 = pbt_jittered(&q3, pb_rand_range(0.5, 1.5));
    pb_pose_interpolate(&q1, &q3, -0.25, s);
    pb_pose_interpolate(&q1, &q3, 1.25, t);
    pb_pose_normalized(s, s);
    pb_pose_normalized(t, t);
    double times[2], u[POINTS + 1];
    pb_pose poses[2];
    pb_motion m;
    pbe_static_motion(&mean, c, times, poses, &m);
    pbe_fit one = {0};
    one.pose = mean;
    pb_status st = pbe_register(ctx, level, frame, c, 60, &one);
    if (st == PB_OK)
        st = pbe_blur_support(ctx, level, &m);
    float *view = pbe_level_views(level, 1);
    if (st == PB_OK && !view)
        st = PB_ERR_OUT_OF_MEMORY;
    if (st == PB_OK)
        st = pbe_view(ctx, level, &one.pose, c, view);
    if (st == PB_OK)
        *one_sse = pbe_weighted_sse(NULL, view, frame, level->host[PBE_SUPPORT], level->n);
    if (st == PB_OK)
        st = pbe_line_dwell(ctx, level, frame, c, s, t, POINTS, 30, u, sse);
    /* the dwell's share within a voxel of the truth's path from A to B */
    double total = 0.0, near = 0.0;
    for (int i = 0; i < POINTS && st == PB_OK && isfinite(*sse); i++) {
        pb_pose p, q;
        pb_pose_interpolate(s, t, (double)i / (POINTS - 1), &p);
        pb_pose_normalized(&p, &p);
        double d = (double)INFINITY;
        for (int j = 0; j <= 40; j++) {
            pb_pose_interpolate(at, bt, j / 40.0, &q);
            pb_pose_normalized(&q, &q);
            d = fmin(d, pbt_pose_distance(&p, &q));
        }
        total += fmax(u[i], 0.0);
        near += d < level->g.voxel_size[0] ? fmax(u[i], 0.0) : 0.0;
    }
    *along = total > 0 ? near / total : -1.0;
    return st;
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_test_deadline(600, "line dwell");
    pb_context *ctx = pb_test_context(argc, argv);
    for (int cs = 0; cs < CASES; cs++) {
        pb_geometry g = pbt_head_grid(NX, NY, NZ);
        const double v = g.voxel_size[0];
        const size_t n = (size_t)NX * NY * NZ;
        float *late = malloc(sizeof(float) * n), *frame = malloc(sizeof(float) * n), *va = malloc(sizeof(float) * n);
        pb_status st = late && frame && va ? pbt_late_head(&g, late) : PB_ERR_OUT_OF_MEMORY;
        const double c[3] = {0.5 * NX * g.voxel_size[0], 0.5 * NY * g.voxel_size[1], 0.5 * NZ * g.voxel_size[2]};
        pb_pose a_true, b_true;
        pbt_jerk(6.0, 9.0, &a_true, &b_true);

        /* a slow jerk: A held for a share of 0.3-0.5, then an even ramp to B */
        const double held = pb_rand_range(0.3, 0.5);
        if (st == PB_OK)
            st = view_of(ctx, &g, late, &a_true, c, frame);
        for (size_t i = 0; i < n && st == PB_OK; i++)
            frame[i] = (float)(held * (double)frame[i]);
        for (int r = 0; r < RAMP_VIEWS && st == PB_OK; r++) {
            pb_pose p;
            pb_pose_interpolate(&a_true, &b_true, (r + 0.5) / RAMP_VIEWS, &p);
            pb_pose_normalized(&p, &p);
            if ((st = view_of(ctx, &g, late, &p, c, va)) == PB_OK)
                for (size_t i = 0; i < n; i++)
                    frame[i] += (float)((1.0 - held) / RAMP_VIEWS * (double)va[i]);
        }
        const double peak = pb_max_abs(frame, n);
        for (size_t i = 0; i < n; i++)
            frame[i] += (float)(0.01 * peak * pbt_gauss());
        pbe_level level;
        if (st == PB_OK)
            st = pbe_level_init(ctx, &level, &g, NULL);
        if (st == PB_OK)
            st = pbe_level_set_reference(&level, late);
        pb_check(st == PB_OK, "case %d: set up: %s", cs, pb_last_error(NULL));
        if (st != PB_OK)
            return pb_test_finish();
        const double apart = pbt_pose_distance(&a_true, &b_true);
        double along = 0.0, sse = 0.0, one_sse = 0.0;
        pb_pose s, e;
        st = fit(ctx, &level, frame, c, &a_true, &b_true, 0.1, 0.6, &along, &s, &e, &sse, &one_sse);
        pb_check(st == PB_OK, "case %d: the ramp's fit: %s", cs, pb_last_error(NULL));
        printf("case %d: voxel %.2f mm, A and B %.2f mm apart, a ramp after %.2f held at A: the line's ends %.3f and "
               "%.3f mm off A and B, %.3f of its dwell along the path, residual %.4g against one pose's %.4g\n",
               cs, v, apart, held, pbt_pose_distance(&s, &a_true), pbt_pose_distance(&e, &b_true), along, sse,
               one_sse);
        pb_check(sse < one_sse, "case %d: the ramp: the line leaves %.4g, one pose %.4g", cs, sse, one_sse);
        pb_check(along >= ALONG, "case %d: the ramp: %.3f of the line's dwell along the path", cs, along);

        /* a quick jerk: A for a share of 0.3-0.7, B for the rest less a twentieth halfway between */
        const double share = pb_rand_range(0.3, 0.7);
        pb_pose mid;
        pb_pose_interpolate(&a_true, &b_true, 0.5, &mid);
        pb_pose_normalized(&mid, &mid);
        st = view_of(ctx, &g, late, &a_true, c, frame);
        for (size_t i = 0; i < n && st == PB_OK; i++)
            frame[i] = (float)(share * (double)frame[i]);
        if (st == PB_OK && (st = view_of(ctx, &g, late, &b_true, c, va)) == PB_OK)
            for (size_t i = 0; i < n; i++)
                frame[i] += (float)((0.95 - share) * (double)va[i]);
        if (st == PB_OK && (st = view_of(ctx, &g, late, &mid, c, va)) == PB_OK)
            for (size_t i = 0; i < n; i++)
                frame[i] += (float)(0.05 * (double)va[i]);
        const double jerk_peak = pb_max_abs(frame, n);
        for (size_t i = 0; i < n; i++)
            frame[i] += (float)(0.01 * jerk_peak * pbt_gauss());
        if (st == PB_OK)
            st = fit(ctx, &level, frame, c, &a_true, &b_true, 0.0, 1.0, &along, &s, &e, &sse, &one_sse);
        pb_check(st == PB_OK, "case %d: the quick jerk's fit: %s", cs, pb_last_error(NULL));
        const double ea = pbt_pose_distance(&s, &a_true), eb = pbt_pose_distance(&e, &b_true);
        printf("case %d: a quick jerk, %.2f at A: the line's ends %.3f and %.3f mm off A and B, %.3f of its "
               "dwell along the path, residual %.4g against one pose's %.4g\n", cs, share, ea, eb, along, sse, one_sse);
        pb_check(sse < one_sse, "case %d: the jerk: the line leaves %.4g, one pose %.4g", cs, sse, one_sse);
        pb_check(along >= ALONG, "case %d: the jerk: %.3f of the line's dwell along the path", cs, along);
        pbe_level_free(&level);
        free(late);
        free(frame);
        free(va);
    }
    pb_context_destroy(ctx);
    return pb_test_finish();
}
