/* A track cut to a frame, by the one rule every frame of every plan is cut by,
 * and the frame's time-weighted mean pose (what one pose per frame takes). */
#include <math.h>

#include "error.h"
#include "motion.h"
#include "numbers.h"

pb_status pb_frame_bounds_check(struct pb_context *ctx, const double *bounds, size_t frames)
{
    if (frames == 0)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "no frames: give at least one frame (two bounds)");
    for (size_t i = 0; i <= frames; i++)
        if (!isfinite(bounds[i]))
            return pb_error(ctx, PB_ERR_NOT_FINITE, "frame bound %zu is %g; give finite times in seconds", i,
                            bounds[i]);
    for (size_t i = 0; i < frames; i++)
        if (!(bounds[i + 1] > bounds[i]))
            return pb_error(ctx, PB_ERR_BAD_FRAME, "frame %zu ends at %s s, not after its start %s s; frame "
                            "bounds must increase", i, PB_NUM(bounds[i + 1]), PB_NUM(bounds[i]));
    /* Each frame may be measurable and the series not: a track over it would
     * hold times no blur can subtract. */
    if (!isfinite(bounds[frames] - bounds[0]))
        return pb_error(ctx, PB_ERR_NOT_FINITE, "the frames span [%s, %s] s, too long to measure in double precision; "
                        "give seconds of a scan", PB_NUM(bounds[0]), PB_NUM(bounds[frames]));
    return PB_OK;
}

size_t pb_sample_before(const double *x, size_t n, double v)
{
    size_t lo = 0, hi = n; /* x[lo] <= v < x[hi], x[n] beyond every v */
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (x[mid] <= v)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

pb_status pb_motion_frame(const pb_motion *track, double t0, double t1, pb_motion *part)
{
    if (!track || !part || !track->times || !track->poses || track->count < 2)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "a track of at least two poses and part must not be NULL");
    size_t a = pb_sample_before(track->times, track->count, t0), b = track->count - 1;
    size_t lo = a;
    while (a < b) { /* the first sample at or after t1 */
        size_t mid = a + (b - a) / 2;
        if (track->times[mid] >= t1)
            b = mid;
        else
            a = mid + 1;
    }
    size_t hi = b;
    if (hi <= lo) { /* a frame at or past the last sample: validation says so, with the frame's number */
        lo = lo + 1 < track->count ? lo : track->count - 2;
        hi = lo + 1;
    }
    *part = *track;
    part->times += lo;
    part->poses += lo;
    part->count = hi - lo + 1;
    part->frame_start = t0;
    part->frame_end = t1;
    return PB_OK;
}

/* SLERP from a to b (same hemisphere, angle 2w apart as 4-vectors) averaged
 * over s in [0, 1]: (sin((1-s)w) a + sin(s w) b) / sin w integrates to
 * (1 - cos w) / (w sin w) (a + b), which tends to (a + b) / 2 as w -> 0. */
static double slerp_mean_weight(double w)
{
    return w < 1e-4 ? 0.5 + w * w / 24.0 : (1.0 - cos(w)) / (w * sin(w));
}

pb_status pb_motion_mean_pose(const pb_motion *motion, pb_pose *mean)
{
    if (!mean)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "mean must not be NULL");
    pb_status st = pb_motion_validate(NULL, motion);
    if (st != PB_OK)
        return st;
    pb_motion m;
    pb_motion_frame(motion, motion->frame_start, motion->frame_end, &m);
    double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 0}, span = m.frame_end - m.frame_start;
    pb_pose a, b, first;
    pb_motion_interpolate(&m, m.frame_start, &first);
    for (size_t i = 0; i + 1 < m.count; i++) {
        double s0 = fmax(m.times[i], m.frame_start), s1 = fmin(m.times[i + 1], m.frame_end);
        if (!(s1 > s0))
            continue;
        /* The segment's own poses at its ends inside the frame: no search. */
        pb_pose p0, p1;
        pb_pose_normalized(&m.poses[i], &p0);
        pb_pose_normalized(&m.poses[i + 1], &p1);
        double dt = m.times[i + 1] - m.times[i];
        pb_pose_interpolate(&p0, &p1, (s0 - m.times[i]) / dt, &a);
        pb_pose_interpolate(&p0, &p1, (s1 - m.times[i]) / dt, &b);
        /* Every piece on the first pose's hemisphere, so that q and -q add up. */
        if (pb_quat_dot(a.rotation, first.rotation) < 0.0)
            for (int k = 0; k < 4; k++)
                a.rotation[k] = -a.rotation[k];
        if (pb_quat_dot(a.rotation, b.rotation) < 0.0)
            for (int k = 0; k < 4; k++)
                b.rotation[k] = -b.rotation[k];
        double f = (s1 - s0) / span, w = slerp_mean_weight(pb_quat_angle(a.rotation, b.rotation));
        for (int k = 0; k < 3; k++)
            t[k] += f * 0.5 * (a.translation[k] + b.translation[k]);
        for (int k = 0; k < 4; k++)
            q[k] += f * w * (a.rotation[k] + b.rotation[k]);
    }
    double n = sqrt(pb_quat_dot(q, q));
    if (!(n > 0.0))
        return pb_error(NULL, PB_ERR_BAD_QUATERNION, "the frame's rotations cancel out (they spread over more than "
                        "180 degrees); a mean pose means nothing for such a frame");
    for (int k = 0; k < 3; k++)
        mean->translation[k] = t[k];
    for (int k = 0; k < 4; k++)
        mean->rotation[k] = q[k] / n;
    return PB_OK;
}
