/* The tracker-to-scanner calibration, read once for the command line and
 * Python: a rigid 4x4 (or its top 3x4) as text, values separated by blanks,
 * or by one comma or semicolon among blanks, line breaks counting as blanks
 * (docs/motion.md, "Calibration files"). */
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "error.h"
#include "numbers.h"
#include "track.h"

/* A calibration is a few lines; anything longer is not one. */
#define MAX_LINE 4096

static const char *const fix = "give the 4x4 tracker-to-scanner matrix as 16 numbers (or its top 3x4 as 12), row by "
                               "row (mm)";

/* Where the values stand: how many were read, and where the last comma or
 * semicolon was that no value has followed yet (line 0: none). */
typedef struct {
    size_t n, separator_line;
    char separator;
} reading;

/* The values and separators of one line, comment cut. */
static pb_status read_line(const char *path, size_t lineno, char *line, double m[16], reading *r)
{
    char *hash = strchr(line, '#');
    if (hash)
        *hash = '\0';
    for (char *s = line; *s;) {
        if (pb_track_blank(*s)) {
            s++;
            continue;
        }
        if (*s == ',' || *s == ';') {
            if (r->n == 0 || r->separator_line)
                return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: '%c' with no value before it%s; an empty value is "
                                "no number: %s", path, lineno, *s, r->n ? " (after another separator)" : "", fix);
            r->separator = *s++;
            r->separator_line = lineno;
            continue;
        }
        size_t len = strcspn(s, " \t\v\f\r,;");
        char end = s[len];
        s[len] = '\0';
        if (r->n == 16)
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: '%.40s' is a 17th value; %s", path, lineno, s, fix);
        char what[32];
        snprintf(what, sizeof what, "value %zu", r->n + 1);
        pb_status st = pb_number_read(path, lineno, what, s, &m[r->n]);
        if (st != PB_OK)
            return st;
        r->n++;
        r->separator_line = 0;
        s[len] = end;
        s += len;
    }
    return PB_OK;
}

pb_status pb_calibration_read(const char *path, double m[16])
{
    if (!path || !m)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "path and matrix must not be NULL");
    FILE *f = fopen(path, "r");
    if (!f)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s: cannot open the calibration (%s); check the path", path,
                        strerror(errno));
    char line[MAX_LINE];
    size_t lineno = 0;
    reading r = {0, 0, 0};
    pb_status st = PB_OK;
    int rc = 0;
    while (st == PB_OK && (rc = pb_track_line(path, f, ++lineno, line, sizeof line)) == 1)
        st = read_line(path, lineno, line, m, &r);
    fclose(f);
    if (st != PB_OK)
        return st;
    if (rc < 0)
        return (pb_status)rc;
    if (r.separator_line)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: '%c' after the last value; an empty value is no number: %s",
                        path, r.separator_line, r.separator, fix);
    if (r.n == 12) { /* a 3x4 matrix: the last row is implied */
        m[12] = m[13] = m[14] = 0.0;
        m[15] = 1.0;
    } else if (r.n != 16) {
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s: %zu numbers; %s", path, r.n, fix);
    }
    pb_pose check;
    if (pb_pose_from_matrix(m, &check) != PB_OK)
        return pb_error_prefix(PB_ERR_NOT_RIGID, "%s: ", path);
    return PB_OK;
}
