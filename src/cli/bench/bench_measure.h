/* What petblur bench measures for one method on one volume and motion: kernel
 * time from device events, end-to-end time with the transfers, and how much
 * work AB's walk must do at least (its texture fetches). */
#ifndef PBC_BENCH_MEASURE_H
#define PBC_BENCH_MEASURE_H

#include "petblur.h"

typedef struct pbc_timing {
    double kernel_ms;     /* median of the timed runs, device events */
    double kernel_min_ms;
    double e2e_ms;        /* median of upload + blur + download, host clock */
    double adjoint_ms;    /* median of the adjoint's runs (zeroing included), device events; NaN if not timed */
} pbc_timing;

/* One warm-up blur of in (already holding host_in) into outv, downloaded into
 * out; then runs blurs timed by device events and e2e_runs round trips timed by
 * the host clock. With adj, also a warm-up and runs of the adjoint of outv into
 * adj. Returns 0 or an exit status after the message. */
int pbc_bench_time(pb_context *ctx, pb_volume *in, pb_volume *outv, const float *host_in, const pb_motion *motion,
                   const pb_blur_options *options, int runs, int e2e_runs, float *out, pb_volume *adj,
                   pbc_timing *t);

/* AB's walk over the grid for the motion (its key poses: frame start, the
 * track's poses inside, frame end): the texture fetches it makes (one per slice
 * visited, summed over voxels and segments) and the most slices any voxel
 * visits on one segment, which is the S that a classical blur with one sample
 * per slice needs. Mirrors the kernel's pb_ab_slices in double precision. */
typedef struct pbc_ab_work {
    double fetches;
    unsigned max_slices;
} pbc_ab_work;

int pbc_ab_work_of(const pb_geometry *g, const pb_motion *motion, pbc_ab_work *work);

#endif
