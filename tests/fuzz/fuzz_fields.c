/* libFuzzer harness: the library's field checks and planner on a field motion
 * made of the bytes given, then its forward and adjoint on the host backend
 * of a 4x3x2 grid: any field, map, surrogate, frame or voxel size must be
 * refused with a status or blurred in bounded time, never crash or write
 * NaN with a status of success.
 *
 * Layout: a byte of options (method, filter, Jacobian, surrogate, map, fixed
 * steps, a coarse path bound), a byte of counts (fields 2-4, signal samples
 * 2-5, steps 1-4), three bytes of voxel sizes
 * (1e-4 to 1e4 mm), then raw doubles: each field's time and base vector, the
 * map's 12 entries (with a map), the frame's ends, the signal's times and
 * values (with a surrogate); then a byte per field voxel and component that
 * scales its field's base vector. Missing bytes read as zero. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_bytes.h"
#include "petblur.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

typedef struct bytes {
    const uint8_t *p;
    size_t n;
} bytes;

static uint8_t take_byte(bytes *b)
{
    uint8_t v = 0;
    if (b->n) {
        v = *b->p++;
        b->n--;
    }
    return v;
}

static double take(bytes *b)
{
    return pbc_fuzz_take(&b->p, &b->n);
}

enum { FIELDS_MOST = 4, SIGNAL_MOST = 5, VOXELS = 24 };

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static pb_context *ctx;
    if (!ctx) {
        pb_context_options o = {PB_BACKEND_HOST, 0, NULL};
        if (pb_context_create(&o, &ctx) != PB_OK)
            abort();
    }
    bytes b = {data, size};
    const uint8_t flags = take_byte(&b), counts = take_byte(&b);
    pb_blur_options opt;
    memset(&opt, 0, sizeof opt); /* the defaults */
    opt.method = (pb_method)(flags & 3);
    opt.filter = (pb_filter)(flags >> 2 & 1);
    opt.jacobian = flags >> 3 & 1;
    opt.ref_points = 4;
    if (flags >> 6 & 1) /* fixed steps (RM, CL: samples; AB: pieces, walked all the same; REF: time steps) */
        opt.steps = opt.ref_time_steps = 1 + (counts >> 6);
    if (flags >> 7 & 1) { /* a coarse bound, for a surrogate's bins */
        opt.path = PB_PATH_BOUNDED;
        opt.max_path_error = 1000.0;
    }
    const int surrogate = flags >> 4 & 1, has_map = flags >> 5 & 1;
    pb_geometry g = {{4, 3, 2}, {0, 0, 0}};
    for (int k = 0; k < 3; k++)
        g.voxel_size[k] = pow(10.0, (double)(take_byte(&b) % 9) - 4.0); /* PB_MIN_VOXEL_MM to PB_MAX_VOXEL_MM */
    const size_t count = 2 + counts % (FIELDS_MOST - 1), signals = 2 + (counts >> 4) % (SIGNAL_MOST - 1);
    const size_t fdims[3] = {has_map ? 2 : 4, has_map ? 2 : 3, 2};
    const size_t fvox = fdims[0] * fdims[1] * fdims[2];
    double times[FIELDS_MOST], base[FIELDS_MOST][3], st[SIGNAL_MOST], sv[SIGNAL_MOST];
    for (size_t k = 0; k < count; k++) {
        times[k] = take(&b);
        for (int c = 0; c < 3; c++)
            base[k][c] = take(&b);
    }
    pb_field_motion f;
    memset(&f, 0, sizeof f);
    f.has_map = has_map;
    for (int i = 0; has_map && i < 12; i++)
        f.field_from_grid[i] = take(&b);
    f.frame_start = take(&b);
    f.frame_end = take(&b);
    for (size_t s = 0; surrogate && s < signals; s++) {
        st[s] = take(&b);
        sv[s] = take(&b);
    }
    float disp[FIELDS_MOST * VOXELS * 3];
    for (size_t k = 0; k < count; k++)
        for (size_t v = 0; v < fvox; v++)
            for (int c = 0; c < 3; c++)
                disp[(k * fvox + v) * 3 + (size_t)c] = (float)(base[k][c] * ((double)take_byte(&b) - 128.0) / 16.0);
    f.times = times;
    f.displacements = disp;
    f.count = count;
    memcpy(f.dims, fdims, sizeof f.dims);
    if (surrogate) {
        f.signal_times = st;
        f.signal = sv;
        f.signal_count = signals;
    }
    pb_plan *plan = NULL;
    if (pb_plan_create_field(ctx, &g, &f, &opt, &plan) != PB_OK)
        return 0;
    pb_volume *in, *out;
    float x[VOXELS], y[VOXELS];
    for (int i = 0; i < VOXELS; i++)
        x[i] = 1.0f + 0.25f * (float)(i % 5);
    if (pb_volume_create(ctx, &g, &in) != PB_OK || pb_volume_create(ctx, &g, &out) != PB_OK ||
        pb_volume_upload(in, x) != PB_OK)
        abort();
    for (int direction = 0; direction < 2; direction++) {
        pb_status s = direction ? pb_plan_adjoint(plan, 0, in, out, 0) : pb_plan_forward(plan, 0, in, out);
        if (s != PB_OK)
            continue;
        if (pb_volume_download(out, y) != PB_OK)
            abort();
        for (int i = 0; i < VOXELS; i++)
            if (!isfinite(y[i]))
                abort(); /* NaN with a status of success */
    }
    pb_volume_destroy(in);
    pb_volume_destroy(out);
    pb_plan_destroy(plan);
    return 0;
}
