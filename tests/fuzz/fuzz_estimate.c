/* libFuzzer harness: pb_motion_estimate on a series made of the bytes given,
 * on the host backend: the grid (8 to 11 voxels a side), the voxel sizes, the
 * world affine, the frame bounds and the smoothing as raw doubles; the frames
 * a blob each, placed and scaled by the bytes, over noise the bytes seed, and
 * the input's last bytes written over the first voxels as floats (NaN,
 * infinities, the largest floats). Any series must be refused with a status
 * and a message or estimated, never crash, and an estimate's track must hold
 * finite times and poses. CI drew a grid of 0.0001 x 9761 x 10000 mm where a
 * fit's step carried a pose to 5e12 mm and the whole estimate failed
 * (pbe_within_grid). Levels and iterations are held low so that each input
 * ends in a fraction of a second. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_bytes.h"
#include "petblur.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

enum { MOST_FRAMES = 4, SIDE_MOST = 11 };

/* xorshift: the noise, from the input's bytes alone */
static uint32_t next(uint32_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 17;
    *s ^= *s << 5;
    return *s;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static pb_context *ctx;
    static float frames[MOST_FRAMES * SIDE_MOST * SIDE_MOST * SIDE_MOST];
    if (!ctx) {
        pb_context_options o = {PB_BACKEND_HOST, 0, NULL};
        if (pb_context_create(&o, &ctx) != PB_OK)
            abort();
    }
    if (size < 8)
        return 0;
    pb_geometry g = {{8 + data[0] % 4u, 8 + data[1] % 4u, 8 + data[2] % 4u}, {2.0, 2.0, 2.0}};
    const size_t count = 2 + data[3] % (MOST_FRAMES - 1u), n = g.dims[0] * g.dims[1] * g.dims[2];
    const uint8_t flags = data[4];
    uint32_t seed = (uint32_t)data[5] << 8 | data[6] | 1u;
    const uint8_t *p = data + 8;
    size_t left = size - 8;
    /* the doubles given: raw where a flag says so, else a voxel size of the
     * scanners' range (0.5 to 8 mm) drawn from them */
    for (int a = 0; a < 3; a++) {
        double v = pbc_fuzz_take(&p, &left);
        g.voxel_size[a] = flags & 1 ? v : 0.5 + fmod(fabs(isfinite(v) ? v : 1.0), 7.5);
    }
    double affine[16], *world = NULL;
    if (flags & 2) {
        for (int i = 0; i < 16; i++)
            affine[i] = pbc_fuzz_take(&p, &left);
        world = affine;
    }
    double bounds[MOST_FRAMES + 1] = {0.0};
    for (size_t k = 0; k <= count; k++) {
        double v = pbc_fuzz_take(&p, &left);
        bounds[k] = flags & 4 ? v : (k ? bounds[k - 1] : 0.0) + 1.0 + fmod(fabs(isfinite(v) ? v : 1.0), 60.0);
    }
    pb_estimate_options o = {0};
    o.levels = 1 + (flags >> 3 & 1);
    o.iterations = 1 + (flags >> 4 & 3);
    o.frame_poses_only = flags >> 6 & 1;
    o.reference = flags >> 7 ? PB_ESTIMATE_REFERENCE_AUTO : data[7] % (count + 1); /* count: out of range */
    o.fwhm_mm = data[7] & 0x80 ? pbc_fuzz_take(&p, &left) : 0.0;
    pb_estimate_frame report_frames[MOST_FRAMES];
    o.frames = report_frames;
    /* a blob per frame, where the next bytes put it, over noise */
    for (size_t k = 0; k < count; k++) {
        double c[3], amp = 1.0 + (left ? *p % 64 : 7), width = 1.0 + (left > 1 ? p[1] % 8 : 3);
        for (int a = 0; a < 3; a++)
            c[a] = (double)g.dims[a] * (left > 2 + (size_t)a ? p[2 + a] : 128) / 256.0;
        if (left >= 5) {
            p += 5;
            left -= 5;
        }
        for (size_t i = 0; i < n; i++) {
            double x = (double)(i % g.dims[0]) - c[0], y = (double)(i / g.dims[0] % g.dims[1]) - c[1],
                   z = (double)(i / g.dims[0] / g.dims[1]) - c[2];
            frames[k * n + i] =
                (float)(amp * exp(-(x * x + y * y + z * z) / width) + (double)(next(&seed) % 1024) / 512.0);
        }
    }
    /* what is left of the input, as floats over the first voxels */
    for (size_t i = 0; left >= sizeof(float) && i < n * count; i++) {
        memcpy(&frames[i], p, sizeof(float));
        p += sizeof(float);
        left -= sizeof(float);
    }
    pb_track *track = NULL;
    pb_status st = pb_motion_estimate(ctx, &g, world, frames, count, bounds, &o, &track, NULL);
    if (st != PB_OK) {
        const char *text = pb_last_error(ctx);
        if (track || !text || !*text)
            abort(); /* a refusal leaves no track and says why */
        return 0;
    }
    if (!track || pb_track_count(track) < 2)
        abort();
    const double *times = pb_track_times(track);
    const pb_pose *poses = pb_track_poses(track);
    for (size_t i = 0; i < pb_track_count(track); i++)
        if (!isfinite(times[i]) || !isfinite(poses[i].translation[0]) || !isfinite(poses[i].translation[1]) ||
            !isfinite(poses[i].translation[2]) || !isfinite(poses[i].rotation[0]) || !isfinite(poses[i].rotation[1]) ||
            !isfinite(poses[i].rotation[2]) || !isfinite(poses[i].rotation[3]))
            abort(); /* NaN with a status of success */
    for (size_t k = 0; k < count; k++)
        if (!(report_frames[k].explained >= 0.0 && report_frames[k].explained <= 1.0) ||
            !(report_frames[k].unfollowed >= 0.0 && report_frames[k].unfollowed <= 1.0))
            abort();
    pb_track_free(track);
    return 0;
}
