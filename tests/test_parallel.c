/* Loops on threads (src/core/parallel.c) as the estimate runs them, on fresh
 * random sizes and volumes each run: every item runs once; sums, smoothing,
 * derivative images and the references' inner products are the same bits on
 * the pool as on the caller alone, and right against closed forms (an
 * impulse smoothed is the product of its Gaussian's weights; a linear ramp's
 * gradient is its slope). */
#define _GNU_SOURCE /* sched_setaffinity: the host forward on one core */
#include <math.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "estimate.h"
#include "testlib.h"

static void count_item(void *user, size_t i)
{
    ((int *)user)[i]++;
}

static void test_every_item_once(pb_pool *pool)
{
    const size_t counts[] = {0, 1, 2, 7, (size_t)pb_rand_range(100, 5000)};
    for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++) {
        int *hits = calloc(counts[c] + 1, sizeof(int));
        for (int round = 0; round < 3; round++)
            pb_pool_for(pool, counts[c], count_item, hits);
        int wrong = 0;
        for (size_t i = 0; i < counts[c]; i++)
            wrong += hits[i] != 3;
        pb_check(wrong == 0 && hits[counts[c]] == 0, "pool_for over %zu items, three times: %d items not run three "
                 "times", counts[c], wrong);
        free(hits);
    }
}

typedef struct pair {
    const float *x, *y;
} pair;

static void moments(void *user, size_t begin, size_t end, double *s)
{
    const pair *p = user;
    for (size_t i = begin; i < end; i++) {
        s[0] += (double)p->x[i];
        s[1] += (double)p->x[i] * (double)p->x[i];
        s[2] += (double)p->x[i] * (double)p->y[i];
    }
}

static void test_sums(pb_pool *pool)
{
    for (int round = 0; round < 4; round++) {
        /* sizes off and on the chunk's multiples, one under a chunk */
        size_t n = round == 0 ? (size_t)pb_rand_range(1, PB_CHUNK) : round == 1 ? 5 * PB_CHUNK
                                                                       : (size_t)pb_rand_range(PB_CHUNK, 300000);
        float *x = pb_random_volume(n), *y = pb_random_volume(n);
        pair p = {x, y};
        double threaded[3], alone[3];
        long double exact[3] = {0, 0, 0};
        pb_pool_sums(pool, n, 3, moments, &p, threaded);
        pb_pool_sums(NULL, n, 3, moments, &p, alone);
        for (size_t i = 0; i < n; i++) {
            exact[0] += (long double)x[i];
            exact[1] += (long double)x[i] * (long double)x[i];
            exact[2] += (long double)x[i] * (long double)y[i];
        }
        for (int k = 0; k < 3; k++) {
            pb_check(memcmp(&threaded[k], &alone[k], sizeof(double)) == 0, "sum %d of %zu voxels: %.17g on %zu "
                     "threads, %.17g alone", k, n, threaded[k], pb_pool_threads(pool), alone[k]);
            double rel = fabs(threaded[k] - (double)exact[k]) / fmax(1e-300, fabsl(exact[k]));
            pb_check(rel < 1e-12, "sum %d of %zu voxels off the long-double sum by %.3g of it", k, n, rel);
        }
        free(x);
        free(y);
    }
}

static pb_geometry random_grid(void)
{
    pb_geometry g;
    for (int a = 0; a < 3; a++) {
        g.dims[a] = (size_t)pb_rand_range(9, 41);
        g.voxel_size[a] = pb_rand_range(1.0, 4.0);
    }
    return g;
}

static void test_smooth(pb_pool *pool)
{
    pb_geometry g = random_grid();
    const size_t n = g.dims[0] * g.dims[1] * g.dims[2];
    const double fwhm = pb_rand_range(3.0, 9.0);
    float *a = pb_random_volume(n), *b = malloc(sizeof(float) * n), *tmp = malloc(sizeof(float) * 64);
    memcpy(b, a, sizeof(float) * n);
    pbe_smooth(pool, &g, a, fwhm, tmp);
    pbe_smooth(NULL, &g, b, fwhm, tmp);
    pb_check(memcmp(a, b, sizeof(float) * n) == 0, "smoothing %zu x %zu x %zu: the pool's differs from the "
             "caller's by %.3g", g.dims[0], g.dims[1], g.dims[2], pb_max_abs_diff(a, b, n));
    /* an impulse far from the faces: the product of the three axes' weights */
    memset(a, 0, sizeof(float) * n);
    size_t c[3] = {g.dims[0] / 2, g.dims[1] / 2, g.dims[2] / 2};
    a[c[0] + g.dims[0] * (c[1] + g.dims[1] * c[2])] = 1.0f;
    pbe_smooth(pool, &g, a, fwhm, tmp);
    double worst = 0.0;
    for (size_t z = 0; z < g.dims[2]; z++)
        for (size_t y = 0; y < g.dims[1]; y++)
            for (size_t x = 0; x < g.dims[0]; x++) {
                const size_t at[3] = {x, y, z};
                double want = 1.0;
                for (int ax = 0; ax < 3; ax++) {
                    double sigma = fwhm / (2.0 * sqrt(2.0 * log(2.0))) / g.voxel_size[ax];
                    if (sigma < 0.2) {
                        want *= at[ax] == c[ax];
                        continue;
                    }
                    int radius = 3.0 * sigma < (double)(g.dims[ax] - 1) ? (int)ceil(3.0 * sigma)
                                                                        : (int)(g.dims[ax] - 1);
                    long d = (long)at[ax] - (long)c[ax];
                    /* the weights the line's other end sees: those inside the grid */
                    double sum = 0.0;
                    for (long q = -radius; q <= radius; q++) {
                        long p = (long)at[ax] + q;
                        if (p >= 0 && p < (long)g.dims[ax])
                            sum += exp(-0.5 * (double)(q * q) / (sigma * sigma));
                    }
                    want *= labs(d) <= radius ? exp(-0.5 * (double)(d * d) / (sigma * sigma)) / sum : 0.0;
                }
                worst = fmax(worst, fabs((double)a[x + g.dims[0] * (y + g.dims[1] * z)] - want));
            }
    pb_check(worst < 1e-6, "an impulse smoothed (fwhm %.2f mm) is off the Gaussian's weights by %.3g", fwhm, worst);
    free(a);
    free(b);
    free(tmp);
}

static void test_gradients(pb_pool *pool)
{
    pb_geometry g = random_grid();
    const size_t n = g.dims[0] * g.dims[1] * g.dims[2];
    const double c[3] = {pb_rand_range(0, 60), pb_rand_range(0, 60), pb_rand_range(0, 60)};
    const double slope[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), pb_rand_range(-1, 1)};
    float *x = malloc(sizeof(float) * n), *mem = malloc(sizeof(float) * 12 * n);
    float *threaded[6], *alone[6];
    for (int j = 0; j < 6; j++) {
        threaded[j] = mem + (size_t)j * n;
        alone[j] = mem + (size_t)(6 + j) * n;
    }
    for (size_t z = 0; z < g.dims[2]; z++)
        for (size_t y = 0; y < g.dims[1]; y++)
            for (size_t i = 0; i < g.dims[0]; i++)
                x[i + g.dims[0] * (y + g.dims[1] * z)] =
                    (float)(slope[0] * ((double)i + 0.5) * g.voxel_size[0] +
                            slope[1] * ((double)y + 0.5) * g.voxel_size[1] +
                            slope[2] * ((double)z + 0.5) * g.voxel_size[2] + 100.0);
    pbe_pose_gradients(pool, &g, x, c, threaded);
    pbe_pose_gradients(NULL, &g, x, c, alone);
    pb_check(memcmp(threaded[0], alone[0], sizeof(float) * 6 * n) == 0, "the derivative images on the pool differ "
             "from the caller's");
    double worst = 0.0;
    for (size_t z = 1; z + 1 < g.dims[2]; z++)
        for (size_t y = 1; y + 1 < g.dims[1]; y++)
            for (size_t i = 1; i + 1 < g.dims[0]; i++)
                for (int a = 0; a < 3; a++)
                    worst = fmax(worst, fabs((double)threaded[a][i + g.dims[0] * (y + g.dims[1] * z)] - slope[a]));
    /* the ramp is stored in float: its steps round at about 1e-5 of 100 */
    pb_check(worst < 2e-4, "a ramp's gradient inside the grid is off its slope by %.3g", worst);
    free(x);
    free(mem);
}

static void test_gram_band(pb_pool *pool)
{
    const size_t frames = (size_t)pb_rand_range(2, 40), n = (size_t)pb_rand_range(1000, 40000);
    float *moved = pb_random_volume(frames * n);
    double *threaded = calloc(frames * (PBE_REFERENCE_OTHERS + 1), sizeof(double));
    double *alone = calloc(frames * (PBE_REFERENCE_OTHERS + 1), sizeof(double));
    pbe_gram_band(pool, moved, n, frames, threaded);
    pbe_gram_band(NULL, moved, n, frames, alone);
    pb_check(memcmp(threaded, alone, sizeof(double) * frames * (PBE_REFERENCE_OTHERS + 1)) == 0,
             "the band of %zu frames' inner products differs on the pool", frames);
    size_t i = (size_t)pb_rand_range(0, (double)frames);
    double d = pbe_dot(moved + i * n, moved + i * n, n);
    pb_check(threaded[i * (PBE_REFERENCE_OTHERS + 1)] == d, "frame %zu's own product: %.17g, by hand %.17g", i,
             threaded[i * (PBE_REFERENCE_OTHERS + 1)], d);
    free(moved);
    free(threaded);
    free(alone);
}

/* The host backend's forward on the machine's cores gives the bits it gives
 * on one core (the affinity narrowed to one CPU: its pool is then none). */
static void test_host_forward(void)
{
    cpu_set_t all, one;
    if (sched_getaffinity(0, sizeof all, &all) != 0 || CPU_COUNT(&all) < 2) {
        printf("host forward on threads: one core here, nothing to compare\n");
        return;
    }
    pb_geometry g = {{(size_t)pb_rand_range(32, 40), (size_t)pb_rand_range(32, 40), (size_t)pb_rand_range(32, 40)},
                     {pb_rand_range(1.5, 3.0), pb_rand_range(1.5, 3.0), pb_rand_range(1.5, 3.0)}};
    const size_t n = g.dims[0] * g.dims[1] * g.dims[2];
    double axis[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), 1.0};
    pb_pose a = pb_test_pose(0, 0, 0, axis, 0), b = pb_test_pose(pb_rand_range(-6, 6), pb_rand_range(-6, 6),
                                                                  pb_rand_range(-6, 6), axis, pb_rand_range(-8, 8));
    pb_test_motion tm;
    pb_test_motion_init(&tm, &a, &b);
    float *x = pb_random_volume(n), *threaded = malloc(sizeof(float) * n), *alone = malloc(sizeof(float) * n);
    pb_context *ctx = NULL;
    pb_context_options host = {.backend = PB_BACKEND_HOST};
    pb_status st = pb_context_create(&host, &ctx);
    pb_test_progress_log progress = {0};
    if (st == PB_OK) {
        pb_context_set_progress(ctx, pb_test_record_progress, &progress);
        for (size_t i = 0; i < n; i++)
            threaded[i] = alone[i] = NAN;
        st = pb_test_blur(ctx, &g, x, &tm.motion, NULL, threaded);
        pb_context_set_progress(ctx, NULL, NULL);
    }
    CPU_ZERO(&one);
    for (int c = 0; c < CPU_SETSIZE; c++)
        if (CPU_ISSET(c, &all)) {
            CPU_SET(c, &one);
            break;
        }
    if (st == PB_OK && sched_setaffinity(0, sizeof one, &one) == 0) {
        st = pb_test_blur(ctx, &g, x, &tm.motion, NULL, alone);
        sched_setaffinity(0, sizeof all, &all);
        pb_check(st == PB_OK && memcmp(threaded, alone, sizeof(float) * n) == 0, "the host forward of %zu x %zu x "
                 "%zu on %d cores differs from one core's by %.3g", g.dims[0], g.dims[1], g.dims[2], CPU_COUNT(&all),
                 pb_max_abs_diff(threaded, alone, n));
        pb_check(pb_max_abs(threaded, n) > 0.0 && !isnan(pb_sum(threaded, n)), "the host forward wrote no values");
        pb_check(progress.calls > 0 && progress.bad == 0, "the threaded forward's progress: %d calls, %d out of "
                 "order", progress.calls, progress.bad);
    } else
        pb_check(0, "the host forward or the affinity failed (status %d)", (int)st);
    pb_context_destroy(ctx);
    free(x);
    free(threaded);
    free(alone);
}

int main(void)
{
    pb_test_seed();
    pb_test_deadline(120, "test_parallel");
    pb_pool *pool = pb_pool_create();
    printf("pool: %zu threads\n", pb_pool_threads(pool));
    test_every_item_once(pool);
    test_every_item_once(NULL);
    test_sums(pool);
    test_smooth(pool);
    test_gradients(pool);
    test_gram_band(pool);
    test_host_forward();
    pb_pool_destroy(pool);
    pb_pool_destroy(NULL);
    return pb_test_finish();
}
