/* The taps of a short motion of translations (cl/pb_taps.cl), measured once
 * per plan on the device itself: the walk's blur of a unit impulse in a small
 * grid, by the kernel the frame would run on the caller's memory. Under
 * translations the blur is a convolution, so that blur is the kernel's
 * weights themselves, c_d at offset d = impulse - W, whatever the kernel does
 * to compute them (AB's slices, the sweep's two points, RM's and CL's
 * samples, sub-segments, the clipped parts of a path, the texture unit's
 * rounded weights). No second copy of the walk is written here. */
#include <limits.h>
#include <math.h>
#include <stdlib.h>

#include "backend.h"
#include "kernel_choice.h"

/* The impulse grid's largest volume. It holds the offsets from 0 to the
 * path's, so a short path far from the frame's reference (up to about 60
 * voxels along every axis) still fits; past it the kernel stays. A path that
 * spans 64 voxels or more along an axis is not measured: its taps would cost
 * more than the kernel, or their impulse grid more than they save. */
#define PB_SHIFT_TAPS_GRID_MAX (64 * 64 * 64)

/* Voxel 0's place (texel coordinates of its centre) under a key pose's map. */
static void voxel0_at(const pb_path_pose *pose, double *p)
{
    const double *m = pose->map;
    for (int r = 0; r < 3; r++)
        p[r] = 0.5 * (m[4 * r] + m[4 * r + 1] + m[4 * r + 2]) + m[4 * r + 3] - 0.5;
}

/* The most taps worth reading instead of the frame's kernel. Each tap costs
 * one read of the input a voxel, about 7 us at 256^3 on the H200; the
 * kernels cost more wherever they read the texture through the EXACT filter
 * (eight point reads a sample), read chords (AB's chord sampling, and AB's
 * and RM's segments shorter than PB_AB_WALK_FROM voxels by the rule by
 * length) or sample as CL does: at least 2.1, 2.5 and 1.2 times the taps on
 * 544 random translations of 0.5 to 40 voxels, and more the longer the path,
 * so there every measured count is worth it. AB's walk and RM's samples
 * through the HARDWARE filter, on segments long enough to be walked alone,
 * cost less, about 40 + 2.1 L and 15 + 4.4 S taps' worth (L the path's length
 * along its major axis in voxels, S RM's samples a voxel, about L by default;
 * the lower edge of the same run's times), while an oblique path has up to 4
 * taps a slice: past those the kernel stays (docs/performance.md, "Short
 * translations"). AB's sweep and sub-segments cost more than its walk, so its
 * line leaves them no taps that cost more than they do. Below
 * PB_SHIFT_TAPS_MAX the taps always are. A device without a texture unit
 * (gpu 0: a CPU under OpenCL) filters in software, where every kernel cost
 * 10-58 times its taps on PoCL, so there every count is worth it.
 * PETBLUR_SHIFT_TAPS sets a fixed limit, 0 none, for comparisons. */
long pb_shift_taps_limit(const pb_blur_options *opt, const pb_path *path, int gpu)
{
    const char *env = getenv("PETBLUR_SHIFT_TAPS");
    if (env && *env) {
        char *end;
        long v = strtol(env, &end, 10);
        if (*end == '\0' && v >= 0)
            return v;
    }
    int rm = opt->method == PB_METHOD_RM;
    int walks = rm || (opt->method == PB_METHOD_AB && opt->ab_sampling != PB_AB_SAMPLING_CHORD);
    if (!gpu || opt->filter == PB_FILTER_EXACT || !walks)
        return LONG_MAX;
    /* AB's sub-segments, and RM's segments unless it takes S samples, are
     * each read by the rule by length. */
    double pieces = rm ? 1.0 : (opt->steps > 1 ? (double)opt->steps : 1.0);
    int by_length = !rm || opt->steps == 0, walked = 0, segments = 0;
    double length = 0.0;
    for (size_t i = 1; i < path->count; i++) {
        if (path->poses[i - 1].skip) /* read by no kernel */
            continue;
        segments++;
        double along = pb_path_segment_along(path, i - 1);
        walked += !by_length || along / pieces >= (double)PB_AB_WALK_FROM;
        length += along;
    }
    /* A path with no segment walked alone reads chords (or points, at one
     * fetch each): it costs as chords do. */
    if (!walked)
        return LONG_MAX;
    double samples = rm && opt->steps ? (double)opt->steps * segments : length;
    double worth = rm ? 15.0 + 4.4 * samples : 40.0 + 2.1 * length;
    if (!(worth < 1e9)) /* costs more than the most taps an impulse grid holds */
        return LONG_MAX;
    return worth > PB_SHIFT_TAPS_MAX ? (long)worth : PB_SHIFT_TAPS_MAX;
}

/* The offsets d that voxel 0's path can reach, per axis [lo, hi], widened to
 * hold 0: its points (voxel-centre coordinates) lie between the key poses'
 * and a sample's reach is the trilinear tent's, one voxel; one more each side
 * spares the rounding any thought. Returns 0 where the grid would be larger
 * than is measured. */
static int offset_box(const pb_path *path, long *lo, long *hi)
{
    double least[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, most[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (size_t i = 0; i < path->count; i++) {
        double p[3];
        voxel0_at(&path->poses[i], p);
        for (int r = 0; r < 3; r++) {
            least[r] = fmin(least[r], p[r]);
            most[r] = fmax(most[r], p[r]);
        }
    }
    double volume = 1.0;
    for (int r = 0; r < 3; r++) {
        if (!(most[r] - least[r] < 64.0)) /* also NaN */
            return 0;
        lo[r] = (long)floor(least[r]) - 2;
        hi[r] = (long)floor(most[r]) + 3;
        lo[r] = lo[r] < 0 ? lo[r] : 0;
        hi[r] = hi[r] > 0 ? hi[r] : 0;
        volume *= (double)(hi[r] - lo[r] + 1);
    }
    return volume <= PB_SHIFT_TAPS_GRID_MAX;
}

/* The frame's kernel for a fresh input (the one the walk would run on the
 * caller's memory: the 3-D image, or layers along y or z), over a grid of n,
 * on a unit impulse at voxel `at`, read back into *response (malloc'd). */
static pb_status impulse_response(pb_device *dev, const pb_plan_frame *f, const size_t *n, const size_t *at,
                                  float **response)
{
    const pb_backend_ops *ops = dev->ops;
    size_t count = n[0] * n[1] * n[2], bytes = count * sizeof(float);
    float *host = calloc(count, sizeof *host);
    void *in = NULL, *out = NULL;
    if (!host)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for a translation's taps");
    host[at[0] + n[0] * (at[1] + n[1] * at[2])] = 1.0f;
    pb_kparams prm = f->forward_prm;
    for (int d = 0; d < 3; d++)
        prm.dims[d] = (int)n[d];
    prm.mirror = prm.accumulate = prm.z0 = 0;
    pb_status st = ops->buffer_create(dev, bytes, &in);
    if (st == PB_OK)
        st = ops->buffer_create(dev, bytes, &out);
    if (st == PB_OK)
        st = ops->buffer_write(dev, in, host, bytes);
    if (st == PB_OK)
        st = pb_launch_read(dev, f->forward_fresh, &prm, in, n, f->poses, out, host);
    if (out)
        ops->buffer_release(dev, out);
    if (in)
        ops->buffer_release(dev, in);
    if (st != PB_OK) {
        free(host);
        return st;
    }
    *response = host;
    return PB_OK;
}

pb_status pb_shift_taps_prepare(pb_device *dev, const pb_blur_options *opt, pb_plan_frame *f)
{
    long lo[3], hi[3];
    if (!pb_path_shift_invariant(&f->path, opt) || !offset_box(&f->path, lo, hi))
        return PB_OK;
    long limit = pb_shift_taps_limit(opt, &f->path, dev->info.is_gpu);
    if (limit == 0)
        return PB_OK;
    size_t n[3], at[3];
    /* Tomograph voxel w of the grid reads the impulse at `at` through offset
     * at - w: at = hi puts every offset of [lo, hi] inside, lo <= 0 <= hi. */
    for (int r = 0; r < 3; r++) {
        n[r] = (size_t)(hi[r] - lo[r] + 1);
        at[r] = (size_t)hi[r];
    }
    float *response = NULL;
    pb_status st = impulse_response(dev, f, n, at, &response);
    if (st != PB_OK)
        return st;
    size_t count = n[0] * n[1] * n[2], k = 0;
    for (size_t i = 0; i < count; i++)
        k += response[i] != 0.0f;
    if ((long)k > limit) {
        free(response);
        return PB_OK;
    }
    /* Zero taps (a path that never meets the object) still make a buffer. */
    pb_ktap *taps = calloc(k ? k : 1, sizeof *taps);
    if (!taps) {
        free(response);
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for a translation's taps");
    }
    k = 0;
    int least[3] = {0, 0, 0}, most[3] = {0, 0, 0}; /* the offsets' bounds along each axis */
    for (size_t i = 0; i < count; i++) { /* in memory order, as the kernel's reads go best */
        if (response[i] == 0.0f)
            continue;
        size_t w[3] = {i % n[0], i / n[0] % n[1], i / (n[0] * n[1])};
        const size_t *dims = f->path.geometry.dims;
        long d[3];
        int lands = 1; /* a tap as long as the grid never reads inside it */
        for (int r = 0; r < 3; r++) {
            d[r] = (long)at[r] - (long)w[r];
            lands = lands && (size_t)labs(d[r]) < dims[r];
        }
        if (!lands)
            continue;
        for (int r = 0; r < 3; r++) {
            taps[k].offset[r] = (int)d[r];
            least[r] = k == 0 || d[r] < least[r] ? (int)d[r] : least[r];
            most[r] = k == 0 || d[r] > most[r] ? (int)d[r] : most[r];
        }
        taps[k].linear = (int)(d[0] + (long)dims[0] * (d[1] + (long)dims[1] * d[2]));
        taps[k].weight = response[i];
        k++;
    }
    free(response);
    /* pb_shift_taps_tile where the window fits its tile, the same size
     * mirrored; each tap's place in the tile, forward and mirrored. */
    const unsigned *group = pb_kernel_table[PB_KERNEL_SHIFT_TAPS_TILE].group;
    int tiled = group[0] == 32 && group[0] * group[1] * group[2] == PB_TAP_GROUP &&
                group[0] + most[0] - least[0] <= PB_TAP_TX && group[1] + most[1] - least[1] <= PB_TAP_TY &&
                group[2] * PB_TAP_RUN + most[2] - least[2] <= PB_TAP_TZ;
    for (size_t t = 0; t < k; t++) {
        const int *d = taps[t].offset;
        taps[t].tile[0] = d[0] - least[0] + PB_TAP_TX * (d[1] - least[1] + PB_TAP_TY * (d[2] - least[2]));
        taps[t].tile[1] = most[0] - d[0] + PB_TAP_TX * (most[1] - d[1] + PB_TAP_TY * (most[2] - d[2]));
    }
    void *buffer = NULL;
    size_t bytes = (k ? k : 1) * sizeof *taps;
    st = dev->ops->buffer_create(dev, bytes, &buffer);
    if (st == PB_OK)
        st = dev->ops->buffer_write(dev, buffer, taps, bytes);
    free(taps);
    if (st != PB_OK) {
        if (buffer)
            dev->ops->buffer_release(dev, buffer);
        return st;
    }
    dev->ops->buffer_release(dev, f->poses);
    f->poses = buffer;
    f->forward = f->forward_fresh = f->adjoint = tiled ? PB_KERNEL_SHIFT_TAPS_TILE : PB_KERNEL_SHIFT_TAPS;
    f->forward_prm.taps = f->adjoint_prm.taps = (int)k;
    for (int r = 0; r < 3; r++) {
        int reach = abs(least[r]) > abs(most[r]) ? abs(least[r]) : abs(most[r]);
        f->forward_prm.tap_reach[r] = f->adjoint_prm.tap_reach[r] = reach;
        f->forward_prm.tap_lo[r] = least[r];
        f->adjoint_prm.tap_lo[r] = -most[r];
        f->forward_prm.tap_size[r] = f->adjoint_prm.tap_size[r] = most[r] - least[r] + 1;
    }
    return PB_OK;
}
