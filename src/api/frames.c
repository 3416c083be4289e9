/* Dynamic PET: many frames of one pose track. pb_plan_create_frames checks
 * and plans every frame before any work, so a bad frame costs nothing; the
 * track is validated once and each frame plans only its own part of it.
 * pb_blur_frames and pb_blur_frames_adjoint are one-shot plans of frames: the
 * forward queues the frames back to back on a device and waits once (unless a
 * progress report asks for a wait per frame); the adjoint runs them in order,
 * and frames that share an object volume sum into it, which makes it the
 * transpose of pb_blur_frames with the same arguments. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "plan.h"

/* The progress of frame `done` of `frames`, handed on as the whole call's. */
typedef struct frames_progress {
    pb_progress_fn fn;
    void *user;
    size_t done, frames;
} frames_progress;

static void frame_progress(double fraction, void *user)
{
    frames_progress *p = user;
    double f = ((double)p->done + fraction) / (double)p->frames;
    if (f < 1.0)
        p->fn(f, p->user);
}

/* The frames' arguments: ins[i] is read and outs[i] written (the forward
 * reads objects and writes tomographs, the adjoint the other way round).
 * The adjoint's frames may name one output, which they sum into. */
static pb_status check_frames(pb_context *ctx, const pb_volume *const *ins, const pb_motion *track,
                              const double *bounds, size_t frames, pb_volume *const *outs, int adjoint)
{
    const char *in_name = adjoint ? "tomograph" : "object", *out_name = adjoint ? "object" : "tomograph";
    if (!ins || !track || !bounds || !outs)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "objects, track, bounds and tomographs must not be NULL");
    pb_status st = pb_frame_bounds_check(ctx, bounds, frames);
    if (st != PB_OK)
        return st;
    /* A frame's output must not be another frame's input, which it would
     * overwrite before it is read; nor, forward, another frame's output. */
    for (size_t i = 0; i < frames; i++)
        for (size_t j = 0; j < frames; j++) {
            if (outs[i] && outs[i] == ins[j])
                return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "frame %zu's %s (its output) is frame %zu's %s (an "
                                "input); give every frame an output volume of its own", i, out_name, j, in_name);
            if (!adjoint && i < j && outs[i] && outs[i] == outs[j])
                return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "frames %zu and %zu share one tomograph volume; "
                                "give every frame an output volume of its own", i, j);
        }
    return PB_OK;
}

/* Frame i is the union of counts[i] intervals, taken in turn from
 * intervals[] (two numbers each, finite); with counts NULL, one each. */
static pb_status plan_track_entered(pb_context *ctx, const pb_geometry *geometry, const pb_motion *track,
                                    const double *intervals, const size_t *counts, size_t frames,
                                    const pb_blur_options *options, pb_plan **plan)
{
    *plan = NULL;
    size_t total = 0;
    for (size_t i = 0; i < frames; i++)
        total += counts ? counts[i] : 1;
    /* The whole track once, over every interval's span; each frame's
     * planning then checks only its parts and says which frame leaves the
     * track. */
    pb_motion whole = *track;
    whole.frame_start = intervals[0];
    whole.frame_end = intervals[1];
    for (size_t k = 0; k < total; k++) {
        whole.frame_start = fmin(whole.frame_start, intervals[2 * k]);
        whole.frame_end = fmax(whole.frame_end, intervals[2 * k + 1]);
    }
    pb_status st = pb_motion_validate(ctx, &whole);
    if (st != PB_OK && st != PB_ERR_TRACK_GAP && st != PB_ERR_BAD_FRAME)
        return st;
    pb_plan *p;
    if ((st = pb_plan_new(ctx, geometry, options, frames, &p)) != PB_OK)
        return st;
    size_t next = 0;
    for (size_t i = 0; i < frames && st == PB_OK; i++) {
        pb_plan_frame *f = &p->set.frame[i];
        size_t n = counts ? counts[i] : 1;
        st = pb_path_create_gate(ctx, &p->set.geometry, track, intervals + 2 * next, n, &p->set.options, &f->path);
        next += n;
        if (st == PB_OK)
            st = ctx->dev.ops->frame_prepare(&ctx->dev, &p->set.options, f);
        if (st != PB_OK) {
            char where[64];
            snprintf(where, sizeof where, " (frame %zu of %zu)", i, frames);
            pb_error_append(ctx, where);
        }
    }
    if (st != PB_OK)
        pb_plan_destroy(p);
    else
        *plan = p;
    return st;
}

pb_status pb_plan_create_frames(pb_context *ctx, const pb_geometry *geometry, const pb_motion *track,
                                const double *bounds, size_t frames, const pb_blur_options *options, pb_plan **plan)
{
    if (!ctx || !geometry || !track || !bounds || !plan)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ctx, geometry, track, bounds and plan must not be NULL");
    pb_status st = pb_context_enter(ctx);
    if (st != PB_OK)
        return st;
    /* Frame i is [bounds[i], bounds[i+1]]. */
    double *iv = NULL;
    st = pb_frame_intervals(ctx, bounds, frames, &iv);
    if (st == PB_OK)
        st = plan_track_entered(ctx, geometry, track, iv, NULL, frames, options, plan);
    free(iv);
    pb_context_leave(ctx);
    return st;
}

pb_status pb_plan_create_gates(pb_context *ctx, const pb_geometry *geometry, const pb_motion *track,
                               const double *intervals, const size_t *counts, size_t frames,
                               const pb_blur_options *options, pb_plan **plan)
{
    if (!ctx || !geometry || !track || !intervals || !counts || !plan)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ctx, geometry, track, intervals, counts and plan must not be "
                        "NULL");
    *plan = NULL;
    if (frames == 0)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "no frames: give at least one gate");
    pb_status st = pb_gate_counts_check(ctx, counts, frames);
    if (st != PB_OK)
        return st;
    size_t next = 0;
    for (size_t i = 0; i < frames; i++) {
        for (size_t k = 0; k < 2 * counts[i]; k++)
            if (!isfinite(intervals[2 * next + k]))
                return pb_error(ctx, PB_ERR_NOT_FINITE, "a time of frame %zu is %g; give finite seconds", i,
                                intervals[2 * next + k]);
        next += counts[i];
    }
    if ((st = pb_context_enter(ctx)) != PB_OK)
        return st;
    st = plan_track_entered(ctx, geometry, track, intervals, counts, frames, options, plan);
    pb_context_leave(ctx);
    return st;
}

/* Both directions: every frame checked and planned, then run in order. */
static pb_status run_frames_entered(pb_context *ctx, const pb_volume *const *ins, const pb_motion *track,
                                    const double *bounds, size_t frames, const pb_blur_options *options,
                                    pb_volume *const *outs, int adjoint)
{
    pb_status st = check_frames(ctx, ins, track, bounds, frames, outs, adjoint);
    if (st != PB_OK)
        return st;
    if (!ins[0])
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "frame 0's %s volume is NULL", adjoint ? "tomograph" : "object");
    /* Every frame's volumes, then every frame's plan, before any work. */
    for (size_t i = 0; i < frames && st == PB_OK; i++)
        if ((st = pb_check_volumes(ctx, &ins[0]->geometry, ins[i], outs[i], adjoint)) != PB_OK) {
            char where[64];
            snprintf(where, sizeof where, " (frame %zu of %zu)", i, frames);
            pb_error_append(ctx, where);
        }
    pb_plan *plan = NULL;
    if (st == PB_OK)
        st = pb_plan_create_frames(ctx, &ins[0]->geometry, track, bounds, frames, options, &plan);
    if (st != PB_OK) {
        pb_error_append(ctx, adjoint ? "; no frame was back projected" : "; no frame was blurred");
        return st;
    }
    frames_progress prog = {ctx->dev.progress, ctx->dev.progress_user, 0, frames};
    double total = 0.0, input = 0.0;
    if (!adjoint && !ctx->dev.progress) {
        /* Queued back to back: progress would need a wait per frame. */
        const pb_memory **in_mem = malloc(frames * sizeof *in_mem);
        pb_memory **out_mem = malloc(frames * sizeof *out_mem);
        for (size_t i = 0; in_mem && out_mem && i < frames; i++) {
            in_mem[i] = &ins[i]->mem;
            out_mem[i] = &outs[i]->mem;
        }
        st = in_mem && out_mem ? ctx->dev.ops->frames_forward(&ctx->dev, &plan->set, in_mem, out_mem)
                               : pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu frames", frames);
        free(in_mem);
        free(out_mem);
        for (size_t i = 0; i < frames; i++)
            pb_images_stale(&outs[i]->mem.images);
        total = ctx->dev.last_kernel_ms;
    } else {
        if (ctx->dev.progress)
            ctx->dev.progress = frame_progress, ctx->dev.progress_user = &prog;
        for (size_t i = 0; i < frames && st == PB_OK; i++) {
            prog.done = i;
            if (adjoint) {
                /* The first frame into an object overwrites it, later ones add. */
                int seen = 0;
                for (size_t j = 0; j < i; j++)
                    seen |= outs[j] == outs[i];
                st = pb_plan_adjoint(plan, i, ins[i], outs[i], seen);
            } else {
                st = pb_plan_forward(plan, i, ins[i], outs[i]);
            }
            total += ctx->dev.last_kernel_ms;
            input += ctx->dev.last_input_ms;
        }
    }
    if (prog.fn) {
        ctx->dev.progress = prog.fn;
        ctx->dev.progress_user = prog.user;
    }
    pb_plan_destroy(plan);
    ctx->dev.last_kernel_ms = total;
    ctx->dev.last_input_ms = input;
    if (st == PB_OK && ctx->dev.progress)
        ctx->dev.progress(1.0, ctx->dev.progress_user);
    return st;
}

static pb_status run_frames(pb_context *ctx, const pb_volume *const *ins, const pb_motion *track,
                            const double *bounds, size_t frames, const pb_blur_options *options,
                            pb_volume *const *outs, int adjoint)
{
    if (!ctx)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "ctx must not be NULL");
    pb_status st = pb_context_enter(ctx);
    if (st != PB_OK)
        return st;
    st = run_frames_entered(ctx, ins, track, bounds, frames, options, outs, adjoint);
    pb_context_leave(ctx);
    return st;
}

pb_status pb_blur_frames(pb_context *ctx, const pb_volume *const *objects, const pb_motion *track,
                         const double *bounds, size_t frames, const pb_blur_options *options,
                         pb_volume *const *tomographs)
{
    return run_frames(ctx, objects, track, bounds, frames, options, tomographs, 0);
}

pb_status pb_blur_frames_adjoint(pb_context *ctx, const pb_volume *const *tomographs, const pb_motion *track,
                                 const double *bounds, size_t frames, const pb_blur_options *options,
                                 pb_volume *const *objects)
{
    return run_frames(ctx, tomographs, track, bounds, frames, options, objects, 1);
}
