/* Pose tracks from motion-tracking logs: CSV with the header
 * t,tx,ty,tz,qw,qx,qy,qz (seconds, mm, unit quaternion w first). */
#ifndef PBC_TRACK_CSV_H
#define PBC_TRACK_CSV_H

#include <stddef.h>

#include "petblur.h"

typedef struct pbc_track {
    double *times;
    pb_pose *poses;
    size_t count;
} pbc_track;

/* Reads and checks a track: every field a finite number, times strictly
 * increasing, no zero quaternion, at least two poses. Returns 0 or
 * PBC_EXIT_USAGE after printing "petblur: FILE:LINE: what is wrong; how to fix it". */
int pbc_track_read(const char *path, pbc_track *track);
void pbc_track_free(pbc_track *track);

#endif
