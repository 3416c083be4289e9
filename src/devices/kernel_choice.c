#include "kernel_choice.h"

#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#define PB_KERNEL_INFO_(id, name, family, method, filter, reads, group)                                          \
    {#name, PB_FAMILY_##family, PB_KT_##method, PB_KT_##filter, PB_READS_##reads, PB_KT_##group},
const pb_kernel_info pb_kernel_table[PB_KERNEL_COUNT] = {PB_KERNELS(PB_KERNEL_INFO_)};
#undef PB_KERNEL_INFO_

/* The knots a field frame's buffer holds before its fields: the key points,
 * or REF's time steps, rounded up to whole 64-byte lines. */
static size_t field_knot_slots(const pb_path *path, pb_method method)
{
    size_t n = method == PB_METHOD_REF ? path->ref_count : path->count;
    return (n + 3) / 4 * 4;
}

void pb_kparams_from_path(const pb_path *path, const pb_blur_options *opt, pb_kparams *prm)
{
    memset(prm, 0, sizeof *prm);
    for (int d = 0; d < 3; d++) {
        prm->dims[d] = (int)path->geometry.dims[d];
        prm->voxel[d] = (float)path->geometry.voxel_size[d];
        prm->inv_voxel[d] = (float)(1.0 / path->geometry.voxel_size[d]);
        prm->center[d] = (float)path->center[d];
    }
    prm->segments = (int)path->count - 1;
    /* AB's steps are sub-segments, at least one; CL and RM's 0 means "as many as
     * AB's slices", decided per voxel in the kernel. */
    prm->steps = opt->method == PB_METHOD_AB && opt->steps == 0 ? 1 : (int)opt->steps;
    prm->chord = opt->method == PB_METHOD_AB && opt->ab_sampling == PB_AB_SAMPLING_CHORD;
    prm->ref_points = (int)opt->ref_points;
    prm->ref_steps = (int)path->ref_count;
    prm->seed = opt->seed;
    if (path->field) {
        const pb_path_field *pf = path->field;
        for (int d = 0; d < 3; d++)
            prm->field_dims[d] = (int)pf->dims[d];
        prm->field_same = pf->same;
        for (int k = 0; k < 12; k++)
            prm->field_map[k] = (float)pf->map[k];
        prm->field_start = (int)field_knot_slots(path, opt->method);
        prm->jacobian = opt->jacobian;
        return;
    }
    if (pb_path_shift_invariant(path, opt))
        prm->layer_axis = pb_path_layer_axis(path);
}

int pb_path_shift_invariant(const pb_path *path, const pb_blur_options *opt)
{
    if (opt->method == PB_METHOD_REF || path->field)
        return 0;
    /* The rotations themselves, not the maps: a map is built by differences
     * (pb_pose_texel_map) and its identity may be off by an ulp in double. A
     * unit quaternion with no vector part is the identity even where SLERP's
     * normalisation left w an ulp off 1. */
    for (size_t i = 0; i < path->count; i++) {
        const double *q = path->poses[i].pose.rotation;
        if (q[1] != 0.0 || q[2] != 0.0 || q[3] != 0.0)
            return 0;
    }
    return 1;
}

/* How far segment j of a motion of translations moves every voxel along axis
 * r: the difference of its maps' offsets. */
static double segment_move(const pb_path *path, size_t j, int r)
{
    return fabs(path->poses[j + 1].map[4 * r + 3] - path->poses[j].map[4 * r + 3]);
}

double pb_path_segment_along(const pb_path *path, size_t j)
{
    return fmax(segment_move(path, j, 0), fmax(segment_move(path, j, 1), segment_move(path, j, 2)));
}

int pb_path_layer_axis(const pb_path *path)
{
    int axis = -1;
    for (size_t j = 0; j + 1 < path->count; j++) {
        double d[3];
        if (path->poses[j].skip)
            continue;
        for (int r = 0; r < 3; r++)
            d[r] = segment_move(path, j, r);
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
static double longest_walk(const pb_path *path, const pb_blur_options *opt, int m)
{
    double most = 0.0;
    for (size_t j = 0; j + 1 < path->count; j++)
        if (!path->poses[j].skip)
            most = fmax(most, segment_move(path, j, m));
    return most / (opt->steps ? (double)opt->steps : 1.0);
}

/* The fewest slices a walk of a motion of translations crosses: its
 * shortest segment's move along its major axis over AB's sub-segments. The
 * layers hold only the paper's walk, which AB takes from PB_AB_WALK_FROM
 * slices on (shorter segments are read exactly, through the 3-D image). */
static double shortest_walk(const pb_path *path, const pb_blur_options *opt)
{
    double least = HUGE_VAL;
    for (size_t j = 0; j + 1 < path->count; j++)
        if (!path->poses[j].skip)
            least = fmin(least, pb_path_segment_along(path, j));
    return least / (opt->steps ? (double)opt->steps : 1.0);
}

/* Layers along x pay only on long walks: their work items walk PB_X_RUN voxels
 * one after the other, and a short walk leaves too little work in flight to
 * hide that; the 3-D image wins below about 8 slices a walk, the layers above
 * (docs/performance.md, "What bounds AB"). And along x
 * they pay only for an input laid out once and read many times: the layout
 * there is a transpose, which costs more than the layers save on one blur, so
 * an input laid out anew every call reads the 3-D image along x. Along y and
 * z the layers save more than their layout costs even on one blur
 * (docs/performance.md, "Device memory in and out"). */
#define PB_X_LAYERS_MIN_SLICES 8.0

/* The kernel of a family that computes the options' method under their
 * filter: AB sweep has kernels of its own (PB_KT_AB_SWEEP). */
static pb_kernel_id find_kernel(pb_kernel_family family, const pb_blur_options *opt)
{
    int method = opt->method == PB_METHOD_AB && opt->ab_sampling == PB_AB_SAMPLING_SWEEP ? PB_KT_AB_SWEEP
                                                                                        : (int)opt->method;
    /* A field is linear in time between its samples: CL's interpolated
     * motion at a step is RM's point on the chord. */
    if (family >= PB_FAMILY_FIELD && method == PB_KT_CL)
        method = PB_KT_RM;
    pb_filter filter = opt->filter;
    for (int k = 0; k < PB_KERNEL_COUNT; k++) {
        const pb_kernel_info *info = &pb_kernel_table[k];
        if (info->family == family && (info->method == PB_KT_ANY || info->method == method) &&
            (info->filter == PB_KT_ANY || info->filter == (int)filter))
            return (pb_kernel_id)k;
    }
    return PB_KERNEL_COUNT; /* unreachable: the table covers every method and filter */
}

/* Whether the object fits the device's layered images laid out along m. */
static int layers_fit(const size_t *n, int m, const size_t *layer_limits)
{
    return n[pb_layer_across(m, 0)] <= layer_limits[0] && n[pb_layer_across(m, 1)] <= layer_limits[1] &&
           n[m] <= layer_limits[2];
}

pb_kernel_id pb_forward_kernel(const pb_path *path, const pb_blur_options *opt, const size_t *layer_limits,
                               int fresh_input)
{
    if (path->field)
        return find_kernel(opt->jacobian && opt->method != PB_METHOD_REF ? PB_FAMILY_FIELD_MASS : PB_FAMILY_FIELD, opt);
    if (!pb_path_shift_invariant(path, opt))
        return find_kernel(PB_FAMILY_GENERAL, opt);
    int m = -1;
    if (opt->method == PB_METHOD_AB && opt->filter == PB_FILTER_HARDWARE && layer_limits)
        m = pb_path_layer_axis(path);
    if (m == 0 && (fresh_input || longest_walk(path, opt, 0) < PB_X_LAYERS_MIN_SLICES))
        m = -1;
    if (m >= 0 && (opt->ab_sampling == PB_AB_SAMPLING_CHORD ||
                   shortest_walk(path, opt) < (double)PB_AB_WALK_FROM + 0.01)) /* the margin: the kernels' float */
        m = -1;
    if (m >= 0 && layers_fit(path->geometry.dims, m, layer_limits))
        return find_kernel(m == 0 ? PB_FAMILY_LAYERS_X : PB_FAMILY_LAYERS, opt);
    return find_kernel(PB_FAMILY_SHIFT, opt);
}

pb_kernel_id pb_adjoint_kernel(const pb_path *path, const pb_blur_options *opt, const size_t *layer_limits)
{
    if (path->field)
        return find_kernel(opt->jacobian && opt->method != PB_METHOD_REF ? PB_FAMILY_FIELD_MASS_SCATTER
                                                                          : PB_FAMILY_FIELD_SCATTER, opt);
    if (pb_path_shift_invariant(path, opt))
        return pb_forward_kernel(path, opt, layer_limits, 1);
    return find_kernel(PB_FAMILY_SCATTER, opt);
}

void pb_kparams_permute(const size_t *dims, int m, pb_kparams *prm)
{
    memset(prm, 0, sizeof *prm);
    for (int d = 0; d < 3; d++)
        prm->dims[d] = (int)dims[d];
    prm->layer_axis = m;
}

/* The kernels read each key pose's map as three float4 (pb_map_pose): in a
 * buffer of poses, which the devices align to at least 16 bytes, every map
 * must start on 16 bytes. */
_Static_assert(sizeof(pb_kpose) % 16 == 0 && offsetof(pb_kpose, map) == 0,
               "pb_kpose: a whole number of 16 bytes, its map first");

static void kpose_from_path(const pb_path *path, size_t index, pb_kpose *out)
{
    const pb_path_pose *p = &path->poses[index];
    memset(out, 0, sizeof *out);
    for (int k = 0; k < 12; k++)
        out->map[k] = (float)p->map[k];
    for (int k = 0; k < 4; k++)
        out->rotation[k] = (float)p->pose.rotation[k];
    for (int k = 0; k < 3; k++)
        out->translation[k] = (float)p->pose.translation[k];
    out->weight = (float)p->weight;
    if (index + 1 < path->count) {
        double angle = pb_quat_angle(p->pose.rotation, path->poses[index + 1].pose.rotation);
        out->angle = (float)angle;
        out->cos_angle = (float)cos(angle);
        out->inv_sin_angle = angle > 0.0 ? (float)(1.0 / sin(angle)) : 0.0f;
    }
}

static void kstep_from_path(const pb_path *path, size_t index, pb_kstep *out)
{
    for (int k = 0; k < 12; k++)
        out->map[k] = (float)path->ref_steps[index].map[k];
    out->weight = (float)path->ref_steps[index].weight;
}

int pb_kernel_scatters(pb_kernel_id kernel)
{
    pb_kernel_family f = pb_kernel_table[kernel].family;
    return f == PB_FAMILY_SCATTER || f == PB_FAMILY_FIELD_SCATTER || f == PB_FAMILY_FIELD_MASS_SCATTER;
}

/* A field frame's buffer: its knots (key points, or REF's steps), then its
 * fields, in texel units. */
static void *field_pack(const pb_path *path, pb_method method, size_t *bytes)
{
    const pb_path_field *pf = path->field;
    size_t slots = field_knot_slots(path, method), n = method == PB_METHOD_REF ? path->ref_count : path->count;
    size_t values = pf->fields * pf->dims[0] * pf->dims[1] * pf->dims[2] * 3;
    *bytes = slots * sizeof(pb_kknot) + values * sizeof(float);
    pb_kknot *k = calloc(1, *bytes);
    if (!k)
        return NULL;
    for (size_t i = 0; i < n; i++) {
        const pb_path_knot *src = method == PB_METHOD_REF ? &pf->ref_knots[i] : &pf->knots[i];
        k[i].f0 = (int)src->f0;
        k[i].f1 = (int)src->f1;
        k[i].alpha = (float)src->alpha;
        k[i].weight = (float)(method == PB_METHOD_REF ? path->ref_steps[i].weight : path->poses[i].weight);
    }
    memcpy(k + slots, pf->data, values * sizeof(float));
    return k;
}

void *pb_kernel_path_pack(const pb_path *path, pb_method method, size_t *bytes)
{
    if (path->field)
        return field_pack(path, method, bytes);
    if (method == PB_METHOD_REF) {
        pb_kstep *s = calloc(path->ref_count, sizeof *s);
        for (size_t i = 0; s && i < path->ref_count; i++)
            kstep_from_path(path, i, &s[i]);
        *bytes = path->ref_count * sizeof *s;
        return s;
    }
    pb_kpose *p = calloc(path->count, sizeof *p);
    for (size_t i = 0; p && i < path->count; i++)
        kpose_from_path(path, i, &p[i]);
    *bytes = path->count * sizeof *p;
    return p;
}

void pb_kernel_extent(pb_kernel_id kernel, const size_t *dims, size_t *extent)
{
    int runs = pb_kernel_table[kernel].family == PB_FAMILY_LAYERS_X;
    extent[0] = runs ? dims[1] : dims[0];
    extent[1] = runs ? (dims[0] + PB_X_RUN - 1) / PB_X_RUN : dims[1];
    extent[2] = (dims[2] + pb_kernel_run_z(kernel) - 1) / pb_kernel_run_z(kernel);
}

unsigned pb_kernel_run_z(pb_kernel_id kernel)
{
    return pb_kernel_table[kernel].family == PB_FAMILY_TAPS ? PB_TAP_RUN : 1;
}
