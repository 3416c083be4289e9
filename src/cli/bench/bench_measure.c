/* Timing and AB's work count for petblur bench. */
#include <math.h>
#include <stdlib.h>

#include "bench_measure.h"
#include "bench_stats.h"
#include "blur_run.h"
#include "cli.h"

static int failed(pb_context *ctx, pb_status st, const char *what)
{
    return pbc_fail(pbc_exit_for(st), "%s: %s: %s", what, pb_status_string(st), pb_last_error(ctx));
}

int pbc_bench_time(pb_context *ctx, pb_volume *in, pb_volume *outv, const float *host_in, const pb_motion *motion,
                   const pb_blur_options *options, int runs, int e2e_runs, float *out, pb_volume *adj,
                   pbc_timing *t)
{
    int n = runs > e2e_runs ? runs : e2e_runs;
    double *ms = malloc((size_t)(n > 0 ? n : 1) * sizeof *ms);
    if (!ms)
        return pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the timings");
    pb_status st = pb_blur(ctx, in, motion, options, outv); /* warm-up, and the result */
    if (st == PB_OK)
        st = pb_volume_download(outv, out);
    t->kernel_ms = t->kernel_min_ms = t->e2e_ms = t->adjoint_ms = (double)NAN;
    if (st == PB_OK && runs == 0)
        pb_context_last_kernel_ms(ctx, &t->kernel_ms); /* the warm-up's time is all there is */
    for (int r = 0; r < runs && st == PB_OK; r++) {
        st = pb_blur(ctx, in, motion, options, outv);
        pb_context_last_kernel_ms(ctx, &ms[r]);
    }
    if (st == PB_OK && runs > 0) {
        t->kernel_ms = pbc_median(ms, runs);
        t->kernel_min_ms = ms[0];
    }
    /* End to end as an application sees it: the volume goes up, is blurred and
     * comes back (the download waits for the kernel). */
    for (int r = 0; r < e2e_runs && st == PB_OK; r++) {
        double t0 = pbc_now_ms();
        st = pb_volume_upload(in, host_in);
        if (st == PB_OK)
            st = pb_blur(ctx, in, motion, options, outv);
        if (st == PB_OK)
            st = pb_volume_download(outv, out);
        ms[r] = pbc_now_ms() - t0;
    }
    if (st == PB_OK && e2e_runs > 0)
        t->e2e_ms = pbc_median(ms, e2e_runs);
    if (st != PB_OK || !adj) {
        free(ms);
        return st == PB_OK ? 0 : failed(ctx, st, "blur");
    }
    /* The adjoint of the blur just made, as back projection would run it. */
    st = pb_blur_adjoint(ctx, outv, motion, options, adj);
    for (int r = 0; r < runs && st == PB_OK; r++) {
        st = pb_blur_adjoint(ctx, outv, motion, options, adj);
        pb_context_last_kernel_ms(ctx, &ms[r]);
    }
    if (st == PB_OK && runs > 0)
        t->adjoint_ms = pbc_median(ms, runs);
    free(ms);
    return st == PB_OK ? 0 : failed(ctx, st, "adjoint");
}

/* Object texel coordinates of texel-coordinate point u under pose p:
 * (R^T (u vs - c - t) + c) / vs. */
static void to_object(const pb_pose *p, const double c[3], const double vs[3], const double u[3], double o[3])
{
    const double *q = p->rotation;
    double d[3];
    for (int i = 0; i < 3; i++)
        d[i] = u[i] * vs[i] - c[i] - p->translation[i];
    /* R(q)^T d = d - 2w (v x d) + 2 v x (v x d) */
    double cx = q[2] * d[2] - q[3] * d[1], cy = q[3] * d[0] - q[1] * d[2], cz = q[1] * d[1] - q[2] * d[0];
    double ccx = q[2] * cz - q[3] * cy, ccy = q[3] * cx - q[1] * cz, ccz = q[1] * cy - q[2] * cx;
    double r[3] = {d[0] - 2 * q[0] * cx + 2 * ccx, d[1] - 2 * q[0] * cy + 2 * ccy, d[2] - 2 * q[0] * cz + 2 * ccz};
    for (int i = 0; i < 3; i++)
        o[i] = (r[i] + c[i]) / vs[i];
}

/* The kernel's pb_ab_slices; a path shorter than 1e-4 voxels is one fetch.
 * Ends within 1e-6 voxels of a slice centre count as on it: an integer
 * translation then visits its length + 1 slices, not one or two more for the
 * last bits of the mm-to-texel arithmetic (the kernel gives those slices zero
 * share). */
static unsigned ab_slices(const double a[3], const double b[3])
{
    double ad[3] = {fabs(b[0] - a[0]), fabs(b[1] - a[1]), fabs(b[2] - a[2])};
    int m = ad[1] > ad[0] ? 1 : 0;
    m = ad[2] > ad[m] ? 2 : m;
    double lo = fmin(a[m], b[m]) - 0.5, hi = fmax(a[m], b[m]) - 0.5;
    if (hi - lo < 1e-4)
        return 1;
    return (unsigned)(ceil(hi - 1e-6) - floor(lo + 1e-6) + 1.0);
}

int pbc_ab_work_of(const pb_geometry *g, const pb_motion *motion, pbc_ab_work *work)
{
    /* Key times: the frame's ends and the tracked times strictly inside. */
    size_t nk = 0;
    double *keys = malloc((motion->count + 2) * sizeof *keys);
    pb_pose *poses = malloc((motion->count + 2) * sizeof *poses);
    int rc = 0;
    if (!keys || !poses) {
        rc = pbc_fail(PBC_EXIT_RUNTIME, "out of memory");
        goto done;
    }
    keys[nk++] = motion->frame_start;
    for (size_t i = 0; i < motion->count; i++)
        if (motion->times[i] > motion->frame_start && motion->times[i] < motion->frame_end)
            keys[nk++] = motion->times[i];
    keys[nk++] = motion->frame_end;
    for (size_t k = 0; k < nk; k++) {
        pb_status st = pb_motion_pose_at(motion, keys[k], &poses[k]);
        if (st != PB_OK) {
            rc = pbc_fail(pbc_exit_for(st), "motion: %s", pb_last_error(NULL));
            goto done;
        }
    }
    double c[3];
    for (int i = 0; i < 3; i++)
        c[i] = motion->has_center ? motion->center[i] : 0.5 * (double)g->dims[i] * g->voxel_size[i];
    work->fetches = 0.0;
    work->max_slices = 0;
    for (size_t z = 0; z < g->dims[2]; z++)
        for (size_t y = 0; y < g->dims[1]; y++) {
            double row = 0.0;
            for (size_t x = 0; x < g->dims[0]; x++) {
                double u[3] = {(double)x + 0.5, (double)y + 0.5, (double)z + 0.5}, a[3], b[3];
                to_object(&poses[0], c, g->voxel_size, u, b);
                for (size_t k = 1; k < nk; k++) {
                    a[0] = b[0], a[1] = b[1], a[2] = b[2];
                    to_object(&poses[k], c, g->voxel_size, u, b);
                    unsigned s = ab_slices(a, b);
                    row += s;
                    if (s > work->max_slices)
                        work->max_slices = s;
                }
            }
            work->fetches += row;
        }
done:
    free(keys);
    free(poses);
    return rc;
}
