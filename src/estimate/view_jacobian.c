/* The derivative of a still pose's view in the pose's six perturbations,
 * from the view itself. A pose held still over a frame views the reference
 * at P(y) = R^T (y - c - t) + c, one exact trilinear read a voxel; under
 * pb_pose_perturb's G(xi) the view is x(G(P(y))), whose derivative is
 * grad x(P(y)) . dG/dxi: the gradient for the shifts, (P(y) - c) x gradient
 * for the turns. And grad x(P(y)) = R^T grad_y view(y), so the view's own
 * central differences, turned into the object's axes, give what the blurs
 * of the reference's six derivative images gave (pb_blur_pose_derivative)
 * without those six blurs and downloads a step, which were most of a
 * registration's time. Under a shift alone the two are one arithmetic (a
 * trilinear read commutes with a whole-voxel difference); under a turn they
 * differ by the differences' directions, within the discretisation of
 * either (tests/test_pose_derivative.c measures it). */
#include <string.h>

#include "estimate.h"

void pbe_view_jacobian_init(pbe_view_jacobian *J, const pb_geometry *g, const float *view, const pb_pose *pose,
                            const double c[3])
{
    double m[16];
    memset(J, 0, sizeof *J);
    pb_pose_to_matrix(pose, m);
    J->view = view;
    for (int a = 0; a < 3; a++) {
        J->dims[a] = g->dims[a];
        J->voxel[a] = g->voxel_size[a];
        for (int b = 0; b < 3; b++)
            J->rows[a][b] = m[a * 4 + b];
    }
    J->step[0] = 1;
    J->step[1] = g->dims[0];
    J->step[2] = g->dims[0] * g->dims[1];
    /* P(y) - c = R^T (y - c - t): row a of R carries the tomograph's axis a */
    for (int b = 0; b < 3; b++) {
        J->origin[b] = 0.0;
        for (int a = 0; a < 3; a++)
            J->origin[b] += m[a * 4 + b] * (0.5 * g->voxel_size[a] - c[a] - pose->translation[a]);
    }
}

void pbe_view_jacobian_at(const pbe_view_jacobian *J, size_t at, double out[6])
{
    const size_t idx[3] = {at % J->dims[0], at / J->dims[0] % J->dims[1], at / J->step[2]};
    const float *v = J->view;
    double r[3], gp[3] = {0.0, 0.0, 0.0};
    memcpy(r, J->origin, sizeof r);
    for (int a = 0; a < 3; a++) {
        /* central differences, one-sided on the grid's faces */
        const int lo = idx[a] > 0, hi = idx[a] + 1 < J->dims[a];
        double gy = 0.0;
        if (lo || hi)
            gy = ((double)v[hi ? at + J->step[a] : at] - (double)v[lo ? at - J->step[a] : at]) /
                 ((double)(lo + hi) * J->voxel[a]);
        const double along = (double)idx[a] * J->voxel[a];
        for (int b = 0; b < 3; b++) {
            gp[b] += J->rows[a][b] * gy;
            r[b] += J->rows[a][b] * along;
        }
    }
    out[0] = gp[0];
    out[1] = gp[1];
    out[2] = gp[2];
    out[3] = r[1] * gp[2] - r[2] * gp[1];
    out[4] = r[2] * gp[0] - r[0] * gp[2];
    out[5] = r[0] * gp[1] - r[1] * gp[0];
}
