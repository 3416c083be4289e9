/* Error-bounded polylines: AB and RM walk straight segments between key poses,
 * while a voxel's true path under rotation is curved. Each tracked interval is
 * cut into equal pieces until no voxel centre of the grid can leave its chord
 * by more than the bound.
 *
 * The bound. Over one interval from pose A to pose B (parameter s in [0, 1]),
 * a tomograph point p is seen in object space at
 *     o(s) - c = Q(s) v(s),  v(s) = R_A^T (p - c - t(s)),
 * where Q(s) = exp(-s theta K) turns by -s theta about the interval's axis K
 * (SLERP) and t(s) is the LERP of the translations. v is linear in s, so
 *     o'' = theta^2 K^2 Q v - 2 theta K Q v',  |o''| <= theta^2 |v| + 2 theta |dt|
 * with |v| = |p - c - t(s)| <= r + max(|t_A|, |t_B|), r the largest distance of
 * a voxel centre from c (at a corner: the grid is a box) and dt = t_B - t_A.
 * A C2 curve leaves its chord over a piece of length h by at most
 * h^2 max|o''| / 8, so n pieces (h = 1/n) keep every voxel within E when
 * n >= sqrt(D / (8 E)), D the bound above in voxels of the smallest size (a
 * distance of d mm is at most d / vmin voxels along any axis). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "motion.h"

/* The most segments one blur may get; far above what any sane bound needs
 * (a full turn at 0.01 voxels on a 512^3 grid takes about 6000). */
enum { PB_MAX_SEGMENTS = 100000 };

static double norm3(const double v[3])
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

size_t pb_path_pieces(const pb_geometry *g, const double center[3], const pb_pose *a, const pb_pose *b,
                      double max_error)
{
    const double *v = g->voxel_size;
    double vmin = fmin(v[0], fmin(v[1], v[2]));
    double r = 0.0;
    for (int c = 0; c < 8; c++) {
        double d[3];
        for (int i = 0; i < 3; i++)
            d[i] = ((c >> i & 1) ? ((double)g->dims[i] - 0.5) * v[i] : 0.5 * v[i]) - center[i];
        r = fmax(r, norm3(d));
    }
    double dt[3] = {b->translation[0] - a->translation[0], b->translation[1] - a->translation[1],
                    b->translation[2] - a->translation[2]};
    double theta = 2.0 * pb_quat_angle(a->rotation, b->rotation); /* the turn: twice SLERP's angle */
    double tmax = fmax(norm3(a->translation), norm3(b->translation));
    double curvature = (theta * theta * (r + tmax) + 2.0 * theta * norm3(dt)) / vmin;
    double n = ceil(sqrt(curvature / (8.0 * max_error)));
    return n < 1.0 ? 1 : (n > (double)PB_MAX_SEGMENTS ? (size_t)PB_MAX_SEGMENTS + 1 : (size_t)n);
}

pb_status pb_plan_split(struct pb_context *ctx, pb_plan *plan, double max_error)
{
    size_t total = 0, intervals = plan->count - 1;
    size_t *pieces = malloc(intervals * sizeof *pieces);
    if (!pieces)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory planning the path");
    for (size_t j = 0; j < intervals; j++) {
        pieces[j] = pb_path_pieces(&plan->geometry, plan->center, &plan->poses[j].pose, &plan->poses[j + 1].pose,
                                   max_error);
        total += pieces[j];
    }
    if (total > PB_MAX_SEGMENTS) {
        free(pieces);
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT,
                        "max_path_error %g voxels would cut this motion into more than %d segments; raise it "
                        "(default %g)", max_error, (int)PB_MAX_SEGMENTS, PB_DEFAULT_MAX_PATH_ERROR);
    }
    if (total == intervals) {
        free(pieces);
        return PB_OK;
    }
    pb_plan_pose *poses = calloc(total + 1, sizeof *poses);
    if (!poses) {
        free(pieces);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu key poses", total + 1);
    }
    size_t k = 0;
    for (size_t j = 0; j < intervals; j++) {
        const pb_plan_pose *a = &plan->poses[j], *b = &plan->poses[j + 1];
        for (size_t i = 0; i < pieces[j]; i++, k++) {
            double s = (double)i / (double)pieces[j];
            poses[k].time = a->time + s * (b->time - a->time);
            /* The same LERP and SLERP as the motion's own interpolation, so the
             * new key poses lie on the true path. */
            pb_pose_interpolate(&a->pose, &b->pose, s, &poses[k].pose);
        }
    }
    poses[k] = plan->poses[intervals];
    free(plan->poses);
    free(pieces);
    plan->poses = poses;
    plan->count = total + 1;
    return PB_OK;
}
