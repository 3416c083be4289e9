/* Motions from the command line, in the scanner's world coordinates or the
 * grid's, from --translate/--rotate or from a tracker's log, with the checks
 * that catch a motion that cannot be what was meant. */
#ifndef PBC_MOTION_ARGS_H
#define PBC_MOTION_ARGS_H

#include "image_io.h"
#include "options.h"
#include "petblur.h"

/* The option rows every command that takes a motion shares. */
#define PBC_MOTION_OPTIONS                                                                                            \
    {"--translate", NULL, "TX,TY,TZ", "translation at the frame's end, mm (world axes; see --coords)"},               \
    {"--rotate", NULL, "DEG", "rotation at the frame's end, degrees, right-hand rule about --axis; beyond 180 the "  \
                              "arc asked for is followed"},                                                           \
    {"--axis", NULL, "AX,AY,AZ", "rotation axis (default 0,0,1: world z, the scanner axis)"},                        \
    {"--center", NULL, "CX,CY,CZ", "rotation centre of --rotate and csv tracks, world mm (grid mm with --coords " \
                                   "grid; default the grid's centre)"},                                                                        \
    {"--coords", NULL, "world|grid", "world (default where the input has a placement: NIfTI sform/qform, "           \
                                     "Interfile): RAS+ mm; grid (.raw): mm from the grid's corner along its axes"},   \
    {"--motion", NULL, "TRACK", "pose track: csv (t,tx,ty,tz,qw,qx,qy,qz), matrix-csv or a Polaris log"},           \
    {"--motion-format", NULL, "FMT", "csv, matrix-csv (t,r00,r01,r02,tx,...,tz; yrt-pet) or polaris (.mt, "          \
                                     "Toolviewer CSV); default: told from the content"},                             \
    {"--time-unit", NULL, "s|ms", "the track's time unit (csv, matrix-csv; default s)"},                             \
    {"--quaternion-order", NULL, "wxyz|xyzw", "order of a csv track's numbered quaternion columns q0..q3 (default "  \
                                              "wxyz)"},                                                               \
    {"--calibration", NULL, "FILE", "4x4 tracker-to-scanner matrix, text, row by row: M(t) = C P(t) P(ref)^-1 C^-1"}, \
    {"--reference-time", NULL, "T", "when the image's pose was taken, s; the motion is relative to it (Polaris "     \
                                    "default: the first sample)"},                                                   \
    {"--motion-inverse", NULL, NULL, "the track's poses map scanner to object (yrt-pet's matrices): invert them"},   \
    {"--frame", NULL, "T0,T1", "the frame inside the track, seconds (default the whole track)"}

/* The track a motion is made of: a file's, as pb_track_read read it, or the
 * poses --translate/--rotate make. Its own copy, since the conventions
 * rewrite the poses in place. */
typedef struct pbc_track {
    double *times;   /* seconds, strictly increasing */
    pb_pose *poses;  /* csv: about the motion's centre; the other formats: 4x4 maps about the origin */
    size_t *lines;   /* each pose's line in the file (0 for --translate/--rotate) */
    size_t *missing; /* missing samples skipped just before each pose */
    size_t count;
    pb_track_format format;
} pbc_track;

typedef struct pbc_motion {
    pb_motion motion;  /* in the grid frame once placed */
    pbc_track track;   /* the track as read, or the poses --translate/--rotate make */
    pb_pose *grid;     /* the poses in the grid frame */
    const char *source; /* the track's path, or "--translate/--rotate" */
    int about_origin;  /* poses map about the world's origin (tracker formats) */
    int has_center;
    double center[3];  /* --center */
    int coords;        /* -1: told by the input; 0: world; 1: grid */
    int has_calibration, has_reference, inverse;
    double calibration[16], reference_time;
    /* Once placed: the track's poses turn about world_center, and the grid's
     * centre lies at grid_center (world mm; the grid frame's with --coords grid). */
    double world_center[3], grid_center[3];
} pbc_motion;

/* Parses the motion options and reads the track; the motion is placed once
 * the input is read. Returns 0 or an exit status after the message. */
int pbc_motion_from_args(const pbc_command *cmd, const pbc_args *args, pbc_motion *m);

/* Puts the motion into img's grid frame: world coordinates through the image's
 * affine, or the grid's own; applies the tracker conventions and warns about
 * poses that turn more than 90 degrees between samples or times that look like
 * milliseconds. */
int pbc_motion_place(pbc_motion *m, const pbc_image *img, const char *in_path);

/* Warns once when the frames (bounds[0..frames]) of a track look like
 * milliseconds, or span almost none of the track together. */
void pbc_motion_check_frames(const pbc_motion *m, const double *bounds, size_t frames);

/* Checks a frame [t0, t1] of a placed motion: a gap of missing samples inside
 * it, a motion that takes the whole grid out of the field of view (refusals),
 * or out of it at some poses (a warning). */
int pbc_motion_check_frame(const pbc_motion *m, const pbc_image *img, double t0, double t1);

/* The placed motion's samples that frame [t0, t1] needs (the one before it to
 * the one after), found by bisection, with the frame set: a frame of a long log
 * costs its own samples. */
pb_motion pbc_motion_part(const pbc_motion *m, double t0, double t1);

/* The angle in degrees of the turn between two poses' quaternions. */
double pbc_turn_deg(const double a[4], const double b[4]);
/* Where a pose about centre c takes point v: c + t + R (v - c). */
void pbc_pose_move(const pb_pose *p, const double c[3], const double v[3], double out[3]);

void pbc_motion_free(pbc_motion *m);

#endif
