/* Dynamic PET on one device: F frames of an N^3 volume, each with its own
 * activity and its own part of a 30 Hz pose track, blurred by one
 * pb_blur_frames call against the same frames blurred one pb_blur call at a
 * time. Both are timed by device events (the kernels' total) and by the host
 * clock around the calls (what the application waits for); the volumes are on
 * the device throughout, so no transfer is timed. The outputs of the two must
 * be identical, bit for bit.
 *
 * The track: a slow drift and nod (a few mm, a few degrees over minutes) with
 * 0.05 mm of marker jitter at every sample, so that every frame holds
 * rate x frame-length tracked poses, as a motion log from an optical tracker
 * does. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "petblur.h"
#include "bench_stats.h"

/* A reproducible uniform in [-1, 1) (xorshift), so runs compare. */
static double jitter(unsigned long long *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return (double)(*s >> 11) / 4503599627370496.0 - 1.0;
}

static void usage(void)
{
    fputs("usage: pb_frames [--device DEV] [--size N] [--frames F] [--frame-seconds S] [--rate HZ] [--runs R]\n"
          "                 [--method ab|rm|cl] [--csv FILE] [--label TEXT]\n"
          "F frames (default 20) of an N^3 volume (default 256) with a HZ pose track (default 30) over F x S\n"
          "seconds (default 6): one pb_blur_frames call against F pb_blur calls, device events and host clock,\n"
          "median of R runs (default 5) after a warm-up.\n",
          stderr);
}

static int fail(pb_context *ctx, pb_status st, const char *what)
{
    fprintf(stderr, "pb_frames: %s: %s: %s\n", what, pb_status_string(st), pb_last_error(ctx));
    return 1;
}

int main(int argc, char **argv)
{
    pb_context_options copt = {PB_BACKEND_AUTO, 0, NULL};
    size_t size = 256;
    int frames = 20, runs = 5;
    double seconds = 6.0, rate = 30.0;
    pb_method method = PB_METHOD_AB;
    const char *csv = NULL, *label = "";
    for (int i = 1; i < argc; i += 2) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!v) {
            usage();
            return 2;
        }
        if (!strcmp(a, "--device")) {
            if (pb_device_parse(v, &copt.backend, &copt.device_index) != PB_OK) {
                fprintf(stderr, "pb_frames: --device: %s\n", pb_last_error(NULL));
                return 2;
            }
        } else if (!strcmp(a, "--size"))
            size = (size_t)atol(v);
        else if (!strcmp(a, "--frames"))
            frames = atoi(v);
        else if (!strcmp(a, "--frame-seconds"))
            seconds = atof(v);
        else if (!strcmp(a, "--rate"))
            rate = atof(v);
        else if (!strcmp(a, "--runs"))
            runs = atoi(v);
        else if (!strcmp(a, "--method"))
            method = !strcmp(v, "rm") ? PB_METHOD_RM : !strcmp(v, "cl") ? PB_METHOD_CL : PB_METHOD_AB;
        else if (!strcmp(a, "--csv"))
            csv = v;
        else if (!strcmp(a, "--label"))
            label = v;
        else {
            usage();
            return 2;
        }
    }
    if (size < 2 || frames < 1 || runs < 1 || !(seconds > 0.0) || !(rate > 0.0)) {
        usage();
        return 2;
    }

    /* The track, one sample past the last frame's end. */
    size_t count = (size_t)ceil(frames * seconds * rate) + 2;
    double *times = malloc(count * sizeof *times), *bounds = malloc((size_t)(frames + 1) * sizeof *bounds);
    pb_pose *poses = malloc(count * sizeof *poses);
    unsigned long long seed = 88172645463325252ULL;
    double axis[3] = {0.3, 1.0, 0.1};
    for (size_t k = 0; k < count; k++) {
        double t = (double)k / rate, minutes = t / 60.0;
        times[k] = t;
        poses[k].translation[0] = 3.0 * sin(1.3 * minutes) + 0.05 * jitter(&seed);
        poses[k].translation[1] = 2.0 * minutes + 0.05 * jitter(&seed);
        poses[k].translation[2] = -1.5 * sin(0.7 * minutes) + 0.05 * jitter(&seed);
        pb_quaternion_from_axis_angle(axis, 4.0 * sin(2.1 * minutes) + 0.02 * jitter(&seed), poses[k].rotation);
    }
    for (int f = 0; f <= frames; f++)
        bounds[f] = f * seconds;
    pb_motion track = {times, poses, count, 0.0, 0.0, 0, {0, 0, 0}};

    pb_context *ctx = NULL;
    pb_status st = pb_context_create(&copt, &ctx);
    if (st != PB_OK)
        return fail(NULL, st, "context");
    pb_device_info info;
    pb_context_device_info(ctx, &info);
    pb_geometry g = {{size, size, size}, {1.0, 1.0, 1.0}};
    size_t n = size * size * size;
    pb_blur_options opt = {method, PB_FILTER_HARDWARE, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    pb_motion first = track;
    first.frame_start = bounds[0];
    first.frame_end = bounds[1];
    size_t segments = 0;
    pb_path_segments(&g, &first, &opt, &segments);

    /* Every frame its own activity (the tracer's uptake changes) and output. */
    pb_volume **obj = calloc((size_t)frames, sizeof *obj), **out = calloc((size_t)frames, sizeof *out), *single;
    float *data = malloc(n * sizeof *data), *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
    for (int f = 0; f < frames && st == PB_OK; f++) {
        for (size_t i = 0; i < n; i++)
            data[i] = (float)((1.0 + jitter(&seed)) * (1.0 + 0.05 * f));
        if ((st = pb_volume_create(ctx, &g, &obj[f])) == PB_OK && (st = pb_volume_create(ctx, &g, &out[f])) == PB_OK)
            st = pb_volume_upload(obj[f], data);
    }
    if (st == PB_OK)
        st = pb_volume_create(ctx, &g, &single);
    if (st != PB_OK)
        return fail(ctx, st, "volumes (use a smaller --size or fewer --frames)");

    /* One frame at a time: each frame's median, summed. */
    double alone_kernel = 0.0, alone_wall = 0.0, *k_ms = malloc((size_t)runs * sizeof *k_ms),
           *w_ms = malloc((size_t)runs * sizeof *w_ms);
    for (int f = 0; f < frames && st == PB_OK; f++) {
        pb_motion m = track;
        m.frame_start = bounds[f];
        m.frame_end = bounds[f + 1];
        st = pb_blur(ctx, obj[f], &m, &opt, single);
        for (int r = 0; r < runs && st == PB_OK; r++) {
            double t0 = pbc_now_ms();
            st = pb_blur(ctx, obj[f], &m, &opt, single);
            w_ms[r] = pbc_now_ms() - t0;
            pb_context_last_kernel_ms(ctx, &k_ms[r]);
        }
        alone_kernel += pbc_median(k_ms, runs);
        alone_wall += pbc_median(w_ms, runs);
    }
    if (st != PB_OK)
        return fail(ctx, st, "pb_blur");

    /* All frames in one call. */
    st = pb_blur_frames(ctx, (const pb_volume *const *)obj, &track, bounds, (size_t)frames, &opt, out);
    for (int r = 0; r < runs && st == PB_OK; r++) {
        double t0 = pbc_now_ms();
        st = pb_blur_frames(ctx, (const pb_volume *const *)obj, &track, bounds, (size_t)frames, &opt, out);
        w_ms[r] = pbc_now_ms() - t0;
        pb_context_last_kernel_ms(ctx, &k_ms[r]);
    }
    if (st != PB_OK)
        return fail(ctx, st, "pb_blur_frames");
    double batch_kernel = pbc_median(k_ms, runs), batch_wall = pbc_median(w_ms, runs);

    /* The same numbers either way: the last frame (its single blur is the
     * last one made) and the first (made again). */
    int same = 1;
    for (int pass = 0; pass < 2 && st == PB_OK; pass++) {
        int f = pass ? 0 : frames - 1;
        if (pass) {
            pb_motion m = track;
            m.frame_start = bounds[0];
            m.frame_end = bounds[1];
            st = pb_blur(ctx, obj[0], &m, &opt, single);
        }
        if (st == PB_OK && (st = pb_volume_download(single, a)) == PB_OK && (st = pb_volume_download(out[f], b)) == PB_OK)
            same &= memcmp(a, b, n * sizeof *a) == 0;
    }
    if (st != PB_OK)
        return fail(ctx, st, "check");

    const char *mname = method == PB_METHOD_RM ? "RM" : method == PB_METHOD_CL ? "CL" : "AB";
    printf("# %s on %s [%s]: %d frames of %zu^3, %.3g s each, a %.3g Hz track (%zu poses); %s HARDWARE, default "
           "path bound (%zu segments in frame 0); median of %d runs after a warm-up\n",
           pb_backend_name(pb_context_backend(ctx)), info.name, info.platform, frames, size, seconds, rate, count,
           mname, segments, runs);
    printf("%-28s %14s %14s\n", "", "kernel ms", "host clock ms");
    printf("%-28s %14.3f %14.3f\n", "one frame at a time, total", alone_kernel, alone_wall);
    printf("%-28s %14.3f %14.3f\n", "pb_blur_frames, total", batch_kernel, batch_wall);
    printf("%-28s %14.3f %14.3f\n", "per frame, one at a time", alone_kernel / frames, alone_wall / frames);
    printf("%-28s %14.3f %14.3f\n", "per frame, pb_blur_frames", batch_kernel / frames, batch_wall / frames);
    printf("%-28s %14.3f %14.3f\n", "pb_blur_frames / alone", batch_kernel / alone_kernel, batch_wall / alone_wall);
    printf("outputs identical to one frame at a time: %s\n", same ? "yes" : "NO");
    printf("target (per frame at least as fast in one call, host clock): %s\n",
           batch_wall <= alone_wall ? "met" : "NOT met");
    if (csv) {
        FILE *fp = fopen(csv, "w");
        if (!fp) {
            perror(csv);
            return 1;
        }
        fprintf(fp, "label,backend,device,method,size,frames,frame_s,rate_hz,poses,segments_frame0,runs,"
                    "alone_kernel_ms,alone_wall_ms,batch_kernel_ms,batch_wall_ms,identical\n");
        fprintf(fp, "%s,%s,%s,%s,%zu,%d,%g,%g,%zu,%zu,%d,%.6g,%.6g,%.6g,%.6g,%d\n", label,
                pb_backend_name(pb_context_backend(ctx)), info.name, mname, size, frames, seconds, rate, count, segments,
                runs, alone_kernel, alone_wall, batch_kernel, batch_wall, same);
        fclose(fp);
    }
    for (int f = 0; f < frames; f++) {
        pb_volume_destroy(obj[f]);
        pb_volume_destroy(out[f]);
    }
    pb_volume_destroy(single);
    pb_context_destroy(ctx);
    free(obj);
    free(out);
    free(data);
    free(a);
    free(b);
    free(k_ms);
    free(w_ms);
    free(times);
    free(bounds);
    free(poses);
    return same ? 0 : 1;
}
