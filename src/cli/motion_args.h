/* Motions from the command line, in the scanner's world coordinates or the
 * grid's, from --translate/--rotate or from a tracker's log, with the checks
 * that catch a motion that cannot be what was meant. */
#ifndef PBC_MOTION_ARGS_H
#define PBC_MOTION_ARGS_H

#include "image_io.h"
#include "options.h"
#include "petblur.h"

/* The option rows every command that takes a motion shares: the poses
 * --translate/--rotate make, the track file (--motion) and the conventions
 * of both (PBC_TRACK_OPTIONS). A command that takes the track as its
 * argument lists PBC_TRACK_OPTIONS and --motion with no help
 * (pbc_print_help leaves it out). */
#define PBC_MOTION_OPTIONS                                                                                            \
    {"--translate", NULL, "TX,TY,TZ", "translation at the frame's end, mm (world axes; see --coords)"},               \
    {"--rotate", NULL, "DEG", "rotation at the frame's end, degrees, right-hand rule about --axis; beyond 180 the "  \
                              "arc asked for is followed"},                                                           \
    {"--axis", NULL, "AX,AY,AZ", "rotation axis (default 0,0,1: world z, the scanner axis)"},                        \
    {"--motion", NULL, "TRACK", "pose track: csv (t,tx,ty,tz,qw,qx,qy,qz), matrix-csv or a Polaris log"},           \
    PBC_TRACK_OPTIONS

#define PBC_TRACK_OPTIONS                                                                                             \
    {"--center", NULL, "CX,CY,CZ", "rotation centre of --rotate and csv tracks, world mm (grid mm with --coords " \
                                   "grid; default the grid's centre)"},                                           \
    {"--coords", NULL, "world|grid", "world (default where the input has a placement: NIfTI sform/qform, "           \
                                     "Interfile): RAS+ mm; grid (.raw): mm from the grid's corner along its axes"},   \
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

/* A motion as the command line gives it: the track (a file's, or the poses
 * --translate/--rotate make) and the conventions, both the library's
 * (petblur.h, "the motion layer"); this file only parses and prints. */
typedef struct pbc_motion {
    pb_track *track;
    pb_track_conventions conventions;
    const char *source; /* the track's path, or "--translate/--rotate" */
    int coords;         /* -1: told by the input; 0: world; 1: grid */
    int has_frame;
    double frame[2];    /* --frame, else the whole track */
    /* Once placed: */
    pb_geometry geometry;
    double affine[16];  /* the grid's voxel-to-world affine, or the grid frame's (--coords grid, .raw) */
    pb_pose *grid;      /* the poses in the grid frame */
    pb_motion motion;   /* in the grid frame, over the frame */
} pbc_motion;

/* Parses the motion options and reads the track; the motion is placed once
 * the input is read. Returns 0 or an exit status after the message. */
int pbc_motion_from_args(const pbc_command *cmd, const pbc_args *args, pbc_motion *m);

/* Puts the motion into img's grid frame (world coordinates through the image's
 * affine, or the grid's own), printing the library's warnings. */
int pbc_motion_place(pbc_motion *m, const pbc_image *img, const char *in_path);

/* Checks frames bounds[0..frames] (NULL: the motion's frame) of a placed
 * motion: the library's refusals and warnings. With refuse 0 a grid out of
 * view is a warning (petblur motion shows a track a blur would refuse). */
int pbc_motion_check_frames(const pbc_motion *m, const double *bounds, size_t frames, int refuse);

/* Prints a library call's warnings, one "petblur: warning:" line each. */
void pbc_print_warnings(const pb_warnings *w);

void pbc_motion_free(pbc_motion *m);

#endif
