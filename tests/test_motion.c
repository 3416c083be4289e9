/* Quaternion, SLERP, pose and plan identities of the host maths (src/motion/quaternion.c,
 * src/paths/path_plan.c), on fresh random poses each run. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "path.h"
#include "testlib.h"

static pb_pose random_pose(void)
{
    double axis[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), pb_rand_range(-1, 1)};
    return pb_test_pose(pb_rand_range(-30, 30), pb_rand_range(-30, 30), pb_rand_range(-30, 30), axis,
                        pb_rand_range(-179, 179));
}

static double dist3(const double a[3], const double b[3])
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

/* Angle of the rotation taking a to b, in radians: 4 atan2(|a - b|, |a + b|)
 * with b on a's hemisphere, accurate for tiny angles where acos is not. */
static double quat_angle(const double a[4], const double b[4])
{
    double sign = pb_quat_dot(a, b) < 0.0 ? -1.0 : 1.0, dm = 0.0, dp = 0.0;
    for (int k = 0; k < 4; k++) {
        dm += (a[k] - sign * b[k]) * (a[k] - sign * b[k]);
        dp += (a[k] + sign * b[k]) * (a[k] + sign * b[k]);
    }
    return 4.0 * atan2(sqrt(dm), sqrt(dp));
}

static void test_quaternions(void)
{
    for (int i = 0; i < 200; i++) {
        pb_pose a = random_pose(), b = random_pose();
        double ab[4], conj[4], id[4];
        pb_quat_mul(a.rotation, b.rotation, ab);
        pb_check(fabs(sqrt(pb_quat_dot(ab, ab)) - 1.0) < 1e-12, "product of unit quaternions is unit");
        pb_quat_conj(a.rotation, conj);
        pb_quat_mul(a.rotation, conj, id);
        pb_check(fabs(id[0] - 1.0) < 1e-12 && fabs(id[1]) + fabs(id[2]) + fabs(id[3]) < 1e-12, "q q* = 1");
        /* Rotating by a product is rotating twice. */
        double v[3] = {pb_rand_range(-5, 5), pb_rand_range(-5, 5), pb_rand_range(-5, 5)}, r1[3], r2[3], r3[3];
        pb_quat_rotate(ab, v, r1);
        pb_quat_rotate(b.rotation, v, r2);
        pb_quat_rotate(a.rotation, r2, r3);
        pb_check(dist3(r1, r3) < 1e-12, "R(ab) v = R(a) R(b) v");
        pb_check(fabs(sqrt(r1[0] * r1[0] + r1[1] * r1[1] + r1[2] * r1[2]) -
                      sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])) < 1e-12,
                 "rotation keeps lengths");
    }
    /* Right-hand rule: +90 degrees about z takes x to y. */
    double z[3] = {0, 0, 1}, q[4], x[3] = {1, 0, 0}, y[3];
    pb_quaternion_from_axis_angle(z, 90.0, q);
    pb_quat_rotate(q, x, y);
    pb_check(fabs(y[0]) < 1e-15 && fabs(y[1] - 1.0) < 1e-15 && fabs(y[2]) < 1e-15, "+90 deg about z: x -> y");
}

static void test_slerp(void)
{
    for (int i = 0; i < 200; i++) {
        pb_pose a = random_pose(), b = random_pose();
        double q[4], neg[4];
        pb_quat_slerp(a.rotation, b.rotation, 0.0, q);
        pb_check(quat_angle(q, a.rotation) < 1e-7, "slerp(0) = a");
        pb_quat_slerp(a.rotation, b.rotation, 1.0, q);
        pb_check(quat_angle(q, b.rotation) < 1e-7, "slerp(1) = b");
        /* Constant angular speed: the angle from a grows linearly in s. */
        double total = quat_angle(a.rotation, b.rotation), s = pb_rand_uniform();
        pb_quat_slerp(a.rotation, b.rotation, s, q);
        pb_check(fabs(quat_angle(a.rotation, q) - s * total) < 1e-9 &&
                     fabs(quat_angle(q, b.rotation) - (1.0 - s) * total) < 1e-9,
                 "slerp at s = %.3f lies on the geodesic at s of its length (%.3g rad)", s, total);
        /* q and -q are one rotation: the shorter arc either way. */
        for (int k = 0; k < 4; k++)
            neg[k] = -b.rotation[k];
        double q2[4];
        pb_quat_slerp(a.rotation, neg, s, q2);
        pb_check(quat_angle(q, q2) < 1e-9, "slerp(a, -b) = slerp(a, b)");
        pb_check(total <= 3.14159265358979323846 + 1e-12, "shorter arc");
    }
}

static void test_poses(void)
{
    double c[3] = {pb_rand_range(0, 200), pb_rand_range(0, 200), pb_rand_range(0, 100)};
    for (int i = 0; i < 200; i++) {
        pb_pose a = random_pose(), b = random_pose(), ab, inv, id;
        double p[3] = {pb_rand_range(-50, 250), pb_rand_range(-50, 250), pb_rand_range(-50, 150)};
        double r1[3], r2[3], r3[3];
        pb_pose_compose(&a, &b, &ab);
        pb_pose_apply(&ab, c, p, r1);
        pb_pose_apply(&b, c, p, r2);
        pb_pose_apply(&a, c, r2, r3);
        pb_check(dist3(r1, r3) < 1e-9, "(a o b)(p) = a(b(p))");
        pb_pose_invert(&a, &inv);
        pb_pose_compose(&a, &inv, &id);
        pb_pose_apply(&id, c, p, r1);
        pb_check(dist3(r1, p) < 1e-9, "a o a^-1 = identity");
        pb_pose_apply(&a, c, p, r1);
        pb_pose_apply_inverse(&a, c, r1, r2);
        pb_check(dist3(r2, p) < 1e-9, "apply_inverse undoes apply");
        pb_pose_apply(&inv, c, r1, r2);
        pb_check(dist3(r2, p) < 1e-9, "invert agrees with apply_inverse");
        /* The centre is fixed by a pure rotation. */
        pb_pose rot = a;
        memset(rot.translation, 0, sizeof rot.translation);
        pb_pose_apply(&rot, c, c, r1);
        pb_check(dist3(r1, c) < 1e-9, "rotation centre stays put");
        /* The texel map is apply_inverse in texel units. */
        double vox[3] = {pb_rand_range(0.5, 3), pb_rand_range(0.5, 3), pb_rand_range(0.5, 3)}, m[12];
        pb_pose_texel_map(&a, c, vox, m);
        double u[3] = {p[0] / vox[0], p[1] / vox[1], p[2] / vox[2]}, o[3];
        for (int r = 0; r < 3; r++)
            o[r] = (m[4 * r] * u[0] + m[4 * r + 1] * u[1] + m[4 * r + 2] * u[2] + m[4 * r + 3]) * vox[r];
        pb_pose_apply_inverse(&a, c, p, r1);
        pb_check(dist3(o, r1) < 1e-9, "texel map = inverse pose in texel units");
    }
}

static void test_plan(void)
{
    pb_pose poses[5];
    double times[5] = {-1.0, 0.3, 0.9, 1.7, 4.0};
    for (int i = 0; i < 5; i++)
        poses[i] = random_pose();
    pb_motion m = {times, poses, 5, 0.1, 2.0, 0, {0, 0, 0}};
    pb_geometry g = {{20, 30, 10}, {2.0, 1.5, 3.0}};
    pb_blur_options opt = {PB_METHOD_REF, PB_FILTER_EXACT, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0, PB_AB_SAMPLING_DEFAULT, 0};
    pb_path plan;
    if (!pb_check(pb_path_create(NULL, &g, &m, &opt, &plan) == PB_OK, "plan: %s", pb_last_error(NULL)))
        return;
    pb_check(plan.count == 5, "key poses: frame start, 0.3, 0.9, 1.7, frame end (got %zu)", plan.count);
    double wsum = 0.0, rsum = 0.0;
    for (size_t j = 0; j < plan.count; j++)
        wsum += plan.poses[j].weight;
    for (size_t k = 0; k < plan.ref_count; k++)
        rsum += plan.ref_steps[k].weight;
    pb_check(fabs(wsum - 1.0) < 1e-12, "segment weights sum to 1 (%.15g)", wsum);
    pb_check(fabs(rsum - 1.0) < 1e-12, "reference step weights sum to 1 (%.15g)", rsum);
    pb_check(fabs(plan.poses[0].time - 0.1) < 1e-15 && fabs(plan.poses[4].time - 2.0) < 1e-15, "frame ends");
    pb_check(fabs(plan.center[0] - 20.0) < 1e-12 && fabs(plan.center[1] - 22.5) < 1e-12 &&
                 fabs(plan.center[2] - 15.0) < 1e-12,
             "default centre is the grid's centre");
    /* The start pose is the track's pose at 0.1, on the arc from pose 0 to pose 1. */
    pb_pose expect;
    pb_pose_interpolate(&poses[0], &poses[1], 1.1 / 1.3, &expect);
    pb_check(dist3(expect.translation, plan.poses[0].pose.translation) < 1e-12 &&
                 quat_angle(expect.rotation, plan.poses[0].pose.rotation) < 1e-7,
             "frame start interpolated in the track");
    for (size_t j = 1; j < plan.count; j++)
        pb_check(pb_quat_dot(plan.poses[j].pose.rotation, plan.poses[j - 1].pose.rotation) >= 0.0,
                 "key pose %zu on the previous one's hemisphere", j);
    pb_path_destroy(&plan);
}

/* grid mm -> world mm through a NIfTI-style affine (index at voxel centres). */
static void grid_to_world(const double a[16], const double vox[3], const double p[3], double w[3])
{
    double idx[3] = {p[0] / vox[0] - 0.5, p[1] / vox[1] - 0.5, p[2] / vox[2] - 0.5};
    for (int r = 0; r < 3; r++)
        w[r] = a[4 * r] * idx[0] + a[4 * r + 1] * idx[1] + a[4 * r + 2] * idx[2] + a[4 * r + 3];
}

/* pb_motion_world_to_grid: a world pose applied to a grid point's world
 * position must land where the grid pose takes the point, for rotated,
 * reflected and anisotropic affines; pose matrices round-trip; shears and
 * non-rigid pose matrices are refused with their own status. */
static void test_world(void)
{
    for (int trial = 0; trial < 100; trial++) {
        pb_pose dir = random_pose();
        double r[9], a[16] = {0}, vox[3] = {pb_rand_range(0.5, 4), pb_rand_range(0.5, 4), pb_rand_range(0.5, 4)};
        pb_quat_to_matrix(dir.rotation, r);
        int flip = trial % 3; /* 0: proper; 1, 2: one axis reflected (LAS-like) */
        for (int i = 0; i < 3; i++) {
            for (int j = 0; j < 3; j++)
                a[4 * i + j] = r[3 * i + j] * vox[j] * (flip && j == flip ? -1.0 : 1.0);
            a[4 * i + 3] = pb_rand_range(-200, 200);
        }
        a[15] = 1.0;
        pb_geometry g = {{40, 30, 20}, {vox[0], vox[1], vox[2]}};
        pb_pose wp[3] = {random_pose(), random_pose(), random_pose()}, gp[3];
        double times[3] = {0, 1, 2};
        pb_motion world = {times, wp, 3, 0.0, 2.0, trial % 2, {pb_rand_range(-100, 100), pb_rand_range(-100, 100),
                                                                pb_rand_range(-100, 100)}},
                  grid;
        if (!world.has_center) /* the grid's centre, in world mm */
            grid_to_world(a, vox, (double[3]){20 * vox[0], 15 * vox[1], 10 * vox[2]}, world.center);
        if (!pb_check(pb_motion_world_to_grid(&g, a, &world, gp, &grid) == PB_OK, "world to grid: %s",
                      pb_last_error(NULL)))
            continue;
        double gc[3] = {20 * vox[0], 15 * vox[1], 10 * vox[2]};
        const double *c = grid.has_center ? grid.center : gc;
        for (int k = 0; k < 3; k++) {
            double p[3] = {pb_rand_range(0, 40 * vox[0]), pb_rand_range(0, 30 * vox[1]), pb_rand_range(0, 20 * vox[2])};
            double moved[3], w[3], wmoved[3], expect[3];
            pb_pose_apply(&gp[k], c, p, moved);
            grid_to_world(a, vox, moved, expect);
            grid_to_world(a, vox, p, w);
            pb_pose_apply(&wp[k], world.center, w, wmoved);
            pb_check(dist3(wmoved, expect) < 1e-9, "trial %d pose %d: world pose = grid pose through the affine "
                     "(off %.3g mm)", trial, k, dist3(wmoved, expect));
        }
        double m[16];
        pb_pose back;
        pb_check(pb_pose_to_matrix(&wp[0], m) == PB_OK && pb_pose_from_matrix(m, &back) == PB_OK &&
                     dist3(back.translation, wp[0].translation) < 1e-12 && quat_angle(back.rotation, wp[0].rotation) < 1e-9,
                 "pose -> matrix -> pose");
    }
    pb_geometry g = {{4, 4, 4}, {1, 1, 1}};
    double shear[16] = {1, 0.1, 0, 0, 0, 0.99498743710662, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}, times[2] = {0, 1};
    pb_pose p[2] = {{{0, 0, 0}, {1, 0, 0, 0}}, {{1, 0, 0}, {1, 0, 0, 0}}}, out[2];
    pb_motion m = {times, p, 2, 0, 1, 0, {0, 0, 0}}, grid;
    pb_check(pb_motion_world_to_grid(&g, shear, &m, out, &grid) == PB_ERR_AFFINE_SHEAR, "a shear is refused");
    double scaled[16] = {2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    pb_check(pb_motion_world_to_grid(&g, scaled, &m, out, &grid) == PB_ERR_BAD_VOXEL_SIZE,
             "an affine whose voxels are not the geometry's is refused");
    double mirror[16] = {-1, 0, 0, 5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    pb_pose pose;
    pb_check(pb_pose_from_matrix(mirror, &pose) == PB_ERR_NOT_RIGID, "a reflection is no pose");
}

int main(void)
{
    pb_test_seed();
    test_quaternions();
    test_slerp();
    test_poses();
    test_plan();
    test_world();
    return pb_test_finish();
}
