/* Every refusal the library makes: each bad input is triggered and its own
 * status checked, with a message that names the problem. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "objects.h"
#include "testlib.h"

static void expect(pb_status got, pb_status want, const char *what, const char *text, const char *needle)
{
    pb_check(got == want, "%s: got %s (%d), want %s (%d): %s", what, pb_status_string(got), (int)got,
             pb_status_string(want), (int)want, text);
    if (needle)
        pb_check(strstr(text, needle) != NULL, "%s: message \"%s\" does not mention \"%s\"", what, text, needle);
}

static void test_volumes(pb_context *ctx)
{
    pb_volume *v = NULL;
    pb_geometry zero = {{8, 0, 8}, {1, 1, 1}};
    expect(pb_volume_create(ctx, &zero, &v), PB_ERR_ZERO_DIMS, "zero dim", pb_last_error(ctx), "dimension y is 0");
    pb_check(v == NULL, "no volume on failure");
    pb_geometry neg = {{8, 8, 8}, {1, -2, 1}};
    expect(pb_volume_create(ctx, &neg, &v), PB_ERR_BAD_VOXEL_SIZE, "negative voxel", pb_last_error(ctx), "voxel size y");
    pb_geometry nan_vox = {{8, 8, 8}, {(double)NAN, 1, 1}};
    expect(pb_volume_create(ctx, &nan_vox, &v), PB_ERR_BAD_VOXEL_SIZE, "NaN voxel", pb_last_error(ctx), NULL);
    /* Sizes beyond a tenth of a micrometre and ten metres, quoted as given; the ends are taken. */
    const double sizes[] = {1e-30, 9.99e-5, 10000.000001, 1e12, 1e300};
    const char *quoted[] = {"is 1e-30 mm", "is 9.99e-05 mm", "is 10000.000001 mm", "is 1000000000000 mm",
                            "is 1e+300 mm"};
    for (int i = 0; i < 5; i++) {
        pb_geometry odd = {{8, 8, 8}, {2, 2, 2}};
        odd.voxel_size[i % 3] = sizes[i];
        expect(pb_volume_create(ctx, &odd, &v), PB_ERR_BAD_VOXEL_SIZE, "voxel size out of range",
               pb_last_error(ctx), quoted[i]);
        pb_check(strstr(pb_last_error(ctx), "from 0.0001 to 10000 mm") != NULL, "the range: %s", pb_last_error(ctx));
    }
    pb_geometry ends = {{2, 2, 2}, {0.0001, 10000, 1}};
    pb_check(pb_volume_create(ctx, &ends, &v) == PB_OK, "0.0001 and 10000 mm taken: %s", pb_last_error(ctx));
    pb_volume_destroy(v);
    v = NULL;
    pb_geometry huge = {{4096, 4096, 4096}, {1, 1, 1}};
    expect(pb_volume_create(ctx, &huge, &v), PB_ERR_VOLUME_TOO_LARGE, "2^36 voxels", pb_last_error(ctx), "2^31");
    expect(pb_volume_create(ctx, NULL, &v), PB_ERR_INVALID_ARGUMENT, "NULL geometry", pb_last_error(ctx), NULL);

    pb_device_info info;
    pb_context_device_info(ctx, &info);
    /* Beyond the device's 3-D image limit along x, within every other limit. */
    if (info.image3d_max[0] && info.image3d_max[0] < 1u << 20) {
        pb_geometry wide = {{info.image3d_max[0] + 1, 2, 2}, {1, 1, 1}};
        expect(pb_volume_create(ctx, &wide, &v), PB_ERR_VOLUME_TOO_LARGE, "wider than the image limit",
               pb_last_error(ctx), "largest 3-D image");
    }
    /* More bytes than one allocation may hold, when a volume of fewer than 2^31
     * voxels inside the image limits can ask for that (PoCL: 1 GiB). */
    if (info.max_alloc_bytes && info.max_alloc_bytes < (1ull << 33) - 64 && info.image3d_max[2] >= 1024) {
        size_t depth = (size_t)(info.max_alloc_bytes / (1024 * 1024 * 4)) + 1;
        pb_geometry big = {{1024, 1024, depth}, {1, 1, 1}};
        expect(pb_volume_create(ctx, &big, &v), PB_ERR_OUT_OF_MEMORY, "more than the largest allocation",
               pb_last_error(ctx), "allocation");
    } else {
        printf("note: no volume here can exceed the device's largest allocation (%.1f GiB, 0 = no limit); the "
               "limit is checked on a described device below\n",
               info.max_alloc_bytes / 1073741824.0);
    }

    pb_geometry a = {{8, 8, 8}, {1, 1, 1}}, b = {{8, 8, 9}, {1, 1, 1}};
    pb_volume *va = NULL, *vb = NULL;
    pb_volume_create(ctx, &a, &va);
    pb_volume_create(ctx, &b, &vb);
    pb_pose p = pb_test_pose(1, 0, 0, NULL, 0);
    pb_test_motion tm;
    pb_test_motion_init(&tm, &p, &p);
    expect(pb_blur(ctx, va, &tm.motion, NULL, vb), PB_ERR_SIZE_MISMATCH, "different sizes", pb_last_error(ctx),
           "differ");
    expect(pb_blur(ctx, va, &tm.motion, NULL, va), PB_ERR_INVALID_ARGUMENT, "in place", pb_last_error(ctx), "same");
    pb_volume_destroy(va);
    pb_volume_destroy(vb);
}

/* The device checks are a pure function of what a device reports, so the
 * refusals a real device here may not provoke are checked on described ones. */
static void test_device_limits(void)
{
    pb_device_info info;
    memset(&info, 0, sizeof info);
    strcpy(info.name, "described device");
    pb_geometry g = {{64, 64, 64}, {1, 1, 1}};
    expect(pb_device_check_volume(NULL, &info, &g), PB_ERR_NO_IMAGE_SUPPORT, "no image support", pb_last_error(NULL),
           "3-D float images");
    info.image_support = 1;
    info.image3d_max[0] = info.image3d_max[1] = info.image3d_max[2] = 2048;
    info.max_alloc_bytes = 512 * 1024;
    expect(pb_device_check_volume(NULL, &info, &g), PB_ERR_OUT_OF_MEMORY, "beyond the largest allocation",
           pb_last_error(NULL), "1.0 MiB");
    info.max_alloc_bytes = 1024 * 1024;
    expect(pb_device_check_volume(NULL, &info, &g), PB_OK, "exactly the largest allocation", pb_last_error(NULL),
           NULL);
    pb_geometry deep = {{16, 16, 2049}, {1, 1, 1}};
    expect(pb_device_check_volume(NULL, &info, &deep), PB_ERR_VOLUME_TOO_LARGE, "deeper than the image limit",
           pb_last_error(NULL), "2048");
}

static void test_motions(pb_context *ctx)
{
    pb_geometry g = {{6, 6, 6}, {2, 2, 2}};
    pb_volume *in = NULL, *out = NULL;
    pb_volume_create(ctx, &g, &in);
    pb_volume_create(ctx, &g, &out);
    float data[216];
    for (int i = 0; i < 216; i++)
        data[i] = (float)pb_rand_uniform();
    data[100] = NAN;
    expect(pb_volume_upload(in, data), PB_ERR_NOT_FINITE, "NaN activity", pb_last_error(ctx), "(4, 4, 2)");
    data[100] = -INFINITY;
    expect(pb_volume_upload(in, data), PB_ERR_NOT_FINITE, "infinite activity", pb_last_error(ctx), "-inf");
    data[100] = 0.5f;
    pb_check(pb_volume_upload(in, data) == PB_OK, "finite upload: %s", pb_last_error(ctx));

    double times[3] = {0.0, 1.0, 2.0};
    pb_pose poses[3];
    for (int i = 0; i < 3; i++)
        poses[i] = pb_test_pose(i, -i, 0.5 * i, NULL, 0);
    pb_motion good = {times, poses, 3, 0.0, 2.0, 0, {0, 0, 0}};
    pb_check(pb_blur(ctx, in, &good, NULL, out) == PB_OK, "the good motion blurs: %s", pb_last_error(ctx));

    pb_motion m = good;
    m.frame_end = 0.0;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_BAD_FRAME, "empty frame", pb_last_error(ctx), "not after");
    m.frame_end = -1.0;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_BAD_FRAME, "reversed frame", pb_last_error(ctx), NULL);

    m = good;
    m.frame_end = 2.5;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_TRACK_GAP, "frame past the track", pb_last_error(ctx),
           "covers [0, 2]");
    m = good;
    m.frame_start = -0.1;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_TRACK_GAP, "frame before the track", pb_last_error(ctx), NULL);

    double back[3] = {0.0, 1.5, 1.0};
    m = good;
    m.times = back;
    m.frame_end = 1.0;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_TRACK_ORDER, "time going backwards", pb_last_error(ctx),
           "track time 2");
    m = good;
    m.count = 1;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_TRACK_GAP, "one pose", pb_last_error(ctx), "one pose");
    m.count = 0;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_INVALID_ARGUMENT, "no poses", pb_last_error(ctx), "no poses");

    double nan_times[3] = {0.0, (double)NAN, 2.0};
    m = good;
    m.times = nan_times;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_NOT_FINITE, "NaN time", pb_last_error(ctx), "time 1");
    m = good;
    m.frame_end = (double)INFINITY;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_NOT_FINITE, "infinite frame", pb_last_error(ctx), NULL);
    pb_pose bad[3] = {poses[0], poses[1], poses[2]};
    bad[1].translation[2] = (double)NAN;
    m = good;
    m.poses = bad;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_NOT_FINITE, "NaN translation", pb_last_error(ctx), "pose 1");
    bad[1] = poses[1];
    bad[2].rotation[3] = (double)INFINITY;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_NOT_FINITE, "infinite quaternion", pb_last_error(ctx), NULL);
    m = good;
    m.has_center = 1;
    m.center[1] = (double)NAN;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_NOT_FINITE, "NaN centre", pb_last_error(ctx), "centre");

    bad[2] = poses[2];
    memset(bad[0].rotation, 0, sizeof bad[0].rotation);
    m = good;
    m.poses = bad;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_BAD_QUATERNION, "zero quaternion", pb_last_error(ctx),
           "zero quaternion");
    bad[0] = poses[0];
    bad[0].rotation[0] = 2.0;
    expect(pb_blur(ctx, in, &m, NULL, out), PB_ERR_BAD_QUATERNION, "norm 2 quaternion", pb_last_error(ctx), "norm 2");

    /* Near-unit quaternions are normalised: the blur equals the unit one's. */
    float ref[216], near[216];
    double axis[3] = {0.2, 0.4, 1.0};
    pb_pose unit[2] = {pb_test_pose(0, 0, 0, NULL, 0), pb_test_pose(1.5, 0, -1, axis, 20)};
    pb_pose scaled[2] = {unit[0], unit[1]};
    for (int k = 0; k < 4; k++)
        scaled[1].rotation[k] *= 1.0 + 5e-4;
    pb_motion mu = {times, unit, 2, 0.0, 1.0, 0, {0, 0, 0}}, ms = mu;
    ms.poses = scaled;
    pb_check(pb_blur(ctx, in, &mu, NULL, out) == PB_OK && pb_volume_download(out, ref) == PB_OK, "unit blur");
    pb_check(pb_blur(ctx, in, &ms, NULL, out) == PB_OK && pb_volume_download(out, near) == PB_OK,
             "near-unit quaternion accepted: %s", pb_last_error(ctx));
    pb_check(pb_max_abs_diff(ref, near, 216) <= 1e-6, "near-unit quaternion normalised (diff %.3g)",
             pb_max_abs_diff(ref, near, 216));

    pb_blur_options opt = {(pb_method)7, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    expect(pb_blur(ctx, in, &good, &opt, out), PB_ERR_INVALID_ARGUMENT, "unknown method", pb_last_error(ctx),
           "method");
    expect(pb_blur(ctx, in, NULL, NULL, out), PB_ERR_INVALID_ARGUMENT, "NULL motion", pb_last_error(ctx), NULL);
    /* The path error bound: not a number, and one that would need absurdly many
     * segments for a 20 degree turn. */
    pb_blur_options bound = {PB_METHOD_AB, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_BOUNDED, (double)NAN, PB_AB_SAMPLING_DEFAULT, 0};
    expect(pb_blur(ctx, in, &mu, &bound, out), PB_ERR_INVALID_ARGUMENT, "NaN max_path_error", pb_last_error(ctx),
           "max_path_error");
    bound.max_path_error = 1e-12;
    expect(pb_blur(ctx, in, &mu, &bound, out), PB_ERR_INVALID_ARGUMENT, "tiny max_path_error", pb_last_error(ctx),
           "max_path_error 1e-12: give a bound in voxels from 0.001 to 1000");
    pb_geometry g6 = {{6, 6, 6}, {1, 1, 1}};
    size_t segments = 0;
    expect(pb_path_segments(&g6, &mu, &bound, &segments), PB_ERR_INVALID_ARGUMENT, "pb_path_segments, tiny bound",
           pb_last_error(NULL), "from 0.001");
    /* The value as given, not %g's six digits of it. */
    bound.max_path_error = 1000.0000001;
    expect(pb_options_check(&bound), PB_ERR_INVALID_ARGUMENT, "a bound just above 1000", pb_last_error(NULL),
           "max_path_error 1000.0000001:");
    expect(pb_path_segments(&g6, NULL, NULL, &segments), PB_ERR_INVALID_ARGUMENT, "pb_path_segments, NULL motion",
           pb_last_error(NULL), "NULL");
    /* Sign-coded bounds of old are refused, not read as a model. */
    bound.max_path_error = -1.0;
    expect(pb_path_segments(&g6, &mu, &bound, &segments), PB_ERR_INVALID_ARGUMENT, "negative bound",
           pb_last_error(NULL), "from 0.001");
    bound.path = PB_PATH_DEFAULT;
    expect(pb_path_segments(&g6, &mu, &bound, &segments), PB_ERR_INVALID_ARGUMENT, "a bound without its model",
           pb_last_error(NULL), "PB_PATH_BOUNDED");
    bound.path = (pb_path_model)3;
    bound.max_path_error = 0.0;
    expect(pb_options_check(&bound), PB_ERR_INVALID_ARGUMENT, "unknown path model", pb_last_error(NULL),
           "path model");
    bound.path = PB_PATH_TRACKED; /* the paper's one segment */
    pb_check(pb_path_segments(&g6, &mu, &bound, &segments) == PB_OK && segments == 1,
             "no cuts on the paper's polyline (%zu segments)", segments);
    double noise = -1.0;
    size_t again = 0;
    pb_check(pb_path_noise(&g6, &mu, &bound, &noise, NULL) == PB_OK && noise == 0.0,
             "no noise measured on the paper's polyline (%g mm)", noise);
    pb_check(pb_path_noise(&g6, &mu, &bound, &noise, &again) == PB_OK && again == segments,
             "pb_path_noise's segments are pb_path_segments' (%zu, %zu)", again, segments);
    bound.max_path_error = -1.0;
    expect(pb_path_noise(&g6, &mu, &bound, &noise, NULL), PB_ERR_INVALID_ARGUMENT, "pb_path_noise, negative bound",
           pb_last_error(NULL), "max_path_error");
    pb_check(pb_options_check(NULL) == PB_OK, "the defaults pass");
    pb_volume_destroy(in);
    pb_volume_destroy(out);
}

static void test_contexts(pb_backend backend)
{
    pb_context *ctx = (pb_context *)1;
    pb_context_options o = {backend, 99, NULL};
    expect(pb_context_create(&o, &ctx), PB_ERR_NO_DEVICE, "device 99", pb_last_error(NULL), "99");
    pb_check(ctx == NULL, "no context on failure");
    o.backend = (pb_backend)42;
    expect(pb_context_create(&o, &ctx), PB_ERR_INVALID_ARGUMENT, "unknown backend", pb_last_error(NULL), "42");
    for (int b = PB_BACKEND_OPENCL; b <= PB_BACKEND_CUDA; b++) {
        if (pb_backend_compiled((pb_backend)b))
            continue;
        o.backend = (pb_backend)b;
        o.device_index = 0;
        expect(pb_context_create(&o, &ctx), PB_ERR_BACKEND_UNAVAILABLE, "backend not built", pb_last_error(NULL),
               "not compiled");
    }
    if (backend == PB_BACKEND_OPENCL) {
        /* A build that cannot compile: the status and the compiler's log. */
        pb_context_options broken = {PB_BACKEND_OPENCL, 0, "-Dfloat=undefined_type"};
        expect(pb_context_create(&broken, &ctx), PB_ERR_BUILD, "broken build", pb_last_error(NULL), "Build log");
        pb_check(strstr(pb_last_error(NULL), "undefined_type") != NULL, "the build log names the error: %s",
                 pb_last_error(NULL));
    }
    pb_backend pb = PB_BACKEND_HOST;
    int idx = -1;
    pb_check(pb_device_parse("opencl:3", &pb, &idx) == PB_OK && pb == PB_BACKEND_OPENCL && idx == 3, "parse opencl:3");
    pb_check(pb_device_parse("cuda", &pb, &idx) == PB_OK && pb == PB_BACKEND_CUDA && idx == 0, "parse cuda");
    pb_check(pb_device_parse("auto", &pb, &idx) == PB_OK && pb == PB_BACKEND_AUTO, "parse auto");
    static const char *bad[] = {"o", "gpu", "host:1", "opencl:", "opencl:-1", "opencl:x", "cuda:2a", ""};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        expect(pb_device_parse(bad[i], &pb, &idx), PB_ERR_INVALID_ARGUMENT, bad[i], pb_last_error(NULL),
               "opencl[:N]");
    for (int s = PB_OK; s >= PB_ERR_BAD_FILE; s--)
        pb_check(strlen(pb_status_string((pb_status)s)) > 0, "status %d has a string", s);
}

/* What a binding can do to the API: destroy a context before its volumes
 * (they keep it alive: the volume still works and its destroy frees both, which
 * a sanitizer run checks), pass NULL where a pointer belongs, give an axis of
 * 1e200 (still a unit quaternion), and a track of 10^6 samples walked as it is. */
static void test_binding_misuse(int argc, char **argv)
{
    pb_context *ctx = pb_test_context(argc, argv);
    pb_geometry g = {{4, 4, 4}, {1, 1, 1}};
    pb_volume *v = NULL;
    float in[64], out[64];
    for (int i = 0; i < 64; i++)
        in[i] = (float)i;
    pb_check(pb_volume_create(ctx, &g, &v) == PB_OK, "volume: %s", pb_last_error(ctx));
    pb_context_destroy(ctx);
    pb_check(v && pb_volume_upload(v, in) == PB_OK && pb_volume_download(v, out) == PB_OK && out[63] == 63.0f,
             "a volume outlives pb_context_destroy of its context");
    pb_volume_destroy(v);
    pb_check(isnan(pb_error_percent(NULL, in, 64)) && isnan(pb_error_percent(in, NULL, 64)),
             "pb_error_percent with NULL gives NaN");
    double axis[3] = {1e200, -3e200, 2e200}, q[4];
    pb_check(pb_quaternion_from_axis_angle(axis, 30.0, q) == PB_OK &&
                 fabs(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1.0) < 1e-12,
             "an axis of 1e200 gives a unit quaternion");
}

/* pb_compare against sums written out here in long double: relative RMS and
 * max, the worst voxel, eq. (5) as the square of RMS / 10; refusals of
 * NULL, n = 0, a zero reference and values that are not finite. */
static void test_compare(void)
{
    enum { N = 997 };
    static float ref[N], x[N];
    const uint32_t first_seed = (uint32_t)time(NULL);
    uint32_t seed = first_seed;
    long double num = 0, den = 0, maxd = 0, maxr = 0;
    size_t worst = 0;
    for (size_t i = 0; i < N; i++) {
        seed = seed * 1664525u + 1013904223u;
        ref[i] = (float)(seed >> 8) / (float)(1u << 24) * 10.0f - 2.0f;
        seed = seed * 1664525u + 1013904223u;
        x[i] = ref[i] + ((float)(seed >> 8) / (float)(1u << 24) - 0.5f) * 0.2f;
        long double d = fabsl((long double)x[i] - (long double)ref[i]);
        num += d * d;
        den += (long double)ref[i] * (long double)ref[i];
        if (d > maxd) {
            maxd = d;
            worst = i;
        }
        if (fabsl((long double)ref[i]) > maxr)
            maxr = fabsl((long double)ref[i]);
    }
    pb_comparison c;
    double rms = (double)(100.0L * sqrtl(num / den)), mx = (double)(100.0L * maxd / maxr);
    pb_check(pb_compare(ref, x, N, &c) == PB_OK && fabs(c.rms_percent / rms - 1.0) < 1e-12 &&
                 fabs(c.max_percent / mx - 1.0) < 1e-12 && c.worst == worst &&
                 fabs(c.eq5_percent / (c.rms_percent * c.rms_percent / 100.0) - 1.0) < 1e-12,
             "pb_compare: rms %.9g (want %.9g), max %.9g (want %.9g), worst %zu (want %zu); seed %u", c.rms_percent,
             rms, c.max_percent, mx, c.worst, worst, first_seed);
    pb_check(pb_compare(NULL, x, N, &c) == PB_ERR_INVALID_ARGUMENT && pb_compare(ref, x, 0, &c) ==
                 PB_ERR_INVALID_ARGUMENT && pb_compare(ref, x, N, NULL) == PB_ERR_INVALID_ARGUMENT,
             "pb_compare refuses NULL and n = 0");
    x[17] = NAN;
    pb_check(pb_compare(ref, x, N, &c) == PB_ERR_NOT_FINITE && strstr(pb_last_error(NULL), "value 17"),
             "pb_compare refuses NaN: %s", pb_last_error(NULL));
    static float zero[N];
    pb_check(pb_compare(zero, ref, N, &c) == PB_ERR_INVALID_ARGUMENT && strstr(pb_last_error(NULL), "zero everywhere"),
             "pb_compare refuses a zero reference: %s", pb_last_error(NULL));
}

/* Every public function that takes a pointer refuses NULL with a status (the
 * sanitizer run checks that nothing is read through one). */
static void test_null_pointers(pb_context *ctx)
{
    pb_backend b;
    int i;
    size_t n;
    double d;
    pb_pose p;
    double q[4], m[16] = {0};
    pb_geometry g = {{2, 2, 2}, {1, 1, 1}};
    pb_volume *v = NULL;
    const pb_status got[] = {
        pb_device_parse(NULL, &b, &i), pb_device_parse("host", NULL, NULL), pb_device_count(PB_BACKEND_HOST, NULL),
        pb_device_get_info(PB_BACKEND_HOST, 0, NULL), pb_context_create(NULL, NULL),
        pb_context_device_info(NULL, NULL), pb_context_set_progress(NULL, NULL, NULL),
        pb_context_last_kernel_ms(ctx, NULL), pb_volume_create(NULL, NULL, NULL), pb_volume_create(ctx, &g, NULL),
        pb_volume_get_geometry(NULL, &g), pb_volume_upload(NULL, NULL), pb_volume_download(NULL, NULL),
        pb_motion_pose_at(NULL, 0, &p), pb_quaternion_from_axis_angle(NULL, 0, q), pb_pose_from_matrix(NULL, &p),
        pb_pose_to_matrix(NULL, m), pb_motion_world_to_grid(NULL, NULL, NULL, NULL, NULL),
        pb_path_segments(NULL, NULL, NULL, &n), pb_path_noise(&g, NULL, NULL, &d, &n), pb_path_noise(&g, NULL, NULL, NULL, &n),
        pb_blur(NULL, NULL, NULL, NULL, NULL),
        pb_blur(ctx, NULL, NULL, NULL, NULL), pb_blur_adjoint(ctx, NULL, NULL, NULL, NULL),
        pb_blur_frames(ctx, NULL, NULL, NULL, 2, NULL, NULL), pb_blur_frames_adjoint(ctx, NULL, NULL, NULL, 2, NULL, NULL)};
    for (size_t k = 0; k < sizeof got / sizeof got[0]; k++)
        pb_check(got[k] == PB_ERR_INVALID_ARGUMENT, "NULL argument %zu: status %d, want invalid argument", k,
                 (int)got[k]);
    if (pb_check(pb_volume_create(ctx, &g, &v) == PB_OK, "volume: %s", pb_last_error(ctx))) {
        pb_check(pb_volume_upload(v, NULL) == PB_ERR_INVALID_ARGUMENT && pb_volume_download(v, NULL) ==
                 PB_ERR_INVALID_ARGUMENT, "NULL host data");
        pb_volume_destroy(v);
    }
    pb_context_destroy(NULL);
    pb_volume_destroy(NULL);
}

/* A 10^6-sample track with one segment per sample (PB_PATH_TRACKED) is
 * refused with a message saying what to do, not walked for minutes. */
static void test_segment_cap(pb_context *ctx)
{
    enum { SAMPLES = 1000000 };
    double *t = malloc(SAMPLES * sizeof *t);
    pb_pose *p = malloc(SAMPLES * sizeof *p);
    for (size_t i = 0; i < SAMPLES; i++) {
        t[i] = (double)i / 30.0;
        p[i] = (pb_pose){{1e-3 * (double)(i % 7), 0, 0}, {1, 0, 0, 0}};
    }
    pb_motion m = {t, p, SAMPLES, 0.0, t[SAMPLES - 1], 0, {0, 0, 0}};
    pb_geometry g = {{4, 4, 4}, {1, 1, 1}};
    pb_volume *a = NULL, *b = NULL;
    pb_blur_options opt = {PB_METHOD_AB, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_TRACKED, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    if (pb_volume_create(ctx, &g, &a) == PB_OK && pb_volume_create(ctx, &g, &b) == PB_OK) {
        expect(pb_blur(ctx, a, &m, &opt, b), PB_ERR_INVALID_ARGUMENT, "10^6 segments", pb_last_error(ctx),
               "path error bound");
        /* A frame that starts at the track's last sample, and one past it: refused by number, with the part
         * of the track each frame plans on kept inside the track (a sanitizer run checks the reads). */
        const pb_volume *ins[1] = {a};
        pb_volume *outs[1] = {b};
        double at_end[2] = {t[SAMPLES - 1], t[SAMPLES - 1] + 1.0}, past[2] = {t[SAMPLES - 1] + 1.0, t[SAMPLES - 1] + 2.0};
        expect(pb_blur_frames(ctx, ins, &m, at_end, 1, NULL, outs), PB_ERR_TRACK_GAP, "a frame from the last sample",
               pb_last_error(ctx), "frame 0 of 1");
        expect(pb_blur_frames(ctx, ins, &m, past, 1, NULL, outs), PB_ERR_TRACK_GAP, "a frame past the track",
               pb_last_error(ctx), "frame 0 of 1");
    }
    pb_volume_destroy(a);
    pb_volume_destroy(b);
    free(t);
    free(p);
}

/* pb_number_text, which messages and files quote numbers by: every finite
 * double (random bit patterns, and the doubles just below 1e17 where log10
 * rounds up to 17) reads back to itself, in at most 24 characters. */
static void test_number_text(void)
{
    int bad = 0;
    for (int i = 0; i < 20000; i++) {
        double v;
        if (i < 64) {
            v = nextafter(1e17, 0.0);
            for (int k = 0; k < i; k++)
                v = nextafter(v, 0.0);
        } else {
            uint64_t bits = 0;
            for (int k = 0; k < 4; k++)
                bits = bits << 16 | (uint64_t)pb_rand_range(0, 65536);
            memcpy(&v, &bits, sizeof v);
            if (!isfinite(v))
                continue;
        }
        char text[PB_NUMBER_TEXT_SIZE];
        pb_number_text(v, text);
        if (strtod(text, NULL) != v || strlen(text) > 24) {
            if (bad++ < 5)
                pb_check(0, "pb_number_text(%.17g) is '%s'", v, text);
        }
    }
    pb_check(bad == 0, "%d doubles of 20000 do not read back from pb_number_text", bad);
    char text[PB_NUMBER_TEXT_SIZE];
    pb_check(!strcmp(pb_number_text(0.1, text), "0.1") && !strcmp(pb_number_text(10000, text), "10000") &&
                 !strcmp(pb_number_text(1000.0000001, text), "1000.0000001"),
             "the shortest forms: 0.1, 10000, 1000.0000001");
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *ctx = pb_test_context(argc, argv);
    test_volumes(ctx);
    test_motions(ctx);
    test_device_limits();
    test_contexts(pb_test_backend(argc, argv));
    test_segment_cap(ctx);
    test_null_pointers(ctx);
    test_binding_misuse(argc, argv);
    test_compare();
    test_number_text();
    pb_context_destroy(ctx);
    return pb_test_finish();
}
