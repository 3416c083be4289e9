/* The benchmarks' two small tools, shared by petblur bench and bench/pb_frames:
 * the median of timed runs and a monotonic host clock. */
#ifndef PBC_BENCH_STATS_H
#define PBC_BENCH_STATS_H

/* The median of v[0..n-1] (n >= 1); sorts v in place. */
double pbc_median(double *v, int n);

/* Milliseconds on the monotonic clock, for host-side timings. */
double pbc_now_ms(void);

#endif
