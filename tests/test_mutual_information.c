/* The estimator's mutual-information fit (src/estimate/mutual_information.c)
 * on fresh heads each run: tissues of their own contrast (cortex, white
 * matter, lesions, a blood vessel), a late frame as the reference and an
 * early frame whose contrast is another (blood bright, tissue dim), moved by
 * a fresh pose. The gradient points as central differences of the measure
 * do (its length within 15 %: the view's derivative is from its own central
 * differences, view_jacobian.c); the fit from the identity climbs all but
 * 2 % of the way to the truth's measure and ends within 0.3 voxel of the
 * truth (a tenth mostly); the least-squares fit of register.c, which asks the frame to
 * be a scale and offset of the reference, is printed beside it. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "heads.h"
#include "motion.h"
#include "testlib.h"

enum { NX = 40, NY = 36, NZ = 30, TISSUES = PBT_TISSUES, CASES = 4 };
#define RADIUS_MM PBT_RADIUS_MM

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_test_deadline(600, "mutual information");
    pb_context *ctx = pb_test_context(argc, argv);
    for (int cs = 0; cs < CASES; cs++) {
        pb_geometry g = pbt_head_grid(NX, NY, NZ);
        const double v = g.voxel_size[0];
        const size_t n = (size_t)NX * NY * NZ;
        float *t[TISSUES], *late = malloc(sizeof(float) * n), *early = malloc(sizeof(float) * n);
        float *frame = malloc(sizeof(float) * n), *tmp = malloc(sizeof(float) * 64);
        for (int k = 0; k < TISSUES; k++)
            t[k] = malloc(sizeof(float) * n);
        pbt_head_tissues(&g, t, tmp);
        /* late: cortex over white matter, lesions hot, blood washed out;
         * early: blood far above everything, tissue still dim */
        double late_c[TISSUES];
        pbt_late_contrast(late_c);
        /* an early frame's: blood above tissue, tissue dim */
        const double early_c[TISSUES] = {pb_rand_range(0.3, 0.5), pb_rand_range(0.1, 0.2),
                                         pb_rand_range(0.3, 0.6), pb_rand_range(1.0, 2.0)};
        pbt_mix((const float *const *)t, late_c, n, late);
        pbt_mix((const float *const *)t, early_c, n, early);
        const double c[3] = {0.5 * NX * g.voxel_size[0], 0.5 * NY * g.voxel_size[1], 0.5 * NZ * g.voxel_size[2]};
        double axis[3] = {pbt_gauss(), pbt_gauss(), pbt_gauss()};
        pb_pose truth = pb_test_pose(pb_rand_range(-2.0, 2.0), pb_rand_range(-2.0, 2.0), pb_rand_range(-2.0, 2.0),
                                     axis, pb_rand_range(1.0, 3.0));
        double times[2];
        pb_pose poses[2];
        pb_motion m;
        pbe_static_motion(&truth, c, times, poses, &m);
        pb_status st = pb_test_blur(ctx, &g, early, &m, NULL, frame);
        double peak = pb_max_abs(frame, n);
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

        /* the gradient against central differences at a pose half a voxel to a voxel off the truth, in a
         * fresh direction: at the measure's top the gradient is nil and central differences see only its
         * curvature (a Gaussian jitter of 0.3 mm landed there one run in about 30: cosine 0.68, seed
         * 1796447021641646) */
        double jitter[6], length = 0.0, off = pb_rand_range(0.5, 1.0) * v;
        for (int p = 0; p < 6; p++) {
            jitter[p] = pbt_gauss();
            length += jitter[p] * jitter[p];
        }
        for (int p = 0; p < 6; p++) /* turns in units of the head's displacement, RADIUS_MM a radian */
            jitter[p] *= off / sqrt(length) / (p < 3 ? 1.0 : RADIUS_MM);
        pb_pose near, identity = pb_test_pose(0, 0, 0, axis, 0.0);
        pb_pose_perturb(&truth, jitter, &near);
        double mi, grad[6], fd[6], dot = 0.0, grad2 = 0.0, norm2 = 0.0;
        st = pbe_mutual_information(ctx, &level, frame, c, &near, &near, &mi, grad);
        for (int p = 0; p < 6 && st == PB_OK; p++) {
            const double h = p < 3 ? 0.1 : 0.1 / RADIUS_MM;
            double xi[6] = {0}, up = 0.0, down = 0.0;
            pb_pose a, b;
            xi[p] = h;
            pb_pose_perturb(&near, xi, &a);
            xi[p] = -h;
            pb_pose_perturb(&near, xi, &b);
            st = pbe_mutual_information(ctx, &level, frame, c, &a, &near, &up, NULL);
            if (st == PB_OK)
                st = pbe_mutual_information(ctx, &level, frame, c, &b, &near, &down, NULL);
            fd[p] = (up - down) / (2.0 * h);
            /* in units of the head's displacement, so turns and shifts weigh alike */
            const double s = p < 3 ? 1.0 : 1.0 / RADIUS_MM;
            dot += grad[p] * fd[p] * s * s;
            grad2 += grad[p] * grad[p] * s * s;
            norm2 += fd[p] * fd[p] * s * s;
        }
        pb_check(st == PB_OK, "case %d: the measure: %s", cs, pb_last_error(NULL));
        const double cosine = dot / sqrt(grad2 * norm2), ratio = sqrt(grad2 / norm2);
        printf("case %d: MI %.4f; gradient against central differences: cosine %.4f, length ratio %.3f\n", cs, mi,
               cosine, ratio);
        pb_check(cosine > 0.98 && ratio > 0.85 && ratio < 1.15,
                 "case %d: gradient against central differences: cosine %.4f, length ratio %.3f", cs, cosine, ratio);

        /* the fit from the identity, against the least squares of register.c */
        pb_pose found = identity;
        double mi_end = 0.0;
        st = pbe_register_mi(ctx, &level, frame, c, RADIUS_MM, 60, &found, &mi_end);
        pbe_fit ls = {0};
        ls.pose = identity;
        if (st == PB_OK)
            st = pbe_register(ctx, &level, frame, c, 60, &ls);
        pb_check(st == PB_OK, "case %d: the fits: %s", cs, pb_last_error(NULL));
        double mi_truth = 0.0, mi_start = 0.0;
        st = pbe_mutual_information(ctx, &level, frame, c, &truth, &identity, &mi_truth, NULL);
        if (st == PB_OK)
            st = pbe_mutual_information(ctx, &level, frame, c, &identity, &identity, &mi_start, NULL);
        pb_check(st == PB_OK, "case %d: the measure at the truth and the start: %s", cs, pb_last_error(NULL));

        const double err = pbt_pose_distance(&found, &truth), err_ls = pbt_pose_distance(&ls.pose, &truth), moved = pbt_pose_distance(&identity, &truth);
        printf("case %d: voxel %.2f mm, moved %.2f mm; mutual information %.3f mm off (MI %.4f), least squares %.3f mm off\n",
               cs, v, moved, err, mi_end, err_ls);
        /* the fit climbs to the measure's top: it closes all but 2 % of the gap between the start's measure and
         * the truth's (the same weights and bins; views sampled trilinearly kink the measure at every voxel
         * crossing, and quasi-Newton steps slow there), and ends within 0.3 voxel of the truth, where the
         * measure's own top lies off it by the noise */
        const double left = (mi_truth - mi_end) / (mi_truth - mi_start);
        printf("case %d: MI from %.5f to %.5f, the truth's %.5f: %.2f %% of the climb left; %.2f voxel off\n", cs,
               mi_start, mi_end, mi_truth, 100.0 * left, err / v);
        pb_check(left < 0.02, "case %d: the fit ended at MI %.5f, %.1f %% of the climb from %.5f to the truth's %.5f "
                 "left", cs, mi_end, 100.0 * left, mi_start, mi_truth);
        pb_check(err < 0.3 * v, "case %d: the mutual-information fit is %.3f mm off the truth (voxel %.2f mm)", cs, err, v);
        pbe_level_free(&level);
        for (int k = 0; k < TISSUES; k++)
            free(t[k]);
        free(late);
        free(early);
        free(frame);
        free(tmp);
    }
    pb_context_destroy(ctx);
    return pb_test_finish();
}
