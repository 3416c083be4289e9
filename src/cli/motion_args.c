/* Motions from the command line: options parsed into the library's track and
 * conventions, and the library's messages and warnings printed. The motion's
 * maths, its checks and its frames live in the library (src/motion). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "motion_args.h"

/* --rotate is followed in pieces of at most this, so SLERP takes the arc asked for. */
#define MAX_ARC_DEG 90.0

/* A library call's failure, its message printed as it stands. */
static int library_fail(pb_status st, const char *prefix)
{
    return pbc_fail(st == PB_ERR_OUT_OF_MEMORY ? PBC_EXIT_RUNTIME : PBC_EXIT_USAGE, "%s%s", prefix,
                    pb_last_error(NULL));
}

void pbc_print_warnings(const pb_warnings *w)
{
    for (const char *s = w->text; *s;) {
        const char *end = strchr(s, '\n');
        int n = end ? (int)(end - s) : (int)strlen(s);
        fprintf(stderr, "petblur: warning: %.*s\n", n, s);
        s += n + (end != NULL);
    }
}

static int parse_format(const char *text, pb_track_format *format)
{
    return pb_track_format_parse(text, format) == PB_OK ? 0 : pbc_refused_name("--motion-format");
}

static int track_options(const pbc_command *cmd, const pbc_args *args, pb_track_read_options *o)
{
    static const char *const units[] = {"s", "ms"}, *const orders[] = {"wxyz", "xyzw"};
    const char *v;
    int idx, rc = 0;
    o->format = PB_TRACK_AUTO;
    o->time_divisor = 1.0;
    o->xyzw = 0;
    if ((v = pbc_arg(cmd, args, "--motion-format")) && (rc = parse_format(v, &o->format)))
        return rc;
    if ((v = pbc_arg(cmd, args, "--time-unit"))) {
        if ((rc = pbc_parse_choice("--time-unit", v, units, 2, &idx)))
            return rc;
        o->time_divisor = idx ? 1000.0 : 1.0;
    }
    if ((v = pbc_arg(cmd, args, "--quaternion-order"))) {
        if ((rc = pbc_parse_choice("--quaternion-order", v, orders, 2, &idx)))
            return rc;
        o->xyzw = idx;
    }
    return 0;
}

static int motion_from_track(const pbc_command *cmd, const pbc_args *args, pbc_motion *m)
{
    pb_track_read_options o;
    const char *frame = pbc_arg(cmd, args, "--frame");
    int rc = track_options(cmd, args, &o);
    if (rc)
        return rc;
    pb_status st = pb_track_read(m->source, &o, &m->track);
    if (st != PB_OK)
        return library_fail(st, "");
    if (frame && (rc = pbc_parse_interval("--frame", frame, m->frame)))
        return rc;
    m->has_frame = frame != NULL;
    return 0;
}

/* The frame runs from the identity to the pose asked for, along the arc asked
 * for: a turn beyond 90 degrees is cut into tracked pieces, since SLERP
 * between two poses takes the shorter way (270 degrees would be -90). */
static int motion_from_pose(const pbc_command *cmd, const pbc_args *args, pbc_motion *m)
{
    const char *tr = pbc_arg(cmd, args, "--translate"), *rot = pbc_arg(cmd, args, "--rotate"),
               *axis = pbc_arg(cmd, args, "--axis");
    double t[3] = {0, 0, 0}, a[3] = {0, 0, 1}, deg = 0.0;
    int rc = 0;
    if ((tr && (rc = pbc_parse_vec3("--translate", tr, 0, t))) || (rot && (rc = pbc_parse_number("--rotate", rot, &deg))) ||
        (axis && (rc = pbc_parse_vec3("--axis", axis, 0, a))))
        return rc;
    if (axis && !rot)
        return pbc_fail(PBC_EXIT_USAGE, "--axis without --rotate turns nothing; add --rotate DEG");
    if (a[0] == 0.0 && a[1] == 0.0 && a[2] == 0.0)
        return pbc_fail(PBC_EXIT_USAGE, "--axis %s: the rotation axis must not be zero; e.g. 0,0,1 (z, the scanner "
                        "axis)", axis);
    if (fabs(deg) > 3600.0)
        return pbc_fail(PBC_EXIT_USAGE, "--rotate %s: more than ten turns within one frame; give the angle in "
                        "degrees", rot);
    size_t pieces = (size_t)fmax(1.0, ceil(fabs(deg) / MAX_ARC_DEG - 1e-12));
    double *times = malloc((pieces + 1) * sizeof *times);
    pb_pose *poses = malloc((pieces + 1) * sizeof *poses);
    pb_status st = times && poses ? PB_OK : PB_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; st == PB_OK && i <= pieces; i++) {
        double s = (double)i / (double)pieces;
        poses[i] = (pb_pose){{s * t[0], s * t[1], s * t[2]}, {1, 0, 0, 0}};
        pb_quaternion_from_axis_angle(a, s * deg, poses[i].rotation);
        times[i] = s;
    }
    if (st == PB_OK)
        st = pb_track_create(m->source, PB_TRACK_CSV, times, poses, NULL, NULL, pieces + 1, &m->track);
    free(times);
    free(poses);
    if (st == PB_ERR_OUT_OF_MEMORY && !m->track)
        return pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the motion's %zu poses", pieces + 1);
    return st == PB_OK ? 0 : library_fail(st, "");
}

static int convention_args(const pbc_command *cmd, const pbc_args *args, pbc_motion *m)
{
    const char *cal = pbc_arg(cmd, args, "--calibration"), *ref = pbc_arg(cmd, args, "--reference-time"),
               *coords = pbc_arg(cmd, args, "--coords"), *center = pbc_arg(cmd, args, "--center");
    static const char *const coord_names[] = {"world", "grid"};
    pb_track_conventions *cv = &m->conventions;
    int rc = 0;
    m->coords = -1;
    cv->inverse = pbc_arg(cmd, args, "--motion-inverse") != NULL;
    if (coords && (rc = pbc_parse_choice("--coords", coords, coord_names, 2, &m->coords)))
        return rc;
    if (center && (rc = pbc_parse_vec3("--center", center, 0, cv->center)))
        return rc;
    cv->has_center = center != NULL;
    if (cal) {
        pb_status st = pb_calibration_read(cal, cv->calibration);
        if (st != PB_OK)
            return library_fail(st, "--calibration ");
        cv->has_calibration = 1;
    }
    if (ref && !(rc = pbc_parse_number("--reference-time", ref, &cv->reference_time)))
        cv->has_reference_time = 1;
    return rc;
}

int pbc_motion_from_args(const pbc_command *cmd, const pbc_args *args, pbc_motion *m)
{
    memset(m, 0, sizeof *m);
    m->source = pbc_arg(cmd, args, "--motion");
    int has_track = m->source != NULL;
    int has_pose = pbc_arg(cmd, args, "--translate") || pbc_arg(cmd, args, "--rotate");
    if (has_track && has_pose)
        return pbc_fail(PBC_EXIT_USAGE, "give either --motion TRACK or --translate/--rotate, not both");
    if (!has_track && !has_pose)
        return pbc_fail(PBC_EXIT_USAGE, "no motion given; use --translate TX,TY,TZ and/or --rotate DEG, or "
                        "--motion TRACK (or --fields TABLE.csv for non-rigid motion)");
    static const char *const track_only[] = {"--frame", "--motion-format", "--time-unit", "--quaternion-order",
                                             "--calibration", "--reference-time", "--motion-inverse"};
    for (size_t i = 0; !has_track && i < sizeof track_only / sizeof track_only[0]; i++)
        if (pbc_arg(cmd, args, track_only[i]))
            return pbc_fail(PBC_EXIT_USAGE, "%s applies to a --motion track; give --motion too", track_only[i]);
    if (!has_track)
        m->source = "--translate/--rotate";
    int rc = convention_args(cmd, args, m);
    if (!rc)
        rc = has_track ? motion_from_track(cmd, args, m) : motion_from_pose(cmd, args, m);
    if (rc)
        pbc_motion_free(m);
    return rc;
}

int pbc_motion_place(pbc_motion *m, const pbc_image *img, const char *in_path)
{
    int placed = pbc_image_affine(img, m->affine);
    if (m->coords == 0 && !placed)
        return pbc_fail(PBC_EXIT_USAGE, "--coords world: %s carries no placement in the world (a .raw file, or a "
                        "NIfTI with sform and qform codes 0); give --coords grid, or an image with its affine",
                        in_path);
    m->geometry = (pb_geometry){{img->dims[0], img->dims[1], img->dims[2]},
                                {img->voxel_size[0], img->voxel_size[1], img->voxel_size[2]}};
    if (m->coords == 1 || !placed)
        pb_geometry_grid_affine(&m->geometry, m->affine);
    size_t n = pb_track_count(m->track);
    m->grid = malloc(n * sizeof *m->grid);
    if (!m->grid)
        return pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the motion's %zu poses", n);
    pb_warnings w = {0, ""};
    pb_status st = pb_track_place(m->track, &m->conventions, &m->geometry, m->affine, m->grid, &m->motion, &w);
    pbc_print_warnings(&w);
    if (st == PB_ERR_AFFINE_SHEAR || st == PB_ERR_BAD_VOXEL_SIZE)
        return pbc_fail(PBC_EXIT_USAGE, "%s: %s; --coords grid takes the motion along the array's axes instead",
                        in_path, pb_last_error(NULL));
    if (st != PB_OK)
        return library_fail(st, "");
    if (m->has_frame) {
        m->motion.frame_start = m->frame[0];
        m->motion.frame_end = m->frame[1];
    }
    return 0;
}

int pbc_motion_check_frames(const pbc_motion *m, const double *bounds, size_t frames, int refuse)
{
    double whole[2] = {m->motion.frame_start, m->motion.frame_end};
    pb_warnings w = {0, ""};
    pb_status st = pb_track_check_frames(m->track, &m->motion, &m->geometry, bounds ? bounds : whole,
                                         bounds ? frames : 1, &w);
    pbc_print_warnings(&w);
    if (st == PB_OK)
        return 0;
    if (!refuse && st == PB_ERR_OUT_OF_VIEW) {
        fprintf(stderr, "petblur: warning: %s\n", pb_last_error(NULL));
        return 0;
    }
    return library_fail(st, "");
}

void pbc_motion_free(pbc_motion *m)
{
    pb_track_free(m->track);
    free(m->grid);
    m->track = NULL;
    m->grid = NULL;
}
