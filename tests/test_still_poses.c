/* The estimator's pooling of still frames (src/estimate/still_poses.c), on
 * fresh random series each run: frames of few and of many counts, the head
 * still over runs of them and jumping between the runs, each frame's pose
 * measured with noise of sd / sqrt(counts). Pooling must bring the frames
 * of few counts closer to the truth, keep every jump (no frame pooled
 * across one), leave skipped frames alone, and change nothing where the
 * series has too few pairs to measure its noise. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "motion.h"
#include "testlib.h"

enum { FRAMES = 18, N = 12 };

static double gauss(void)
{
    double u = pb_rand_range(1e-12, 1.0), v = pb_rand_uniform();
    return sqrt(-2.0 * log(u)) * cos(6.283185307179586 * v);
}

/* The largest displacement, mm, between two poses about c over the corners
 * of a 60 mm cube about c. */
static double apart(const pb_pose *a, const pb_pose *b, const double c[3])
{
    double worst = 0.0;
    for (int k = 0; k < 8; k++) {
        double p[3] = {c[0] + ((k & 1) ? 30 : -30), c[1] + ((k & 2) ? 30 : -30), c[2] + ((k & 4) ? 30 : -30)};
        double pa[3], pb[3];
        pb_pose_apply(a, c, p, pa);
        pb_pose_apply(b, c, p, pb);
        worst = fmax(worst, sqrt((pa[0] - pb[0]) * (pa[0] - pb[0]) + (pa[1] - pb[1]) * (pa[1] - pb[1]) +
                                 (pa[2] - pb[2]) * (pa[2] - pb[2])));
    }
    return worst;
}

int main(void)
{
    pb_test_seed();
    pb_geometry g = {{N, N, N}, {4.0, 4.0, 4.0}};
    const size_t n = N * N * N;
    const double c[3] = {0.5 * N * 4.0, 0.5 * N * 4.0, 0.5 * N * 4.0};
    float *raw = malloc(sizeof(float) * n * FRAMES);
    double bounds[FRAMES + 1];
    if (!raw)
        return 1;
    int failed = 0;
    double before_sum = 0.0, after_sum = 0.0;
    for (int trial = 0; trial < 40; trial++) {
        /* frames 0-7 short (2-6 s), the rest long (30-60 s): counts 5-30x */
        bounds[0] = 0.0;
        for (int k = 0; k < FRAMES; k++)
            bounds[k + 1] = bounds[k] + (k < 8 ? pb_rand_range(2.0, 6.0) : pb_rand_range(30.0, 60.0));
        for (int k = 0; k < FRAMES; k++)
            for (size_t v = 0; v < n; v++)
                raw[(size_t)k * n + v] = (float)pb_rand_range(0.5, 1.5);
        /* the truth: still over the short frames (the tracer's arrival), then runs with a jump of 5-10 mm
         * and 3-8 degrees between them, the first where the long frames begin or later */
        int jump_at[3] = {(int)pb_rand_range(8, 11), (int)pb_rand_range(11, 14), (int)pb_rand_range(14, 18)};
        pb_pose truth[FRAMES], held = pb_test_pose(0, 0, 0, (double[3]){0, 0, 1}, 0);
        for (int k = 0; k < FRAMES; k++) {
            if (k == jump_at[0] || k == jump_at[1] || k == jump_at[2]) {
                double axis[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), pb_rand_range(-1, 1)};
                double mm = pb_rand_range(5, 10), t[3] = {gauss(), gauss(), gauss()};
                double s = mm / sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
                pb_pose step = pb_test_pose(s * t[0], s * t[1], s * t[2], axis,
                                            pb_rand_range(3, 8) * (pb_rand_uniform() < 0.5 ? -1 : 1)), next;
                pb_pose_compose(&step, &held, &next);
                held = next;
            }
            truth[k] = held;
        }
        /* measured: the truth moved by noise of sd / sqrt(counts / the mean frame's) per number */
        double counts[FRAMES], mean_counts = 0.0;
        for (int k = 0; k < FRAMES; k++) {
            double sum = 0.0;
            for (size_t v = 0; v < n; v++)
                sum += (double)raw[(size_t)k * n + v];
            counts[k] = sum * (bounds[k + 1] - bounds[k]);
            mean_counts += counts[k] / FRAMES;
        }
        const double sd = pb_rand_range(0.05, 0.3);
        pbe_fit fits[FRAMES];
        int skip[FRAMES] = {0};
        skip[(int)pb_rand_range(0, FRAMES)] = 1;
        for (int k = 0; k < FRAMES; k++) {
            double s = sd * sqrt(mean_counts / counts[k]);
            double xi[6] = {s * gauss(), s * gauss(), s * gauss(), s * gauss() / 20.0, s * gauss() / 20.0,
                            s * gauss() / 20.0};
            memset(&fits[k], 0, sizeof fits[k]);
            pb_pose_perturb(&truth[k], xi, &fits[k].pose);
        }
        pbe_fit measured[FRAMES];
        memcpy(measured, fits, sizeof fits);
        size_t pooled = 0;
        if (pbe_pool_still(&g, raw, FRAMES, bounds, c, skip, fits, &pooled) != PB_OK) {
            printf("FAIL trial %d: pbe_pool_still failed\n", trial);
            return 1;
        }
        for (int k = 0; k < FRAMES; k++) {
            double was = apart(&measured[k].pose, &truth[k], c), is = apart(&fits[k].pose, &truth[k], c);
            if (skip[k] && memcmp(&fits[k].pose, &measured[k].pose, sizeof(pb_pose)) != 0) {
                printf("FAIL trial %d: skipped frame %d changed\n", trial, k);
                failed = 1;
            }
            /* no frame pooled across a jump: that would move it by half a jump (5 mm at least) or more
             * towards the other run, where pooling inside its own run moves it by its noise */
            if (is > was + 2.0) {
                printf("FAIL trial %d: frame %d %.2f mm from the truth after pooling (%.2f before; jumps at "
                       "%d, %d, %d)\n", trial, k, is, was, jump_at[0], jump_at[1], jump_at[2]);
                failed = 1;
            }
            if (k < 8) {
                before_sum += was;
                after_sum += is;
            }
        }
    }
    printf("frames of few counts, mean error over 40 series: %.3f mm measured, %.3f mm pooled\n",
           before_sum / 320.0, after_sum / 320.0);
    if (!(after_sum < 0.7 * before_sum)) {
        printf("FAIL: pooling took the frames of few counts from %.3f to %.3f mm (less than 30 %% off)\n",
               before_sum / 320.0, after_sum / 320.0);
        failed = 1;
    }
    /* too few pairs: four frames, nothing changes */
    pbe_fit four[4];
    int none[4] = {0};
    for (int k = 0; k < 4; k++) {
        memset(&four[k], 0, sizeof four[k]);
        four[k].pose = pb_test_pose(gauss(), gauss(), gauss(), (double[3]){1, 0, 0}, gauss());
    }
    pbe_fit copy[4];
    memcpy(copy, four, sizeof four);
    size_t pooled = 0;
    if (pbe_pool_still(&g, raw, 4, bounds, c, none, four, &pooled) != PB_OK || pooled != 0 ||
        memcmp(copy, four, sizeof four) != 0) {
        printf("FAIL: a series of four frames (three pairs) was pooled\n");
        failed = 1;
    }
    free(raw);
    if (!failed)
        printf("ok\n");
    return failed;
}
