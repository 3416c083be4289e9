/* Host maths shared by every backend: quaternions, poses, and the plan that turns
 * a frame's pose track into the key poses whose segments the methods walk.
 * Double precision throughout. The one internal header of the motion layer
 * (src/motion), in sections by the file that implements them. */
#ifndef PB_MOTION_H
#define PB_MOTION_H

#include "petblur.h"

struct pb_context;

/* ---- quaternion.c: quaternion and pose maths ----------------------------- */

/* 1 when none of v[0..n-1] is NaN or infinite. */
int pb_all_finite(const double *v, size_t n);

/* qsort's comparison of two doubles, ascending (motion_summary.c). */
int pb_compare_doubles(const void *a, const void *b);

/* Quaternions are w, x, y, z. */
void pb_quat_mul(const double a[4], const double b[4], double out[4]);
void pb_quat_conj(const double q[4], double out[4]);
double pb_quat_dot(const double a[4], const double b[4]);
/* The angle between two unit quaternions as 4-vectors (SLERP's angle; half the
 * rotation from a to b when they share a hemisphere), as 2 atan2(|a - b|,
 * |a + b|), which stays accurate for tiny angles where acos(a . b) does not. */
double pb_quat_angle(const double a[4], const double b[4]);
/* Shorter-arc SLERP: the result for s in [0, 1] runs from a to b (or -b). */
void pb_quat_slerp(const double a[4], const double b[4], double s, double out[4]);
/* Row-major 3x3 rotation matrix of a unit quaternion. */
void pb_quat_to_matrix(const double q[4], double r[9]);
void pb_quat_rotate(const double q[4], const double v[3], double out[3]);

/* A pose with its centre: p_tomo = R(q) (p_obj - c) + c + t. */
void pb_pose_apply_inverse(const pb_pose *pose, const double center[3], const double p[3], double out[3]);
/* For poses about one common centre, which cancels: (a o b)(p) = a(b(p)). */
void pb_pose_compose(const pb_pose *a, const pb_pose *b, pb_pose *out);
void pb_pose_invert(const pb_pose *pose, pb_pose *out);
/* LERP of translations, shorter-arc SLERP of rotations. */
void pb_pose_interpolate(const pb_pose *a, const pb_pose *b, double s, pb_pose *out);

/* The affine map from tomograph texel coordinates to object texel coordinates
 * (texel i's centre at i + 0.5) of a pose: u_obj = M[:, 0:3] u_tomo + M[:, 3],
 * row-major 3x4. */
void pb_pose_texel_map(const pb_pose *pose, const double center[3], const double voxel[3], double m[12]);
/* How far the grid's voxels (texel coordinates 0 to dims) move along object
 * axis `axis` from texel map a to texel map b, in object texels: the largest
 * over the grid's corners, where an affine change is largest. What a walk
 * between the two maps crosses along that axis. */
double pb_texel_map_walk(const double a[12], const double b[12], const size_t dims[3], int axis);

/* A copy of the pose with its quaternion scaled to unit norm. */
void pb_pose_normalized(const pb_pose *in, pb_pose *out);

/* ---- world.c: world coordinates ------------------------------------------ */

/* A voxel-to-world affine's direction matrix d (row-major, unit columns) and
 * the world position of the grid's corner, after checking that its columns
 * are perpendicular and as long as the voxels: world = d p + corner for p in
 * mm from the grid's corner. */
pb_status pb_affine_frame(const pb_geometry *g, const double a[16], double d[9], double corner[3]);

/* ---- motion_check.c: validation, and poses of a validated track ---------- */


/* Checks a motion: every problem gets its own status and a message (on ctx, or
 * the thread's when ctx is NULL) naming what to fix. */
pb_status pb_motion_validate(struct pb_context *ctx, const pb_motion *motion);

/* The pose of a validated motion at time t in [times[0], times[count-1]]. */
void pb_motion_interpolate(const pb_motion *motion, double t, pb_pose *pose);

/* ---- motion_frame.c: frames ----------------------------------------------- */

/* Frame bounds bounds[0..frames]: at least one frame, finite, increasing;
 * the one check of them that plans and the track checks share. */
pb_status pb_frame_bounds_check(struct pb_context *ctx, const double *bounds, size_t frames);
/* The last of n increasing samples x at or before v, by bisection; 0 where
 * none is (or v is NaN). Tracks, fields, surrogates and gates' intervals
 * find their samples with it. */
size_t pb_sample_before(const double *x, size_t n, double v);

/* ---- field_motion.c: motion from deformation fields ----------------------- */

/* Voxels of one field. */
size_t pb_field_voxels(const pb_field_motion *field);
/* Checks a field motion against the image grid: every problem its own
 * status and message. */
pb_status pb_field_validate(struct pb_context *ctx, const pb_geometry *geometry, const pb_field_motion *field);
/* Refuses a field that moves a voxel farther than twice the image grid's
 * diagonal (field_motion.c says why); after pb_field_validate, with the
 * image's geometry. */
pb_status pb_field_check_reach(struct pb_context *ctx, const pb_geometry *geometry, const pb_field_motion *field);
/* The field voxels an image voxel's reading can reach, per axis [lo, hi]:
 * with a map, the box of the image grid's corners (widened by `margin` image
 * voxels: REF's random points reach half a voxel past the centres) in field
 * voxels, one voxel wider for the trilinear reading; without one, the grids
 * are the same. */
void pb_field_reach_box(const pb_geometry *geometry, const pb_field_motion *field, double margin, size_t lo[3],
                        size_t hi[3]);
/* Checks that frame [t0, t1] lies inside a validated field motion's times. */
pb_status pb_field_frame_check(struct pb_context *ctx, const pb_field_motion *field, double t0, double t1);
/* The field at time t inside the motion's span: (1 - alpha) D_f0 + alpha
 * D_f1, through the surrogate where there is one (refused where it leaves
 * the fields' values). */
pb_status pb_field_locate(struct pb_context *ctx, const pb_field_motion *field, double t, size_t *f0, size_t *f1,
                          double *alpha);
/* One field (dims vectors of three floats) trilinearly at field voxel
 * coordinates q (voxel i's centre at i), held at its edge values beyond. */
void pb_field_sample(const float *field, const size_t dims[3], const double q[3], double out[3]);

/* ---- conventions.c and track_checks.c: a track made the patient's motion -- */

struct pb_track;
/* The warnings of a track's poses in the world (conventions applied): turns
 * between samples, poses far from rest, times that look like milliseconds. */
void pb_track_warn_poses(const struct pb_track *track, const pb_pose *world, pb_warnings *warnings);

#endif
