/* The checks that catch a track that cannot be what was meant: warnings on
 * its poses (a quaternion order slip, millisecond times) and, per frame,
 * refusals (gaps, a grid out of view for a whole frame) and warnings. They
 * live in the library so that the command line and Python warn and refuse
 * alike. */
#include <math.h>
#include <string.h>

#include "error.h"
#include "motion.h"
#include "numbers.h"
#include "track.h"

/* A turn of more than this between two samples is taken the short way round by
 * SLERP, and no head turns that fast: a quaternion order slip looks like it. */
#define MAX_STEP_DEG 90.0
/* Interpolating across a longer run of missing samples would invent the motion. */
#define MAX_GAP_S 1.0
/* A frame or a track longer than this, in seconds, has its times in ms. */
#define MS_SUSPECT_S (6.0 * 3600.0)

static double turn_from_rest(const double q[4])
{
    pb_pose rest = {{0, 0, 0}, {1, 0, 0, 0}}, p = {{0, 0, 0}, {q[0], q[1], q[2], q[3]}};
    return pb_pose_turn_deg(&rest, &p);
}

/* The largest turn from rest of the file's quaternions read in the other
 * order: x,y,z,w taken as w,x,y,z (shift 1), or the other way round (3). */
static double reordered_max_turn(const pb_track *t, int shift)
{
    double worst = 0.0;
    for (size_t i = 0; i < t->count; i++) {
        const double *q = t->poses[i].rotation;
        double r[4];
        for (int k = 0; k < 4; k++)
            r[k] = q[(k + shift) % 4];
        worst = fmax(worst, turn_from_rest(r));
    }
    return worst;
}

/* Every pose far from rest (or every later one far from the first) while
 * neighbours stay close: a whole track read in the wrong order. */
static void warn_far(const pb_track *t, const pb_pose *world, pb_warnings *w)
{
    double least_rest = 180.0, least_first = 180.0;
    size_t at = 0;
    for (size_t i = 0; i < t->count; i++) {
        double d = turn_from_rest(world[i].rotation);
        if (d < least_rest)
            least_rest = d, at = i;
        if (i > 0)
            least_first = fmin(least_first, pb_pose_turn_deg(&world[0], &world[i]));
    }
    if (least_rest > MAX_STEP_DEG + 1e-6) {
        char fit[160] = "";
        double a = t->format == PB_TRACK_CSV ? reordered_max_turn(t, 3) : 180.0;
        double b = t->format == PB_TRACK_CSV ? reordered_max_turn(t, 1) : 180.0;
        if (fmin(a, b) <= MAX_STEP_DEG)
            snprintf(fit, sizeof fit, "; read as %s instead, every pose stays within %.0f degrees of rest",
                     a <= b ? "x,y,z,w (--quaternion-order xyzw)" : "w,x,y,z (--quaternion-order wxyz)", fmin(a, b));
        pb_warn(w, PB_WARN_FAR_FROM_REST, "%s: every pose turns more than %.0f degrees from rest (the least %.0f "
                "degrees, line %zu), as a quaternion read in the wrong order does%s; check --quaternion-order",
                t->source, MAX_STEP_DEG, least_rest, t->lines[at], fit);
    } else if (t->count > 2 && least_first > MAX_STEP_DEG + 1e-6) {
        pb_warn(w, PB_WARN_FAR_FROM_REST, "%s:%zu: the first pose turns more than %.0f degrees from every other (at "
                "least %.0f); is the first sample a glitch?", t->source, t->lines[0], MAX_STEP_DEG, least_first);
    }
}

void pb_track_warn_poses(const pb_track *t, const pb_pose *world, pb_warnings *w)
{
    for (size_t i = 1; i < t->count; i++) {
        double deg = pb_pose_turn_deg(&world[i - 1], &world[i]);
        if (deg > MAX_STEP_DEG + 1e-6) { /* --rotate's own pieces are 90 degrees to rounding */
            pb_warn(w, PB_WARN_TURN_STEP, "%s:%zu: the pose turns %.0f degrees from the one before (line %zu) "
                    "within %.3g s; a quaternion read in the wrong order (x,y,z,w as w,x,y,z) looks like this: check "
                    "--quaternion-order", t->source, t->lines[i], deg, t->lines[i - 1], t->times[i] - t->times[i - 1]);
            break;
        }
    }
    warn_far(t, world, w);
    double span = t->times[t->count - 1] - t->times[0];
    if (span > MS_SUSPECT_S && span / (double)(t->count - 1) >= 1.0)
        pb_warn(w, PB_WARN_TIME_UNIT, "%s: the track spans %.6g s (%.3g h) in samples %.3g s apart: are its times "
                "in milliseconds? then give --time-unit ms", t->source, span, span / 3600.0,
                span / (double)(t->count - 1));
}

/* ---- frames ---------------------------------------------------------------- */

/* The grid's box and the centre a pose turns it about, grid mm. */
static void grid_box(const pb_motion *mo, const pb_geometry *g, double ext[3], double c[3])
{
    for (int i = 0; i < 3; i++) {
        ext[i] = (double)g->dims[i] * g->voxel_size[i];
        c[i] = mo->has_center ? mo->center[i] : 0.5 * ext[i];
    }
}

/* Whether the pose leaves any of the grid's box inside the grid: the box's
 * image under a rigid map lies inside the box around its eight corners. */
static int grid_seen(const pb_motion *mo, const pb_geometry *g, const pb_pose *p)
{
    double inf = (double)INFINITY, ext[3], c[3], lo[3] = {inf, inf, inf}, hi[3] = {-inf, -inf, -inf};
    grid_box(mo, g, ext, c);
    for (int k = 0; k < 8; k++) {
        double v[3] = {(k & 1) ? ext[0] : 0, (k & 2) ? ext[1] : 0, (k & 4) ? ext[2] : 0}, w[3];
        pb_pose_apply(p, c, v, w);
        for (int i = 0; i < 3; i++) {
            lo[i] = fmin(lo[i], w[i]);
            hi[i] = fmax(hi[i], w[i]);
        }
    }
    for (int i = 0; i < 3; i++)
        if (hi[i] <= 0.0 || lo[i] >= ext[i])
            return 0;
    return 1;
}

/* Whether some pose between a and b (LERP of translations) may leave part of
 * the grid in view: the moved grid lies within rho of its moved centre
 * c + t(s), so it can meet the grid's box only while that ball's box does,
 * an interval of s per axis. Conservative: a refusal needs every segment out. */
static int segment_may_see(const pb_motion *mo, const pb_geometry *g, const pb_pose *a, const pb_pose *b)
{
    double lo = 0.0, hi = 1.0, rho2 = 0.0, ext[3], c[3];
    grid_box(mo, g, ext, c);
    for (int i = 0; i < 3; i++)
        rho2 += fmax(c[i] * c[i], (ext[i] - c[i]) * (ext[i] - c[i]));
    double rho = sqrt(rho2);
    for (int i = 0; i < 3 && lo <= hi; i++) {
        /* needs -rho <= c + t(s) <= ext + rho, with t(s) = ta + s (tb - ta) */
        double ta = a->translation[i], d = b->translation[i] - ta, low = -rho - c[i] - ta, high = ext[i] + rho - c[i] - ta;
        if (d == 0.0) {
            if (low > 0.0 || high < 0.0)
                return 0;
        } else {
            double s1 = low / d, s2 = high / d;
            lo = fmax(lo, fmin(s1, s2));
            hi = fmin(hi, fmax(s1, s2));
        }
    }
    return lo <= hi;
}

/* The frame's samples are lo to hi, as pb_motion_frame cuts them: from the
 * last at or before the frame's start to the first at or after its end. */
static pb_status check_gap(const pb_track *t, double t0, double t1, size_t lo, size_t hi)
{
    for (size_t i = lo + 1; i <= hi; i++)
        if (t->missing[i] && t->times[i] > t0 && t->times[i - 1] < t1 && t->times[i] - t->times[i - 1] > MAX_GAP_S)
            return pb_error(NULL, PB_ERR_TRACK_GAP, "%s:%zu-%zu: %zu missing samples leave a gap of %.3g s (%.9g to "
                            "%.9g s) inside the frame %.9g to %.9g s, longer than the %.3g s petblur interpolates "
                            "across; choose frames outside the gap", t->source, t->lines[i - 1], t->lines[i],
                            t->missing[i], t->times[i] - t->times[i - 1], t->times[i - 1], t->times[i], t0, t1,
                            MAX_GAP_S);
    return PB_OK;
}

/* The frame's ends and every tracked pose inside it (taken as they are:
 * interpolating each would cost a pass over the track). */
static pb_status check_view(const pb_track *t, const pb_motion *grid, const pb_geometry *g,
                            const pb_motion *part, pb_warnings *w)
{
    double t0 = part->frame_start, t1 = part->frame_end;
    size_t seen = 0, poses = 0;
    int may_see = 0;
    pb_pose prev = {{0, 0, 0}, {1, 0, 0, 0}};
    for (size_t i = 0; i <= part->count + 1; i++) {
        pb_pose p;
        if (i == 0 || i == part->count + 1)
            pb_motion_interpolate(part, i == 0 ? t0 : t1, &p);
        else if (part->times[i - 1] > t0 && part->times[i - 1] < t1)
            p = part->poses[i - 1];
        else
            continue;
        if (poses++ > 0)
            may_see |= segment_may_see(grid, g, &prev, &p);
        prev = p;
        seen += (size_t)grid_seen(grid, g, &p);
    }
    if (poses > 1 && !may_see)
        return pb_error(NULL, PB_ERR_OUT_OF_VIEW, "%s: the motion takes the whole grid out of the field of view for "
                        "the whole frame %.9g to %.9g s, so the blur would be zero; are the translations in mm, in "
                        "the image's coordinates (see --coords), and the times in seconds?", t->source, t0, t1);
    if (seen < poses)
        pb_warn(w, PB_WARN_OUT_OF_VIEW, "%s: at %zu of the frame's %zu poses the grid lies wholly outside the field "
                "of view", t->source, poses - seen, poses);
    return PB_OK;
}

/* The bounds' own warning: a frame longer than a scan. Returns whether it warned. */
static int warn_long_frame(const double *bounds, size_t frames, pb_warnings *w)
{
    double longest = 0.0;
    size_t at = 0;
    for (size_t i = 0; i < frames; i++)
        if (bounds[i + 1] - bounds[i] > longest) {
            longest = bounds[i + 1] - bounds[i];
            at = i;
        }
    if (!(longest > MS_SUSPECT_S))
        return 0;
    pb_warn(w, PB_WARN_TIME_UNIT, "frame %zu (%.9g to %.9g s) lasts %.3g h: are the times in milliseconds? frames "
            "and tracks are in seconds (--time-unit ms reads a track in ms)", at, bounds[at], bounds[at + 1],
            longest / 3600.0);
    return 1;
}

static void warn_frames(const pb_track *t, const double *bounds, size_t frames, pb_warnings *w)
{
    double span = t->times[t->count - 1] - t->times[0], all = bounds[frames] - bounds[0];
    if (warn_long_frame(bounds, frames, w))
        return;
    if (all < 1e-3 * span)
        pb_warn(w, PB_WARN_FRAMES_SPAN, "the frame%s %.9g to %.9g s span%s %.2g %% of the track %s (%.9g to %.9g s); "
                "are the frames and the track in the same time unit?", frames > 1 ? "s" : "", bounds[0],
                bounds[frames], frames > 1 ? "" : "s", 100.0 * all / span, t->source, t->times[0],
                t->times[t->count - 1]);
}

pb_status pb_track_check_frames(const pb_track *track, const pb_motion *grid, const pb_geometry *geometry,
                                const double *bounds, size_t frames, pb_warnings *warnings)
{
    if (!track || !grid || !geometry || !bounds)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "track, grid, geometry and bounds must not be NULL");
    if (grid->count != track->count || grid->times != track->times)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "grid must be the track's motion as pb_track_place made it");
    pb_status st = pb_frame_bounds_check(NULL, bounds, frames);
    if (st != PB_OK)
        return st;
    const pb_track *t = track;
    for (size_t i = 0; i < frames; i++) {
        if (bounds[i] < t->times[0] || bounds[i + 1] > t->times[t->count - 1])
            return pb_error(NULL, PB_ERR_TRACK_GAP, "frame %zu (%s to %s s) lies outside the track %s, which "
                            "covers %s to %s s; choose frames inside it", i, PB_NUM(bounds[i]), PB_NUM(bounds[i + 1]),
                            t->source, PB_NUM(t->times[0]), PB_NUM(t->times[t->count - 1]));
    }
    warn_frames(t, bounds, frames, warnings);
    for (size_t i = 0; i < frames; i++) {
        pb_motion part;
        pb_motion_frame(grid, bounds[i], bounds[i + 1], &part);
        size_t lo = (size_t)(part.times - grid->times);
        st = check_gap(t, bounds[i], bounds[i + 1], lo, lo + part.count - 1);
        if (st == PB_OK)
            st = check_view(t, grid, geometry, &part, warnings);
        if (st != PB_OK)
            return st;
    }
    return PB_OK;
}

pb_status pb_frames_check(const double *bounds, size_t frames, pb_warnings *warnings)
{
    if (!bounds)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "bounds must not be NULL");
    pb_status st = pb_frame_bounds_check(NULL, bounds, frames);
    if (st == PB_OK)
        warn_long_frame(bounds, frames, warnings);
    return st;
}

pb_status pb_frames_from_starts(const double *starts, const double *durations, size_t n, double *bounds)
{
    if (!starts || !durations || !bounds || n == 0)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "give at least one frame start and duration, and room for "
                        "n + 1 bounds");
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(starts[i]) || !isfinite(durations[i]))
            return pb_error(NULL, PB_ERR_NOT_FINITE, "frame %zu starts at %g s and lasts %g s; give finite seconds",
                            i, starts[i], durations[i]);
        if (!(durations[i] > 0.0))
            return pb_error(NULL, PB_ERR_BAD_FRAME, "frame %zu lasts %g s; durations must be positive", i,
                            durations[i]);
        if (i + 1 < n && fabs(starts[i] + durations[i] - starts[i + 1]) > 1e-6 * fmax(1.0, fabs(starts[i + 1])))
            return pb_error(NULL, PB_ERR_BAD_FRAME, "frame %zu ends at %s s but frame %zu starts at %s s; "
                            "petblur's frames follow each other without gaps (give --frames for other frames)", i,
                            PB_NUM(starts[i] + durations[i]), i + 1, PB_NUM(starts[i + 1]));
    }
    memcpy(bounds, starts, n * sizeof *bounds);
    bounds[n] = starts[n - 1] + durations[n - 1];
    if (!isfinite(bounds[n]))
        return pb_error(NULL, PB_ERR_NOT_FINITE, "the last frame ends beyond the largest double (%g s + %g s); give "
                        "seconds of a scan", starts[n - 1], durations[n - 1]);
    /* A duration far below its start's rounding step leaves the frame empty
     * in doubles (1.8 s after 5e74 s is 5e74 s): the frames must still follow
     * each other. */
    for (size_t i = 0; i < n; i++) {
        if (bounds[i + 1] > bounds[i])
            continue;
        if (starts[i] + durations[i] == starts[i])
            return pb_error(NULL, PB_ERR_BAD_FRAME, "frame %zu starts at %.17g s and lasts %g s, which at that time "
                            "is below double precision (it would end where it starts); give times in seconds from "
                            "the scan's TimeZero", i, starts[i], durations[i]);
        return pb_error(NULL, PB_ERR_BAD_FRAME, "frame %zu starts at %.9g s and frame %zu at %.9g s: frames must start "
                        "one after another, each where the one before ends", i, bounds[i], i + 1, bounds[i + 1]);
    }
    return PB_OK;
}
