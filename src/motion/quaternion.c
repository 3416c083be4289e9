/* Quaternion and pose maths: products, SLERP, rotation matrices, applying,
 * composing, inverting and interpolating poses about a centre, and the texel
 * maps the kernels read. Pure double-precision functions with no error paths
 * of their own (bar the public axis-angle constructor), shared by validation
 * (motion_check.c), planning (path_plan.c, path_split.c, path_clip.c) and the
 * tests. */
#include "motion.h"

#include <math.h>
#include <string.h>

#include "error.h"

#define PB_PI 3.14159265358979323846

int pb_all_finite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

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

double pb_texel_map_walk(const double a[12], const double b[12], const size_t dims[3], int axis)
{
    double most = 0.0;
    for (int corner = 0; corner < 8; corner++) {
        double d = b[4 * axis + 3] - a[4 * axis + 3];
        for (int i = 0; i < 3; i++)
            d += (b[4 * axis + i] - a[4 * axis + i]) * ((corner >> i) & 1 ? (double)dims[i] : 0.0);
        if (isnan(d) || fabs(d) > most) /* a NaN, once in, stays */
            most = fabs(d);
    }
    return most;
}

void pb_pose_normalized(const pb_pose *in, pb_pose *out)
{
    *out = *in;
    quat_normalize(in->rotation, out->rotation);
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

double pb_pose_turn_deg(const pb_pose *a, const pb_pose *b)
{
    const double *p = a->rotation, *r = b->rotation;
    double dot = fabs(p[0] * r[0] + p[1] * r[1] + p[2] * r[2] + p[3] * r[3]);
    double na = sqrt(pb_quat_dot(p, p)), nb = sqrt(pb_quat_dot(r, r));
    return 2.0 * acos(fmin(1.0, dot / (na * nb))) * 180.0 / 3.14159265358979323846;
}

pb_status pb_pose_perturb(const pb_pose *pose, const double xi[6], pb_pose *out)
{
    if (!pose || !xi || !out)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "pose, xi and out must not be NULL");
    if (!pb_all_finite(xi, 6) || !pb_all_finite(pose->translation, 3) || !pb_all_finite(pose->rotation, 4))
        return pb_error(NULL, PB_ERR_NOT_FINITE, "the pose or xi holds NaN or infinity");
    pb_pose g, gi;
    double angle = sqrt(xi[3] * xi[3] + xi[4] * xi[4] + xi[5] * xi[5]);
    memcpy(g.translation, xi, sizeof g.translation);
    g.rotation[0] = cos(0.5 * angle);
    for (int i = 0; i < 3; i++)
        g.rotation[i + 1] = angle > 0 ? sin(0.5 * angle) / angle * xi[3 + i] : 0.0;
    pb_pose_invert(&g, &gi);
    pb_pose_compose(pose, &gi, out);
    pb_pose_normalized(out, out);
    return PB_OK;
}
