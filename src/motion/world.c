/* Poses as rigid matrices, and motions from the scanner's world frame into the
 * grid frame that the blur walks. */
#include <math.h>
#include <string.h>

#include "error.h"
#include "motion.h"

/* Matrices from files and trackers carry 6-9 significant digits. */
#define PB_RIGID_TOLERANCE 1e-4

/* Largest |(A^T A - I)_ij| of a 3x3 (row-major) matrix: how far its columns
 * are from orthonormal. */
static double orthonormal_error(const double a[9])
{
    double worst = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double dot = a[i] * a[j] + a[3 + i] * a[3 + j] + a[6 + i] * a[6 + j];
            worst = fmax(worst, fabs(dot - (i == j)));
        }
    return worst;
}

static double det3(const double a[9])
{
    return a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) +
           a[2] * (a[3] * a[7] - a[4] * a[6]);
}

/* Shepperd's method: the largest of 4w^2, 4x^2, 4y^2, 4z^2 is taken from the
 * diagonal and the others from off-diagonal sums, so no square root of a
 * small difference loses digits. */
static void rotation_to_quaternion(const double r[9], double q[4])
{
    double tr = r[0] + r[4] + r[8];
    if (tr >= r[0] && tr >= r[4] && tr >= r[8]) {
        double s = 2.0 * sqrt(1.0 + tr);
        q[0] = 0.25 * s;
        q[1] = (r[7] - r[5]) / s;
        q[2] = (r[2] - r[6]) / s;
        q[3] = (r[3] - r[1]) / s;
    } else if (r[0] >= r[4] && r[0] >= r[8]) {
        double s = 2.0 * sqrt(1.0 + r[0] - r[4] - r[8]);
        q[0] = (r[7] - r[5]) / s;
        q[1] = 0.25 * s;
        q[2] = (r[1] + r[3]) / s;
        q[3] = (r[2] + r[6]) / s;
    } else if (r[4] >= r[8]) {
        double s = 2.0 * sqrt(1.0 + r[4] - r[0] - r[8]);
        q[0] = (r[2] - r[6]) / s;
        q[1] = (r[1] + r[3]) / s;
        q[2] = 0.25 * s;
        q[3] = (r[5] + r[7]) / s;
    } else {
        double s = 2.0 * sqrt(1.0 + r[8] - r[0] - r[4]);
        q[0] = (r[3] - r[1]) / s;
        q[1] = (r[2] + r[6]) / s;
        q[2] = (r[5] + r[7]) / s;
        q[3] = 0.25 * s;
    }
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    double sign = q[0] < 0.0 ? -1.0 : 1.0;
    for (int i = 0; i < 4; i++)
        q[i] *= sign / n;
}

pb_status pb_pose_from_matrix(const double m[16], pb_pose *pose)
{
    if (!m || !pose)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "matrix and pose must not be NULL");
    if (!pb_all_finite(m, 16))
        return pb_error(NULL, PB_ERR_NOT_FINITE, "the pose matrix holds NaN or infinity; give finite numbers");
    if (fabs(m[12]) > PB_RIGID_TOLERANCE || fabs(m[13]) > PB_RIGID_TOLERANCE || fabs(m[14]) > PB_RIGID_TOLERANCE ||
        fabs(m[15] - 1.0) > PB_RIGID_TOLERANCE)
        return pb_error(NULL, PB_ERR_NOT_RIGID, "the pose matrix's last row is (%g, %g, %g, %g), not (0, 0, 0, 1)",
                        m[12], m[13], m[14], m[15]);
    double r[9] = {m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]};
    double err = orthonormal_error(r), det = det3(r);
    if (err > PB_RIGID_TOLERANCE || det < 0.0)
        return pb_error(NULL, PB_ERR_NOT_RIGID,
                        "the pose matrix's 3x3 part is not a rotation (columns off orthonormal by %.3g, determinant "
                        "%.6g); give a rotation and a translation in mm, without scaling, shear or reflection",
                        err, det);
    rotation_to_quaternion(r, pose->rotation);
    for (int i = 0; i < 3; i++)
        pose->translation[i] = m[4 * i + 3];
    return PB_OK;
}

pb_status pb_pose_to_matrix(const pb_pose *pose, double m[16])
{
    if (!pose || !m)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "pose and matrix must not be NULL");
    double r[9], q[4], n = sqrt(pb_quat_dot(pose->rotation, pose->rotation));
    if (!pb_all_finite(pose->rotation, 4) || !pb_all_finite(pose->translation, 3))
        return pb_error(NULL, PB_ERR_NOT_FINITE, "the pose holds NaN or infinity; give finite numbers");
    if (fabs(n - 1.0) > 1e-3)
        return pb_error(NULL, PB_ERR_BAD_QUATERNION, "the pose's quaternion has norm %.6g; give a unit quaternion", n);
    for (int i = 0; i < 4; i++)
        q[i] = pose->rotation[i] / n;
    pb_quat_to_matrix(q, r);
    for (int i = 0; i < 3; i++) {
        memcpy(m + 4 * i, r + 3 * i, 3 * sizeof(double));
        m[4 * i + 3] = pose->translation[i];
    }
    m[12] = m[13] = m[14] = 0.0;
    m[15] = 1.0;
    return PB_OK;
}

/* The affine's direction matrix (row-major) and the world position of the
 * grid's corner, after checking that its columns are perpendicular and as long
 * as the voxels. */
pb_status pb_affine_frame(const pb_geometry *g, const double a[16], double d[9], double corner[3])
{
    if (!pb_all_finite(a, 16))
        return pb_error(NULL, PB_ERR_NOT_FINITE, "the voxel-to-world affine holds NaN or infinity");
    for (int c = 0; c < 3; c++) {
        double len = sqrt(a[c] * a[c] + a[4 + c] * a[4 + c] + a[8 + c] * a[8 + c]);
        if (!(len > 0.0))
            return pb_error(NULL, PB_ERR_AFFINE_SHEAR,
                            "column %d of the voxel-to-world affine is zero: the affine is singular", c + 1);
        if (fabs(len - g->voxel_size[c]) > PB_RIGID_TOLERANCE * g->voxel_size[c])
            return pb_error(NULL, PB_ERR_BAD_VOXEL_SIZE,
                            "column %d of the voxel-to-world affine is %.9g mm long but the voxels are %.9g mm along "
                            "that axis; give the geometry the affine's voxel sizes",
                            c + 1, len, g->voxel_size[c]);
        for (int r = 0; r < 3; r++)
            d[3 * r + c] = a[4 * r + c] / len;
    }
    double err = orthonormal_error(d);
    if (err > PB_RIGID_TOLERANCE)
        return pb_error(NULL, PB_ERR_AFFINE_SHEAR,
                        "the voxel-to-world affine's axes are not perpendicular (off by %.3g): a shear, which a rigid "
                        "motion cannot be carried through; resample the image onto a grid without shear first",
                        err);
    if (fabs(a[12]) > 1e-9 || fabs(a[13]) > 1e-9 || fabs(a[14]) > 1e-9 || fabs(a[15] - 1.0) > 1e-9)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the voxel-to-world affine's last row is not 0 0 0 1");
    /* Voxel (0, 0, 0)'s centre is at a[.,3]; the corner lies half a voxel back. */
    for (int r = 0; r < 3; r++) {
        corner[r] = a[4 * r + 3];
        for (int c = 0; c < 3; c++)
            corner[r] -= 0.5 * a[4 * r + c];
    }
    return PB_OK;
}

static void transpose_times(const double d[9], const double v[3], double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = d[i] * v[0] + d[3 + i] * v[1] + d[6 + i] * v[2];
}

pb_status pb_motion_world_to_grid(const pb_geometry *geometry, const double affine[16], const pb_motion *world,
                                  pb_pose *grid_poses, pb_motion *grid)
{
    if (!geometry || !affine || !world || !grid_poses || !grid)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "geometry, affine, motion, poses and grid must not be NULL");
    pb_status st = pb_motion_validate(NULL, world);
    if (st != PB_OK)
        return st;
    for (int i = 0; i < 3; i++)
        if (!(geometry->voxel_size[i] > 0.0) || !isfinite(geometry->voxel_size[i]))
            return pb_error(NULL, PB_ERR_BAD_VOXEL_SIZE, "voxel size %d is %g mm; give a positive finite size", i,
                            geometry->voxel_size[i]);
    double d[9], corner[3];
    if ((st = pb_affine_frame(geometry, affine, d, corner)) != PB_OK)
        return st;
    /* A quaternion's vector part is an axis, a pseudovector: in the grid's
     * axes it is det(D) D^T v, so a reflected frame turns the other way. */
    double handed = det3(d) < 0.0 ? -1.0 : 1.0;
    for (size_t k = 0; k < world->count; k++) {
        const pb_pose *w = &world->poses[k];
        pb_pose *p = &grid_poses[k];
        p->rotation[0] = w->rotation[0];
        transpose_times(d, w->rotation + 1, p->rotation + 1);
        for (int i = 1; i < 4; i++)
            p->rotation[i] *= handed;
        transpose_times(d, w->translation, p->translation);
    }
    *grid = *world;
    grid->poses = grid_poses;
    if (world->has_center) {
        double rel[3] = {world->center[0] - corner[0], world->center[1] - corner[1], world->center[2] - corner[2]};
        transpose_times(d, rel, grid->center);
    }
    return PB_OK;
}
