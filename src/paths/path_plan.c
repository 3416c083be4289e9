/* Planning: turns a validated pose track into the key poses whose segments
 * the methods walk (frame ends and tracked poses inside, on one hemisphere),
 * cut by the path error bound (path_split.c) and clipped to the grid
 * (path_clip.c), with their texel maps, weights and, for REF, time steps. */
#include "path.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"

/* Largest distance any point of the grid moves between two poses, each axis
 * in its own voxels (what a trilinear read resolves). The displacement is
 * affine in the point, so its norm is largest at a corner. */
static double largest_corner_motion(const pb_path *plan, const pb_pose *a, const pb_pose *b)
{
    const double *v = plan->geometry.voxel_size;
    double worst = 0.0;
    for (int c = 0; c < 8; c++) {
        double p[3], pa[3], pb[3], d = 0.0;
        for (int i = 0; i < 3; i++)
            p[i] = (c >> i & 1) ? (double)plan->geometry.dims[i] * v[i] : 0.0;
        pb_pose_apply_inverse(a, plan->center, p, pa);
        pb_pose_apply_inverse(b, plan->center, p, pb);
        for (int i = 0; i < 3; i++)
            d += (pa[i] - pb[i]) / v[i] * ((pa[i] - pb[i]) / v[i]);
        worst = fmax(worst, sqrt(d));
    }
    return worst;
}

static pb_status plan_ref_steps(struct pb_context *ctx, const pb_blur_options *opt, pb_path *plan)
{
    size_t nseg = plan->count - 1;
    size_t total = 0;
    unsigned *per = calloc(nseg, sizeof *per);
    if (!per)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory planning the reference");
    for (size_t j = 0; j < nseg; j++) {
        unsigned n = plan->poses[j].skip ? 0 : opt->ref_time_steps;
        if (n == 0 && !plan->poses[j].skip) {
            double d = largest_corner_motion(plan, &plan->poses[j].pose, &plan->poses[j + 1].pose);
            /* pb_path_check_walk bounds d; the cast is kept defined all the same */
            n = (unsigned)fmin(4e9, fmax(16.0, 2.0 * ceil(d)));
        }
        per[j] = n;
        total += n;
    }
    plan->ref_steps = calloc(total ? total : 1, sizeof *plan->ref_steps);
    if (!plan->ref_steps) {
        free(per);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu reference time steps", total);
    }
    size_t k = 0;
    for (size_t j = 0; j < nseg; j++) {
        for (unsigned i = 0; i < per[j]; i++, k++) {
            pb_pose p;
            pb_pose_interpolate(&plan->poses[j].pose, &plan->poses[j + 1].pose, (i + 0.5) / per[j], &p);
            pb_pose_texel_map(&p, plan->center, plan->geometry.voxel_size, plan->ref_steps[k].map);
            plan->ref_steps[k].weight = plan->poses[j].weight / per[j];
        }
    }
    /* Every segment clipped: one step of weight 0 keeps the buffers that the
     * devices upload non-empty, and adds nothing. */
    if (total == 0) {
        pb_pose_texel_map(&plan->poses[0].pose, plan->center, plan->geometry.voxel_size, plan->ref_steps[0].map);
        plan->ref_steps[0].weight = 0.0;
        total = 1;
    }
    plan->ref_count = total;
    free(per);
    return PB_OK;
}

int pb_path_walk_counts(const pb_blur_options *opt)
{
    /* AB's steps cut a segment into pieces that are walked all the same */
    return opt->method == PB_METHOD_REF ? !opt->ref_time_steps : opt->method == PB_METHOD_AB || !opt->steps;
}

pb_status pb_path_walk_check(struct pb_context *ctx, const pb_geometry *g, const char *what, int axis, double most,
                             double *total, double place, int by_value)
{
    const double limit = fmax((double)PB_WALK_LEAST, (double)PB_WALK_GRIDS * (double)g->dims[axis]);
    *total += most;
    if (most <= limit && *total <= (double)PB_WALK_SEGMENTS * limit)
        return PB_OK;
    char at[64];
    snprintf(at, sizeof at, by_value ? "the surrogate's value %.9g" : "%.9g s", place);
    return pb_error(ctx, PB_ERR_INVALID_ARGUMENT,
                    "the %s %s the object %.3g voxels along %c (%.6g mm voxels) %s %s, more than a blur walks (%.0f "
                    "a segment, %d times the grid's %zu voxels or %d; %d times that a frame): check the units of the "
                    "%s and of the voxel sizes (micrometres read as mm?)",
                    what, what[strlen(what) - 1] == 's' ? "carry" : "carries", most <= limit ? *total : most,
                    "xyz"[axis], g->voxel_size[axis], most <= limit ? "by" : "in the segment from", at, limit,
                    (int)PB_WALK_GRIDS, g->dims[axis], (int)PB_WALK_LEAST, (int)PB_WALK_SEGMENTS, what);
}

pb_status pb_path_check_samples(struct pb_context *ctx, const pb_blur_options *opt, const pb_path *plan,
                                double *total)
{
    const unsigned steps = opt->method == PB_METHOD_REF ? opt->ref_time_steps : opt->steps;
    const char *what = opt->method == PB_METHOD_REF ? "time steps" : "steps";
    size_t walked = 0;
    for (size_t j = 0; j + 1 < plan->count; j++)
        walked += !plan->poses[j].skip;
    *total += (double)walked * (double)steps;
    if (*total <= (double)PB_FIXED_SAMPLES)
        return PB_OK;
    return pb_error(ctx, PB_ERR_INVALID_ARGUMENT,
                    "%zu segments at %u fixed %s each take %.3g samples a voxel in the frame, more than the %.0e a "
                    "blur takes: use fewer %s, or AB or RM with a path error bound, which merges a log's samples",
                    walked, steps, what, *total, (double)PB_FIXED_SAMPLES, what);
}

pb_status pb_path_check_walk(struct pb_context *ctx, const pb_blur_options *opt, const pb_path *plan, double total[3])
{
    if (!pb_path_walk_counts(opt))
        return pb_path_check_samples(ctx, opt, plan, &total[0]);
    pb_status st = PB_OK;
    for (size_t j = 0; j + 1 < plan->count && st == PB_OK; j++)
        for (int axis = 0; axis < 3 && !plan->poses[j].skip && st == PB_OK; axis++)
            st = pb_path_walk_check(ctx, &plan->geometry, "motion", axis,
                                    pb_texel_map_walk(plan->poses[j].map, plan->poses[j + 1].map,
                                                      plan->geometry.dims, axis),
                                    &total[axis], plan->poses[j].time, 0);
    return st;
}

pb_status pb_path_create(struct pb_context *ctx, const pb_geometry *g, const pb_motion *m,
                         const pb_blur_options *opt, pb_path *plan)
{
    memset(plan, 0, sizeof *plan);
    pb_status st = pb_motion_validate(ctx, m);
    if (st != PB_OK)
        return st;
    plan->geometry = *g;
    for (int i = 0; i < 3; i++)
        plan->center[i] = m->has_center ? m->center[i] : 0.5 * (double)g->dims[i] * g->voxel_size[i];

    /* Key poses: the frame's start, every tracked pose strictly inside, its end. */
    size_t inside = 0;
    for (size_t i = 0; i < m->count; i++)
        inside += m->times[i] > m->frame_start && m->times[i] < m->frame_end;
    plan->count = inside + 2;
    plan->poses = calloc(plan->count, sizeof *plan->poses);
    if (!plan->poses)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu key poses", plan->count);
    size_t k = 0;
    plan->poses[k].time = m->frame_start;
    pb_motion_interpolate(m, m->frame_start, &plan->poses[k++].pose);
    for (size_t i = 0; i < m->count; i++) {
        if (m->times[i] > m->frame_start && m->times[i] < m->frame_end) {
            plan->poses[k].time = m->times[i];
            pb_pose_normalized(&m->poses[i], &plan->poses[k++].pose);
        }
    }
    plan->poses[k].time = m->frame_end;
    pb_motion_interpolate(m, m->frame_end, &plan->poses[k].pose);

    /* Same hemisphere as the previous pose, so a plain SLERP between
     * neighbours (as the kernels do it) takes the shorter arc. */
    for (size_t j = 1; j < plan->count; j++)
        if (pb_quat_dot(plan->poses[j].pose.rotation, plan->poses[j - 1].pose.rotation) < 0.0)
            for (int i = 0; i < 4; i++)
                plan->poses[j].pose.rotation[i] = -plan->poses[j].pose.rotation[i];
    /* The polyline methods get their key poses fitted to the track, where it
     * has samples inside the frame, and their intervals cut to the path error
     * bound. The fit (path_fit.c): a chord through two samples leaves the
     * track between them on one side, which shifts every voxel's time average
     * by up to the bound, and a sharp edge's blur is first-order sensitive to
     * that; the fitted polyline's residual has zero time mean (docs/methods.md,
     * "Where the merged chords' error comes from"). */
    if ((opt->method == PB_METHOD_AB || opt->method == PB_METHOD_RM) && opt->path != PB_PATH_TRACKED) {
        double bound = opt->path == PB_PATH_BOUNDED ? opt->max_path_error : PB_DEFAULT_MAX_PATH_ERROR;
        int fit = plan->count >= 3;
        st = fit ? pb_path_fit(ctx, plan, m, 0.0, bound) : PB_OK;
        /* Fitted knots are cut, not merged again: a merge keeps a chord
         * within the bound of the fitted polyline, and such a chord through
         * fitted knots leaves it on one side as a chord through samples left
         * the track (seeds 101-1010 of the noise-free kinds: 0.05-0.35 % RMS
         * merged, 0.04-0.25 % cut only, at about the same segments). */
        if (st == PB_OK)
            st = pb_path_split(ctx, plan, bound, !fit);
        if (st != PB_OK) {
            pb_path_destroy(plan);
            return st;
        }
    }
    /* The error bound caps the segments it makes; a track walked as it is
     * (PB_PATH_TRACKED, CL, REF) gets the same cap. */
    if (plan->count - 1 > PB_MAX_SEGMENTS) {
        size_t n = plan->count - 1;
        pb_path_destroy(plan);
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT,
                        "the frame holds %zu tracked intervals, more than the %d segments one blur walks; use AB or RM "
                        "with a path error bound (which merges a log's samples), or shorter frames", n,
                        PB_MAX_SEGMENTS);
    }
    if ((st = pb_path_clip(ctx, plan)) != PB_OK) {
        pb_path_destroy(plan);
        return st;
    }
    double span = m->frame_end - m->frame_start;
    for (size_t j = 0; j < plan->count; j++) {
        pb_path_pose *p = &plan->poses[j];
        pb_pose_texel_map(&p->pose, plan->center, g->voxel_size, p->map);
        p->weight = j + 1 < plan->count && !p->skip ? (plan->poses[j + 1].time - p->time) / span : 0.0;
    }
    double walked[3] = {0.0, 0.0, 0.0};
    if ((st = pb_path_check_walk(ctx, opt, plan, walked)) != PB_OK) {
        pb_path_destroy(plan);
        return st;
    }
    if (opt->method == PB_METHOD_REF) {
        st = plan_ref_steps(ctx, opt, plan);
        if (st != PB_OK) {
            pb_path_destroy(plan);
            return st;
        }
    }
    return PB_OK;
}

void pb_path_destroy(pb_path *plan)
{
    free(plan->poses);
    free(plan->ref_steps);
    if (plan->field) {
        free(plan->field->data);
        free(plan->field->knots);
        free(plan->field->ref_knots);
        free(plan->field);
    }
    memset(plan, 0, sizeof *plan);
}
