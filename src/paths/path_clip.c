/* Walks clipped to the grid: the part of a segment during which no sample can
 * land in the object grid (widened by the samplers' reach) costs nothing.
 *
 * A tomograph voxel centre w in the grid box lies within rho of the rotation
 * centre c. Its object-space point on segment a-b at fraction s is
 *   chord (AB, RM):      c + ((1 - s) Ra^T + s Rb^T)(w - c) - ((1 - s) Ra^T ta + s Rb^T tb)
 *   pose (CL, REF):      c + R(s)^T (w - c) - R(s)^T ((1 - s) ta + s tb)
 * and in both the first term is at most rho long, so the point lies within rho
 * of c - tau(s), tau linear in s (chord) or of the length of one that is
 * (pose). It can reach the widened object box, itself within rho' of c, only
 * while |p + s q| <= rho + rho': an interval of s, from a quadratic. Outside
 * the hull of the two intervals every sample reads zero, so the segment is
 * cut to that hull and the rest is marked skipped; for motions that keep the
 * object in view the hull is the whole segment and nothing changes. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "path.h"

/* Where |p + s q| <= len within [0, 1]: lo > hi when nowhere. The
 * discriminant as |q|^2 len^2 - |p x q|^2 keeps its digits when p and q are
 * huge and nearly parallel. */
static void inside_interval(const double p_mm[3], const double q_mm[3], double len_mm, double *lo, double *hi)
{
    /* In units of the largest length, so that squares of 1e200 mm stay finite. */
    double unit = len_mm, p[3], q[3];
    for (int i = 0; i < 3; i++)
        unit = fmax(unit, fmax(fabs(p_mm[i]), fabs(q_mm[i])));
    for (int i = 0; i < 3; i++) {
        p[i] = p_mm[i] / unit;
        q[i] = q_mm[i] / unit;
    }
    double len = len_mm / unit;
    double qq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2], pq = p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
    double cx = p[1] * q[2] - p[2] * q[1], cy = p[2] * q[0] - p[0] * q[2], cz = p[0] * q[1] - p[1] * q[0];
    *lo = 1.0;
    *hi = 0.0;
    if (qq == 0.0) {
        if (p[0] * p[0] + p[1] * p[1] + p[2] * p[2] <= len * len)
            *lo = 0.0, *hi = 1.0;
        return;
    }
    double disc = qq * len * len - (cx * cx + cy * cy + cz * cz);
    if (disc < 0.0)
        return;
    double root = sqrt(disc);
    *lo = fmax(0.0, (-pq - root) / qq);
    *hi = fmin(1.0, (-pq + root) / qq);
}

static double corner_reach(const pb_path *plan, double margin)
{
    double r2 = 0.0;
    for (int k = 0; k < 8; k++) {
        double d2 = 0.0;
        for (int i = 0; i < 3; i++) {
            double e = (double)plan->geometry.dims[i] * plan->geometry.voxel_size[i];
            double x = ((k >> i) & 1 ? e + margin : -margin) - plan->center[i];
            d2 += x * x;
        }
        r2 = fmax(r2, d2);
    }
    return sqrt(r2);
}

/* The part [lo, hi] of segment a-b whose samples can read the object. */
static void segment_reach(const pb_pose *a, const pb_pose *b, double len, double *lo, double *hi)
{
    double qa[4], qb[4], pa[3], pb[3], p[3], q[3], l2, h2;
    pb_quat_conj(a->rotation, qa);
    pb_quat_conj(b->rotation, qb);
    pb_quat_rotate(qa, a->translation, pa);
    pb_quat_rotate(qb, b->translation, pb);
    for (int i = 0; i < 3; i++) {
        p[i] = pa[i];
        q[i] = pb[i] - pa[i];
    }
    inside_interval(p, q, len, lo, hi);
    for (int i = 0; i < 3; i++) {
        p[i] = a->translation[i];
        q[i] = b->translation[i] - a->translation[i];
    }
    inside_interval(p, q, len, &l2, &h2);
    if (l2 <= h2) {
        int first = *lo <= *hi;
        *lo = first ? fmin(*lo, l2) : l2;
        *hi = first ? fmax(*hi, h2) : h2;
    }
}

pb_status pb_path_clip(struct pb_context *ctx, pb_path *plan)
{
    const double *v = plan->geometry.voxel_size;
    /* Trilinear reads reach a voxel past a point, AB's slice samples one more. */
    double margin = 2.0 * fmax(v[0], fmax(v[1], v[2]));
    double len = corner_reach(plan, 0.0) + corner_reach(plan, margin);
    size_t n = plan->count, cut = 0;
    for (size_t j = 0; j + 1 < n; j++) {
        double lo, hi;
        segment_reach(&plan->poses[j].pose, &plan->poses[j + 1].pose, len, &lo, &hi);
        cut += !(lo <= 0.0 && hi >= 1.0);
    }
    if (cut == 0)
        return PB_OK;
    /* Each cut segment becomes at most a skipped lead-in, the part walked and a
     * skipped tail. */
    pb_path_pose *out = calloc(n + 2 * cut, sizeof *out);
    if (!out)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory clipping %zu segments", n - 1);
    size_t k = 0;
    for (size_t j = 0; j + 1 < n; j++) {
        const pb_path_pose *a = &plan->poses[j], *b = &plan->poses[j + 1];
        double lo, hi;
        segment_reach(&a->pose, &b->pose, len, &lo, &hi);
        out[k] = *a;
        if (lo <= 0.0 && hi >= 1.0) {
            k++;
            continue;
        }
        if (!(lo <= hi)) { /* nothing of the object is in view over the whole segment */
            out[k++].skip = 1;
            continue;
        }
        if (lo > 0.0) {
            out[k++].skip = 1;
            out[k].time = a->time + lo * (b->time - a->time);
            pb_pose_interpolate(&a->pose, &b->pose, lo, &out[k].pose);
        }
        if (hi < 1.0) {
            k++;
            out[k].time = a->time + hi * (b->time - a->time);
            pb_pose_interpolate(&a->pose, &b->pose, hi, &out[k].pose);
            out[k].skip = 1;
        }
        k++;
    }
    out[k++] = plan->poses[n - 1];
    free(plan->poses);
    plan->poses = out;
    plan->count = k;
    return PB_OK;
}
