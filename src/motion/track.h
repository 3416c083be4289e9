/* Pose tracks from motion logs (pb_track_read, petblur.h): the one internal
 * header of track.c, track_samples.c, track_csv.c and track_polaris.c; their
 * numbers are numbers.h's. Every message names the file and line, and says how
 * to fix it. */
#ifndef PB_TRACK_H
#define PB_TRACK_H

#include <stddef.h>
#include <stdio.h>

#include "petblur.h"

struct pb_track {
    double *times;   /* seconds, strictly increasing */
    pb_pose *poses;  /* csv: about the motion's centre; the other formats: 4x4 maps about the origin */
    size_t *lines;   /* each pose's line in the file */
    size_t *missing; /* missing samples skipped just before each pose */
    size_t count, capacity;
    pb_track_format format;
    char *source;    /* what messages call it: the path, or pb_track_create's source */
};

/* ---- track_samples.c: what every format's reader shares -------------------- */

/* Appends a pose read at line; checks that its time comes after the last
 * one's. */
pb_status pb_track_append(const char *path, size_t line, double t, const pb_pose *pose, size_t missing,
                          pb_track *track);
/* A quaternion w,x,y,z as a unit quaternion: norm within 1e-3 of 1 when strict
 * (kept as it is), any nonzero norm otherwise (normalised). The norm is taken
 * after scaling by the largest part, so that NDI's unnormalised quaternions
 * neither overflow (1e200) nor underflow (1e-170). */
pb_status pb_track_unit_quaternion(const char *path, size_t line, const double q[4], int strict, double out[4]);
/* Reads one line into buf (NUL-terminated, end of line stripped): 0 at the
 * end of the file, 1 for a line, or a negative status after the message. */
int pb_track_line(const char *path, FILE *f, size_t lineno, char *buf, size_t size);
/* ASCII white space within a line (space, tab, \v, \f, \r), whatever the
 * locale: what the readers trim and split at. */
int pb_track_blank(char c);
/* s without blanks at either end (cut in place). */
char *pb_track_trim(char *s);
/* s in ASCII lower case, in place, whatever the locale. */
void pb_track_lower(char *s);

/* ---- track_csv.c and track_polaris.c: the formats ------------------------- */

/* csv and matrix-csv, after the first line was told (track->format); options
 * with time_divisor > 0. */
pb_status pb_track_read_csv(const char *path, FILE *f, const pb_track_read_options *options, pb_track *track);
pb_status pb_track_read_polaris(const char *path, FILE *f, pb_track *track);
/* A Polaris log's layout from its first line: 1 .mt, 2 Toolviewer CSV, 0 neither. */
int pb_polaris_layout(const char *first_line);

#endif
