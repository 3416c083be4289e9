#include "kernel_args.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void pb_kparams_from_plan(const pb_path *plan, const pb_blur_options *opt, pb_kparams *prm)
{
    memset(prm, 0, sizeof *prm);
    for (int d = 0; d < 3; d++) {
        prm->dims[d] = (int)plan->geometry.dims[d];
        prm->voxel[d] = (float)plan->geometry.voxel_size[d];
        prm->inv_voxel[d] = (float)(1.0 / plan->geometry.voxel_size[d]);
        prm->center[d] = (float)plan->center[d];
    }
    prm->segments = (int)plan->count - 1;
    /* AB's steps are sub-segments, at least one; CL and RM's 0 means "as many as
     * AB's slices", decided per voxel in the kernel. */
    prm->steps = opt->method == PB_METHOD_AB && opt->steps == 0 ? 1 : (int)opt->steps;
    prm->ref_points = (int)opt->ref_points;
    prm->ref_steps = (int)plan->ref_count;
    prm->seed = opt->seed;
    if (pb_path_shift_invariant(plan, opt))
        prm->layer_axis = pb_path_layer_axis(plan);
}

int pb_path_shift_invariant(const pb_path *plan, const pb_blur_options *opt)
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

/* How far segment j of a motion of translations moves every voxel along axis
 * r: the difference of its maps' offsets. */
static double segment_move(const pb_path *plan, size_t j, int r)
{
    return fabs(plan->poses[j + 1].map[4 * r + 3] - plan->poses[j].map[4 * r + 3]);
}

int pb_path_layer_axis(const pb_path *plan)
{
    int axis = -1;
    for (size_t j = 0; j + 1 < plan->count; j++) {
        double d[3];
        if (plan->poses[j].skip)
            continue;
        for (int r = 0; r < 3; r++)
            d[r] = segment_move(plan, j, r);
        if (d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0)
            continue;
        int m = d[1] > d[0] ? 1 : 0;
        m = d[2] > d[m] ? 2 : m;
        if (axis >= 0 && m != axis)
            return -1;
        axis = m;
    }
    return axis < 0 ? 0 : axis;
}

/* The most slices one AB walk of a motion of translations crosses along
 * axis m: its longest segment's move along m over AB's sub-segments. */
static double longest_walk(const pb_path *plan, const pb_blur_options *opt, int m)
{
    double most = 0.0;
    for (size_t j = 0; j + 1 < plan->count; j++)
        if (!plan->poses[j].skip)
            most = fmax(most, segment_move(plan, j, m));
    return most / (opt->steps ? (double)opt->steps : 1.0);
}

/* Layers along x pay only on long walks: their work items walk PB_X_RUN voxels
 * one after the other, and a short walk leaves too little work in flight to
 * hide that. H200, 256^3 (bench/results/2026-11-21_H200_29b8577/x-run.csv):
 * 3 slices 0.233 ms through the 3-D image against 0.284 through layers, 13
 * slices 0.514 against 0.470. The cut lies between. */
#define PB_X_LAYERS_MIN_SLICES 8.0

int pb_forward_kernel(const pb_path *plan, const pb_blur_options *opt, const size_t *layer_limits)
{
    int exact = opt->filter == PB_FILTER_EXACT;
    if (!pb_path_shift_invariant(plan, opt))
        return pb_kernel_index((int)opt->method, exact);
    int m = opt->method == PB_METHOD_AB && !exact && layer_limits ? pb_path_layer_axis(plan) : -1;
    const size_t *n = plan->geometry.dims;
    if (m == 0 && longest_walk(plan, opt, 0) < PB_X_LAYERS_MIN_SLICES)
        m = -1;
    if (m >= 0 && n[pb_layer_across(m, 0)] <= layer_limits[0] && n[pb_layer_across(m, 1)] <= layer_limits[1] &&
        n[m] <= layer_limits[2])
        return m == 0 ? PB_KERNEL_SHIFT_AB_LAYERS_X : PB_KERNEL_SHIFT_AB_LAYERS;
    return pb_shift_index((int)opt->method, exact);
}

void pb_kparams_permute(const size_t *dims, int m, pb_kparams *prm)
{
    memset(prm, 0, sizeof *prm);
    for (int d = 0; d < 3; d++)
        prm->dims[d] = (int)dims[d];
    prm->layer_axis = m;
}

static void kpose_from_plan(const pb_path *plan, size_t index, pb_kpose *out)
{
    const pb_path_pose *p = &plan->poses[index];
    memset(out, 0, sizeof *out);
    for (int k = 0; k < 12; k++)
        out->map[k] = (float)p->map[k];
    for (int k = 0; k < 4; k++)
        out->rotation[k] = (float)p->pose.rotation[k];
    for (int k = 0; k < 3; k++)
        out->translation[k] = (float)p->pose.translation[k];
    out->weight = (float)p->weight;
    if (index + 1 < plan->count) {
        double angle = pb_quat_angle(p->pose.rotation, plan->poses[index + 1].pose.rotation);
        out->angle = (float)angle;
        out->cos_angle = (float)cos(angle);
        out->inv_sin_angle = angle > 0.0 ? (float)(1.0 / sin(angle)) : 0.0f;
    }
}

static void kstep_from_plan(const pb_path *plan, size_t index, pb_kstep *out)
{
    for (int k = 0; k < 12; k++)
        out->map[k] = (float)plan->ref_steps[index].map[k];
    out->weight = (float)plan->ref_steps[index].weight;
}

void *pb_kernel_plan_pack(const pb_path *plan, pb_method method, size_t *bytes)
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

int pb_kernel_layered(int kernel)
{
    return kernel == PB_KERNEL_SHIFT_AB_LAYERS || kernel == PB_KERNEL_SHIFT_AB_LAYERS_X;
}

void pb_kernel_extent(int kernel, const size_t *dims, size_t *extent)
{
    int runs = kernel == PB_KERNEL_SHIFT_AB_LAYERS_X;
    extent[0] = runs ? dims[1] : dims[0];
    extent[1] = runs ? (dims[0] + PB_X_RUN - 1) / PB_X_RUN : dims[1];
    extent[2] = dims[2];
}

/* A warp of 32 x-neighbours suits the walks under translations: their reads
 * and writes coalesce, and the layered kernel's work items share their layers
 * (the one along x turns its warps along y: pb_kernel_extent). Under rotation
 * a warp's 32 paths fan out across the object, and tiles of 16 x 2 keep them
 * closer: the rotated scatters' atomic adds fall on fewer L2 lines and the
 * classical method's fetches on fewer texture lines. H200, homogeneity 256^3
 * (bench/results/2026-11-21_H200_29b8577/groups-13a3282), 32x4x2 -> 16x2x8:
 * AB's adjoint at 60 degrees 17.9 -> 15.4 ms, AB-E's 21.8 -> 17.6, CL's
 * forward 12.7 -> 12.1; no row of that experiment slower by more than 1.5 %
 * (in the full run, scenario 7's RM adjoint was 13 % slower). */
void pb_kernel_group(int kernel, unsigned group[3])
{
    int general = kernel <= pb_adjoint_index(PB_METHOD_REF);
    group[0] = general ? 16 : 32;
    group[1] = general ? 2 : 4;
    group[2] = general ? 8 : 2;
}
