/* The estimator's fit of a frame as two poses held in turn
 * (src/estimate/two_poses.c), on fresh heads each run: a frame that holds
 * pose A for a share of its time and B, a jerk of 5-8 mm and 5-8 degrees
 * away, for the rest (the late contrast, Gaussian noise of 1 % of the
 * peak), fitted from starts 0.5-1.5 mm off each pose, as pass 3's path
 * halves give them. Measured on 160 fresh cases while writing this test:
 * each pose found within 0.35 voxel of its truth (median 0.10), the share
 * within 0.083 (median 0.019), and the frame dwelling at the two poses
 * (pbe_two_poses_held) for 0.82-0.99 of its time (median 0.925; PATH_TWO
 * asks 0.9, which passes a jerk between poses many voxels apart, as issue
 * 47's draw 142718924, and refuses about half of these). Asserted: 0.5
 * voxel, 0.12 and 0.75, and the residual below what the best one pose
 * leaves (register.c's fit from the frame's mean pose). A frame held at
 * one pose has no second pose to find: on those 160 the fit gave a share
 * under a twentieth or none (56) or moved a pose from its start by more
 * than half the starts' distance (108), and the frame dwelt at its two
 * poses under 0.9 of its time in 157; PATH_TWO refuses each (estimate.c,
 * two_pose_frames). That one of them holds is asserted: a fifth seed in
 * 80 had neither of the first two. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "heads.h"
#include "motion.h"
#include "testlib.h"

enum { NX = 40, NY = 36, NZ = 30, CASES = 4 };

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_test_deadline(600, "two poses");
    pb_context *ctx = pb_test_context(argc, argv);
    for (int cs = 0; cs < CASES; cs++) {
        pb_geometry g = pbt_head_grid(NX, NY, NZ);
        const double v = g.voxel_size[0];
        const size_t n = (size_t)NX * NY * NZ;
        float *late = malloc(sizeof(float) * n), *frame = malloc(sizeof(float) * n), *va = malloc(sizeof(float) * n);
        pb_status st = late && frame && va ? pbt_late_head(&g, late) : PB_ERR_OUT_OF_MEMORY;
        const double c[3] = {0.5 * NX * g.voxel_size[0], 0.5 * NY * g.voxel_size[1], 0.5 * NZ * g.voxel_size[2]};
        pb_pose a_true, b_true, mean;
        pbt_jerk(5.0, 8.0, &a_true, &b_true);
        const double share = pb_rand_range(0.2, 0.8);
        pb_pose_interpolate(&a_true, &b_true, 1.0 - share, &mean);
        pb_pose_normalized(&mean, &mean);

        /* the frame: A's view for the share, B's for the rest, and noise */
        double times[2];
        pb_pose poses[2];
        pb_motion m;
        pbe_static_motion(&a_true, c, times, poses, &m);
        if (st == PB_OK)
            st = pb_test_blur(ctx, &g, late, &m, NULL, va);
        pbe_static_motion(&b_true, c, times, poses, &m);
        if (st == PB_OK)
            st = pb_test_blur(ctx, &g, late, &m, NULL, frame);
        for (size_t i = 0; i < n; i++)
            frame[i] = (float)(share * (double)va[i] + (1.0 - share) * (double)frame[i]);
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

        /* one pose, from the mean; its weights (the support's blur there) are the two poses' too */
        pbe_fit one = {0};
        one.pose = mean;
        st = pbe_register(ctx, &level, frame, c, 60, &one);
        pbe_static_motion(&mean, c, times, poses, &m);
        if (st == PB_OK)
            st = pbe_blur_support(ctx, &level, &m);
        float *view = malloc(sizeof(float) * n);
        if (st == PB_OK)
            st = pbe_view(ctx, &level, &one.pose, c, view);
        const double one_sse = st == PB_OK ? pbe_weighted_sse(NULL, view, frame, level.host[PBE_SUPPORT], n) : 0.0;

        /* the two poses from starts off each */
        pb_pose a = pbt_jittered(&a_true, pb_rand_range(0.5, 1.5)), b = pbt_jittered(&b_true, pb_rand_range(0.5, 1.5));
        double found_share = -1.0, sse = 0.0;
        if (st == PB_OK)
            st = pbe_two_poses(ctx, &level, frame, c, &a, &b, 30, &found_share, &sse);
        const double apart = pbt_pose_distance(&a_true, &b_true);
        double held = 0.0;
        if (st == PB_OK)
            st = pbe_two_poses_held(ctx, &level, frame, c, &a, &b, v / apart, &held);
        pb_check(st == PB_OK, "case %d: the fits: %s", cs, pb_last_error(NULL));
        const double ea = pbt_pose_distance(&a, &a_true), eb = pbt_pose_distance(&b, &b_true);
        printf("case %d: voxel %.2f mm, poses %.2f mm apart, share %.3f: found %.3f, A %.3f mm and B %.3f mm off; "
               "residual %.4g against one pose's %.4g; held %.3f\n",
               cs, v, apart, share, found_share, ea, eb, sse, one_sse, held);
        pb_check(fabs(found_share - share) < 0.12, "case %d: share %.3f found, %.3f true", cs, found_share, share);
        pb_check(ea < 0.5 * v && eb < 0.5 * v, "case %d: the poses %.3f and %.3f mm off (voxel %.2f mm)", cs, ea, eb, v);
        pb_check(sse < one_sse, "case %d: two poses leave %.4g, one pose %.4g", cs, sse, one_sse);
        pb_check(held >= 0.75, "case %d: the frame dwells at its two poses for %.3f of its time", cs, held);

        /* a frame held at A alone, from starts as fresh: a second pose may fit its noise, but then it leaves
         * its start by more than half the starts' distance, or the shares say one pose, or the frame does not
         * dwell at the two poses for PATH_TWO's 0.9 of its time (PETBLUR_TEST_SEED=1796521555417326: share
         * 0.825, a pose moved 3.46 mm of 3.69, held 0.869) */
        pbe_static_motion(&a_true, c, times, poses, &m);
        for (size_t i = 0; i < n; i++)
            frame[i] = va[i] + (float)(0.01 * peak * pbt_gauss());
        const pb_pose a0 = pbt_jittered(&a_true, pb_rand_range(0.5, 1.5)), b0 = pbt_jittered(&b_true, pb_rand_range(0.5, 1.5));
        a = a0;
        b = b0;
        held = 0.0;
        if ((st = pbe_blur_support(ctx, &level, &m)) == PB_OK)
            st = pbe_two_poses(ctx, &level, frame, c, &a, &b, 30, &found_share, &sse);
        if (st == PB_OK && found_share >= 0.0)
            st = pbe_two_poses_held(ctx, &level, frame, c, &a, &b, v / fmax(pbt_pose_distance(&a, &b), 1e-9),
                                    &held);
        pb_check(st == PB_OK, "case %d: the still frame's fit: %s", cs, pb_last_error(NULL));
        const double half = 0.5 * pbt_pose_distance(&a0, &b0),
                     moved = fmax(pbt_pose_distance(&a, &a0), pbt_pose_distance(&b, &b0));
        printf("case %d: a still frame: share %.3f, A %.3f mm and B %.3f mm off its pose, moved %.3f mm against "
               "%.3f; held %.3f\n", cs, found_share, pbt_pose_distance(&a, &a_true), pbt_pose_distance(&b, &a_true),
               moved, half, held);
        pb_check(found_share < 0.05 || found_share > 0.95 || moved > half || held < 0.9,
                 "case %d: a still frame taken for two poses (share %.3f, moved %.3f mm of %.3f, held %.3f)", cs,
                 found_share, moved, half, held);
        pbe_level_free(&level);
        free(late);
        free(frame);
        free(va);
        free(view);
    }
    pb_context_destroy(ctx);
    return pb_test_finish();
}
