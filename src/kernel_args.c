#include "kernel_args.h"

#include <stdlib.h>
#include <string.h>

void pb_kparams_from_plan(const pb_plan *plan, const pb_blur_options *opt, pb_kparams *prm)
{
    memset(prm, 0, sizeof *prm);
    for (int d = 0; d < 3; d++) {
        prm->dims[d] = (int)plan->geometry.dims[d];
        prm->voxel[d] = (float)plan->geometry.voxel_size[d];
        prm->center[d] = (float)plan->center[d];
    }
    prm->segments = (int)plan->count - 1;
    /* AB's steps are sub-segments, at least one; CL and RM's 0 means "as many as
     * AB's slices", decided per voxel in the kernel. */
    prm->steps = opt->method == PB_METHOD_AB && opt->steps == 0 ? 1 : (int)opt->steps;
    prm->ref_points = (int)opt->ref_points;
    prm->ref_steps = (int)plan->ref_count;
    prm->seed = opt->seed;
}

int pb_plan_shift_invariant(const pb_plan *plan, const pb_blur_options *opt)
{
    if (opt->method == PB_METHOD_REF)
        return 0;
    /* The rotations themselves, not the maps: a map is built by differences
     * (pb_pose_texel_map) and its identity may be off by an ulp in double. A
     * unit quaternion with no vector part is the identity even where SLERP's
     * normalisation left w an ulp off 1. */
    for (size_t i = 0; i < plan->count; i++) {
        const double *q = plan->poses[i].pose.rotation;
        if (q[1] != 0.0 || q[2] != 0.0 || q[3] != 0.0)
            return 0;
    }
    return 1;
}

int pb_forward_kernel(const pb_plan *plan, const pb_blur_options *opt)
{
    int exact = opt->filter == PB_FILTER_EXACT;
    return pb_plan_shift_invariant(plan, opt) ? pb_shift_index((int)opt->method, exact)
                                              : pb_kernel_index((int)opt->method, exact);
}

static void kpose_from_plan(const pb_plan *plan, size_t index, pb_kpose *out)
{
    const pb_plan_pose *p = &plan->poses[index];
    memset(out, 0, sizeof *out);
    for (int k = 0; k < 12; k++)
        out->map[k] = (float)p->map[k];
    for (int k = 0; k < 4; k++)
        out->rotation[k] = (float)p->pose.rotation[k];
    for (int k = 0; k < 3; k++)
        out->translation[k] = (float)p->pose.translation[k];
    out->weight = (float)p->weight;
    if (index + 1 < plan->count)
        out->angle = (float)pb_quat_angle(p->pose.rotation, plan->poses[index + 1].pose.rotation);
}

static void kstep_from_plan(const pb_plan *plan, size_t index, pb_kstep *out)
{
    for (int k = 0; k < 12; k++)
        out->map[k] = (float)plan->ref_steps[index].map[k];
    out->weight = (float)plan->ref_steps[index].weight;
}

void *pb_kernel_plan_pack(const pb_plan *plan, pb_method method, size_t *bytes)
{
    if (method == PB_METHOD_REF) {
        pb_kstep *s = calloc(plan->ref_count, sizeof *s);
        for (size_t i = 0; s && i < plan->ref_count; i++)
            kstep_from_plan(plan, i, &s[i]);
        *bytes = plan->ref_count * sizeof *s;
        return s;
    }
    pb_kpose *p = calloc(plan->count, sizeof *p);
    for (size_t i = 0; p && i < plan->count; i++)
        kpose_from_plan(plan, i, &p[i]);
    *bytes = plan->count * sizeof *p;
    return p;
}
