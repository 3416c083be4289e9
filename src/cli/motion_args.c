/* Motions from the command line: read, put into the grid frame, checked. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "motion_args.h"

/* A turn of more than this between two samples is taken the short way round by
 * SLERP, and no head turns that fast: a quaternion order slip looks like it. */
#define MAX_STEP_DEG 90.0
/* --rotate is followed in pieces of at most this, so SLERP takes the arc asked for. */
#define MAX_ARC_DEG 90.0
/* Interpolating across a longer run of missing samples would invent the motion. */
#define MAX_GAP_S 1.0
/* A frame or a track longer than this, in seconds, has its times in ms. */
#define MS_SUSPECT_S (6.0 * 3600.0)

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

static int matrix_to_pose(const double m[16], const double c[3], pb_pose *p)
{
    if (pb_pose_from_matrix(m, p) != PB_OK)
        return pbc_fail(PBC_EXIT_USAGE, "a composed pose is not rigid: %s", pb_last_error(NULL));
    for (int i = 0; i < 3; i++)
        p->translation[i] -= c[i] - (m[4 * i] * c[0] + m[4 * i + 1] * c[1] + m[4 * i + 2] * c[2]);
    return 0;
}

double pbc_turn_deg(const double a[4], const double b[4])
{
    double dot = fabs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]);
    double na = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] + a[3] * a[3]);
    double nb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2] + b[3] * b[3]);
    return 2.0 * acos(fmin(1.0, dot / (na * nb))) * 180.0 / 3.14159265358979323846;
}

void pbc_pose_move(const pb_pose *p, const double c[3], const double v[3], double out[3])
{
    double m[16];
    pb_pose_to_matrix(p, m);
    for (int i = 0; i < 3; i++)
        out[i] = c[i] + p->translation[i] + m[4 * i] * (v[0] - c[0]) + m[4 * i + 1] * (v[1] - c[1]) +
                 m[4 * i + 2] * (v[2] - c[2]);
}

/* ---- parsing --------------------------------------------------------------- */

static int read_calibration(const char *path, double m[16])
{
    FILE *f = fopen(path, "r");
    if (!f)
        return pbc_fail(PBC_EXIT_USAGE, "--calibration %s: cannot open it (%s); check the path", path, strerror(errno));
    char word[128];
    int n = 0, c, rc = 0;
    while (!rc && (c = fscanf(f, " %127[^ \t\r\n,;]%*[,;]", word)) == 1) {
        if (word[0] == '#') { /* a comment to the end of the line */
            fscanf(f, "%*[^\n]");
            continue;
        }
        if (n == 16 || pbc_plain_number(word, &m[n]) != 0)
            rc = pbc_fail(PBC_EXIT_USAGE, "--calibration %s: '%s' %s; give the 4x4 tracker-to-scanner matrix as 16 "
                          "numbers, row by row (mm)", path, word, n == 16 ? "is a 17th value" : "is not a number");
        n++;
    }
    fclose(f);
    if (!rc && n == 12) { /* a 3x4 matrix: the last row is implied */
        m[12] = m[13] = m[14] = 0.0;
        m[15] = 1.0;
    } else if (!rc && n != 16) {
        rc = pbc_fail(PBC_EXIT_USAGE, "--calibration %s: %d numbers; give the 4x4 tracker-to-scanner matrix as 16 "
                      "numbers (or its top 3x4 as 12), row by row", path, n);
    }
    pb_pose check;
    if (!rc && pb_pose_from_matrix(m, &check) != PB_OK)
        rc = pbc_fail(PBC_EXIT_USAGE, "--calibration %s: %s", path, pb_last_error(NULL));
    return rc;
}

static int parse_format(const char *text, pb_track_format *format)
{
    for (int i = PB_TRACK_CSV; i <= PB_TRACK_POLARIS; i++)
        if (!strcmp(text, pb_track_format_name((pb_track_format)i))) {
            *format = (pb_track_format)i;
            return 0;
        }
    return pbc_fail(PBC_EXIT_USAGE, "--motion-format %s: choose csv (t,tx,ty,tz,qw,qx,qy,qz), matrix-csv (t and a "
                    "3x4 matrix row by row, as yrt-pet writes) or polaris (NDI .mt or Toolviewer CSV)", text);
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

/* Room for n samples, their lines and missing counts zeroed. */
static int track_alloc(pbc_track *t, size_t n)
{
    t->times = malloc(n * sizeof *t->times);
    t->poses = malloc(n * sizeof *t->poses);
    t->lines = calloc(n, sizeof *t->lines);
    t->missing = calloc(n, sizeof *t->missing);
    if (!t->times || !t->poses || !t->lines || !t->missing)
        return pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the motion's %zu poses", n);
    t->count = n;
    return 0;
}

/* The library's reader, its message printed as it stands. */
static int track_read(const char *path, const pb_track_read_options *o, pbc_track *t)
{
    pb_track *file;
    pb_status st = pb_track_read(path, o, &file);
    if (st != PB_OK)
        return pbc_fail(st == PB_ERR_OUT_OF_MEMORY ? PBC_EXIT_RUNTIME : PBC_EXIT_USAGE, "%s", pb_last_error(NULL));
    size_t n = pb_track_count(file);
    int rc = track_alloc(t, n);
    if (!rc) {
        memcpy(t->times, pb_track_times(file), n * sizeof *t->times);
        memcpy(t->poses, pb_track_poses(file), n * sizeof *t->poses);
        memcpy(t->lines, pb_track_lines(file), n * sizeof *t->lines);
        memcpy(t->missing, pb_track_missing(file), n * sizeof *t->missing);
        t->format = pb_track_get_format(file);
    }
    pb_track_free(file);
    return rc;
}

static int motion_from_track(const pbc_command *cmd, const pbc_args *args, pbc_motion *m)
{
    pb_track_read_options o;
    const char *frame = pbc_arg(cmd, args, "--frame");
    int rc = track_options(cmd, args, &o);
    if (rc || (rc = track_read(m->source, &o, &m->track)))
        return rc;
    const pbc_track *t = &m->track;
    m->about_origin = t->format != PB_TRACK_CSV;
    double f[2] = {t->times[0], t->times[t->count - 1]};
    if (frame && (rc = pbc_parse_interval("--frame", frame, f)))
        return rc;
    if (f[0] < t->times[0] || f[1] > t->times[t->count - 1])
        return pbc_fail(PBC_EXIT_USAGE, "--frame %.9g,%.9g: the track %s covers %.9g to %.9g s only; choose a "
                        "frame inside it", f[0], f[1], m->source, t->times[0], t->times[t->count - 1]);
    m->motion = (pb_motion){t->times, t->poses, t->count, f[0], f[1], 0, {0, 0, 0}};
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
    if ((rc = track_alloc(&m->track, pieces + 1)))
        return rc;
    for (size_t i = 0; i <= pieces; i++) {
        double s = (double)i / (double)pieces;
        pb_pose p = {{s * t[0], s * t[1], s * t[2]}, {1, 0, 0, 0}};
        pb_quaternion_from_axis_angle(a, s * deg, p.rotation);
        m->track.times[i] = s;
        m->track.poses[i] = p;
    }
    m->track.format = PB_TRACK_CSV;
    m->motion = (pb_motion){m->track.times, m->track.poses, m->track.count, 0.0, 1.0, 0, {0, 0, 0}};
    return 0;
}

static int convention_args(const pbc_command *cmd, const pbc_args *args, pbc_motion *m)
{
    const char *cal = pbc_arg(cmd, args, "--calibration"), *ref = pbc_arg(cmd, args, "--reference-time"),
               *coords = pbc_arg(cmd, args, "--coords"), *center = pbc_arg(cmd, args, "--center");
    static const char *const coord_names[] = {"world", "grid"};
    int rc = 0;
    m->coords = -1;
    m->inverse = pbc_arg(cmd, args, "--motion-inverse") != NULL;
    if (coords && (rc = pbc_parse_choice("--coords", coords, coord_names, 2, &m->coords)))
        return rc;
    if (center && (rc = pbc_parse_vec3("--center", center, 0, m->center)))
        return rc;
    m->has_center = center != NULL;
    if (cal && !(rc = read_calibration(cal, m->calibration)))
        m->has_calibration = 1;
    if (!rc && ref && !(rc = pbc_parse_number("--reference-time", ref, &m->reference_time)))
        m->has_reference = 1;
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
                        "--motion TRACK");
    static const char *const track_only[] = {"--frame", "--motion-format", "--time-unit", "--quaternion-order",
                                             "--calibration", "--reference-time", "--motion-inverse"};
    for (size_t i = 0; !has_track && i < sizeof track_only / sizeof track_only[0]; i++)
        if (pbc_arg(cmd, args, track_only[i]))
            return pbc_fail(PBC_EXIT_USAGE, "%s applies to a --motion track; give --motion too", track_only[i]);
    int rc = convention_args(cmd, args, m);
    if (!rc)
        rc = has_track ? motion_from_track(cmd, args, m) : motion_from_pose(cmd, args, m);
    if (!has_track)
        m->source = "--translate/--rotate";
    if (!rc && m->about_origin && m->has_center)
        rc = pbc_fail(PBC_EXIT_USAGE, "--center: a %s track's poses are rigid maps about the world's origin, so "
                      "they carry their own centre; drop --center", pb_track_format_name(m->track.format));
    if (!rc && m->has_reference && (m->reference_time < m->track.times[0] ||
                                    m->reference_time > m->track.times[m->track.count - 1]))
        rc = pbc_fail(PBC_EXIT_USAGE, "--reference-time %.9g: the track %s covers %.9g to %.9g s; give a time inside "
                      "it", m->reference_time, m->source, m->track.times[0], m->track.times[m->track.count - 1]);
    if (rc)
        pbc_motion_free(m);
    return rc;
}

/* ---- placing --------------------------------------------------------------- */

/* The grid frame as a world of its own: voxel centres at (i + 0.5) d. */
static void grid_affine(const pbc_image *img, double a[16])
{
    memset(a, 0, 16 * sizeof *a);
    for (int i = 0; i < 3; i++) {
        a[5 * i] = img->voxel_size[i];
        a[4 * i + 3] = 0.5 * img->voxel_size[i];
    }
    a[15] = 1.0;
}

/* M(t) = C P(t) P(ref)^-1 C^-1, with P inverted first for --motion-inverse. */
static int apply_conventions(pbc_motion *m, const double c[3])
{
    pbc_track *t = &m->track;
    double ref[16], cal_inv[16], mt[16];
    int reference = m->has_reference || t->format == PB_TRACK_POLARIS;
    if (!m->inverse && !reference && !m->has_calibration)
        return 0;
    if (m->inverse)
        for (size_t i = 0; i < t->count; i++) {
            pose_to_matrix(&t->poses[i], c, mt);
            mat_rigid_inverse(mt, mt);
            int rc = matrix_to_pose(mt, c, &t->poses[i]);
            if (rc)
                return rc;
        }
    memset(ref, 0, sizeof ref);
    ref[0] = ref[5] = ref[10] = ref[15] = 1.0;
    if (reference) {
        double tr = m->has_reference ? m->reference_time : t->times[0];
        pb_motion whole = {t->times, t->poses, t->count, t->times[0], t->times[t->count - 1], 0, {0, 0, 0}};
        pb_pose p;
        if (pb_motion_pose_at(&whole, tr, &p) != PB_OK)
            return pbc_fail(PBC_EXIT_USAGE, "%s: %s", m->source, pb_last_error(NULL));
        pose_to_matrix(&p, c, ref);
        mat_rigid_inverse(ref, ref);
        if (!m->has_reference)
            fprintf(stderr, "petblur: warning: %s: no --reference-time; the motion is taken relative to the first "
                    "sample (%.9g s, line %zu)\n", m->source, tr, t->lines[0]);
    }
    if (!m->has_calibration) {
        memset(m->calibration, 0, sizeof m->calibration);
        m->calibration[0] = m->calibration[5] = m->calibration[10] = m->calibration[15] = 1.0;
    }
    mat_rigid_inverse(m->calibration, cal_inv);
    for (size_t i = 0; i < t->count; i++) {
        pose_to_matrix(&t->poses[i], c, mt);
        mat_mul(mt, ref, mt);
        mat_mul(m->calibration, mt, mt);
        mat_mul(mt, cal_inv, mt);
        int rc = matrix_to_pose(mt, c, &t->poses[i]);
        if (rc)
            return rc;
    }
    return 0;
}

/* Warns about samples that turn too far from the one before, and about times
 * that look like milliseconds. */
static void check_track(const pbc_motion *m)
{
    const pbc_track *t = &m->track;
    if (t->count < 2)
        return;
    for (size_t i = 1; i < t->count; i++) {
        double deg = pbc_turn_deg(m->grid[i - 1].rotation, m->grid[i].rotation);
        if (deg > MAX_STEP_DEG + 1e-6) { /* --rotate's own pieces are 90 degrees to rounding */
            fprintf(stderr, "petblur: warning: %s:%zu: the pose turns %.0f degrees from the one before (line %zu) "
                    "within %.3g s; a quaternion read in the wrong order (x,y,z,w as w,x,y,z) looks like this: check "
                    "--quaternion-order\n", m->source, t->lines[i], deg, t->lines[i - 1],
                    t->times[i] - t->times[i - 1]);
            break;
        }
    }
    double span = t->times[t->count - 1] - t->times[0];
    if (span > MS_SUSPECT_S && span / (double)(t->count - 1) >= 1.0)
        fprintf(stderr, "petblur: warning: %s: the track spans %.6g s (%.3g h) in samples %.3g s apart: are its "
                "times in milliseconds? then give --time-unit ms\n", m->source, span, span / 3600.0,
                span / (double)(t->count - 1));
}

int pbc_motion_place(pbc_motion *m, const pbc_image *img, const char *in_path)
{
    double affine[16];
    int placed = pbc_image_affine(img, affine);
    if (m->coords == 0 && !placed)
        return pbc_fail(PBC_EXIT_USAGE, "--coords world: %s carries no placement in the world (a .raw file, or a "
                        "NIfTI with sform and qform codes 0); give --coords grid, or an image with its affine",
                        in_path);
    if (m->coords == 1 || !placed)
        grid_affine(img, affine);
    pb_geometry g = {{img->dims[0], img->dims[1], img->dims[2]},
                     {img->voxel_size[0], img->voxel_size[1], img->voxel_size[2]}};
    /* The world centre the track's poses turn about: the origin for tracker
     * matrices, else --center or the grid's centre. */
    double c[3] = {0, 0, 0};
    for (int r = 0; r < 3; r++) {
        m->grid_center[r] = affine[4 * r + 3];
        for (int k = 0; k < 3; k++)
            m->grid_center[r] += affine[4 * r + k] * 0.5 * (double)(img->dims[k] - 1);
    }
    if (!m->about_origin)
        memcpy(c, m->has_center ? m->center : m->grid_center, sizeof c);
    memcpy(m->world_center, c, sizeof c);
    int rc = apply_conventions(m, c);
    if (rc)
        return rc;
    pb_motion world = m->motion;
    world.has_center = m->about_origin || m->has_center;
    memcpy(world.center, c, sizeof c);
    m->grid = malloc(m->track.count * sizeof *m->grid);
    if (!m->grid)
        return pbc_fail(PBC_EXIT_RUNTIME, "out of memory for the motion's %zu poses", m->track.count);
    pb_status st = pb_motion_world_to_grid(&g, affine, &world, m->grid, &m->motion);
    if (st == PB_ERR_AFFINE_SHEAR || st == PB_ERR_BAD_VOXEL_SIZE)
        return pbc_fail(PBC_EXIT_USAGE, "%s: %s; --coords grid takes the motion along the array's axes instead",
                        in_path, pb_last_error(NULL));
    if (st != PB_OK)
        return pbc_fail(PBC_EXIT_USAGE, "%s: %s", m->source, pb_last_error(NULL));
    if (!world.has_center) /* the grid's centre, exactly */
        m->motion.has_center = 0;
    check_track(m);
    return 0;
}

/* ---- frames ---------------------------------------------------------------- */

/* Whether the pose leaves any of the grid's box inside the grid: the box's
 * image under a rigid map lies inside the box around its eight corners. */
static int grid_seen(const pb_motion *mo, const pbc_image *img, const pb_pose *p)
{
    double inf = (double)INFINITY, ext[3], c[3], lo[3] = {inf, inf, inf}, hi[3] = {-inf, -inf, -inf};
    for (int i = 0; i < 3; i++) {
        ext[i] = (double)img->dims[i] * img->voxel_size[i];
        c[i] = mo->has_center ? mo->center[i] : 0.5 * ext[i];
    }
    for (int k = 0; k < 8; k++) {
        double v[3] = {(k & 1) ? ext[0] : 0, (k & 2) ? ext[1] : 0, (k & 4) ? ext[2] : 0}, w[3];
        pbc_pose_move(p, c, v, w);
        for (int i = 0; i < 3; i++) {
            lo[i] = fmin(lo[i], w[i]);
            hi[i] = fmax(hi[i], w[i]);
        }
    }
    for (int i = 0; i < 3; i++)
        if (hi[i] <= 0.0 || lo[i] >= ext[i])
            return 0;
    return 1;
}

/* Whether some pose between a and b (LERP of translations) may leave part of
 * the grid in view: the moved grid lies within rho of its moved centre
 * c + t(s), so it can meet the grid's box only while that ball's box does,
 * an interval of s per axis. Conservative: a refusal needs every segment out. */
static int segment_may_see(const pb_motion *mo, const pbc_image *img, const pb_pose *a, const pb_pose *b)
{
    double lo = 0.0, hi = 1.0, rho2 = 0.0;
    for (int i = 0; i < 3; i++) {
        double ext = (double)img->dims[i] * img->voxel_size[i], c = mo->has_center ? mo->center[i] : 0.5 * ext;
        rho2 += fmax(c * c, (ext - c) * (ext - c));
    }
    double rho = sqrt(rho2);
    for (int i = 0; i < 3 && lo <= hi; i++) {
        double ext = (double)img->dims[i] * img->voxel_size[i], c = mo->has_center ? mo->center[i] : 0.5 * ext;
        /* needs -rho <= c + t(s) <= ext + rho, with t(s) = ta + s (tb - ta) */
        double ta = a->translation[i], d = b->translation[i] - ta, low = -rho - c - ta, high = ext + rho - c - ta;
        if (d == 0.0) {
            if (low > 0.0 || high < 0.0)
                return 0;
        } else {
            double s1 = low / d, s2 = high / d;
            lo = fmax(lo, fmin(s1, s2));
            hi = fmin(hi, fmax(s1, s2));
        }
    }
    return lo <= hi;
}

/* The samples [*lo, *hi) whose times lie in (t0, t1], by bisection: frames
 * of a long log each cost their own samples. */
static void frame_samples(const pbc_track *t, double t0, double t1, size_t *lo, size_t *hi)
{
    size_t a = 0, b = t->count;
    while (a < b) {
        size_t mid = a + (b - a) / 2;
        if (t->times[mid] <= t0)
            a = mid + 1;
        else
            b = mid;
    }
    *lo = a;
    for (b = t->count; a < b;) {
        size_t mid = a + (b - a) / 2;
        if (t->times[mid] <= t1)
            a = mid + 1;
        else
            b = mid;
    }
    *hi = a;
}

pb_motion pbc_motion_part(const pbc_motion *m, double t0, double t1)
{
    size_t lo, hi;
    frame_samples(&m->track, t0, t1, &lo, &hi);
    size_t first = lo > 0 ? lo - 1 : 0, last = hi < m->track.count ? hi : m->track.count - 1;
    if (last <= first)
        last = first + 1 < m->track.count ? first + 1 : first, first = last - 1;
    pb_motion part = m->motion;
    part.times += first;
    part.poses += first;
    part.count = last - first + 1;
    part.frame_start = t0;
    part.frame_end = t1;
    return part;
}

void pbc_motion_check_frames(const pbc_motion *m, const double *bounds, size_t frames)
{
    const pbc_track *t = &m->track;
    double span = t->times[t->count - 1] - t->times[0], all = bounds[frames] - bounds[0], longest = 0.0;
    if (!strcmp(m->source, "--translate/--rotate"))
        return;
    for (size_t i = 0; i < frames; i++)
        longest = fmax(longest, bounds[i + 1] - bounds[i]);
    if (longest > MS_SUSPECT_S)
        fprintf(stderr, "petblur: warning: a frame lasts %.3g h: are the times in milliseconds? frames and tracks are "
                "in seconds (--time-unit ms reads a track in ms)\n", longest / 3600.0);
    else if (all < 1e-3 * span)
        fprintf(stderr, "petblur: warning: the frame%s %.9g to %.9g s span%s %.2g %% of the track %s (%.9g to %.9g "
                "s); are the frames and the track in the same time unit?\n", frames > 1 ? "s" : "", bounds[0],
                bounds[frames], frames > 1 ? "" : "s", 100.0 * all / span, m->source, t->times[0],
                t->times[t->count - 1]);
}

int pbc_motion_check_frame(const pbc_motion *m, const pbc_image *img, double t0, double t1)
{
    const pbc_track *t = &m->track;
    size_t lo, hi;
    frame_samples(t, t0, t1, &lo, &hi);
    /* Gaps that overlap the frame end at a sample in (t0, t1] or at the first after t1. */
    for (size_t i = lo > 0 ? lo : 1; i <= hi && i < t->count; i++)
        if (t->missing[i] && t->times[i] > t0 && t->times[i - 1] < t1 && t->times[i] - t->times[i - 1] > MAX_GAP_S)
            return pbc_fail(PBC_EXIT_USAGE, "%s:%zu-%zu: %zu missing samples leave a gap of %.3g s (%.9g to %.9g s) "
                            "inside the frame %.9g to %.9g s, longer than the %.3g s petblur interpolates across; "
                            "choose frames outside the gap", m->source, t->lines[i - 1], t->lines[i], t->missing[i],
                            t->times[i] - t->times[i - 1], t->times[i - 1], t->times[i], t0, t1, MAX_GAP_S);
    /* The frame's ends and every tracked pose inside it (taken as they are:
     * interpolating each would cost a pass over the track). */
    size_t seen = 0, poses = 0;
    int may_see = 0;
    pb_motion part = pbc_motion_part(m, t0, t1);
    pb_pose prev = {{0, 0, 0}, {1, 0, 0, 0}};
    for (size_t i = lo; i <= hi + 1; i++) {
        pb_pose p;
        if (i == lo || i == hi + 1) {
            if (pb_motion_pose_at(&part, i == lo ? t0 : t1, &p) != PB_OK)
                continue;
        } else if (t->times[i - 1] > t0 && t->times[i - 1] < t1) {
            p = m->motion.poses[i - 1];
        } else {
            continue;
        }
        if (poses++ > 0)
            may_see |= segment_may_see(&m->motion, img, &prev, &p);
        prev = p;
        seen += (size_t)grid_seen(&m->motion, img, &p);
    }
    if (poses > 1 && !may_see)
        return pbc_fail(PBC_EXIT_USAGE, "%s: the motion takes the whole grid out of the field of view for the whole "
                        "frame %.9g to %.9g s, so the blur would be zero; are the translations in mm, in the image's "
                        "coordinates (see --coords), and the times in seconds?", m->source, t0, t1);
    if (seen < poses)
        fprintf(stderr, "petblur: warning: %s: at %zu of the frame's %zu poses the grid lies wholly outside the "
                "field of view\n", m->source, poses - seen, poses);
    return 0;
}

void pbc_motion_free(pbc_motion *m)
{
    free(m->track.times);
    free(m->track.poses);
    free(m->track.lines);
    free(m->track.missing);
    free(m->grid);
    memset(&m->track, 0, sizeof m->track);
    m->grid = NULL;
}
