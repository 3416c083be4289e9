/* The tracker-to-scanner calibration, read once for the command line and
 * Python: a rigid 4x4 (or its top 3x4) as text. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "motion.h"
#include "track.h"

/* A calibration is a few lines; anything longer is not one. */
#define MAX_LINE 4096

pb_status pb_calibration_read(const char *path, double m[16])
{
    if (!path || !m)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "path and matrix must not be NULL");
    FILE *f = fopen(path, "r");
    if (!f)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s: cannot open the calibration (%s); check the path", path,
                        strerror(errno));
    char line[MAX_LINE];
    size_t n = 0, lineno = 0;
    pb_status st = PB_OK;
    int rc = 0;
    while (st == PB_OK && (rc = pb_track_line(path, f, ++lineno, line, sizeof line)) == 1) {
        char *hash = strchr(line, '#');
        if (hash)
            *hash = '\0';
        for (char *save = NULL, *w = strtok_r(line, " \t,;", &save); w && st == PB_OK;
             w = strtok_r(NULL, " \t,;", &save)) {
            double v;
            int bad = pb_track_number(w, &v);
            if (n == 16)
                st = pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: '%s' is a 17th value; give the 4x4 tracker-to-scanner "
                              "matrix as 16 numbers (or its top 3x4 as 12), row by row (mm)", path, lineno, w);
            else if (bad)
                st = pb_error(NULL, bad == 2 ? PB_ERR_NOT_FINITE : PB_ERR_BAD_FILE, "%s:%zu: '%s' is not a "
                              "number; give the 4x4 tracker-to-scanner matrix as 16 numbers (or its top 3x4 as 12), "
                              "row by row (mm)", path, lineno, w);
            else
                m[n++] = v;
        }
    }
    fclose(f);
    if (st != PB_OK)
        return st;
    if (rc < 0)
        return (pb_status)rc;
    if (n == 12) { /* a 3x4 matrix: the last row is implied */
        m[12] = m[13] = m[14] = 0.0;
        m[15] = 1.0;
    } else if (n != 16) {
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s: %zu numbers; give the 4x4 tracker-to-scanner matrix as 16 "
                        "numbers (or its top 3x4 as 12), row by row", path, n);
    }
    pb_pose check;
    if (pb_pose_from_matrix(m, &check) != PB_OK)
        return pb_error_prefix(PB_ERR_NOT_RIGID, "%s: ", path);
    return PB_OK;
}
