/* The benchmarks' two small tools, shared by petblur bench and bench/pb_frames
 * (header-only, so that bench/ compiles nothing of the program): the median of
 * timed runs and a monotonic host clock. */
#ifndef PBC_BENCH_STATS_H
#define PBC_BENCH_STATS_H

#include <stdlib.h>
#include <time.h>

static inline int pbc_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The median of v[0..n-1] (n >= 1); sorts v in place. */
static inline double pbc_median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, pbc_cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* Milliseconds on the monotonic clock, for host-side timings. */
static inline double pbc_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

#endif
