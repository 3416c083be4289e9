/* Plans of field motions: the field checked once against the grid, then
 * each frame planned from the fields its time covers, as frames of a track
 * are (frames.c). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "plan.h"

/* Frame i is the union of counts[i] intervals, taken in turn from
 * intervals[] (two numbers each); with counts NULL, one each. */
static pb_status plan_field_entered(pb_context *ctx, const pb_geometry *geometry, const pb_field_motion *field,
                                    const double *intervals, const size_t *counts, size_t frames,
                                    const pb_blur_options *options, pb_plan **plan)
{
    *plan = NULL;
    size_t count = 0;
    pb_status st = pb_geometry_check(ctx, geometry, &count);
    if (st == PB_OK && frames == 0)
        st = pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "no frames: give at least one");
    if (st == PB_OK)
        st = pb_field_validate(ctx, geometry, field);
    if (st == PB_OK)
        st = pb_field_check_reach(ctx, geometry, field);
    pb_plan *p = NULL;
    if (st == PB_OK)
        st = pb_plan_new(ctx, geometry, options, frames, &p);
    size_t next = 0;
    for (size_t i = 0; i < frames && st == PB_OK; i++) {
        pb_plan_frame *f = &p->set.frame[i];
        size_t n = counts ? counts[i] : 1;
        for (size_t k = 0; k < 2 * n && st == PB_OK; k++)
            if (!isfinite(intervals[2 * next + k]))
                st = pb_error(ctx, PB_ERR_NOT_FINITE, "a time of the frame is %g; give finite seconds",
                              intervals[2 * next + k]);
        if (st == PB_OK)
            st = pb_path_create_field(ctx, geometry, field, intervals + 2 * next, n, &p->set.options, &f->path);
        next += n;
        if (st == PB_OK)
            st = ctx->dev.ops->frame_prepare(&ctx->dev, &p->set.options, f);
        if (st != PB_OK && frames > 1) {
            char where[64];
            snprintf(where, sizeof where, " (frame %zu of %zu)", i, frames);
            pb_error_append(ctx, where);
        }
    }
    if (st != PB_OK) {
        pb_plan_destroy(p);
        return st;
    }
    *plan = p;
    return PB_OK;
}

pb_status pb_plan_create_field_frames(pb_context *ctx, const pb_geometry *geometry, const pb_field_motion *field,
                                      const double *bounds, size_t frames, const pb_blur_options *options,
                                      pb_plan **plan)
{
    if (!ctx || !geometry || !field || !bounds || !plan)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ctx, geometry, field, bounds and plan must not be NULL");
    pb_status st = pb_context_enter(ctx);
    if (st != PB_OK)
        return st;
    /* Frame i is [bounds[i], bounds[i+1]]. */
    double *iv = NULL;
    st = pb_frame_intervals(ctx, bounds, frames, &iv);
    if (st == PB_OK)
        st = plan_field_entered(ctx, geometry, field, iv, NULL, frames, options, plan);
    free(iv);
    pb_context_leave(ctx);
    return st;
}

pb_status pb_plan_create_field_gates(pb_context *ctx, const pb_geometry *geometry, const pb_field_motion *field,
                                     const double *intervals, const size_t *counts, size_t frames,
                                     const pb_blur_options *options, pb_plan **plan)
{
    if (!ctx || !geometry || !field || !intervals || !counts || !plan)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ctx, geometry, field, intervals, counts and plan must not be "
                        "NULL");
    pb_status st = pb_gate_counts_check(ctx, counts, frames);
    if (st == PB_OK)
        st = pb_context_enter(ctx);
    if (st != PB_OK)
        return st;
    st = plan_field_entered(ctx, geometry, field, intervals, counts, frames, options, plan);
    pb_context_leave(ctx);
    return st;
}

pb_status pb_plan_create_field(pb_context *ctx, const pb_geometry *geometry, const pb_field_motion *field,
                               const pb_blur_options *options, pb_plan **plan)
{
    if (!field)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "field must not be NULL");
    double bounds[2] = {field->frame_start, field->frame_end};
    return pb_plan_create_field_frames(ctx, geometry, field, bounds, 1, options, plan);
}
