/* Validation of a pose track and the frame it covers: every problem gets its
 * own status and a message naming what to fix, before anything is planned.
 * Also the pose of a validated track at a time (pb_motion_interpolate, and
 * the public pb_motion_pose_at that validates first). */
#include "motion.h"

#include <math.h>

#include "error.h"

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
    if (m->count == 0)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "the motion has no poses; give at least two, at or before the "
                        "frame's start and at or after its end");
    if (m->count == 1)
        return pb_error(ctx, PB_ERR_TRACK_GAP, "the motion has one pose, which cannot cover a frame; give at least two, "
                        "at or before the frame's start and at or after its end (the same pose twice for none)");
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

void pb_motion_interpolate(const pb_motion *m, double t, pb_pose *pose)
{
    size_t j = 0;
    while (j + 2 < m->count && m->times[j + 1] <= t)
        j++;
    double s = (t - m->times[j]) / (m->times[j + 1] - m->times[j]);
    s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
    pb_pose a, b;
    pb_pose_normalized(&m->poses[j], &a);
    pb_pose_normalized(&m->poses[j + 1], &b);
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
