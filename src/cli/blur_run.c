/* Devices, motions and one blur, in the command line's terms. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "blur_run.h"
#include "cli.h"

int pbc_exit_for(pb_status st)
{
    return st > -100 ? PBC_EXIT_USAGE : PBC_EXIT_RUNTIME;
}

int pbc_open_device(const char *spec, pb_context **ctx)
{
    pb_context_options opt = {PB_BACKEND_AUTO, 0, NULL};
    if (spec && pb_device_parse(spec, &opt.backend, &opt.device_index) != PB_OK)
        return pbc_fail(PBC_EXIT_USAGE, "--device %s: %s", spec, pb_last_error(NULL));
    pb_status st = pb_context_create(&opt, ctx);
    if (st != PB_OK)
        /* No device or no driver is not the user's typo: a runtime failure. */
        return pbc_fail(st == PB_ERR_INVALID_ARGUMENT ? PBC_EXIT_USAGE : PBC_EXIT_RUNTIME,
                        "cannot open device '%s': %s: %s", spec ? spec : "auto", pb_status_string(st),
                        pb_last_error(NULL));
    const char *notes = pb_context_notes(*ctx);
    if (notes[0] && !getenv("PETBLUR_QUIET"))
        fprintf(stderr, "petblur: note: %s\n", notes);
    return 0;
}

void pbc_describe_device(pb_context *ctx, char *text, size_t size)
{
    pb_device_info info;
    pb_context_device_info(ctx, &info);
    snprintf(text, size, "%s  %s [%s]", pb_backend_name(pb_context_backend(ctx)), info.name, info.platform);
}

void pbc_progress_line(double fraction, void *label)
{
    /* \r rewrites one line; the final call clears it. */
    if (fraction < 1.0)
        fprintf(stderr, "\rpetblur: %s %3d%%", (const char *)label, (int)(100.0 * fraction));
    else
        fprintf(stderr, "\r%*s\r", 40, "");
    fflush(stderr);
}

static int blur_failed(pb_context *ctx, pb_status st, const char *label)
{
    return pbc_fail(pbc_exit_for(st), "%s: %s: %s", label, pb_status_string(st), pb_last_error(ctx));
}

int pbc_blur_image(pb_context *ctx, const pbc_image *in, const pb_motion *motion, const pb_blur_options *options,
                   int adjoint, const char *label, float *out, double *ms)
{
    pb_geometry g = {{in->dims[0], in->dims[1], in->dims[2]}, {in->voxel_size[0], in->voxel_size[1], in->voxel_size[2]}};
    pb_volume *src = NULL, *dst = NULL;
    pb_status st;
    pb_context_set_progress(ctx, pbc_show_progress ? pbc_progress_line : NULL, (void *)label);
    if ((st = pb_volume_create(ctx, &g, &src)) == PB_OK && (st = pb_volume_create(ctx, &g, &dst)) == PB_OK &&
        (st = pb_volume_upload(src, in->data)) == PB_OK)
        st = adjoint ? pb_blur_adjoint(ctx, src, motion, options, dst) : pb_blur(ctx, src, motion, options, dst);
    if (st == PB_OK)
        st = pb_volume_download(dst, out);
    if (st == PB_OK)
        pb_context_last_kernel_ms(ctx, ms);
    else if (pbc_show_progress)
        pbc_progress_line(1.0, NULL);
    pb_volume_destroy(src);
    pb_volume_destroy(dst);
    return st == PB_OK ? 0 : blur_failed(ctx, st, label);
}

int pbc_blur_frames_image(pb_context *ctx, const pbc_image *in, const pb_motion *track, const double *bounds,
                          size_t frames, const pb_blur_options *options, int adjoint, int sum, const char *label,
                          float *out, double *ms)
{
    pb_geometry g = {{in->dims[0], in->dims[1], in->dims[2]}, {in->voxel_size[0], in->voxel_size[1], in->voxel_size[2]}};
    size_t n = pbc_image_frame_voxels(in), sources = pbc_image_frame_count(in);
    size_t outputs = adjoint && sum ? 1 : frames;
    pb_volume **src = calloc(sources, sizeof *src), **dst = calloc(outputs, sizeof *dst);
    const pb_volume **inputs = malloc(frames * sizeof *inputs);
    pb_volume **targets = malloc(frames * sizeof *targets);
    if (!src || !dst || !inputs || !targets) {
        free(src);
        free(dst);
        free(inputs);
        free(targets);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: out of host memory for %zu frames", label, frames);
    }
    pb_status st = PB_OK;
    pb_context_set_progress(ctx, pbc_show_progress ? pbc_progress_line : NULL, (void *)label);
    /* Each input frame goes up once; a 3-D input serves every frame. */
    for (size_t i = 0; i < sources && st == PB_OK; i++)
        if ((st = pb_volume_create(ctx, &g, &src[i])) == PB_OK)
            st = pb_volume_upload(src[i], in->data + i * n);
    for (size_t i = 0; i < outputs && st == PB_OK; i++)
        st = pb_volume_create(ctx, &g, &dst[i]);
    *ms = 0.0;
    for (size_t i = 0; i < frames; i++) {
        inputs[i] = src[sources == 1 ? 0 : i];
        targets[i] = dst[outputs == 1 ? 0 : i];
    }
    if (st == PB_OK) {
        /* The adjoint: frame i's tomograph back through frame i's part of the
         * track, into an object volume of its own, or with sum into the one
         * that every frame names (the library adds frames that share one). */
        st = adjoint ? pb_blur_frames_adjoint(ctx, inputs, track, bounds, frames, options, targets)
                     : pb_blur_frames(ctx, inputs, track, bounds, frames, options, targets);
        if (st == PB_OK)
            pb_context_last_kernel_ms(ctx, ms);
    }
    for (size_t i = 0; i < outputs && st == PB_OK; i++)
        st = pb_volume_download(dst[i], out + i * n);
    if (st != PB_OK && pbc_show_progress)
        pbc_progress_line(1.0, NULL);
    for (size_t i = 0; i < sources; i++)
        pb_volume_destroy(src[i]);
    for (size_t i = 0; i < outputs; i++)
        pb_volume_destroy(dst[i]);
    free(src);
    free(dst);
    free(inputs);
    free(targets);
    return st == PB_OK ? 0 : blur_failed(ctx, st, label);
}

static void destroy_all(pb_volume **v, size_t n)
{
    for (size_t i = 0; v && i < n; i++)
        pb_volume_destroy(v[i]);
    free(v);
}

int pbc_blur_plan_image(pb_context *ctx, pb_status st, pb_plan *plan, const pbc_image *in, size_t frames, int adjoint,
                        int sum, const char *label, float *out, double *ms)
{
    pb_geometry g = {{in->dims[0], in->dims[1], in->dims[2]}, {in->voxel_size[0], in->voxel_size[1], in->voxel_size[2]}};
    size_t n = pbc_image_frame_voxels(in), sources = pbc_image_frame_count(in), outputs = adjoint && sum ? 1 : frames;
    pb_volume **src = calloc(sources, sizeof *src), **dst = calloc(outputs, sizeof *dst);
    if (!src || !dst) {
        free(src);
        free(dst);
        pb_plan_destroy(plan);
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: out of host memory for %zu volumes' handles", label, sources + outputs);
    }
    /* Each input frame goes up once; a 3-D input serves every frame. */
    for (size_t i = 0; i < sources && st == PB_OK; i++)
        if ((st = pb_volume_create(ctx, &g, &src[i])) == PB_OK)
            st = pb_volume_upload(src[i], in->data + i * n);
    for (size_t i = 0; i < outputs && st == PB_OK; i++)
        st = pb_volume_create(ctx, &g, &dst[i]);
    *ms = 0.0;
    for (size_t i = 0; i < frames && st == PB_OK; i++) {
        const pb_volume *x = src[sources == 1 ? 0 : i];
        /* With sum, every frame's back projection lands in the one output:
         * the first overwrites it, the others add. */
        st = adjoint ? pb_plan_adjoint(plan, i, x, dst[outputs == 1 ? 0 : i], sum && i > 0)
                     : pb_plan_forward(plan, i, x, dst[i]);
        double t = 0.0;
        if (st == PB_OK && pb_context_last_kernel_ms(ctx, &t) == PB_OK)
            *ms += t;
    }
    for (size_t i = 0; i < outputs && st == PB_OK; i++)
        st = pb_volume_download(dst[i], out + i * n);
    pb_plan_destroy(plan);
    destroy_all(src, sources);
    destroy_all(dst, outputs);
    if (st != PB_OK && pbc_show_progress)
        pbc_progress_line(1.0, NULL);
    return st == PB_OK ? 0 : blur_failed(ctx, st, label);
}

int pbc_blur_gates_image(pb_context *ctx, const pbc_image *in, const pb_motion *track, const double *intervals,
                         const size_t *counts, size_t frames, const pb_blur_options *options, int adjoint, int sum,
                         const char *label, float *out, double *ms)
{
    pb_geometry g = {{in->dims[0], in->dims[1], in->dims[2]}, {in->voxel_size[0], in->voxel_size[1], in->voxel_size[2]}};
    pb_plan *plan = NULL;
    pb_context_set_progress(ctx, pbc_show_progress ? pbc_progress_line : NULL, (void *)label);
    pb_status st = pb_plan_create_gates(ctx, &g, track, intervals, counts, frames, options, &plan);
    return pbc_blur_plan_image(ctx, st, plan, in, frames, adjoint, sum, label, out, ms);
}
