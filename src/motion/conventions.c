/* A track made the patient's motion: the tracker's conventions applied once,
 * M(t) = C P(t) P(ref)^-1 C^-1, in the world, then into a grid's frame. The
 * command line and the Python package both stand on this file, so a track
 * means the same motion to both. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "motion.h"
#include "track.h"

/* ---- 4x4 rigid matrices, row-major --------------------------------------- */

static void mat_mul(const double a[16], const double b[16], double out[16])
{
    double r[16];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            r[4 * i + j] = a[4 * i] * b[j] + a[4 * i + 1] * b[4 + j] + a[4 * i + 2] * b[8 + j] + a[4 * i + 3] * b[12 + j];
    memcpy(out, r, sizeof r);
}

static void mat_rigid_inverse(const double m[16], double out[16])
{
    double r[16] = {0};
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            r[4 * i + j] = m[4 * j + i];
        r[4 * i + 3] = -(m[i] * m[3] + m[4 + i] * m[7] + m[8 + i] * m[11]);
    }
    r[15] = 1.0;
    memcpy(out, r, sizeof r);
}

/* A pose about centre c (p' = R (p - c) + c + t) as a matrix about the origin. */
static void pose_to_matrix(const pb_pose *p, const double c[3], double m[16])
{
    pb_pose_to_matrix(p, m);
    for (int i = 0; i < 3; i++)
        m[4 * i + 3] += c[i] - (m[4 * i] * c[0] + m[4 * i + 1] * c[1] + m[4 * i + 2] * c[2]);
}

static pb_status matrix_to_pose(const pb_track *t, const double m[16], const double c[3], pb_pose *p)
{
    if (pb_pose_from_matrix(m, p) != PB_OK)
        return pb_error_prefix(PB_ERR_NOT_RIGID, "%s: a composed pose is not rigid: ", t->source);
    for (int i = 0; i < 3; i++)
        p->translation[i] -= c[i] - (m[4 * i] * c[0] + m[4 * i + 1] * c[1] + m[4 * i + 2] * c[2]);
    return PB_OK;
}

static const double identity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

pb_status pb_geometry_grid_affine(const pb_geometry *g, double a[16])
{
    if (!g || !a)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "geometry and affine must not be NULL");
    memcpy(a, identity, sizeof identity);
    for (int i = 0; i < 3; i++) {
        a[5 * i] = g->voxel_size[i];
        a[4 * i + 3] = 0.5 * g->voxel_size[i];
    }
    return PB_OK;
}

/* The world centre the track's poses turn about: the origin for tracker
 * matrices, else the conventions' centre or the grid's. */
static pb_status world_center(const pb_track *t, const pb_track_conventions *cv, const pb_geometry *g,
                              const double affine[16], double c[3])
{
    memset(c, 0, 3 * sizeof *c);
    if (t->format != PB_TRACK_CSV) {
        if (cv->has_center)
            return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "--center: a %s track's poses are rigid maps about the "
                            "world's origin, so they carry their own centre; drop --center",
                            pb_track_format_name(t->format));
        return PB_OK;
    }
    if (cv->has_center) {
        if (!pb_all_finite(cv->center, 3))
            return pb_error(NULL, PB_ERR_NOT_FINITE, "--center holds NaN or infinity; give world mm");
        memcpy(c, cv->center, 3 * sizeof *c);
        return PB_OK;
    }
    if (!g) { /* no grid: poses about its centre, wherever it lies, unless a convention needs the point */
        if (cv->inverse || cv->has_reference_time || cv->has_calibration)
            return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "%s turns about the grid's centre, which its conventions "
                            "need: give the grid (geometry), or the rotation centre (--center)", t->source);
        return PB_OK;
    }
    double a[16];
    if (!affine)
        pb_geometry_grid_affine(g, a);
    else
        memcpy(a, affine, sizeof a);
    for (int r = 0; r < 3; r++) {
        c[r] = a[4 * r + 3];
        for (int k = 0; k < 3; k++)
            c[r] += a[4 * r + k] * 0.5 * ((double)g->dims[k] - 1.0);
    }
    return pb_all_finite(c, 3) ? PB_OK
                               : pb_error(NULL, PB_ERR_NOT_FINITE, "the voxel-to-world affine holds NaN or infinity");
}

/* M(t) = C P(t) P(ref)^-1 C^-1, with P inverted first for inverse. */
static pb_status apply_conventions(const pb_track *t, const pb_track_conventions *cv, const double c[3],
                                   pb_pose *out, pb_warnings *w)
{
    double ref[16], cal[16], cal_inv[16], mt[16];
    int reference = cv->has_reference_time || t->format == PB_TRACK_POLARIS;
    memcpy(out, t->poses, t->count * sizeof *out);
    if (!cv->inverse && !reference && !cv->has_calibration)
        return PB_OK;
    pb_status st = PB_OK;
    if (cv->has_calibration) {
        pb_pose check;
        if (pb_pose_from_matrix(cv->calibration, &check) != PB_OK)
            return pb_error_prefix(PB_ERR_NOT_RIGID, "the calibration: ");
    }
    if (cv->inverse)
        for (size_t i = 0; i < t->count && st == PB_OK; i++) {
            pose_to_matrix(&out[i], c, mt);
            mat_rigid_inverse(mt, mt);
            st = matrix_to_pose(t, mt, c, &out[i]);
        }
    memcpy(ref, identity, sizeof ref);
    if (st == PB_OK && reference) {
        double tr = cv->has_reference_time ? cv->reference_time : t->times[0];
        if (!(tr >= t->times[0] && tr <= t->times[t->count - 1]))
            return pb_error(NULL, PB_ERR_TRACK_GAP, "--reference-time %.9g: the track %s covers %.9g to %.9g s; give "
                            "a time inside it", tr, t->source, t->times[0], t->times[t->count - 1]);
        pb_motion whole = {t->times, out, t->count, t->times[0], t->times[t->count - 1], 0, {0, 0, 0}};
        pb_pose p;
        pb_motion_interpolate(&whole, tr, &p);
        pose_to_matrix(&p, c, ref);
        mat_rigid_inverse(ref, ref);
        if (!cv->has_reference_time)
            pb_warn(w, PB_WARN_REFERENCE, "%s: no --reference-time; the motion is taken relative to the first "
                    "sample (%.9g s, line %zu)", t->source, tr, t->lines[0]);
    }
    memcpy(cal, cv->has_calibration ? cv->calibration : identity, sizeof cal);
    mat_rigid_inverse(cal, cal_inv);
    for (size_t i = 0; i < t->count && st == PB_OK; i++) {
        pose_to_matrix(&out[i], c, mt);
        mat_mul(mt, ref, mt);
        mat_mul(cal, mt, mt);
        mat_mul(mt, cal_inv, mt);
        st = matrix_to_pose(t, mt, c, &out[i]);
    }
    return st;
}

pb_status pb_track_world(const pb_track *track, const pb_track_conventions *conventions, const pb_geometry *geometry,
                         const double affine[16], pb_pose *world_poses, pb_motion *world, pb_warnings *warnings)
{
    if (!track || !world_poses || !world)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "track, world_poses and world must not be NULL");
    pb_track_conventions none;
    memset(&none, 0, sizeof none);
    const pb_track_conventions *cv = conventions ? conventions : &none;
    if (cv->has_reference_time && !isfinite(cv->reference_time))
        return pb_error(NULL, PB_ERR_NOT_FINITE, "--reference-time is %g; give a time in seconds",
                        cv->reference_time);
    if (cv->has_calibration && !pb_all_finite(cv->calibration, 16))
        return pb_error(NULL, PB_ERR_NOT_FINITE, "the calibration holds NaN or infinity");
    double c[3];
    pb_status st = world_center(track, cv, geometry, affine, c);
    if (st == PB_OK)
        st = apply_conventions(track, cv, c, world_poses, warnings);
    if (st != PB_OK)
        return st;
    /* Without a grid a csv track's centre stays the grid's, unknown here. */
    int has_center = geometry || track->format != PB_TRACK_CSV || cv->has_center;
    *world = (pb_motion){track->times, world_poses, track->count, track->times[0], track->times[track->count - 1],
                         has_center, {c[0], c[1], c[2]}};
    pb_track_warn_poses(track, world_poses, warnings);
    return PB_OK;
}

pb_status pb_track_place(const pb_track *track, const pb_track_conventions *conventions, const pb_geometry *geometry,
                         const double affine[16], pb_pose *grid_poses, pb_motion *grid, pb_warnings *warnings)
{
    if (!track || !geometry || !grid_poses || !grid)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "track, geometry, grid_poses and grid must not be NULL");
    double a[16];
    if (!affine)
        pb_geometry_grid_affine(geometry, a);
    else
        memcpy(a, affine, sizeof a);
    pb_pose *poses = malloc(track->count * sizeof *poses);
    if (!poses)
        return pb_error(NULL, PB_ERR_OUT_OF_MEMORY, "out of memory for the %zu poses of %s", track->count,
                        track->source);
    pb_motion world;
    pb_status st = pb_track_world(track, conventions, geometry, a, poses, &world, warnings);
    if (st == PB_OK)
        st = pb_motion_world_to_grid(geometry, a, &world, grid_poses, grid);
    /* About the grid's centre: exactly, not its centre carried through the affine. */
    if (st == PB_OK && track->format == PB_TRACK_CSV && !(conventions && conventions->has_center))
        grid->has_center = 0;
    free(poses);
    return st;
}
