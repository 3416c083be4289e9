/* A plan made once inside an MLEM loop, through the public API only: the
 * motion blur B of a frame is the whole system model here (no projector), so
 * the loop deblurs,
 *     x <- x / (B^T 1) * B^T (y / (B x)),
 * from a measured y = B x_true of a hot sphere in a warm cylinder that drifts
 * and turns during the frame. It prints the error against x_true per
 * iteration and exits 1 unless MLEM's error falls (and stays finite), so that
 * the test suite runs it: `examples/mlem_deblur [host|opencl|cuda]` (77 where
 * that backend has no device).
 *
 *     cc mlem_deblur.c $(pkg-config --cflags --libs petblur) -lm */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <petblur.h>

enum { N = 40, ITERATIONS = 12 };

static int fail(const char *what, pb_context *ctx)
{
    fprintf(stderr, "mlem_deblur: %s: %s\n", what, pb_last_error(ctx));
    return 2;
}

int main(int argc, char **argv)
{
    pb_context_options copt = {PB_BACKEND_AUTO, 0, NULL};
    if (argc > 1 && pb_device_parse(argv[1], &copt.backend, &copt.device_index) != PB_OK)
        return fail("device", NULL);
    pb_context *ctx;
    pb_status st = pb_context_create(&copt, &ctx);
    if (st == PB_ERR_NO_DEVICE || st == PB_ERR_BACKEND_UNAVAILABLE) {
        fprintf(stderr, "mlem_deblur: skipped: %s\n", pb_last_error(NULL));
        return 77; /* no such device here: the test suite's "skipped" */
    }
    if (st != PB_OK)
        return fail("context", NULL);

    /* The activity: a warm cylinder along z with a hot sphere off its axis. */
    pb_geometry g = {{N, N, N}, {2.0, 2.0, 2.0}};
    size_t n = (size_t)N * N * N;
    float *truth = malloc(n * sizeof *truth), *x = malloc(n * sizeof *x), *ratio = malloc(n * sizeof *ratio);
    float *y = malloc(n * sizeof *y), *ones = malloc(n * sizeof *ones), *sens = malloc(n * sizeof *sens);
    for (size_t i = 0; i < n; i++) {
        double px = (double)(i % N) - N / 2 + 0.5, py = (double)(i / N % N) - N / 2 + 0.5;
        double pz = (double)(i / (N * N)) - N / 2 + 0.5;
        double hot = (px - 5) * (px - 5) + (py + 3) * (py + 3) + pz * pz < 25.0 ? 4.0 : 0.0;
        truth[i] = (float)(px * px + py * py < 15.0 * 15.0 && fabs(pz) < 16.0 ? 1.0 + hot : 0.0);
        ones[i] = 1.0f;
    }

    /* The frame: 3 mm of drift and a 12 degree turn about a tilted axis. */
    double times[2] = {0.0, 1.0}, axis[3] = {0.3, 0.2, 1.0};
    pb_pose poses[2] = {{{0, 0, 0}, {1, 0, 0, 0}}, {{3.0, -1.5, 1.0}, {1, 0, 0, 0}}};
    pb_quaternion_from_axis_angle(axis, 12.0, poses[1].rotation);
    pb_motion motion = {times, poses, 2, 0.0, 1.0, 0, {0, 0, 0}};

    pb_volume *vx, *vy, *vr;
    pb_plan *B;
    if (pb_volume_create(ctx, &g, &vx) != PB_OK || pb_volume_create(ctx, &g, &vy) != PB_OK ||
        pb_volume_create(ctx, &g, &vr) != PB_OK)
        return fail("volumes", ctx);
    if (pb_plan_create(ctx, &g, &motion, NULL, &B) != PB_OK) /* validated, planned and uploaded once */
        return fail("plan", ctx);

    /* The measurement, and the sensitivity B^T 1. */
    if (pb_volume_upload(vx, truth) != PB_OK || pb_plan_forward(B, 0, vx, vy) != PB_OK ||
        pb_volume_download(vy, y) != PB_OK || pb_volume_upload(vy, ones) != PB_OK ||
        pb_plan_adjoint(B, 0, vy, vr, 0) != PB_OK || pb_volume_download(vr, sens) != PB_OK)
        return fail("measurement", ctx);

    double first = 0.0, last = 0.0;
    for (size_t i = 0; i < n; i++)
        x[i] = 1.0f;
    for (int it = 0; it <= ITERATIONS; it++) {
        pb_comparison c;
        double err = pb_compare(truth, x, n, &c) == PB_OK ? c.rms_percent : (double)NAN;
        printf("iteration %2d: relative RMS error %.3f %%\n", it, err);
        if (!isfinite(err))
            return fail("a NaN in the image", ctx);
        if (it == 1)
            first = err;
        last = err;
        if (it == ITERATIONS)
            break;
        /* B x, the ratio y / B x, and B^T of it, through the one plan. */
        if (pb_volume_upload(vx, x) != PB_OK || pb_plan_forward(B, 0, vx, vy) != PB_OK ||
            pb_volume_download(vy, ratio) != PB_OK)
            return fail("forward", ctx);
        for (size_t i = 0; i < n; i++)
            ratio[i] = ratio[i] > 1e-6f ? y[i] / ratio[i] : 0.0f;
        if (pb_volume_upload(vy, ratio) != PB_OK || pb_plan_adjoint(B, 0, vy, vr, 0) != PB_OK ||
            pb_volume_download(vr, ratio) != PB_OK)
            return fail("adjoint", ctx);
        for (size_t i = 0; i < n; i++)
            x[i] = sens[i] > 1e-6f ? x[i] * ratio[i] / sens[i] : 0.0f;
    }
    pb_plan_destroy(B);
    pb_volume_destroy(vx);
    pb_volume_destroy(vy);
    pb_volume_destroy(vr);
    pb_context_destroy(ctx);
    free(truth), free(x), free(ratio), free(y), free(ones), free(sens);
    /* MLEM on blurred data sharpens: the error after the last iteration must
     * be well below the first iteration's. */
    if (!(last < 0.8 * first)) {
        fprintf(stderr, "mlem_deblur: the error fell from %.3f %% only to %.3f %%\n", first, last);
        return 1;
    }
    return 0;
}
