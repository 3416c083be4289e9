/* What a track and each frame of its motion hold, for a report: one
 * computation that `petblur motion` prints and the bindings return. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "motion.h"
#include "track.h"

static double distance(const double a[3], const double b[3])
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

pb_status pb_motion_frame_summary(const pb_motion *motion, const pb_geometry *geometry, double t0, double t1,
                                  pb_frame_summary *summary)
{
    if (!motion || !geometry || !summary)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the motion, geometry and summary must not be NULL");
    memset(summary, 0, sizeof *summary);
    if (!motion->times || motion->count < 2)
        return pb_motion_validate(NULL, motion); /* its message for a track too short to hold a frame */
    double ext[3], c[3];
    for (int i = 0; i < 3; i++) {
        if (geometry->dims[i] == 0 || !(geometry->voxel_size[i] > 0.0 && isfinite(geometry->voxel_size[i])))
            return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the grid's %c axis holds %zu voxels of %g mm; give at "
                            "least one voxel of a finite positive size", "xyz"[i], geometry->dims[i],
                            geometry->voxel_size[i]);
        ext[i] = (double)geometry->dims[i] * geometry->voxel_size[i];
        c[i] = motion->has_center ? motion->center[i] : 0.5 * ext[i];
    }
    const double *times = motion->times;
    if (!(isfinite(t0) && isfinite(t1) && t0 < t1 && t0 >= times[0] && t1 <= times[motion->count - 1]))
        return pb_error(NULL, PB_ERR_BAD_FRAME, "frame [%g, %g] s: give a start before its end, both inside the "
                        "motion's samples [%g, %g] s", t0, t1, times[0], times[motion->count - 1]);
    /* The frame's part only, cut as plans cut it: a report of many frames of a
     * long track stays linear in the track. */
    pb_motion part;
    pb_status st = pb_motion_frame(motion, t0, t1, &part);
    if (st == PB_OK)
        st = pb_motion_validate(NULL, &part);
    if (st != PB_OK)
        return st;
    pb_pose start, p;
    pb_motion_interpolate(&part, t0, &start);
    for (size_t i = 0; i <= part.count; i++) {
        /* tracked poses as they are, the frame's end interpolated */
        if (i < part.count && (part.times[i] < t0 || part.times[i] > t1))
            continue;
        if (i < part.count) {
            p = part.poses[i];
            summary->samples++;
        } else {
            pb_motion_interpolate(&part, t1, &p);
        }
        summary->max_turn_deg = fmax(summary->max_turn_deg, pb_pose_turn_deg(&start, &p));
        for (int k = 0; k < 8; k++) {
            double v[3] = {(k & 1) ? ext[0] : 0, (k & 2) ? ext[1] : 0, (k & 4) ? ext[2] : 0}, a[3], b[3];
            pb_pose_apply(&start, c, v, a);
            pb_pose_apply(&p, c, v, b);
            summary->max_corner_mm = fmax(summary->max_corner_mm, distance(a, b));
        }
    }
    return PB_OK;
}

int pb_compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

pb_status pb_track_summarize(const pb_track *track, pb_track_summary *summary)
{
    if (!track || !summary)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the track and summary must not be NULL");
    memset(summary, 0, sizeof *summary);
    size_t n = track->count;
    double *steps = malloc((n > 1 ? n - 1 : 1) * sizeof *steps);
    if (!steps)
        return pb_error(NULL, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu steps", n);
    for (size_t i = 1; i < n; i++) {
        double d = track->times[i] - track->times[i - 1];
        steps[i - 1] = d;
        summary->missing += track->missing[i];
        summary->gaps += track->missing[i] > 0;
        if (track->missing[i])
            summary->longest_gap = fmax(summary->longest_gap, d);
    }
    summary->samples = n;
    summary->first = n ? track->times[0] : 0.0;
    summary->last = n ? track->times[n - 1] : 0.0;
    if (n > 1) {
        qsort(steps, n - 1, sizeof *steps, pb_compare_doubles);
        summary->median_step = steps[(n - 1) / 2];
    }
    free(steps);
    return PB_OK;
}
