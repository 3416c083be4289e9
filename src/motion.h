/* Host maths shared by every backend: quaternions, poses, and the plan that turns
 * a frame's pose track into the key poses whose segments the methods walk.
 * Double precision throughout; no backend knows how a plan was made. The one
 * internal header of quaternion.c, motion_check.c, path_plan.c, path_split.c
 * and path_clip.c, in sections by the file that implements them. */
#ifndef PB_MOTION_H
#define PB_MOTION_H

#include "petblur.h"

struct pb_context;

/* ---- quaternion.c: quaternion and pose maths ----------------------------- */

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
void pb_pose_apply(const pb_pose *pose, const double center[3], const double p[3], double out[3]);
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

/* A copy of the pose with its quaternion scaled to unit norm. */
void pb_pose_normalized(const pb_pose *in, pb_pose *out);

/* ---- motion_check.c: validation, and poses of a validated track ---------- */

/* 1 when none of v[0..n-1] is NaN or infinite. */
int pb_all_finite(const double *v, size_t n);

/* Checks a motion: every problem gets its own status and a message (on ctx, or
 * the thread's when ctx is NULL) naming what to fix. */
pb_status pb_motion_validate(struct pb_context *ctx, const pb_motion *motion);

/* The pose of a validated motion at time t in [times[0], times[count-1]]. */
void pb_motion_interpolate(const pb_motion *motion, double t, pb_pose *pose);

/* ---- path_plan.c: the plan ----------------------------------------------- */

/* One key pose of a plan. */
typedef struct pb_path_pose {
    double time;
    pb_pose pose;      /* unit quaternion on the same hemisphere as the previous key pose */
    double map[12];    /* pb_pose_texel_map of the pose */
    double weight;     /* fraction of the frame spent on the segment to the next key pose; 0 when skipped */
    int skip;          /* the segment to the next key pose reads nothing of the object: not walked */
} pb_path_pose;

/* One REF time step: where it is, and its share of the frame. */
typedef struct pb_path_step {
    double map[12];
    double weight;
} pb_path_step;

typedef struct pb_path {
    pb_geometry geometry;
    double center[3];        /* mm */
    size_t count;            /* key poses: frame start, tracked poses inside, frame end */
    pb_path_pose *poses;
    size_t ref_count;        /* REF time steps over the whole frame (0 unless REF) */
    pb_path_step *ref_steps;
} pb_path;

/* Validates the motion and options and builds the plan. */
pb_status pb_path_create(struct pb_context *ctx, const pb_geometry *geometry, const pb_motion *motion,
                         const pb_blur_options *options, pb_path *plan);
void pb_path_destroy(pb_path *plan);

/* The most segments one blur may walk; far above what any sane bound needs (a
 * full turn at 0.01 voxels on a 512^3 grid takes about 6000). */
enum { PB_MAX_SEGMENTS = 100000 };

/* Error-bounded polylines (path_split.c): the plan with every interval cut
 * into the equal pieces that keep each voxel centre within max_error voxels of
 * its chord, then runs of pieces merged into chords within the same bound
 * (maps and weights still to fill). */
pb_status pb_path_split(struct pb_context *ctx, pb_path *plan, double max_error);

/* Walks clipped to the grid (path_clip.c): each segment cut to the part of it
 * during which a sample can land in the object grid, the rest marked skip,
 * so that a blur's cost is bounded by the grid whatever the motion. */
pb_status pb_path_clip(struct pb_context *ctx, pb_path *plan);

#endif
