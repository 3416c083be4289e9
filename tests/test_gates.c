/* pb_plan_create_gates: a gate of a 30 Hz pose track, a union of intervals,
 * blurs to the time-weighted mean of its intervals' blurs, each interval
 * planned as a frame of its own, for every method and filter; its transpose
 * to the same mean of the intervals' transposes, and the pair passes the dot
 * test. A gate of one interval is pb_plan_create_frames' frame bit for bit.
 * Bad gates are refused with the frame and interval named. Fresh random
 * volumes, tracks and intervals each run. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testlib.h"

enum { TRACK = 61, GATES = 2, INTERVALS = 5 }; /* 2 s at 30 Hz; gate 0 three intervals, gate 1 two */

static const char *names[] = {"AB", "RM", "CL", "REF"};

/* A head that nods and drifts (test_frames.c's): a random walk of small
 * steps that turns in the first second and only translates after it, so that
 * gate 0 (inside the first second) takes the general kernels and the
 * adjoint's scatter, gate 1 (inside the second) the shift-invariant ones. */
static void make_track(double *times, pb_pose *poses)
{
    double t[3] = {0, 0, 0}, deg = 0.0, axis[3] = {0.3, 1.0, 0.2};
    for (int k = 0; k < TRACK; k++) {
        times[k] = k / 30.0;
        for (int i = 0; i < 3; i++)
            t[i] += pb_rand_range(-0.25, 0.35);
        deg = k < 30 ? deg + pb_rand_range(-0.4, 0.6) : 0.0;
        poses[k] = pb_test_pose(t[0], t[1], t[2], axis, deg);
    }
}

static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* 2 * count increasing random times in [lo, hi]: count intervals with gaps. */
static void random_intervals(double lo, double hi, size_t count, double *iv)
{
    for (size_t i = 0; i < 2 * count; i++)
        iv[i] = pb_rand_range(lo, hi);
    qsort(iv, 2 * count, sizeof *iv, compare_doubles);
}

/* One direction of frame `frame` of plan, host in and out. */
static pb_status run(pb_plan *plan, size_t frame, pb_volume *in, pb_volume *out, const float *x, float *y, int adjoint)
{
    pb_status st = pb_volume_upload(in, x);
    if (st == PB_OK)
        st = adjoint ? pb_plan_adjoint(plan, frame, in, out, 0) : pb_plan_forward(plan, frame, in, out);
    return st == PB_OK ? pb_volume_download(out, y) : st;
}

/* The mean of the intervals' blurs (or transposes), weighed by their times,
 * each interval a plan of its own. */
static pb_status interval_mean(pb_context *ctx, const pb_geometry *g, const pb_motion *track, const double *iv,
                               size_t count, const pb_blur_options *opt, pb_volume *in, pb_volume *out,
                               const float *x, float *want, int adjoint)
{
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    double total = 0.0, *acc = calloc(n, sizeof *acc);
    float *one = malloc(n * sizeof *one);
    pb_status st = PB_OK;
    for (size_t k = 0; k < count; k++)
        total += iv[2 * k + 1] - iv[2 * k];
    for (size_t k = 0; k < count && st == PB_OK; k++) {
        pb_motion m = *track;
        m.frame_start = iv[2 * k];
        m.frame_end = iv[2 * k + 1];
        pb_plan *p = NULL;
        if ((st = pb_plan_create(ctx, g, &m, opt, &p)) == PB_OK && (st = run(p, 0, in, out, x, one, adjoint)) == PB_OK)
            for (size_t i = 0; i < n; i++)
                acc[i] += (iv[2 * k + 1] - iv[2 * k]) / total * (double)one[i];
        pb_plan_destroy(p);
    }
    for (size_t i = 0; i < n; i++)
        want[i] = (float)acc[i];
    free(acc);
    free(one);
    return st;
}

/* Refusals: each names what is wrong and where. */
static void check_refusals(pb_context *ctx, const pb_geometry *g, const pb_motion *track)
{
    pb_blur_options ab = {PB_METHOD_AB, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    const double ok[2] = {0.1, 0.5}, overlap[4] = {0.1, 0.5, 0.4, 0.8}, unordered[4] = {0.5, 0.8, 0.1, 0.3},
                 outside[4] = {0.1, 0.5, 1.8, 2.5}, empty[2] = {0.3, 0.3}, nan_end[2] = {0.1, (double)NAN};
    const size_t one[2] = {1, 1}, two[2] = {1, 2}, none[2] = {1, 0};
    double late[6] = {0.1, 0.5, 0.2, 0.4, 1.8, 2.5};
    struct {
        const char *what;
        const double *iv;
        const size_t *counts;
        size_t frames;
        pb_status want;
        const char *needle;
    } bad[] = {{"overlapping intervals", overlap, two + 1, 1, PB_ERR_BAD_FRAME, "interval 1 starts at 0.4 s"},
               {"unordered intervals", unordered, two + 1, 1, PB_ERR_BAD_FRAME, "do not overlap"},
               {"an interval past the track", late, two, 2, PB_ERR_TRACK_GAP, "(interval 1 of 2) (frame 1 of 2)"},
               {"a gate past the track", outside + 2, one, 1, PB_ERR_TRACK_GAP, "frame 0 of 1"},
               {"an interval of no time", empty, one, 1, PB_ERR_BAD_FRAME, "not after its start"},
               {"a gate of no intervals", ok, none, 2, PB_ERR_INVALID_ARGUMENT, "frame 1 has 0 intervals"},
               {"no gates", ok, one, 0, PB_ERR_INVALID_ARGUMENT, "no frames"},
               {"no counts", ok, NULL, 1, PB_ERR_INVALID_ARGUMENT, "counts"},
               {"a time that is NaN", nan_end, one, 1, PB_ERR_NOT_FINITE, "frame 0"}};
    for (size_t b = 0; b < sizeof bad / sizeof bad[0]; b++) {
        pb_plan *p = (pb_plan *)&p; /* not NULL: a refusal must set it */
        pb_status st = pb_plan_create_gates(ctx, g, track, bad[b].iv, bad[b].counts, bad[b].frames, &ab, &p);
        pb_check(st == bad[b].want, "%s: status %d, expected %d (%s)", bad[b].what, (int)st, (int)bad[b].want,
                 pb_last_error(ctx));
        pb_check(strstr(pb_last_error(ctx), bad[b].needle) != NULL, "%s: the message names it ('%s'): %s",
                 bad[b].what, bad[b].needle, pb_last_error(ctx));
        if (bad[b].counts)
            pb_check(p == NULL, "%s: the plan is NULL", bad[b].what);
    }
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *ctx = pb_test_context(argc, argv);
    int nvidia = pb_test_nvidia(ctx);
    pb_geometry g = {{15, 13, 9}, {1.3, 1.1, 1.8}};
    size_t n = 15 * 13 * 9;
    double times[TRACK];
    pb_pose poses[TRACK];
    make_track(times, poses);
    pb_motion track = {times, poses, TRACK, 0.0, 0.0, 0, {0, 0, 0}};
    /* Gate 0 inside the turning first second, gate 1 inside the second. */
    double iv[2 * INTERVALS];
    size_t counts[GATES] = {3, 2};
    random_intervals(0.02, 0.98, 3, iv);
    random_intervals(1.02, 1.98, 2, iv + 6);
    printf("gates: [%.3f, %.3f] [%.3f, %.3f] [%.3f, %.3f]; [%.3f, %.3f] [%.3f, %.3f]\n", iv[0], iv[1], iv[2], iv[3],
           iv[4], iv[5], iv[6], iv[7], iv[8], iv[9]);
    float *x = pb_random_volume(n), *y = pb_random_volume(n);
    float *got = malloc(n * sizeof *got), *want = malloc(n * sizeof *want), *back = malloc(n * sizeof *back);
    pb_volume *in, *out;
    pb_volume_create(ctx, &g, &in);
    pb_volume_create(ctx, &g, &out);

    for (int method = 0; method < 4; method++)
        for (int filter = 0; filter < 2; filter++) {
            if (method == PB_METHOD_REF && filter == PB_FILTER_HARDWARE)
                continue;
            const char *what = filter ? "EXACT" : "HARDWARE";
            pb_blur_options opt = {(pb_method)method, (pb_filter)filter, 0, 256, 0, 9, PB_PATH_DEFAULT, 0.0,
                                   PB_AB_SAMPLING_DEFAULT, 0};
            pb_plan *gates = NULL;
            pb_status st = pb_plan_create_gates(ctx, &g, &track, iv, counts, GATES, &opt, &gates);
            if (!pb_check(st == PB_OK && pb_plan_frame_count(gates) == GATES, "%s %s: pb_plan_create_gates: %s",
                          names[method], what, pb_last_error(ctx)))
                continue;
            /* AB, RM and CL: the same walks and weights, summed in float here
             * and in double there (a few hundred adds a voxel). REF's random
             * points are numbered along the whole gate, so its intervals
             * draw other points than alone: two estimates of one mean, each
             * of 256 points times at least 16 steps an interval. With 16
             * points their largest difference reached 0.14 of the largest
             * value (seed 1796231854826810); with 256, at most 0.029 on 54
             * seeds, and a gate whose intervals were weighed wrong would be
             * off by a share of the values themselves.
             * NVIDIA's HARDWARE weights are rounded to 1/256 (by its texture
             * unit, and as it would in the adjoint's scatter): a gate's sample
             * and its interval's alone differ by float rounding, and where
             * one lies on a step's edge its weight moves by a step, a read
             * by up to 1/256 of the largest value (measured: 2.6e-4, CL
             * HARDWARE's adjoint on NVIDIA's OpenCL, seed 1795986535913126). */
            double tol = method == PB_METHOD_REF                    ? 0.07
                         : nvidia && filter == PB_FILTER_HARDWARE ? 1.0 / 256.0
                                                                   : 1e-5;
            double lhs = 0.0, rhs = 0.0, worst = 0.0;
            for (size_t k = 0, first = 0; k < GATES; first += counts[k++]) {
                for (int adjoint = 0; adjoint < 2; adjoint++) {
                    st = run(gates, k, in, out, adjoint ? y : x, got, adjoint);
                    pb_status st2 = interval_mean(ctx, &g, &track, iv + 2 * first, counts[k], &opt, in, out,
                                                  adjoint ? y : x, want, adjoint);
                    if (!pb_check(st == PB_OK && st2 == PB_OK, "%s %s gate %zu: %s", names[method], what, k,
                                  pb_last_error(ctx)))
                        continue;
                    double scale = pb_max_abs(want, n), diff = pb_max_abs_diff(got, want, n);
                    worst = fmax(worst, diff / scale);
                    pb_check(scale > 0.1 && diff <= tol * scale,
                             "%s %s gate %zu%s: off the time-weighted mean of its intervals' by %.3g (largest %.3g)",
                             names[method], what, k, adjoint ? " adjoint" : "", diff, scale);
                    if (adjoint)
                        memcpy(back, got, n * sizeof *back);
                }
                /* The dot test: <G x, y> = <x, G^T y>. */
                run(gates, k, in, out, x, got, 0);
                lhs += pb_dot(got, y, n);
                rhs += pb_dot(x, back, n);
            }
            printf("%s %s: the gates off their intervals' mean by %.2g of the largest value, <G x, y> off <x, G^T y> "
                   "by %.2g\n", names[method], what, worst, fabs(lhs - rhs) / fabs(lhs));
            /* Only EXACT: NVIDIA's HARDWARE blend is not its rounded weights'
             * product (test_adjoint has that pair's own tolerance). */
            /* REF's 4096 or more reads a voxel, summed in float, round more
             * than the walks' few hundred: up to 2e-5 on the 54 seeds. */
            if (filter == PB_FILTER_EXACT)
                pb_check(fabs(lhs - rhs) <= (method == PB_METHOD_REF ? 5e-5 : 1e-5) * fabs(lhs),
                         "%s EXACT gates: <G x, y> = %.9g, <x, G^T y> = %.9g", names[method], lhs, rhs);
            pb_plan_destroy(gates);

            /* A gate of one interval is that frame's plan. */
            size_t one = 1;
            pb_plan *frame = NULL;
            gates = NULL;
            st = pb_plan_create_gates(ctx, &g, &track, iv + 2, &one, 1, &opt, &gates);
            pb_status st2 = pb_plan_create_frames(ctx, &g, &track, iv + 2, 1, &opt, &frame);
            if (pb_check(st == PB_OK && st2 == PB_OK, "%s %s one interval: %s", names[method], what,
                         pb_last_error(ctx))) {
                run(gates, 0, in, out, x, got, 0);
                run(frame, 0, in, out, x, want, 0);
                pb_check(memcmp(got, want, n * sizeof *got) == 0, "%s %s: a gate of one interval differs from its "
                         "frame (max %.3g)", names[method], what, pb_max_abs_diff(got, want, n));
            }
            pb_plan_destroy(gates);
            pb_plan_destroy(frame);
        }
    check_refusals(ctx, &g, &track);
    pb_volume_destroy(in);
    pb_volume_destroy(out);
    free(x);
    free(y);
    free(got);
    free(want);
    free(back);
    pb_context_destroy(ctx);
    return pb_test_finish();
}
