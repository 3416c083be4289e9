/* Pose tracks from motion logs, in the formats trackers and toolkits write:
 *  - csv: petblur's own, t,tx,ty,tz,qw,qx,qy,qz (s, mm, unit quaternion), columns
 *    found by name in its header;
 *  - matrix-csv: t and a 3x4 rigid matrix row by row (r00,r01,r02,tx,r10,...,tz),
 *    as yrt-pet writes it (header optional; a 14th column, yrt-pet's error, is
 *    ignored);
 *  - polaris: NDI Polaris logs in both layouts STIR reads (.mt records
 *    "time rand tool q0 qx qy qz tx ty tz rms", and the NDI Toolviewer CSV
 *    "Frame,Q0,Qx,Qy,Qz,x,y,z,Error,OOV" on a 60 Hz frame clock), missing
 *    samples skipped.
 * Every message names the file and line. */
#ifndef PBC_TRACK_H
#define PBC_TRACK_H

#include <stddef.h>
#include <stdio.h>

#include "petblur.h"

typedef enum pbc_track_format {
    PBC_TRACK_AUTO = -1, /* recognised from the content */
    PBC_TRACK_CSV,
    PBC_TRACK_MATRIX_CSV,
    PBC_TRACK_POLARIS
} pbc_track_format;

/* Conventions a file does not carry, as the command line gives them. */
typedef struct pbc_track_read_options {
    pbc_track_format format;
    double time_divisor; /* time units of the file per second: 1 (s) or 1000 (ms) */
    int xyzw;          /* csv quaternions in x,y,z,w order */
} pbc_track_read_options;

typedef struct pbc_track {
    double *times;       /* seconds, strictly increasing */
    pb_pose *poses;      /* csv: about the motion's centre; the other formats: 4x4 maps about the origin */
    size_t *lines;       /* each pose's line in the file */
    size_t *missing;     /* missing samples skipped just before each pose */
    size_t count, capacity;
    pbc_track_format format;
} pbc_track;

/* "csv", "matrix-csv", "polaris" */
const char *pbc_track_format_name(pbc_track_format format);
/* Parses a --motion-format value; returns 0, or PBC_EXIT_USAGE after the message. */
int pbc_track_format_parse(const char *text, pbc_track_format *format);

/* Reads a track: every number finite, times strictly increasing, quaternions
 * of unit norm (Polaris's are normalised, as NDI's manual allows them not to
 * be), matrices rigid, at least two poses. Returns 0 or PBC_EXIT_USAGE after
 * "petblur: FILE:LINE: what is wrong; how to fix it". */
int pbc_track_read(const char *path, const pbc_track_read_options *options, pbc_track *track);
void pbc_track_free(pbc_track *track);

/* ---- shared by the format readers (track.c) ---- */

/* Appends a pose read at line; checks that its time comes after the last
 * one's. */
int pbc_track_append(const char *path, size_t line, double t, const pb_pose *pose, size_t missing, pbc_track *track);
/* A quaternion w,x,y,z as a unit quaternion: norm within 1e-3 of 1 when strict,
 * any nonzero norm otherwise. */
int pbc_track_unit_quaternion(const char *path, size_t line, const double q[4], int strict, double out[4]);
/* Reads one line into buf (NUL-terminated, end of line stripped); 0 at the end
 * of the file, 1 for a line, or an exit status after the message. */
int pbc_track_line(const char *path, FILE *f, size_t lineno, char *buf, size_t size);

/* A plain decimal number (no hex, inf or nan): 0, 1 when it is not one, 2 when
 * it is beyond double's range. */
int pbc_track_number(const char *text, double *v);

int pbc_track_read_csv(const char *path, FILE *f, const pbc_track_read_options *options, pbc_track *track);
int pbc_track_read_polaris(const char *path, FILE *f, pbc_track *track);
/* A Polaris log's layout from its first line: 1 .mt, 2 Toolviewer CSV, 0 neither. */
int pbc_polaris_layout(const char *first_line);

#endif
