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
 *     o'' = theta^2 K^2 Q v - 2 theta K Q v',  |o''| <= theta^2 |v_x| + 2 theta |dt_x|
 * where _x is the part across the turn's axis: K^2 w = -w_x and Q keeps it,
 * and R_A takes the axis to the tomograph's (that of q_B q_A^*), across which
 * |v_x| <= r + max(|t_A_x|, |t_B_x|), r the largest distance of a voxel centre
 * from the axis through c (at a corner: distance from a line is convex and the
 * grid is a box), and dt = t_B - t_A. A turn about the scanner's axis leaves
 * the grid's extent along it out of r.
 * A C2 curve leaves its chord over a piece of length h by at most
 * h^2 max|o''| / 8, so n pieces (h = 1/n) keep every voxel within E when
 * n >= sqrt(D / (8 E)), D the bound above in voxels of the smallest size (a
 * distance of d mm is at most d / vmin voxels along any axis).
 *
 * Then the other way: a motion log at 30 Hz or more gives far more key poses
 * than a smooth motion needs (180 per 6 s frame, each one a walk per voxel).
 * Runs of consecutive segments are merged into one chord while the chord still
 * keeps every voxel within E of its true path at every time. For a merged run
 * from pose i to pose k, the true path differs from the chord by at most
 *     max over the inner poses m of |o_m - chord(t_m)|  (the old polyline
 *         against the chord: both are linear in time between those poses)
 *   + max over the run's pieces of h^2 D / 8             (the true path
 *         against the old polyline, as above),
 * and o_m - chord(t_m) is affine in the voxel's position, so its largest
 * length over the grid is at one of the grid's 8 corner voxel centres. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "path.h"


static double norm3(const double v[3])
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

/* The length of v across the unit axis k (all of it where k is NULL). */
static double across(const double v[3], const double *k)
{
    if (!k)
        return norm3(v);
    double along = v[0] * k[0] + v[1] * k[1] + v[2] * k[2];
    double w[3] = {v[0] - along * k[0], v[1] - along * k[1], v[2] - along * k[2]};
    return norm3(w);
}

/* The curvature bound D of one interval, in voxels (see above). */
static double path_curvature(const pb_geometry *g, const double center[3], const pb_pose *a, const pb_pose *b)
{
    const double *v = g->voxel_size;
    double vmin = fmin(v[0], fmin(v[1], v[2]));
    /* The turn's axis in tomograph space: that of q_B q_A^*, SLERP's rotation
     * R(s) = exp(s theta K) R_A (none where the poses do not turn). */
    double qa[4], rel[4], k[3];
    pb_quat_conj(a->rotation, qa);
    pb_quat_mul(b->rotation, qa, rel);
    double kn = norm3(&rel[1]);
    const double *axis = NULL;
    if (kn > 1e-12) {
        for (int i = 0; i < 3; i++)
            k[i] = rel[i + 1] / kn;
        axis = k;
    }
    double r = 0.0;
    for (int c = 0; c < 8; c++) {
        double d[3];
        for (int i = 0; i < 3; i++)
            d[i] = ((c >> i & 1) ? ((double)g->dims[i] - 0.5) * v[i] : 0.5 * v[i]) - center[i];
        r = fmax(r, across(d, axis));
    }
    double dt[3] = {b->translation[0] - a->translation[0], b->translation[1] - a->translation[1],
                    b->translation[2] - a->translation[2]};
    double theta = 2.0 * pb_quat_angle(a->rotation, b->rotation); /* the turn: twice SLERP's angle */
    double tmax = fmax(across(a->translation, axis), across(b->translation, axis));
    return (theta * theta * (r + tmax) + 2.0 * theta * across(dt, axis)) / vmin;
}

/* The equal pieces an interval of curvature bound D needs: n = ceil(sqrt(D / (8 E))). */
static size_t path_pieces(double curvature, double max_error)
{
    double n = ceil(sqrt(curvature / (8.0 * max_error)));
    return n < 1.0 ? 1 : (n > (double)PB_MAX_SEGMENTS ? (size_t)PB_MAX_SEGMENTS + 1 : (size_t)n);
}

/* The longest run merged into one chord. */
enum { PB_MAX_RUN = 256 };

/* Would one chord from key pose i to key pose e keep every voxel within E?
 * corner: every key pose's 8 corner voxel centres in object space (mm). */
static int chord_holds(const pb_path *plan, const double *corner, const double *dev, size_t i, size_t e,
                       double vmin, double max_error)
{
    double bend = 0.0, off = 0.0, span = plan->poses[e].time - plan->poses[i].time;
    for (size_t j = i; j < e; j++)
        bend = fmax(bend, dev[j]); /* the run's pieces against their own chords */
    for (size_t m = i + 1; m < e && bend + off <= max_error; m++) {
        double s = (plan->poses[m].time - plan->poses[i].time) / span;
        for (int c = 0; c < 8; c++) {
            const double *a = &corner[24 * i + 3 * c], *b = &corner[24 * e + 3 * c], *o = &corner[24 * m + 3 * c];
            double d[3] = {o[0] - (a[0] + s * (b[0] - a[0])), o[1] - (a[1] + s * (b[1] - a[1])),
                           o[2] - (a[2] + s * (b[2] - a[2]))};
            off = fmax(off, norm3(d) / vmin);
        }
    }
    return bend + off <= max_error;
}

/* Merges runs of the plan's segments into chords (see above); dev[j] bounds
 * how far segment j's true path leaves its own chord, in voxels. Returns 0
 * when out of memory (the plan is then unchanged).
 *
 * From each kept pose i the run grows by doubling while its chord holds, then
 * a binary search between the longest run that held and the shortest that did
 * not finds where to end it. A test costs the run's length, so a run of L
 * segments costs O(L log L) pose checks instead of the L^2 / 2 of growing it
 * one pose at a time, which for a 30 Hz log cost more than the blur it plans
 * (docs/performance.md, "Dynamic frames"). Every chord kept was
 * tested, so the bound holds whatever the search skips. */
static int merge_segments(pb_path *plan, const double *dev, double max_error)
{
    size_t n = plan->count;
    const double *v = plan->geometry.voxel_size;
    double vmin = fmin(v[0], fmin(v[1], v[2]));
    /* Every key pose's 8 corner voxel centres in object space (mm). */
    double *corner = malloc(n * 24 * sizeof *corner);
    if (!corner)
        return 0;
    for (size_t j = 0; j < n; j++)
        for (int c = 0; c < 8; c++) {
            double p[3];
            for (int i = 0; i < 3; i++)
                p[i] = ((c >> i & 1) ? ((double)plan->geometry.dims[i] - 0.5) : 0.5) * v[i];
            pb_pose_apply_inverse(&plan->poses[j].pose, plan->center, p, &corner[24 * j + 3 * c]);
        }
    size_t kept = 1, i = 0;
    while (i + 1 < n) {
        /* One segment always holds: its pieces were cut to E. */
        size_t limit = n - 1 - i < PB_MAX_RUN ? n - 1 : i + PB_MAX_RUN, good = i + 1, bad = limit + 1;
        for (size_t len = 2; good < limit && bad > limit; len *= 2) {
            size_t e = i + len < limit ? i + len : limit;
            if (chord_holds(plan, corner, dev, i, e, vmin, max_error))
                good = e;
            else
                bad = e;
        }
        while (bad <= limit && bad - good > 1) {
            size_t mid = good + (bad - good) / 2;
            if (chord_holds(plan, corner, dev, i, mid, vmin, max_error))
                good = mid;
            else
                bad = mid;
        }
        plan->poses[kept++] = plan->poses[good];
        i = good;
    }
    free(corner);
    plan->count = kept;
    return 1;
}

pb_status pb_path_split(struct pb_context *ctx, pb_path *plan, double max_error, int merge)
{
    size_t total = 0, intervals = plan->count - 1;
    size_t *pieces = malloc(intervals * sizeof *pieces);
    double *curvature = malloc(intervals * sizeof *curvature);
    if (!pieces || !curvature) {
        free(pieces);
        free(curvature);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory planning the path");
    }
    for (size_t j = 0; j < intervals; j++) {
        const pb_pose *a = &plan->poses[j].pose, *b = &plan->poses[j + 1].pose;
        curvature[j] = path_curvature(&plan->geometry, plan->center, a, b);
        pieces[j] = path_pieces(curvature[j], max_error);
        total += pieces[j];
    }
    if (total > PB_MAX_SEGMENTS) {
        free(pieces);
        free(curvature);
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT,
                        "max_path_error %g voxels would cut this motion into more than %d segments; raise it "
                        "(default %g)", max_error, (int)PB_MAX_SEGMENTS, PB_DEFAULT_MAX_PATH_ERROR);
    }
    pb_path_pose *poses = calloc(total + 1, sizeof *poses);
    double *dev = malloc(total * sizeof *dev);
    if (!poses || !dev) {
        free(pieces);
        free(curvature);
        free(poses);
        free(dev);
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu key poses", total + 1);
    }
    size_t k = 0;
    for (size_t j = 0; j < intervals; j++) {
        const pb_path_pose *a = &plan->poses[j], *b = &plan->poses[j + 1];
        double h = 1.0 / (double)pieces[j];
        for (size_t i = 0; i < pieces[j]; i++, k++) {
            double s = (double)i * h;
            poses[k].time = a->time + s * (b->time - a->time);
            /* The same LERP and SLERP as the motion's own interpolation, so the
             * new key poses lie on the true path. */
            pb_pose_interpolate(&a->pose, &b->pose, s, &poses[k].pose);
            dev[k] = h * h * curvature[j] / 8.0;
        }
    }
    poses[k] = plan->poses[intervals];
    free(plan->poses);
    free(pieces);
    free(curvature);
    plan->poses = poses;
    plan->count = total + 1;
    int merged = !merge || merge_segments(plan, dev, max_error);
    free(dev);
    return merged ? PB_OK : pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory merging the path's segments");
}
