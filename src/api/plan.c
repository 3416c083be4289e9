/* The public plan: made once from a context, a geometry, a motion (or a
 * track and frame bounds, frames.c) and options, which it validates, plans and
 * uploads; applied forward and adjoint many times, to volumes or to the
 * caller's device memory; destroyed. pb_blur and pb_blur_adjoint are one-shot
 * plans. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "plan.h"

pb_status pb_frame_intervals(pb_context *ctx, const double *bounds, size_t frames, double **intervals)
{
    *intervals = NULL;
    pb_status st = pb_frame_bounds_check(ctx, bounds, frames);
    if (st != PB_OK)
        return st;
    double *iv = malloc(2 * frames * sizeof *iv);
    if (!iv)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu frames", frames);
    for (size_t i = 0; i < frames; i++) {
        iv[2 * i] = bounds[i];
        iv[2 * i + 1] = bounds[i + 1];
    }
    *intervals = iv;
    return PB_OK;
}

pb_status pb_gate_counts_check(pb_context *ctx, const size_t *counts, size_t frames)
{
    for (size_t i = 0; i < frames; i++)
        if (counts[i] == 0 || counts[i] > ((size_t)1 << 24))
            return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "frame %zu has %zu intervals; give 1 to 16777216", i,
                            counts[i]);
    return PB_OK;
}

pb_status pb_plan_new(pb_context *ctx, const pb_geometry *geometry, const pb_blur_options *options, size_t frames,
                      pb_plan **out)
{
    *out = NULL;
    size_t count = 0;
    pb_blur_options opt;
    pb_status st = pb_geometry_check(ctx, geometry, &count);
    if (st == PB_OK)
        st = pb_device_check_volume(&ctx->dev, &ctx->dev.info, geometry);
    if (st == PB_OK)
        st = pb_options_prepare(ctx, options, &opt);
    if (st != PB_OK)
        return st;
    pb_plan *plan = calloc(1, sizeof *plan);
    pb_plan_frame *frame = calloc(frames, sizeof *frame);
    if (!plan || !frame) {
        free(plan);
        free(frame);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for a plan of %zu frames", frames);
    }
    plan->ctx = ctx;
    plan->set.geometry = *geometry;
    plan->set.count = count;
    plan->set.options = opt;
    plan->set.frames = frames;
    plan->set.frame = frame;
    pb_context_hold(ctx);
    *out = plan;
    return PB_OK;
}

pb_status pb_plan_set_frame(pb_plan *plan, size_t i, const pb_motion *motion)
{
    pb_plan_frame *f = &plan->set.frame[i];
    pb_status st = pb_path_create(plan->ctx, &plan->set.geometry, motion, &plan->set.options, &f->path);
    if (st == PB_OK)
        st = plan->ctx->dev.ops->frame_prepare(&plan->ctx->dev, &plan->set.options, f);
    return st;
}

static pb_status plan_create_entered(pb_context *ctx, const pb_geometry *geometry, const pb_motion *motion,
                                     const pb_blur_options *options, pb_plan **plan)
{
    pb_status st = pb_plan_new(ctx, geometry, options, 1, plan);
    if (st == PB_OK && (st = pb_plan_set_frame(*plan, 0, motion)) != PB_OK) {
        pb_plan_destroy(*plan);
        *plan = NULL;
    }
    return st;
}

pb_status pb_plan_create(pb_context *ctx, const pb_geometry *geometry, const pb_motion *motion,
                         const pb_blur_options *options, pb_plan **plan)
{
    if (!ctx || !geometry || !motion || !plan)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ctx, geometry, motion and plan must not be NULL");
    pb_status st = pb_context_enter(ctx);
    if (st != PB_OK)
        return st;
    st = plan_create_entered(ctx, geometry, motion, options, plan);
    pb_context_leave(ctx);
    return st;
}

void pb_plan_destroy(pb_plan *plan)
{
    if (!plan)
        return;
    pb_context *ctx = plan->ctx;
    for (size_t i = 0; i < plan->set.frames; i++) {
        pb_plan_frame *f = &plan->set.frame[i];
        if (f->poses) {
            ctx->dev.ops->buffer_release(&ctx->dev, f->poses);
            size_t *resident = &ctx->dev.resident_field_bytes; /* the budget for resident fields (launch.c) */
            if (f->path.field)
                *resident -= f->bytes < *resident ? f->bytes : *resident;
        }
        free(f->streamed);
        pb_path_destroy(&f->path);
    }
    pb_images_release(&ctx->dev, &plan->set.input);
    free(plan->set.frame);
    free(plan);
    pb_context_release_hold(ctx);
}

size_t pb_plan_frame_count(const pb_plan *plan)
{
    return plan ? plan->set.frames : 0;
}

pb_status pb_plan_get_geometry(const pb_plan *plan, pb_geometry *geometry)
{
    if (!plan || !geometry)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "plan and geometry must not be NULL");
    *geometry = plan->set.geometry;
    return PB_OK;
}

pb_status pb_check_volumes(pb_context *ctx, const pb_geometry *p, const pb_volume *in, const pb_volume *out,
                           int adjoint)
{
    const char *in_name = adjoint ? "tomograph" : "object", *out_name = adjoint ? "object" : "tomograph";
    if (!in || !out)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "the %s and %s volumes must not be NULL", in_name, out_name);
    if (in->ctx != ctx || out->ctx != ctx)
        return pb_error(ctx, PB_ERR_SIZE_MISMATCH, "both volumes must belong to the context that blurs them");
    if (in == out)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT,
                        "object and tomograph are the same volume; blur into a second volume");
    for (int v = 0; v < 2; v++) {
        const pb_geometry *g = v ? &out->geometry : &in->geometry;
        for (int i = 0; i < 3; i++)
            if (g->dims[i] != p->dims[i] || g->voxel_size[i] != p->voxel_size[i])
                return pb_error(ctx, PB_ERR_SIZE_MISMATCH,
                                "the %s volume (%zu x %zu x %zu, %g x %g x %g mm) differs from the plan's grid "
                                "(%zu x %zu x %zu, %g x %g x %g mm); blur volumes of the plan's geometry",
                                v ? out_name : in_name, g->dims[0], g->dims[1], g->dims[2], g->voxel_size[0],
                                g->voxel_size[1], g->voxel_size[2], p->dims[0], p->dims[1], p->dims[2],
                                p->voxel_size[0], p->voxel_size[1], p->voxel_size[2]);
    }
    return PB_OK;
}

static pb_status check_frame(const pb_plan *plan, size_t frame)
{
    if (frame >= plan->set.frames)
        return pb_error(plan->ctx, PB_ERR_INVALID_ARGUMENT, "frame %zu does not exist: the plan has %zu (0 to %zu)",
                        frame, plan->set.frames, plan->set.frames - 1);
    return PB_OK;
}

/* One direction of one frame, then the progress report's end. */
static pb_status finish(pb_context *ctx, pb_status st)
{
    if (st == PB_OK && ctx->dev.progress)
        ctx->dev.progress(1.0, ctx->dev.progress_user);
    return st;
}

static pb_status apply_volumes_entered(pb_plan *plan, size_t frame, const pb_volume *in, pb_volume *out, int adjoint,
                                       int accumulate)
{
    pb_context *ctx = plan->ctx;
    pb_status st = check_frame(plan, frame);
    if (st == PB_OK)
        st = pb_check_volumes(ctx, &plan->set.geometry, in, out, adjoint);
    if (st != PB_OK)
        return st;
    /* The forward's object is made current once and blurred many times: that
     * copy is not the kernel's. The adjoint's gather lays out every tomograph
     * it reads: a fresh input, which counts with the kernel. */
    st = ctx->dev.ops->frame_apply(&ctx->dev, &plan->set, frame, adjoint, in->mem.buffer, (pb_images *)&in->mem.images, out->mem.buffer,
                               accumulate, adjoint);
    pb_images_stale(&out->mem.images);
    return finish(ctx, st);
}

static pb_status apply_volumes(pb_plan *plan, size_t frame, const pb_volume *in, pb_volume *out, int adjoint,
                               int accumulate)
{
    if (!plan)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "plan must not be NULL");
    pb_status st = pb_context_enter(plan->ctx);
    if (st != PB_OK)
        return st;
    st = apply_volumes_entered(plan, frame, in, out, adjoint, accumulate);
    pb_context_leave(plan->ctx);
    return st;
}

pb_status pb_plan_forward(pb_plan *plan, size_t frame, const pb_volume *object, pb_volume *tomograph)
{
    return apply_volumes(plan, frame, object, tomograph, 0, 0);
}

pb_status pb_plan_adjoint(pb_plan *plan, size_t frame, const pb_volume *tomograph, pb_volume *object, int accumulate)
{
    return apply_volumes(plan, frame, tomograph, object, 1, accumulate);
}

/* "the object" where there is one, "object 3" among several. */
static const char *memory_name(char *buf, size_t size, const char *kind, size_t i, size_t n)
{
    if (n == 1)
        snprintf(buf, size, "the %s", kind);
    else
        snprintf(buf, size, "%s %zu", kind, i);
    return buf;
}

/* The caller's device memory for one direction: n_in inputs and n_out
 * outputs, each a volume of the plan's grid. None may be NULL or fail the
 * backend's check, and no output may overlap an input or another output: it
 * would be read after it is written, or written twice. Where memory is a
 * handle (a cl_mem), only the same handle twice can be seen. */
static pb_status check_device_memory(const pb_plan *plan, int adjoint, const void *const *ins, size_t n_in,
                                     void *const *outs, size_t n_out)
{
    pb_context *ctx = plan->ctx;
    const char *kind[2] = {adjoint ? "tomograph" : "object", adjoint ? "object" : "tomograph"};
    const size_t bytes = plan->set.count * sizeof(float), n = n_in + n_out, count[2] = {n_in, n_out};
    char a_name[48], b_name[48];
#define MEMORY(i) ((i) < n_in ? ins[i] : (const void *)outs[(i) - n_in])
#define NAMED(buf, i) memory_name(buf, sizeof buf, kind[(i) >= n_in], (i) < n_in ? (i) : (i) - n_in, count[(i) >= n_in])
    pb_status st = PB_OK;
    for (size_t i = 0; i < n && st == PB_OK; i++) {
        if (!MEMORY(i))
            st = pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "%s memory is NULL; give device memory of the plan's grid",
                          NAMED(a_name, i));
        else
            st = ctx->dev.ops->buffer_check(&ctx->dev, MEMORY(i), bytes, kind[i >= n_in], i >= n_in);
    }
    for (size_t o = n_in; o < n && st == PB_OK; o++) {
        uintptr_t b = (uintptr_t)MEMORY(o);
        for (size_t j = 0; j < n && st == PB_OK; j++) {
            uintptr_t a = (uintptr_t)MEMORY(j), gap = a < b ? b - a : a - b;
            if (j == o)
                continue;
            if (a == b)
                st = pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "%s overlaps %s: they are the same memory; give every "
                              "output memory of its own", NAMED(a_name, o), NAMED(b_name, j));
            else if (ctx->dev.ops->addresses && gap < bytes)
                st = pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "%s overlaps %s (%zu bytes apart, each %zu bytes); give "
                              "every output memory of its own", NAMED(a_name, o), NAMED(b_name, j), (size_t)gap,
                              bytes);
        }
    }
#undef MEMORY
#undef NAMED
    return st;
}

static pb_status apply_device_entered(pb_plan *plan, size_t frame, const void *in, void *out, int adjoint,
                                      int accumulate)
{
    pb_context *ctx = plan->ctx;
    pb_status st = check_frame(plan, frame);
    if (st == PB_OK)
        st = check_device_memory(plan, adjoint, &in, 1, &out, 1);
    if (st != PB_OK)
        return st;
    /* The caller's memory may have changed since the last call: its copy
     * into the plan's image (on a device) is made every time, and timed. */
    pb_images_stale(&plan->set.input);
    st = ctx->dev.ops->frame_apply(&ctx->dev, &plan->set, frame, adjoint, in, &plan->set.input, out, accumulate, 1);
    /* The output may be a volume's own memory. */
    pb_volume_memory_written(ctx, out);
    return finish(ctx, st);
}

static pb_status apply_device(pb_plan *plan, size_t frame, const void *in, void *out, int adjoint, int accumulate)
{
    if (!plan)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "plan must not be NULL");
    pb_status st = pb_context_enter(plan->ctx);
    if (st != PB_OK)
        return st;
    st = apply_device_entered(plan, frame, in, out, adjoint, accumulate);
    pb_context_leave(plan->ctx);
    return st;
}

/* pb_plan_forward_frames_device and pb_plan_adjoint_frames_device: ins and
 * outs as frames_apply takes them (backend.h). */
static pb_status apply_frames_device_entered(pb_plan *plan, size_t first, size_t count, int adjoint,
                                             const void *const *ins, void *const *outs, int accumulate)
{
    pb_context *ctx = plan->ctx;
    size_t n_in = adjoint ? count : 1, n_out = adjoint ? 1 : count;
    if (count == 0 || first >= plan->set.frames || count > plan->set.frames - first)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "frames %zu to %zu: the plan has frames 0 to %zu; give first "
                        "and count within them (count at least 1)", first, first + count - (count > 0),
                        plan->set.frames - 1);
    if (!ins || !outs)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "the %s and %s arrays must not be NULL",
                        adjoint ? "tomograph" : "object", adjoint ? "object" : "tomograph");
    pb_status st = check_device_memory(plan, adjoint, ins, n_in, outs, n_out);
    if (st != PB_OK)
        return st;
    if (ctx->dev.ops->frames_apply) {
        st = ctx->dev.ops->frames_apply(&ctx->dev, &plan->set, first, count, adjoint, ins, &plan->set.input, outs, accumulate);
    } else { /* the host: frame by frame, the times summed */
        double kernel = 0.0, input = 0.0;
        for (size_t i = 0; i < count && st == PB_OK; i++) {
            st = ctx->dev.ops->frame_apply(&ctx->dev, &plan->set, first + i, adjoint, ins[adjoint ? i : 0], &plan->set.input,
                                       outs[adjoint ? 0 : i], adjoint ? accumulate || i > 0 : 0, 1);
            kernel += ctx->dev.last_kernel_ms;
            input += ctx->dev.last_input_ms;
        }
        ctx->dev.last_kernel_ms = kernel;
        ctx->dev.last_input_ms = input;
    }
    for (size_t o = 0; o < n_out; o++)
        pb_volume_memory_written(ctx, outs[o]);
    return finish(ctx, st);
}

static pb_status apply_frames_device(pb_plan *plan, size_t first, size_t count, int adjoint, const void *const *ins,
                                     void *const *outs, int accumulate)
{
    if (!plan)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "plan must not be NULL");
    pb_status st = pb_context_enter(plan->ctx);
    if (st != PB_OK)
        return st;
    st = apply_frames_device_entered(plan, first, count, adjoint, ins, outs, accumulate);
    pb_context_leave(plan->ctx);
    return st;
}

pb_status pb_plan_forward_frames_device(pb_plan *plan, size_t first, size_t count, const void *object,
                                        void *const *tomographs)
{
    return apply_frames_device(plan, first, count, 0, &object, tomographs, 0);
}

pb_status pb_plan_adjoint_frames_device(pb_plan *plan, size_t first, size_t count, const void *const *tomographs,
                                        void *object, int accumulate)
{
    return apply_frames_device(plan, first, count, 1, tomographs, &object, accumulate);
}

pb_status pb_plan_forward_device(pb_plan *plan, size_t frame, const void *object, void *tomograph)
{
    return apply_device(plan, frame, object, tomograph, 0, 0);
}

pb_status pb_plan_adjoint_device(pb_plan *plan, size_t frame, const void *tomograph, void *object, int accumulate)
{
    return apply_device(plan, frame, tomograph, object, 1, accumulate);
}

/* pb_blur (in: the object, out: the tomograph) and pb_blur_adjoint (the
 * other way round): a plan of one frame, applied once. */
static pb_status one_shot_entered(pb_context *ctx, const pb_volume *in, const pb_motion *motion,
                                  const pb_blur_options *options, pb_volume *out, int adjoint)
{
    pb_plan *plan;
    pb_status st = pb_plan_new(ctx, &in->geometry, options, 1, &plan);
    if (st != PB_OK)
        return st;
    /* The volumes first: a mismatch costs no planning. */
    if ((st = pb_check_volumes(ctx, &plan->set.geometry, in, out, adjoint)) == PB_OK &&
        (st = pb_plan_set_frame(plan, 0, motion)) == PB_OK)
        st = adjoint ? pb_plan_adjoint(plan, 0, in, out, 0) : pb_plan_forward(plan, 0, in, out);
    pb_plan_destroy(plan);
    return st;
}

static pb_status one_shot(pb_context *ctx, const pb_volume *in, const pb_motion *motion,
                          const pb_blur_options *options, pb_volume *out, int adjoint)
{
    if (!ctx || !in || !out || !motion)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ctx, object, motion and tomograph must not be NULL");
    pb_status st = pb_context_enter(ctx);
    if (st != PB_OK)
        return st;
    st = one_shot_entered(ctx, in, motion, options, out, adjoint);
    pb_context_leave(ctx);
    return st;
}

pb_status pb_blur(pb_context *ctx, const pb_volume *object, const pb_motion *motion,
                  const pb_blur_options *options, pb_volume *tomograph)
{
    return one_shot(ctx, object, motion, options, tomograph, 0);
}

pb_status pb_blur_adjoint(pb_context *ctx, const pb_volume *tomograph, const pb_motion *motion,
                          const pb_blur_options *options, pb_volume *object)
{
    return one_shot(ctx, tomograph, motion, options, object, 1);
}
