/* libFuzzer harness: the library's motion checks and planner on a motion made
 * of the bytes given (times, translations, quaternions, a centre, a frame and
 * options, as raw doubles), then a blur on the host backend of a 4x3x2 grid
 * (its voxel sizes from three bytes past the doubles, 1e-4 to 1e4 mm, where
 * there are: a walk's length is the motion over them), or, where a fourth
 * byte asks for one, a gate of 1-4 intervals (doubles after it), forward and
 * adjoint: any motion must be refused with a status or blurred in bounded
 * time, never crash or write NaN. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz_bytes.h"
#include "petblur.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void bytes_skip(const uint8_t **p, size_t *n, size_t k)
{
    k = k < *n ? k : *n;
    *p += k;
    *n -= k;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static pb_context *ctx;
    static pb_volume *in, *out;
    if (!ctx) {
        pb_context_options o = {PB_BACKEND_HOST, 0, NULL};
        pb_geometry g = {{4, 3, 2}, {1.5, 1.0, 2.0}};
        float ones[24];
        for (int i = 0; i < 24; i++)
            ones[i] = 1.0f;
        if (pb_context_create(&o, &ctx) != PB_OK || pb_volume_create(ctx, &g, &in) != PB_OK ||
            pb_volume_create(ctx, &g, &out) != PB_OK || pb_volume_upload(in, ones) != PB_OK)
            abort();
    }
    if (size < 2)
        return 0;
    size_t count = 2 + data[0] % 4;
    pb_blur_options opt = {(pb_method)(data[1] & 3), (pb_filter)(data[1] >> 2 & 1), (data[1] >> 3 & 3), 4, 4, 1,
                           0.0, 0.0, (data[1] & 3) != PB_METHOD_AB ? PB_AB_SAMPLING_DEFAULT
                                     : data[1] >> 5 & 1                 ? PB_AB_SAMPLING_SWEEP
                                     : data[1] >> 6 & 1                 ? PB_AB_SAMPLING_CHORD
                                                                        : PB_AB_SAMPLING_DEFAULT, 0};
    const uint8_t *p = data + 2;
    size_t n = size - 2;
    double times[5];
    pb_pose poses[5];
    for (size_t i = 0; i < count; i++) {
        times[i] = pbc_fuzz_take(&p, &n);
        for (int k = 0; k < 3; k++)
            poses[i].translation[k] = pbc_fuzz_take(&p, &n);
        for (int k = 0; k < 4; k++)
            poses[i].rotation[k] = pbc_fuzz_take(&p, &n);
    }
    /* the frame's ends taken in turn: an initializer's order is unspecified */
    const double start = pbc_fuzz_take(&p, &n), end = pbc_fuzz_take(&p, &n);
    pb_motion m = {times, poses, count, start, end, (int)(size & 1), {0, 0, 0}};
    for (int k = 0; k < 3; k++)
        m.center[k] = pbc_fuzz_take(&p, &n);
    opt.path = (pb_path_model)(data[1] >> 5 & 3);
    opt.max_path_error = pbc_fuzz_take(&p, &n);
    pb_volume *vin = in, *vout = out;
    pb_geometry g = {{4, 3, 2}, {1.5, 1.0, 2.0}};
    if (n >= 3) {
        for (int k = 0; k < 3; k++)
            g.voxel_size[k] = pow(10.0, (double)(p[k] % 9) - 4.0); /* PB_MIN_VOXEL_MM to PB_MAX_VOXEL_MM */
        float ones[24];
        for (int i = 0; i < 24; i++)
            ones[i] = 1.0f;
        if (pb_volume_create(ctx, &g, &vin) != PB_OK || pb_volume_create(ctx, &g, &vout) != PB_OK ||
            pb_volume_upload(vin, ones) != PB_OK)
            abort();
    }
    pb_status st;
    const size_t gate = n >= 4 ? p[3] % 5 : 0;
    if (gate) { /* a gate of that many intervals, a start and an end each, from the doubles after the byte */
        bytes_skip(&p, &n, 4);
        double iv[8];
        for (size_t i = 0; i < 2 * gate; i++)
            iv[i] = pbc_fuzz_take(&p, &n);
        pb_plan *plan = NULL;
        st = pb_plan_create_gates(ctx, &g, &m, iv, &gate, 1, &opt, &plan);
        if (st == PB_OK) {
            st = pb_plan_forward(plan, 0, vin, vout);
            if (st == PB_OK && pb_plan_adjoint(plan, 0, vin, vout, 0) != PB_OK)
                abort(); /* the forward ran: its transpose must */
            pb_plan_destroy(plan);
        }
    } else {
        st = pb_blur(ctx, vin, &m, &opt, vout);
    }
    if (st == PB_OK) {
        float res[24];
        if (pb_volume_download(vout, res) != PB_OK)
            abort();
        for (int i = 0; i < 24; i++)
            if (!isfinite(res[i]))
                abort(); /* NaN with a status of success */
    }
    if (vin != in) {
        pb_volume_destroy(vin);
        pb_volume_destroy(vout);
    }
    return 0;
}
