#include "testlib.h"

#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

int pb_test_failed, pb_test_passed;
static uint64_t rng_state;

int pb_check(int cond, const char *fmt, ...)
{
    if (cond) {
        pb_test_passed++;
        return 1;
    }
    pb_test_failed++;
    va_list ap;
    va_start(ap, fmt);
    fputs("FAIL: ", stdout);
    vprintf(fmt, ap);
    fputc('\n', stdout);
    va_end(ap);
    return 0;
}

int pb_test_finish(void)
{
    printf("%d passed, %d failed\n", pb_test_passed, pb_test_failed);
    return pb_test_failed ? 1 : 0;
}

void pb_test_seed(void)
{
    const char *env = getenv("PB_TEST_SEED");
    if (env) {
        rng_state = strtoull(env, NULL, 10);
    } else {
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        rng_state = (uint64_t)ts.tv_sec * 1000003u ^ (uint64_t)ts.tv_nsec;
    }
    printf("seed %llu (replay with PB_TEST_SEED=%llu)\n", (unsigned long long)rng_state,
           (unsigned long long)rng_state);
}

/* splitmix64 */
static uint64_t next_u64(void)
{
    uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

double pb_rand_uniform(void)
{
    return (double)(next_u64() >> 11) * (1.0 / 9007199254740992.0);
}

double pb_rand_range(double lo, double hi)
{
    return lo + (hi - lo) * pb_rand_uniform();
}

pb_backend pb_test_backend(int argc, char **argv)
{
    const char *name = argc > 1 ? argv[1] : "host";
    if (!strcmp(name, "opencl"))
        return PB_BACKEND_OPENCL;
    if (!strcmp(name, "cuda"))
        return PB_BACKEND_CUDA;
    return PB_BACKEND_HOST;
}

int pb_test_nvidia(pb_context *ctx)
{
    pb_device_info info;
    pb_context_device_info(ctx, &info);
    return pb_context_backend(ctx) == PB_BACKEND_CUDA || strstr(info.platform, "NVIDIA") != NULL;
}

pb_context *pb_test_context(int argc, char **argv)
{
    pb_backend b = pb_test_backend(argc, argv);
    int n = 0;
    if (pb_device_count(b, &n) != PB_OK || n == 0) {
        printf("SKIP: no %s device (%s)\n", pb_backend_name(b), pb_last_error(NULL));
        exit(PB_TEST_SKIP);
    }
    pb_context_options o = {b, 0, NULL};
    pb_context *ctx = NULL;
    pb_status st = pb_context_create(&o, &ctx);
    if (st != PB_OK) {
        printf("FAIL: context on %s: %s: %s\n", pb_backend_name(b), pb_status_string(st), pb_last_error(NULL));
        exit(1);
    }
    pb_device_info info;
    pb_context_device_info(ctx, &info);
    printf("backend %s, device '%s' (%s)\n", pb_backend_name(b), info.name, info.platform);
    return ctx;
}

void pb_test_record_progress(double fraction, void *user)
{
    pb_test_progress_log *log = user;
    if (fraction < log->last || log->last == 1.0 || fraction > 1.0)
        log->bad++;
    log->last = fraction;
    log->calls++;
}

/* One direction of the operator on host data: in -> out through fresh
 * volumes, the output poisoned on both sides first. */
static pb_status apply(pb_context *ctx, const pb_geometry *g, const float *in, const pb_motion *m,
                       const pb_blur_options *opt, int adjoint, float *out)
{
    size_t n = g->dims[0] * g->dims[1] * g->dims[2];
    for (size_t i = 0; i < n; i++)
        out[i] = -1e30f; /* finite, since uploads refuse NaN, and far outside any result */
    pb_volume *a = NULL, *b = NULL;
    pb_status st = pb_volume_create(ctx, g, &a);
    if (st == PB_OK)
        st = pb_volume_create(ctx, g, &b);
    if (st == PB_OK)
        st = pb_volume_upload(a, in);
    if (st == PB_OK)
        st = pb_volume_upload(b, out); /* poison the device copy too */
    for (size_t i = 0; i < n && st == PB_OK; i++)
        out[i] = (double)NAN; /* and the host copy, so a download that did not happen shows */
    if (st == PB_OK)
        st = adjoint ? pb_blur_adjoint(ctx, a, m, opt, b) : pb_blur(ctx, a, m, opt, b);
    if (st == PB_OK)
        st = pb_volume_download(b, out);
    if (st != PB_OK)
        printf("%s failed: %s: %s\n", adjoint ? "adjoint" : "blur", pb_status_string(st), pb_last_error(ctx));
    pb_volume_destroy(a);
    pb_volume_destroy(b);
    return st;
}

pb_status pb_test_blur(pb_context *ctx, const pb_geometry *g, const float *in, const pb_motion *m,
                       const pb_blur_options *opt, float *out)
{
    return apply(ctx, g, in, m, opt, 0, out);
}

pb_status pb_test_adjoint(pb_context *ctx, const pb_geometry *g, const float *in, const pb_motion *m,
                          const pb_blur_options *opt, float *out)
{
    return apply(ctx, g, in, m, opt, 1, out);
}

void pb_test_motion_init(pb_test_motion *tm, const pb_pose *start, const pb_pose *end)
{
    memset(tm, 0, sizeof *tm);
    tm->times[0] = 0.0;
    tm->times[1] = 1.0;
    tm->poses[0] = *start;
    tm->poses[1] = *end;
    tm->motion.times = tm->times;
    tm->motion.poses = tm->poses;
    tm->motion.count = 2;
    tm->motion.frame_start = 0.0;
    tm->motion.frame_end = 1.0;
}

pb_pose pb_test_pose(double tx, double ty, double tz, const double axis[3], double deg)
{
    pb_pose p = {{tx, ty, tz}, {1, 0, 0, 0}};
    if (axis)
        pb_quaternion_from_axis_angle(axis, deg, p.rotation);
    return p;
}

double pb_max_abs_diff(const float *a, const float *b, size_t n)
{
    double worst = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = fabs((double)a[i] - (double)b[i]);
        if (isnan(d))
            return (double)NAN; /* a poisoned voxel fails every bound */
        worst = fmax(worst, d);
    }
    return worst;
}

double pb_max_abs(const float *a, size_t n)
{
    double worst = 0.0;
    for (size_t i = 0; i < n; i++)
        worst = fmax(worst, fabs((double)a[i]));
    return worst;
}

double pb_sum(const float *a, size_t n)
{
    double s = 0.0;
    for (size_t i = 0; i < n; i++)
        s += (double)a[i];
    return s;
}

double pb_dot(const float *a, const float *b, size_t n)
{
    double s = 0.0;
    for (size_t i = 0; i < n; i++)
        s += (double)a[i] * (double)b[i];
    return s;
}

float *pb_random_volume(size_t n)
{
    float *v = malloc(n * sizeof *v);
    for (size_t i = 0; v && i < n; i++)
        v[i] = (float)pb_rand_uniform();
    return v;
}

static char deadline_text[256];
static size_t deadline_length;

static void deadline_passed(int sig)
{
    (void)sig;
    ssize_t w = write(STDOUT_FILENO, deadline_text, deadline_length);
    (void)w;
    _exit(1);
}

void pb_test_deadline(unsigned seconds, const char *what)
{
    if (seconds) {
        int n = snprintf(deadline_text, sizeof deadline_text, "FAIL: %s (killed after %u s)\n", what, seconds);
        deadline_length = n < 0 ? 0 : (size_t)n < sizeof deadline_text ? (size_t)n : sizeof deadline_text - 1;
        signal(SIGALRM, deadline_passed);
    }
    alarm(seconds);
}
