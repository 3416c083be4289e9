/* Pose tracks as CSV: petblur's own (t, translation, quaternion) and rigid
 * matrices row by row (yrt-pet's). Columns are found by name, so their order
 * and extra columns do not matter; a matrix file may come without a header. */
#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "track.h"

enum { MAX_FIELDS = 64, CSV_COLUMNS = 8, MATRIX_COLUMNS = 13 };

/* Column names, in the order the readers take their values. */
static const char *const csv_names[CSV_COLUMNS] = {"t", "tx", "ty", "tz", "qw", "qx", "qy", "qz"};
static const char *const matrix_names[MATRIX_COLUMNS] = {"t", "r00", "r01", "r02", "tx", "r10", "r11", "r12",
                                                         "ty", "r20", "r21", "r22", "tz"};

static char *trim(char *s)
{
    while (isspace((unsigned char)*s))
        s++;
    char *e = s + strlen(s);
    while (e > s && isspace((unsigned char)e[-1]))
        *--e = '\0';
    return s;
}

/* Splits at commas, or with `blanks` at any run of commas, spaces and tabs (as
 * yrt-pet reads its files); returns the number of fields, or MAX_FIELDS + 1
 * when there are more. */
static int split(char *line, char **fields, int blanks)
{
    const char *sep = blanks ? ", \t" : ",";
    int n = 0;
    char *s = trim(line);
    while (n <= MAX_FIELDS) {
        size_t len = strcspn(s, sep);
        char *next = s[len] ? s + len + 1 : NULL;
        s[len] = '\0';
        if (n < MAX_FIELDS)
            fields[n] = trim(s);
        n++;
        if (!next)
            return n;
        if (blanks)
            next += strspn(next, sep);
        s = next;
    }
    return n;
}

static void lower(char *s)
{
    for (; *s; s++)
        *s = (char)tolower((unsigned char)*s);
}

/* Where each wanted column sits in the header; the quaternion's parts may be
 * named (qw, qx, qy, qz) or numbered (q0..q3 or q1..q4, in the order of
 * --quaternion-order). */
static pb_status map_header(const char *path, char **f, int n, const char *const *names, int count, int xyzw,
                            int quat, int *column)
{
    static const char *const numbered[2][4] = {{"q0", "q1", "q2", "q3"}, {"q1", "q2", "q3", "q4"}};
    char found[512] = "";
    size_t used = 0;
    for (int c = 0; c < count; c++)
        column[c] = -1;
    int named_q = 0;
    for (int i = 0; i < n && i < MAX_FIELDS; i++) {
        lower(f[i]);
        if (used + 1 < sizeof found) /* what fits is enough to show */
            used += (size_t)snprintf(found + used, sizeof found - used, "%s%s", i ? "," : "", f[i]);
        for (int c = 0; c < count; c++)
            if (!strcmp(f[i], names[c]) || (c == 0 && (!strcmp(f[i], "time") || !strcmp(f[i], "timestamp")))) {
                column[c] = i;
                named_q |= quat && c >= 4;
            }
    }
    for (int set = 0; quat && !named_q && set < 2; set++) {
        int at[4] = {-1, -1, -1, -1};
        for (int i = 0; i < n && i < MAX_FIELDS; i++)
            for (int k = 0; k < 4; k++)
                if (!strcmp(f[i], numbered[set][k]))
                    at[k] = i;
        if (at[0] >= 0 && at[1] >= 0 && at[2] >= 0 && at[3] >= 0)
            for (int k = 0; k < 4; k++) /* x,y,z,w order: the last numbered part is w */
                column[4 + k] = at[xyzw ? (k + 3) % 4 : k];
    }
    if (quat && named_q && xyzw)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "%s:1: the header names the quaternion's parts (qw,qx,qy,qz), "
                        "so their order is known; --quaternion-order is for headers that number them (q0,q1,q2,q3)",
                        path);
    for (int c = 0; c < count; c++)
        if (column[c] < 0) {
            char expected[256] = "";
            for (int k = 0, u = 0; k < count; k++)
                u += snprintf(expected + u, sizeof expected - (size_t)u, "%s%s", k ? "," : "", names[k]);
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:1: the header has no column '%s'; found '%s', expected the "
                            "columns %s%s (any order, extra columns ignored)", path, names[c], found, expected,
                            quat ? " (or the quaternion as q0,q1,q2,q3 with --quaternion-order)" : "");
        }
    return PB_OK;
}

static pb_status row_values(const char *path, size_t lineno, char **f, int n, const int need[2], const int *column,
                            const char *const *names, int count, double *v)
{
    if (n < need[0] || n > need[1])
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: %d field%s where %s %d; fix that row", path, lineno, n,
                        n == 1 ? "" : "s", need[0] == need[1] ? "the header has" : "a matrix row has 13 or",
                        need[1]);
    for (int c = 0; c < count; c++) {
        const char *text = f[column[c]];
        int bad = pb_track_number(text, &v[c]);
        if (!*text)
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: field %s is empty; every row needs all %d numbers", path,
                            lineno, names[c], count);
        if (bad == 1)
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: field %s is '%s', not a number (plain decimal, e.g. "
                            "-1.5e-3); fix that row", path, lineno, names[c], text);
        if (bad == 2 || !isfinite(v[c]))
            return pb_error(NULL, PB_ERR_NOT_FINITE, "%s:%zu: field %s is '%s', beyond any time, translation or "
                            "rotation a track can hold; fix that row", path, lineno, names[c], text);
    }
    return PB_OK;
}

static pb_status csv_pose(const char *path, size_t lineno, const double *v, double time_divisor, pb_track *tr)
{
    pb_pose p;
    memcpy(p.translation, v + 1, 3 * sizeof(double));
    pb_status st = pb_track_unit_quaternion(path, lineno, v + 4, 1, p.rotation);
    return st != PB_OK ? st : pb_track_append(path, lineno, v[0] / time_divisor, &p, 0, tr);
}

static pb_status matrix_pose(const char *path, size_t lineno, const double *v, double time_divisor, pb_track *tr)
{
    double m[16] = {v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], v[11], v[12], 0, 0, 0, 1};
    pb_pose p;
    pb_status st = pb_pose_from_matrix(m, &p);
    if (st != PB_OK) {
        char why[512]; /* pb_error writes the text it would read */
        snprintf(why, sizeof why, "%s", pb_last_error(NULL));
        return pb_error(NULL, st, "%s:%zu: %s; fix that row", path, lineno, why);
    }
    return pb_track_append(path, lineno, v[0] / time_divisor, &p, 0, tr);
}

pb_status pb_track_read_csv(const char *path, FILE *f, const pb_track_read_options *o, pb_track *tr)
{
    int matrix = tr->format == PB_TRACK_MATRIX_CSV;
    const char *const *names = matrix ? matrix_names : csv_names;
    int count = matrix ? MATRIX_COLUMNS : CSV_COLUMNS, column[MATRIX_COLUMNS], need[2] = {count, count};
    char line[4096], *fields[MAX_FIELDS];
    pb_status rc = PB_OK;
    int header = 0;
    for (size_t lineno = 1; !rc; lineno++) {
        int got = pb_track_line(path, f, lineno, line, sizeof line);
        if (got != 1) {
            rc = (pb_status)got;
            break;
        }
        char *s = lineno == 1 && !strncmp(line, "\xEF\xBB\xBF", 3) ? line + 3 : line; /* spreadsheets' BOM */
        if (!*trim(s) || *trim(s) == '#') /* blank lines and comments, as loggers write them */
            continue;
        int n = split(s, fields, matrix);
        if (!header) {
            header = 1;
            double first;
            if (matrix && pb_track_number(fields[0], &first) == 0) {
                /* yrt-pet writes no header: t, the 12 entries, and an error */
                for (int c = 0; c < count; c++)
                    column[c] = c;
                need[1] = count + 1;
            } else {
                if ((rc = map_header(path, fields, n, names, count, o->xyzw, !matrix, column)))
                    break;
                need[0] = need[1] = n;
                continue;
            }
        }
        double v[MATRIX_COLUMNS];
        if (n > MAX_FIELDS)
            rc = pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: more than %d fields; is this a pose track?", path,
                          lineno, MAX_FIELDS);
        else if (!(rc = row_values(path, lineno, fields, n, need, column, names, count, v)))
            rc = matrix ? matrix_pose(path, lineno, v, o->time_divisor, tr)
                        : csv_pose(path, lineno, v, o->time_divisor, tr);
    }
    if (!rc && !header)
        rc = pb_error(NULL, PB_ERR_BAD_FILE, "%s: no rows; a track needs the header %s and at least two rows",
                      path, matrix ? "t,r00,r01,r02,tx,...,tz" : "t,tx,ty,tz,qw,qx,qy,qz");
    return rc;
}
