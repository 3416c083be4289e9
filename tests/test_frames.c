/* pb_blur_frames: many frames of one 30 Hz pose track in one call must equal
 * the same frames blurred one at a time, bit for bit, for every method and
 * filter; a bad frame anywhere must stop the call before any frame is written.
 * pb_blur_frames_adjoint: each frame equals pb_blur_adjoint of that frame (to
 * the float atomics' rounding), frames sharing an object sum into it, and with
 * EXACT the pair passes the dot-product test. Fresh random volumes and motions
 * each run; outputs poisoned first. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testlib.h"

enum { FRAMES = 4, TRACK = 61 }; /* 2 s at 30 Hz */

static const char *names[] = {"AB", "RM", "CL", "REF"};

/* A head that nods and drifts: a random walk of small steps, 30 times a
 * second, that in the first second also turns up to a few degrees about a
 * tilted axis, and is back at its first angle from then on. The first two
 * frames turn, which takes the general kernels (and the adjoint's scatter);
 * the last two are translations only, which take the shift-invariant ones (and
 * the gather). Frames 0, 2 and 3 share an object, so the adjoint adds the
 * gather onto the scatter's sum and onto its own. */
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

/* Frame f of the track, as one pb_blur call would be given it. */
static pb_motion frame_of(const pb_motion *track, const double *bounds, int f)
{
    pb_motion m = *track;
    m.frame_start = bounds[f];
    m.frame_end = bounds[f + 1];
    return m;
}

static void poison(pb_volume *v, size_t n)
{
    float *p = malloc(n * sizeof *p);
    for (size_t i = 0; i < n; i++)
        p[i] = -1e30f;
    pb_volume_upload(v, p);
    free(p);
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *ctx = pb_test_context(argc, argv);
    pb_geometry g = {{15, 13, 9}, {1.3, 1.1, 1.8}};
    size_t n = 15 * 13 * 9;
    double times[TRACK];
    pb_pose poses[TRACK];
    make_track(times, poses);
    pb_motion track = {times, poses, TRACK, 0.0, 0.0, 0, {0, 0, 0}};
    /* Frames of uneven length, the first starting after the track does. */
    double bounds[FRAMES + 1] = {0.1, pb_rand_range(0.3, 0.6), 1.0, pb_rand_range(1.2, 1.6), 1.95};

    /* Two activity volumes; the first serves frames 0, 2 and 3 (a static
     * object shared by frames must not be re-read wrongly). */
    float *data[2] = {pb_random_volume(n), pb_random_volume(n)};
    pb_volume *obj[2], *tomo[FRAMES], *single;
    for (int i = 0; i < 2; i++) {
        pb_volume_create(ctx, &g, &obj[i]);
        pb_volume_upload(obj[i], data[i]);
    }
    for (int f = 0; f < FRAMES; f++)
        pb_volume_create(ctx, &g, &tomo[f]);
    pb_volume_create(ctx, &g, &single);
    const pb_volume *objects[FRAMES] = {obj[0], obj[1], obj[0], obj[0]};
    float *got = malloc(n * sizeof *got), *want = malloc(n * sizeof *want);

    for (int method = 0; method < 4; method++)
        for (int filter = 0; filter < 2; filter++) {
            if (method == PB_METHOD_REF && filter == PB_FILTER_HARDWARE)
                continue;
            pb_blur_options opt = {(pb_method)method, (pb_filter)filter, 0, 16, 0, 9, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
            for (int f = 0; f < FRAMES; f++)
                poison(tomo[f], n);
            pb_status st = pb_blur_frames(ctx, objects, &track, bounds, FRAMES, &opt, tomo);
            if (!pb_check(st == PB_OK, "%s %s: pb_blur_frames: %s", names[method], filter ? "EXACT" : "HARDWARE",
                          pb_last_error(ctx)))
                continue;
            double total = -1.0;
            pb_context_last_kernel_ms(ctx, &total);
            pb_check(total > 0.0, "%s: the frames' kernel time %g ms", names[method], total);
            for (int f = 0; f < FRAMES; f++) {
                pb_motion m = frame_of(&track, bounds, f);
                poison(single, n);
                pb_check(pb_blur(ctx, objects[f], &m, &opt, single) == PB_OK, "pb_blur frame %d: %s", f,
                         pb_last_error(ctx));
                pb_volume_download(single, want);
                pb_volume_download(tomo[f], got);
                pb_check(memcmp(got, want, n * sizeof *got) == 0,
                         "%s %s frame %d: pb_blur_frames differs from pb_blur (max %.3g)", names[method],
                         filter ? "EXACT" : "HARDWARE", f, pb_max_abs_diff(got, want, n));
                pb_check(pb_max_abs(got, n) < 2.0, "%s frame %d: every voxel written (largest %.3g)", names[method],
                         f, pb_max_abs(got, n));
            }
        }

    /* The adjoint, against pb_blur_adjoint frame by frame. */
    pb_volume *back[FRAMES], *sum[2];
    float *y[FRAMES], *x[2] = {data[0], data[1]};
    for (int f = 0; f < FRAMES; f++) {
        pb_volume_create(ctx, &g, &back[f]);
        y[f] = pb_random_volume(n);
        pb_volume_upload(tomo[f], y[f]);
    }
    for (int i = 0; i < 2; i++)
        pb_volume_create(ctx, &g, &sum[i]);
    const pb_volume *ys[FRAMES] = {tomo[0], tomo[1], tomo[2], tomo[3]};
    pb_volume *shared_out[FRAMES] = {sum[0], sum[1], sum[0], sum[0]};
    float *acc = malloc(n * sizeof *acc), *fwd = malloc(n * sizeof *fwd);
    for (int method = 0; method < 4; method++)
        for (int filter = 0; filter < 2; filter++) {
            if (method == PB_METHOD_REF && filter == PB_FILTER_HARDWARE)
                continue;
            const char *what = filter ? "EXACT" : "HARDWARE";
            pb_blur_options opt = {(pb_method)method, (pb_filter)filter, 0, 16, 0, 9, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
            /* Float atomics round each add at the running sum's size, in an
             * order no run repeats. AB, RM and CL add a few hundred times per
             * voxel; REF adds every random point on its own, thousands of
             * times (and frames into a shared object add onto its sum): up to
             * 4096 x 2^-24 = 2.4e-4 of the largest value. */
            double tol = method == PB_METHOD_REF ? 3e-4 : 1e-5;
            for (int f = 0; f < FRAMES; f++)
                poison(back[f], n);
            for (int i = 0; i < 2; i++)
                poison(sum[i], n);
            pb_status st = pb_blur_frames_adjoint(ctx, ys, &track, bounds, FRAMES, &opt, back);
            if (!pb_check(st == PB_OK, "%s %s: pb_blur_frames_adjoint: %s", names[method], what, pb_last_error(ctx)))
                continue;
            double total = -1.0;
            pb_context_last_kernel_ms(ctx, &total);
            pb_check(total > 0.0, "%s adjoint: the frames' kernel time %g ms", names[method], total);
            /* Frame by frame, and the sums the shared objects must hold. */
            double sums[2][2] = {{0, 0}, {0, 0}}; /* [object][0: summed here, 1: frames' dot] */
            float *want_sum[2] = {calloc(n, sizeof(float)), calloc(n, sizeof(float))};
            for (int f = 0; f < FRAMES; f++) {
                pb_motion m = frame_of(&track, bounds, f);
                poison(single, n);
                pb_check(pb_blur_adjoint(ctx, tomo[f], &m, &opt, single) == PB_OK, "pb_blur_adjoint frame %d: %s", f,
                         pb_last_error(ctx));
                pb_volume_download(single, want);
                pb_volume_download(back[f], got);
                double scale = pb_max_abs(want, n);
                pb_check(scale > 0.0 && pb_max_abs_diff(got, want, n) <= tol * scale,
                         "%s %s adjoint frame %d: pb_blur_frames_adjoint differs from pb_blur_adjoint by %.3g "
                         "(largest value %.3g)", names[method], what, f, pb_max_abs_diff(got, want, n), scale);
                int o = objects[f] == obj[0] ? 0 : 1;
                for (size_t i = 0; i < n; i++)
                    want_sum[o][i] += want[i];
                /* <B_f x, y_f>, the forward side of the dot test. */
                pb_check(pb_blur(ctx, objects[f], &m, &opt, single) == PB_OK, "pb_blur frame %d", f);
                pb_volume_download(single, fwd);
                sums[o][1] += pb_dot(fwd, y[f], n);
            }
            st = pb_blur_frames_adjoint(ctx, ys, &track, bounds, FRAMES, &opt, shared_out);
            pb_check(st == PB_OK, "%s %s: pb_blur_frames_adjoint into shared objects: %s", names[method], what,
                     pb_last_error(ctx));
            double lhs = 0.0, rhs = 0.0;
            for (int o = 0; o < 2; o++) {
                pb_volume_download(sum[o], acc);
                double scale = pb_max_abs(want_sum[o], n);
                pb_check(pb_max_abs_diff(acc, want_sum[o], n) <= tol * scale,
                         "%s %s: object %d holds the sum of its frames' back projections (off by %.3g of %.3g)",
                         names[method], what, o, pb_max_abs_diff(acc, want_sum[o], n), scale);
                lhs += sums[o][1];
                rhs += pb_dot(x[o], acc, n);
                free(want_sum[o]);
            }
            /* Only EXACT: NVIDIA's HARDWARE blend is not its rounded weights'
             * product (test_adjoint has that pair's own tolerance). */
            if (filter == PB_FILTER_EXACT)
                pb_check(fabs(lhs - rhs) <= 1e-5 * fabs(lhs), "%s EXACT frames: <B x, y> = %.9g, <x, B^T y> = %.9g",
                         names[method], lhs, rhs);
        }
    /* An output that is a frame's input is refused before anything is written. */
    pb_blur_options ab_ex = {PB_METHOD_AB, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    pb_volume *into_input[FRAMES] = {back[0], tomo[2], back[2], back[3]};
    for (int f = 0; f < FRAMES; f++)
        poison(back[f], n);
    pb_status bad_st = pb_blur_frames_adjoint(ctx, ys, &track, bounds, FRAMES, &ab_ex, into_input);
    pb_check(bad_st == PB_ERR_INVALID_ARGUMENT && strstr(pb_last_error(ctx), "frame 1's object") != NULL,
             "adjoint into an input: status %d (%s)", (int)bad_st, pb_last_error(ctx));
    pb_volume_download(tomo[2], got);
    pb_check(memcmp(got, y[2], n * sizeof *got) == 0, "adjoint into an input: the input is unchanged");
    for (int f = 0; f < FRAMES; f++) {
        pb_volume_download(back[f], got);
        pb_check(got[0] == -1e30f && got[n - 1] == -1e30f, "adjoint into an input: frame %d was written", f);
        pb_volume_destroy(back[f]);
        free(y[f]);
    }
    for (int i = 0; i < 2; i++)
        pb_volume_destroy(sum[i]);
    free(acc);
    free(fwd);

    /* Progress runs over the whole call: rising, below 1 until the end, 1 last. */
    pb_test_progress_log log = {0, 0, 0.0};
    pb_context_set_progress(ctx, pb_test_record_progress, &log);
    pb_blur_options rm = {PB_METHOD_RM, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    pb_check(pb_blur_frames(ctx, objects, &track, bounds, FRAMES, &rm, tomo) == PB_OK, "frames with progress");
    pb_check(log.calls >= 1 && log.last == 1.0 && !log.bad, "progress: %d calls, last %g, %d out of order",
             log.calls, log.last, log.bad);
    pb_context_set_progress(ctx, NULL, NULL);

    /* A bad frame anywhere stops the call before any frame is written. */
    pb_blur_options ab = {PB_METHOD_AB, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    double late[FRAMES + 1], backwards[FRAMES + 1];
    memcpy(late, bounds, sizeof late);
    memcpy(backwards, bounds, sizeof backwards);
    late[FRAMES] = 2.5; /* after the track's last pose */
    backwards[2] = backwards[1];
    pb_volume *aliased[FRAMES] = {tomo[0], tomo[1], obj[1], tomo[3]};
    pb_volume *shared[FRAMES] = {tomo[0], tomo[1], tomo[1], tomo[3]};
    struct {
        const char *what;
        const double *bounds;
        size_t frames;
        pb_volume *const *out;
        pb_status want;
        const char *needle;
    } bad[] = {{"a frame past the track", late, FRAMES, tomo, PB_ERR_TRACK_GAP, "frame 3 of 4"},
               {"an empty frame", backwards, FRAMES, tomo, PB_ERR_BAD_FRAME, "frame 1"},
               {"no frames", bounds, 0, tomo, PB_ERR_INVALID_ARGUMENT, "no frames"},
               {"an output that is an input", bounds, FRAMES, aliased, PB_ERR_INVALID_ARGUMENT, "object"},
               {"two frames into one output", bounds, FRAMES, shared, PB_ERR_INVALID_ARGUMENT, "share"}};
    for (size_t b = 0; b < sizeof bad / sizeof bad[0]; b++) {
        for (int f = 0; f < FRAMES; f++)
            poison(tomo[f], n);
        pb_status st = pb_blur_frames(ctx, objects, &track, bad[b].bounds, bad[b].frames, &ab, bad[b].out);
        pb_check(st == bad[b].want, "%s: status %d, expected %d (%s)", bad[b].what, (int)st, (int)bad[b].want,
                 pb_last_error(ctx));
        pb_check(strstr(pb_last_error(ctx), bad[b].needle) != NULL, "%s: the message names it: %s", bad[b].what,
                 pb_last_error(ctx));
        for (int f = 0; f < FRAMES; f++) {
            pb_volume_download(tomo[f], got);
            pb_check(got[0] == -1e30f && got[n - 1] == -1e30f, "%s: frame %d was written", bad[b].what, f);
        }
    }
    for (int i = 0; i < 2; i++) {
        pb_volume_destroy(obj[i]);
        free(data[i]);
    }
    for (int f = 0; f < FRAMES; f++)
        pb_volume_destroy(tomo[f]);
    pb_volume_destroy(single);
    free(got);
    free(want);
    pb_context_destroy(ctx);
    return pb_test_finish();
}
