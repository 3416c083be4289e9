#include "motion.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"

#define PB_PI 3.14159265358979323846

void pb_quat_mul(const double a[4], const double b[4], double out[4])
{
    double r[4];
    r[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
    r[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
    r[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
    r[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
    memcpy(out, r, sizeof r);
}

void pb_quat_conj(const double q[4], double out[4])
{
    out[0] = q[0];
    out[1] = -q[1];
    out[2] = -q[2];
    out[3] = -q[3];
}

double pb_quat_dot(const double a[4], const double b[4])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
}

double pb_quat_angle(const double a[4], const double b[4])
{
    double dm = 0.0, dp = 0.0;
    for (int k = 0; k < 4; k++) {
        dm += (a[k] - b[k]) * (a[k] - b[k]);
        dp += (a[k] + b[k]) * (a[k] + b[k]);
    }
    return 2.0 * atan2(sqrt(dm), sqrt(dp));
}

static void quat_normalize(const double q[4], double out[4])
{
    double n = sqrt(pb_quat_dot(q, q));
    for (int i = 0; i < 4; i++)
        out[i] = q[i] / n;
}

void pb_quat_slerp(const double a[4], const double b[4], double s, double out[4])
{
    double bb[4];
    double d = pb_quat_dot(a, b);
    /* q and -q are one rotation: take the shorter arc. */
    double sign = d < 0.0 ? -1.0 : 1.0;
    for (int i = 0; i < 4; i++)
        bb[i] = sign * b[i];
    d = fabs(d);
    double wa, wb;
    if (d > 1.0 - 1e-12) {
        /* Nearly equal: sin(theta) ~ 0, LERP is exact to rounding. */
        wa = 1.0 - s;
        wb = s;
    } else {
        double theta = acos(d);
        double st = sin(theta);
        wa = sin((1.0 - s) * theta) / st;
        wb = sin(s * theta) / st;
    }
    double r[4];
    for (int i = 0; i < 4; i++)
        r[i] = wa * a[i] + wb * bb[i];
    quat_normalize(r, out);
}

void pb_quat_to_matrix(const double q[4], double r[9])
{
    double w = q[0], x = q[1], y = q[2], z = q[3];
    r[0] = 1 - 2 * (y * y + z * z);
    r[1] = 2 * (x * y - w * z);
    r[2] = 2 * (x * z + w * y);
    r[3] = 2 * (x * y + w * z);
    r[4] = 1 - 2 * (x * x + z * z);
    r[5] = 2 * (y * z - w * x);
    r[6] = 2 * (x * z - w * y);
    r[7] = 2 * (y * z + w * x);
    r[8] = 1 - 2 * (x * x + y * y);
}

void pb_quat_rotate(const double q[4], const double v[3], double out[3])
{
    double r[9];
    pb_quat_to_matrix(q, r);
    double o[3];
    for (int i = 0; i < 3; i++)
        o[i] = r[3 * i] * v[0] + r[3 * i + 1] * v[1] + r[3 * i + 2] * v[2];
    memcpy(out, o, sizeof o);
}

void pb_pose_apply(const pb_pose *pose, const double center[3], const double p[3], double out[3])
{
    double d[3] = {p[0] - center[0], p[1] - center[1], p[2] - center[2]};
    pb_quat_rotate(pose->rotation, d, out);
    for (int i = 0; i < 3; i++)
        out[i] += center[i] + pose->translation[i];
}

void pb_pose_apply_inverse(const pb_pose *pose, const double center[3], const double p[3], double out[3])
{
    double qc[4];
    double d[3];
    for (int i = 0; i < 3; i++)
        d[i] = p[i] - center[i] - pose->translation[i];
    pb_quat_conj(pose->rotation, qc);
    pb_quat_rotate(qc, d, out);
    for (int i = 0; i < 3; i++)
        out[i] += center[i];
}

void pb_pose_compose(const pb_pose *a, const pb_pose *b, pb_pose *out)
{
    /* a(b(p)) = Ra Rb (p - c) + c + Ra tb + ta */
    pb_pose r;
    pb_quat_mul(a->rotation, b->rotation, r.rotation);
    pb_quat_rotate(a->rotation, b->translation, r.translation);
    for (int i = 0; i < 3; i++)
        r.translation[i] += a->translation[i];
    *out = r;
}

void pb_pose_invert(const pb_pose *pose, pb_pose *out)
{
    /* p = R^T (q - c - t) + c = R^T (q - c) + c - R^T t */
    pb_pose r;
    pb_quat_conj(pose->rotation, r.rotation);
    pb_quat_rotate(r.rotation, pose->translation, r.translation);
    for (int i = 0; i < 3; i++)
        r.translation[i] = -r.translation[i];
    *out = r;
}

void pb_pose_interpolate(const pb_pose *a, const pb_pose *b, double s, pb_pose *out)
{
    pb_pose r;
    for (int i = 0; i < 3; i++)
        r.translation[i] = (1.0 - s) * a->translation[i] + s * b->translation[i];
    pb_quat_slerp(a->rotation, b->rotation, s, r.rotation);
    *out = r;
}

void pb_pose_texel_map(const pb_pose *pose, const double center[3], const double voxel[3], double m[12])
{
    /* u_obj = D^-1 (R^T (D u - c - t) + c): columns are images of the unit texel steps. */
    double origin[3], zero[3] = {0, 0, 0};
    pb_pose_apply_inverse(pose, center, zero, origin);
    for (int col = 0; col < 3; col++) {
        double e[3] = {0, 0, 0}, img[3];
        e[col] = voxel[col];
        pb_pose_apply_inverse(pose, center, e, img);
        for (int row = 0; row < 3; row++)
            m[4 * row + col] = (img[row] - origin[row]) / voxel[row];
    }
    for (int row = 0; row < 3; row++)
        m[4 * row + 3] = origin[row] / voxel[row];
}

/* ---- validation --------------------------------------------------------- */

int pb_all_finite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* mm; a light year is 1e19. Beyond this, squares and norms of translations
 * (the planner's) leave double's range, and no scanner is that large. */
#define PB_MAX_TRANSLATION 1e12

static pb_status validate_pose(struct pb_context *ctx, const pb_pose *p, size_t i)
{
    if (!pb_all_finite(p->translation, 3))
        return pb_error(ctx, PB_ERR_NOT_FINITE,
                        "pose %zu has a NaN or infinite translation (%g, %g, %g); give finite mm values", i,
                        p->translation[0], p->translation[1], p->translation[2]);
    for (int k = 0; k < 3; k++)
        if (fabs(p->translation[k]) > PB_MAX_TRANSLATION)
            return pb_error(ctx, PB_ERR_INVALID_ARGUMENT,
                            "pose %zu translates by %g mm, beyond 1e12 mm (a million km); translations are mm", i,
                            p->translation[k]);
    if (!pb_all_finite(p->rotation, 4))
        return pb_error(ctx, PB_ERR_NOT_FINITE,
                        "pose %zu has a NaN or infinite quaternion; give a finite unit quaternion (w, x, y, z)", i);
    double n = sqrt(pb_quat_dot(p->rotation, p->rotation));
    if (n == 0.0)
        return pb_error(ctx, PB_ERR_BAD_QUATERNION,
                        "pose %zu has a zero quaternion, which is no rotation; use (1, 0, 0, 0) for none", i);
    if (fabs(n - 1.0) > 1e-3)
        return pb_error(ctx, PB_ERR_BAD_QUATERNION,
                        "pose %zu has a quaternion of norm %.6g; give a unit quaternion (w, x, y, z) "
                        "(norms within 1e-3 of 1 are normalised)",
                        i, n);
    return PB_OK;
}

pb_status pb_motion_validate(struct pb_context *ctx, const pb_motion *m)
{
    if (!m || !m->times || !m->poses)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "motion, its times and its poses must not be NULL");
    if (m->count < 2)
        return pb_error(ctx, PB_ERR_TRACK_ORDER,
                        "the track has %zu pose(s); give at least two, at or before the frame's start and at or "
                        "after its end",
                        m->count);
    if (!isfinite(m->frame_start) || !isfinite(m->frame_end))
        return pb_error(ctx, PB_ERR_NOT_FINITE, "the frame [%g, %g] is not finite; give finite times in seconds",
                        m->frame_start, m->frame_end);
    if (!(m->frame_end > m->frame_start))
        return pb_error(ctx, PB_ERR_BAD_FRAME, "the frame ends at %g s, not after its start at %g s; give end > start",
                        m->frame_end, m->frame_start);
    /* Finite times may still be too far apart to subtract: the weights would be NaN. */
    if (!isfinite(m->frame_end - m->frame_start))
        return pb_error(ctx, PB_ERR_NOT_FINITE, "the frame [%g, %g] s is too long to measure in double precision; "
                        "give times in seconds of a scan", m->frame_start, m->frame_end);
    for (size_t i = 0; i < m->count; i++) {
        if (!isfinite(m->times[i]))
            return pb_error(ctx, PB_ERR_NOT_FINITE, "track time %zu is NaN or infinite; give finite seconds", i);
        if (i > 0 && !isfinite(m->times[i] - m->times[i - 1]))
            return pb_error(ctx, PB_ERR_NOT_FINITE, "track times %zu and %zu (%g s, %g s) are too far apart to "
                            "subtract in double precision; give times in seconds of a scan", i - 1, i,
                            m->times[i - 1], m->times[i]);
        if (i > 0 && !(m->times[i] > m->times[i - 1]))
            return pb_error(ctx, PB_ERR_TRACK_ORDER,
                            "track time %zu (%g s) is not after time %zu (%g s); sort the track and drop repeated "
                            "times",
                            i, m->times[i], i - 1, m->times[i - 1]);
        pb_status st = validate_pose(ctx, &m->poses[i], i);
        if (st != PB_OK)
            return st;
    }
    if (m->times[0] > m->frame_start || m->times[m->count - 1] < m->frame_end)
        return pb_error(ctx, PB_ERR_TRACK_GAP,
                        "the track covers [%g, %g] s but the frame is [%g, %g] s; add poses at or beyond the frame's "
                        "ends or pick a frame inside the track",
                        m->times[0], m->times[m->count - 1], m->frame_start, m->frame_end);
    if (m->has_center && !pb_all_finite(m->center, 3))
        return pb_error(ctx, PB_ERR_NOT_FINITE, "the rotation centre is NaN or infinite; give mm from the grid's corner");
    for (int k = 0; m->has_center && k < 3; k++)
        if (fabs(m->center[k]) > PB_MAX_TRANSLATION)
            return pb_error(ctx, PB_ERR_INVALID_ARGUMENT,
                            "the rotation centre lies %g mm from the grid, beyond 1e12 mm; give mm from the grid's corner",
                            m->center[k]);
    return PB_OK;
}

static void normalized_pose(const pb_pose *in, pb_pose *out)
{
    *out = *in;
    quat_normalize(in->rotation, out->rotation);
}

void pb_motion_interpolate(const pb_motion *m, double t, pb_pose *pose)
{
    size_t j = 0;
    while (j + 2 < m->count && m->times[j + 1] <= t)
        j++;
    double s = (t - m->times[j]) / (m->times[j + 1] - m->times[j]);
    s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
    pb_pose a, b;
    normalized_pose(&m->poses[j], &a);
    normalized_pose(&m->poses[j + 1], &b);
    pb_pose_interpolate(&a, &b, s, pose);
}

pb_status pb_motion_pose_at(const pb_motion *motion, double t, pb_pose *pose)
{
    pb_status st = pb_motion_validate(NULL, motion);
    if (st != PB_OK)
        return st;
    if (!pose)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "pose must not be NULL");
    if (!isfinite(t) || t < motion->times[0] || t > motion->times[motion->count - 1])
        return pb_error(NULL, PB_ERR_TRACK_GAP, "time %g s is outside the track [%g, %g] s", t, motion->times[0],
                        motion->times[motion->count - 1]);
    pb_motion_interpolate(motion, t, pose);
    return PB_OK;
}

pb_status pb_quaternion_from_axis_angle(const double axis[3], double angle_deg, double q[4])
{
    if (!axis || !q)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "axis and q must not be NULL");
    if (!pb_all_finite(axis, 3) || !isfinite(angle_deg))
        return pb_error(NULL, PB_ERR_NOT_FINITE, "the axis or angle is NaN or infinite");
    /* The axis over its largest component first, so that 1e200 squares stay finite. */
    double big = fmax(fabs(axis[0]), fmax(fabs(axis[1]), fabs(axis[2]))), a[3];
    if (big == 0.0)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the rotation axis is the zero vector; give a direction");
    for (int i = 0; i < 3; i++)
        a[i] = axis[i] / big;
    double n = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    double half = 0.5 * angle_deg * PB_PI / 180.0;
    q[0] = cos(half);
    for (int i = 0; i < 3; i++)
        q[i + 1] = sin(half) * a[i] / n;
    return PB_OK;
}

/* ---- plan --------------------------------------------------------------- */

/* Largest distance any point of the grid moves between two poses, in voxels of
 * the smallest voxel size. The displacement is affine in the point, so its norm
 * is largest at a corner. */
static double largest_corner_motion(const pb_path *plan, const pb_pose *a, const pb_pose *b)
{
    const double *v = plan->geometry.voxel_size;
    double vmin = fmin(v[0], fmin(v[1], v[2]));
    double worst = 0.0;
    for (int c = 0; c < 8; c++) {
        double p[3], pa[3], pb[3];
        for (int i = 0; i < 3; i++)
            p[i] = (c >> i & 1) ? (double)plan->geometry.dims[i] * v[i] : 0.0;
        pb_pose_apply_inverse(a, plan->center, p, pa);
        pb_pose_apply_inverse(b, plan->center, p, pb);
        double d = sqrt((pa[0] - pb[0]) * (pa[0] - pb[0]) + (pa[1] - pb[1]) * (pa[1] - pb[1]) +
                        (pa[2] - pb[2]) * (pa[2] - pb[2]));
        worst = fmax(worst, d / vmin);
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
            n = (unsigned)fmax(16.0, 2.0 * ceil(d));
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
            normalized_pose(&m->poses[i], &plan->poses[k++].pose);
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
    /* The polyline methods get their intervals cut to the path error bound. */
    if ((opt->method == PB_METHOD_AB || opt->method == PB_METHOD_RM) && opt->max_path_error >= 0.0) {
        st = pb_path_split(ctx, plan, opt->max_path_error > 0.0 ? opt->max_path_error : PB_DEFAULT_MAX_PATH_ERROR);
        if (st != PB_OK) {
            pb_path_destroy(plan);
            return st;
        }
    }
    /* The error bound caps the segments it makes; a track walked as it is
     * (max_path_error < 0, CL, REF) gets the same cap. */
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
    memset(plan, 0, sizeof *plan);
}
