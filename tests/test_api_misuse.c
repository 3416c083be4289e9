/* The C API used wrongly, as a careless caller would, under the sanitizers in
 * CI: every failing call's message is its own (never an earlier call's, and
 * per thread), statuses name the cause, overlapping memory, foreign and
 * mismatched handles are refused, a plan outlives its context, and two
 * threads on one plan are refused rather than raced. */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "testlib.h"

enum { N = 16 };

static int says(const char *text, const char *needle)
{
    return strstr(text, needle) != NULL;
}

static void random_volume(float *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        v[i] = (float)pb_rand_uniform();
}

/* A failing call without a context after one with, and the other way round:
 * the thread's text is always the last failure's. */
static void test_fresh_messages(pb_context *ctx)
{
    pb_volume *v = NULL;
    pb_geometry zero = {{N, 0, N}, {1, 1, 1}};
    pb_status st = pb_plan_forward(NULL, 0, NULL, NULL);
    pb_check(st == PB_ERR_INVALID_ARGUMENT && says(pb_last_error(NULL), "plan must not be NULL"),
             "a NULL plan: %d '%s'", (int)st, pb_last_error(NULL));
    st = pb_volume_create(ctx, &zero, &v);
    pb_check(st == PB_ERR_ZERO_DIMS && says(pb_last_error(NULL), "dimension y is 0") &&
                 says(pb_last_error(ctx), "dimension y is 0"),
             "zero dims after a NULL plan: status %s, thread '%s', context '%s'", pb_status_string(st),
             pb_last_error(NULL), pb_last_error(ctx));
    st = pb_options_check(&(pb_blur_options){.ab_sampling = (pb_ab_sampling)(PB_AB_SAMPLING_CHORD + 1)});
    pb_check(st == PB_ERR_INVALID_ARGUMENT && says(pb_last_error(NULL), "unknown AB sampling 4"),
             "AB sampling past CHORD: %s '%s'", pb_status_string(st), pb_last_error(NULL));
    st = pb_options_check(&(pb_blur_options){.method = PB_METHOD_RM, .ab_sampling = PB_AB_SAMPLING_CHORD});
    pb_check(st == PB_ERR_INVALID_ARGUMENT && says(pb_last_error(NULL), "ab_sampling is set, but the method is RM"),
             "chord with RM: %s '%s'", pb_status_string(st), pb_last_error(NULL));
    st = pb_options_check(&(pb_blur_options){.path = PB_PATH_BOUNDED, .max_path_error = -1.0});
    pb_check(st == PB_ERR_INVALID_ARGUMENT && says(pb_last_error(NULL), "max_path_error -1"),
             "options after a context's failure: '%s'", pb_last_error(NULL));

    /* No poses and one pose: the status says why, not "times not increasing". */
    pb_geometry g = {{N, N, N}, {2, 2, 2}};
    double times[2] = {0, 1};
    pb_pose poses[2] = {{{0, 0, 0}, {1, 0, 0, 0}}, {{1, 0, 0}, {1, 0, 0, 0}}};
    pb_plan *plan = NULL;
    pb_motion none = {times, poses, 0, 0, 1, 0, {0, 0, 0}};
    st = pb_plan_create(ctx, &g, &none, NULL, &plan);
    pb_check(st == PB_ERR_INVALID_ARGUMENT && says(pb_last_error(NULL), "no poses") && !plan, "no poses: %s '%s'",
             pb_status_string(st), pb_last_error(NULL));
    none.count = 1;
    st = pb_plan_create(ctx, &g, &none, NULL, &plan);
    pb_check(st == PB_ERR_TRACK_GAP && says(pb_last_error(NULL), "one pose"), "one pose: %s '%s'",
             pb_status_string(st), pb_last_error(NULL));
}

typedef struct failing_thread {
    int which;
    int wrong; /* messages that were not this thread's */
} failing_thread;

/* Two threads fail different calls many times; each reads its own message. */
static void *fail_repeatedly(void *arg)
{
    failing_thread *t = arg;
    pb_geometry g = {{4, 4, 4}, {1, 1, 1}};
    for (int i = 0; i < 2000; i++) {
        size_t segments;
        if (t->which == 0) {
            g.voxel_size[1] = -1.0 - i;
            pb_status st = pb_path_segments(&g, NULL, NULL, &segments);
            t->wrong += st != PB_ERR_INVALID_ARGUMENT || !says(pb_last_error(NULL), "must not be NULL");
        } else {
            pb_status st = pb_options_check(&(pb_blur_options){.steps = 200000u + (unsigned)i});
            t->wrong += st != PB_ERR_INVALID_ARGUMENT || !says(pb_last_error(NULL), "steps");
        }
    }
    return NULL;
}

static void test_thread_messages(void)
{
    pthread_t th[2];
    failing_thread t[2] = {{0, 0}, {1, 0}};
    for (int i = 0; i < 2; i++)
        pthread_create(&th[i], NULL, fail_repeatedly, &t[i]);
    for (int i = 0; i < 2; i++)
        pthread_join(th[i], NULL);
    pb_check(t[0].wrong == 0 && t[1].wrong == 0, "threads read another thread's message: %d and %d times",
             t[0].wrong, t[1].wrong);
}

/* Memory of the caller that overlaps: by one float, by all but one. Where the
 * backend's buffers are addresses the library can see it; on OpenCL they are
 * handles and only equal ones can be told. */
static void test_overlap(pb_context *ctx, pb_plan *plan)
{
    size_t n = (size_t)N * N * N;
    pb_volume *big;
    pb_geometry twice = {{N, N, 2 * N}, {2, 2, 2}};
    if (pb_volume_create(ctx, &twice, &big) != PB_OK) {
        pb_check(0, "a volume of two grids: %s", pb_last_error(ctx));
        return;
    }
    char *mem;
    pb_volume_memory(big, (void **)&mem);
    int addresses = pb_context_backend(ctx) != PB_BACKEND_OPENCL;
    if (addresses) {
        size_t shifts[3] = {sizeof(float), (n - 1) * sizeof(float), n / 2 * sizeof(float)};
        for (int i = 0; i < 3; i++) {
            pb_status st = pb_plan_forward_device(plan, 0, mem, mem + shifts[i]);
            pb_check(st == PB_ERR_INVALID_ARGUMENT && says(pb_last_error(NULL), "overlap"),
                     "forward into memory %zu bytes past its input: %s '%s'", shifts[i], pb_status_string(st),
                     pb_last_error(NULL));
            st = pb_plan_adjoint_device(plan, 0, mem + shifts[i], mem, 0);
            pb_check(st == PB_ERR_INVALID_ARGUMENT && says(pb_last_error(NULL), "overlap"),
                     "adjoint from memory %zu bytes past its output: %s '%s'", shifts[i], pb_status_string(st),
                     pb_last_error(NULL));
        }
        /* Side by side is fine. */
        pb_status st = pb_plan_forward_device(plan, 0, mem, mem + n * sizeof(float));
        pb_check(st == PB_OK, "adjacent, not overlapping: %s", pb_last_error(NULL));
    }
    pb_status st = pb_plan_forward_device(plan, 0, mem, mem);
    pb_check(st == PB_ERR_INVALID_ARGUMENT && says(pb_last_error(NULL), "same memory"), "the same memory: '%s'",
             pb_last_error(NULL));
    pb_volume_destroy(big);
}

/* Volumes of another context, of another grid, a frame past the last. */
static void test_foreign(pb_context *ctx, pb_plan *plan, pb_volume *in, pb_volume *out)
{
    pb_context_options host = {PB_BACKEND_HOST, 0, NULL};
    pb_context *other;
    if (pb_context_create(&host, &other) != PB_OK) {
        pb_check(0, "a host context: %s", pb_last_error(NULL));
        return;
    }
    pb_geometry g;
    pb_plan_get_geometry(plan, &g);
    pb_volume *alien;
    pb_volume_create(other, &g, &alien);
    pb_status st = pb_plan_forward(plan, 0, alien, out);
    pb_check(st == PB_ERR_SIZE_MISMATCH && says(pb_last_error(ctx), "belong to the context"),
             "a volume of another context: %s '%s'", pb_status_string(st), pb_last_error(ctx));
    pb_geometry smaller = g;
    smaller.dims[2] -= 1;
    pb_volume *small;
    pb_volume_create(ctx, &smaller, &small);
    st = pb_plan_adjoint(plan, 0, out, small, 0);
    pb_check(st == PB_ERR_SIZE_MISMATCH && says(pb_last_error(ctx), "differs from the plan's grid"),
             "a volume of another grid: %s '%s'", pb_status_string(st), pb_last_error(ctx));
    st = pb_plan_forward(plan, 1, in, out);
    pb_check(st == PB_ERR_INVALID_ARGUMENT && says(pb_last_error(ctx), "frame 1 does not exist"),
             "frame 1 of a plan of one: '%s'", pb_last_error(ctx));
    pb_volume_destroy(small);
    /* The other context destroyed first: its volume keeps it alive. */
    pb_context_destroy(other);
    pb_volume_destroy(alien);
}

typedef struct racing {
    pb_plan *plan;
    pb_volume *in, *out;
    int ok, refused, other;
    char message[512];
} racing;

static void *forward_repeatedly(void *arg)
{
    racing *r = arg;
    for (int i = 0; i < 100000 && r->ok < 20; i++) {
        pb_status st = pb_plan_forward(r->plan, 0, r->in, r->out);
        if (st == PB_OK) {
            r->ok++;
        } else if (st == PB_ERR_INVALID_ARGUMENT && says(pb_last_error(NULL), "in use by another thread")) {
            r->refused++;
            nanosleep(&(struct timespec){0, 20000}, NULL); /* let the other thread finish its call */
        } else if (r->other++ == 0) {
            snprintf(r->message, sizeof r->message, "%s: %s", pb_status_string(st), pb_last_error(NULL));
        }
    }
    return NULL;
}

/* Two threads on one plan: each call runs whole or is refused, and what ran
 * is right. */
static void test_two_threads(pb_context *ctx, pb_plan *plan, const float *object, const float *want)
{
    size_t n = (size_t)N * N * N;
    pb_geometry g;
    pb_plan_get_geometry(plan, &g);
    racing r[2] = {{plan, NULL, NULL, 0, 0, 0, ""}, {plan, NULL, NULL, 0, 0, 0, ""}};
    for (int i = 0; i < 2; i++) {
        pb_volume_create(ctx, &g, &r[i].in);
        pb_volume_create(ctx, &g, &r[i].out);
        pb_volume_upload(r[i].in, object);
    }
    pthread_t th[2];
    for (int i = 0; i < 2; i++)
        pthread_create(&th[i], NULL, forward_repeatedly, &r[i]);
    for (int i = 0; i < 2; i++)
        pthread_join(th[i], NULL);
    float *got = malloc(n * sizeof *got);
    for (int i = 0; i < 2; i++) {
        pb_check(r[i].other == 0 && r[i].ok == 20, "thread %d: %d ran, %d refused, %d failed otherwise (%s)", i,
                 r[i].ok, r[i].refused, r[i].other, r[i].message);
        for (size_t k = 0; k < n; k++)
            got[k] = (float)NAN;
        pb_volume_download(r[i].out, got);
        double worst = 0.0;
        for (size_t k = 0; k < n; k++)
            worst = fmax(worst, fabs((double)got[k] - (double)want[k]));
        pb_check(worst == 0.0, "thread %d's tomograph differs from one thread's by %.3g", i, worst);
        pb_volume_destroy(r[i].in);
        pb_volume_destroy(r[i].out);
    }
    free(got);
    printf("two threads on one plan: %d + %d calls ran, %d + %d refused\n", r[0].ok, r[1].ok, r[0].refused,
           r[1].refused);
}

/* The names front ends parse through the library: every name round-trips,
 * a wrong one or NULL is refused with the list of choices, NULL outputs too. */
static void test_names(void)
{
    for (int m = PB_METHOD_AB; m <= PB_METHOD_REF; m++) {
        pb_method back = PB_METHOD_REF;
        pb_check(pb_method_name((pb_method)m) && pb_method_parse(pb_method_name((pb_method)m), &back) == PB_OK &&
                     back == (pb_method)m, "method %d round trip", m);
    }
    for (int f = PB_FILTER_HARDWARE; f <= PB_FILTER_EXACT; f++) {
        pb_filter back = PB_FILTER_EXACT;
        pb_check(pb_filter_parse(pb_filter_name((pb_filter)f), &back) == PB_OK && back == (pb_filter)f,
                 "filter %d round trip", f);
    }
    for (int a = PB_AB_SAMPLING_DEFAULT; a <= PB_AB_SAMPLING_CHORD; a++) {
        pb_ab_sampling back = (pb_ab_sampling)-1;
        pb_check(pb_ab_sampling_parse(pb_ab_sampling_name((pb_ab_sampling)a), &back) == PB_OK &&
                     back == (pb_ab_sampling)a, "sampling %d round trip", a);
    }
    for (int t = PB_TRACK_AUTO; t <= PB_TRACK_POLARIS; t++) {
        pb_track_format back = PB_TRACK_POLARIS;
        pb_check(pb_track_format_parse(pb_track_format_name((pb_track_format)t), &back) == PB_OK &&
                     back == (pb_track_format)t, "format %d round trip", t);
    }
    pb_method m;
    pb_check(pb_method_parse("AB", &m) == PB_ERR_INVALID_ARGUMENT && strstr(pb_last_error(NULL), "'AB'") &&
                 strstr(pb_last_error(NULL), "ref (the multi-point reference)"), "AB: %s", pb_last_error(NULL));
    pb_check(pb_method_parse(NULL, &m) == PB_ERR_INVALID_ARGUMENT && pb_method_parse("ab", NULL) != PB_OK,
             "NULL name or output");
    pb_track_format f;
    pb_check(pb_track_format_parse("unknown", &f) == PB_ERR_INVALID_ARGUMENT, "'unknown' is no format");
    pb_check(pb_method_name((pb_method)7) == NULL && pb_filter_name((pb_filter)-1) == NULL, "no name out of range");
}

int main(int argc, char **argv)
{
    pb_test_seed();
    pb_context *ctx = pb_test_context(argc, argv);
    size_t n = (size_t)N * N * N;
    pb_geometry g = {{N, N, N}, {2, 2, 2}};
    double times[2] = {0, 1};
    pb_pose poses[2] = {{{0, 0, 0}, {1, 0, 0, 0}},
                        {{pb_rand_range(-4, 4), pb_rand_range(-4, 4), pb_rand_range(-4, 4)}, {1, 0, 0, 0}}};
    pb_motion m = {times, poses, 2, 0, 1, 0, {0, 0, 0}};
    float *object = malloc(n * sizeof *object), *want = malloc(n * sizeof *want);
    random_volume(object, n);

    test_fresh_messages(ctx);
    test_thread_messages();
    test_names();

    pb_plan *plan = NULL;
    pb_volume *in = NULL, *out = NULL;
    pb_check(pb_plan_create(ctx, &g, &m, NULL, &plan) == PB_OK && pb_volume_create(ctx, &g, &in) == PB_OK &&
                 pb_volume_create(ctx, &g, &out) == PB_OK && pb_volume_upload(in, object) == PB_OK &&
                 pb_plan_forward(plan, 0, in, out) == PB_OK && pb_volume_download(out, want) == PB_OK,
             "a plan and its volumes: %s", pb_last_error(ctx));
    test_overlap(ctx, plan);
    test_foreign(ctx, plan, in, out);
    test_two_threads(ctx, plan, object, want);

    /* The plan and volumes outlive their context, and still blur. */
    pb_context_destroy(ctx);
    float *again = malloc(n * sizeof *again);
    for (size_t k = 0; k < n; k++)
        again[k] = (float)NAN;
    pb_status st = pb_volume_upload(in, object);
    if (st == PB_OK)
        st = pb_plan_forward(plan, 0, in, out);
    if (st == PB_OK)
        st = pb_volume_download(out, again);
    int same = st == PB_OK && memcmp(again, want, n * sizeof *want) == 0;
    pb_check(same, "a plan after pb_context_destroy: %s", st == PB_OK ? "differs" : pb_last_error(NULL));
    pb_plan_destroy(plan);
    pb_volume_destroy(in);
    pb_volume_destroy(out); /* the last holder: the context goes with it (ASan: no leak) */
    free(again);
    free(object);
    free(want);
    return pb_test_finish();
}
