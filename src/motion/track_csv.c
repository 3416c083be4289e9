/* Pose tracks as CSV: petblur's own (t, translation, quaternion) and rigid
 * matrices row by row (yrt-pet's). Columns are found by name, so their order
 * and extra columns do not matter; a matrix file may come without a header. */
#include <stdio.h>
#include <string.h>

#include "error.h"
#include "numbers.h"
#include "track.h"

enum { MAX_FIELDS = 64, CSV_COLUMNS = 8, MATRIX_COLUMNS = 13 };

/* Column names, in the order the readers take their values. */
static const char *const csv_names[CSV_COLUMNS] = {"t", "tx", "ty", "tz", "qw", "qx", "qy", "qz"};
static const char *const matrix_names[MATRIX_COLUMNS] = {"t", "r00", "r01", "r02", "tx", "r10", "r11", "r12",
                                                         "ty", "r20", "r21", "r22", "tz"};

/* Splits at commas, or with `blanks` at any run of commas and blanks (as
 * yrt-pet reads its files); returns the number of fields, or MAX_FIELDS + 1
 * when there are more. */
static int split(char *line, char **fields, int blanks)
{
    int n = 0;
    char *s = pb_track_trim(line);
    while (n <= MAX_FIELDS) {
        size_t len = 0;
        while (s[len] && s[len] != ',' && !(blanks && pb_track_blank(s[len])))
            len++;
        char *next = s[len] ? s + len + 1 : NULL;
        s[len] = '\0';
        if (n < MAX_FIELDS)
            fields[n] = pb_track_trim(s);
        n++;
        if (!next)
            return n;
        while (blanks && (*next == ',' || pb_track_blank(*next)))
            next++;
        s = next;
    }
    return n;
}

/* The column that holds name, by one of its spellings: the time is t, time or
 * timestamp. -1 where none does; -2, after the message, where two do. */
static int find_column(const char *path, size_t lineno, char **f, int n, const char *name)
{
    int at = -1;
    for (int i = 0; i < n; i++) {
        int time = !strcmp(name, "t") && (!strcmp(f[i], "time") || !strcmp(f[i], "timestamp"));
        if (strcmp(f[i], name) && !time)
            continue;
        if (at >= 0) {
            pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: the header names %s twice, '%s' (column %d) and '%s' (column "
                     "%d), so which one to read is ambiguous; keep one", path, lineno,
                     strcmp(name, "t") ? name : "the time", f[at], at + 1, f[i], i + 1);
            return -2;
        }
        at = i;
    }
    return at;
}

/* The quaternion's parts as numbered columns, q0..q3 or q1..q4, in the order
 * of --quaternion-order: 0 when the header numbers none of them, 1 after
 * filling part[] as w,x,y,z (-1 where one is missing), or a negative status. */
static int numbered_quaternion(const char *path, size_t lineno, char **f, int n, int xyzw, int part[4])
{
    int at[5];
    for (int k = 0; k < 5; k++) {
        char name[3] = {'q', (char)('0' + k), '\0'};
        if ((at[k] = find_column(path, lineno, f, n, name)) == -2)
            return PB_ERR_BAD_FILE;
    }
    if (at[0] >= 0 && at[4] >= 0)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: the header numbers the quaternion both q0..q3 and q1..q4 "
                        "(columns %d and %d), so which parts to read is ambiguous; keep one numbering", path, lineno,
                        at[0] + 1, at[4] + 1);
    if (at[0] < 0 && at[1] < 0 && at[2] < 0 && at[3] < 0 && at[4] < 0)
        return 0;
    const int *first = at[0] >= 0 ? at : at + 1;
    for (int k = 0; k < 4; k++) /* x,y,z,w order: the last numbered part is w */
        part[k] = first[xyzw ? (k + 3) % 4 : k];
    return 1;
}

/* Where each wanted column sits in the header at lineno; the quaternion's
 * parts may be named (qw, qx, qy, qz) or numbered (q0..q3 or q1..q4, in the
 * order of --quaternion-order), not both. A name given twice is ambiguous. */
static pb_status map_header(const char *path, size_t lineno, char **f, int n, const char *const *names, int count,
                            int xyzw, int quat, int *column)
{
    if (n > MAX_FIELDS)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: the header has more than %d columns; is this a pose track?",
                        path, lineno, MAX_FIELDS);
    char found[512] = "";
    size_t used = 0;
    for (int i = 0; i < n; i++) {
        pb_track_lower(f[i]);
        if (used + 1 < sizeof found) /* what fits is enough to show */
            used += (size_t)snprintf(found + used, sizeof found - used, "%s%s", i ? "," : "", f[i]);
    }
    int named_q = 0;
    for (int c = 0; c < count; c++) {
        if ((column[c] = find_column(path, lineno, f, n, names[c])) == -2)
            return PB_ERR_BAD_FILE;
        named_q |= quat && c >= 4 && column[c] >= 0;
    }
    int part[4];
    int numbered = quat ? numbered_quaternion(path, lineno, f, n, xyzw, part) : 0;
    if (numbered < 0)
        return (pb_status)numbered;
    if (named_q && numbered)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: the header gives the quaternion both named (qw,qx,qy,qz) "
                        "and numbered (q0..q3 or q1..q4), so which to read is ambiguous; keep one", path, lineno);
    for (int k = 0; numbered && k < 4; k++)
        column[4 + k] = part[k];
    if (named_q && xyzw)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "%s:%zu: the header names the quaternion's parts (qw,qx,qy,"
                        "qz), so their order is known; --quaternion-order is for headers that number them (q0,q1,q2,"
                        "q3)", path, lineno);
    for (int c = 0; c < count; c++)
        if (column[c] < 0) {
            char expected[256] = "";
            for (int k = 0, u = 0; k < count; k++)
                u += snprintf(expected + u, sizeof expected - (size_t)u, "%s%s", k ? "," : "", names[k]);
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: the header has no column '%s'; found '%s', expected the "
                            "columns %s%s (any order, extra columns ignored)", path, lineno, names[c], found,
                            expected, quat ? " (or the quaternion as q0,q1,q2,q3 with --quaternion-order)" : "");
        }
    return PB_OK;
}

static pb_status row_values(const char *path, size_t lineno, char **f, int n, const int need[2], const int *column,
                            const char *const *names, int count, double *v)
{
    if (n > MAX_FIELDS)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: more than %d fields; is this a pose track?", path, lineno,
                        MAX_FIELDS);
    if (n < need[0] || n > need[1])
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: %d field%s where %s %d; fix that row", path, lineno, n,
                        n == 1 ? "" : "s", need[0] == need[1] ? "the header has" : "a matrix row has 13 or",
                        need[1]);
    for (int c = 0; c < count; c++) {
        char what[32];
        snprintf(what, sizeof what, "field %s", names[c]);
        pb_status st = pb_number_read(path, lineno, what, f[column[c]], &v[c]);
        if (st != PB_OK)
            return st;
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
        s = pb_track_trim(s);
        if (!*s || *s == '#') /* blank lines and comments, as loggers write them */
            continue;
        int n = split(s, fields, matrix);
        if (!header) {
            header = 1;
            double first;
            if (matrix && pb_number_scan(fields[0], &first) != PB_NUMBER_MALFORMED) {
                /* yrt-pet writes no header: t, the 12 entries, and an error */
                for (int c = 0; c < count; c++)
                    column[c] = c;
                need[1] = count + 1;
            } else {
                if ((rc = map_header(path, lineno, fields, n, names, count, o->xyzw, !matrix, column)))
                    break;
                need[0] = need[1] = n;
                continue;
            }
        }
        double v[MATRIX_COLUMNS];
        if (!(rc = row_values(path, lineno, fields, n, need, column, names, count, v)))
            rc = matrix ? matrix_pose(path, lineno, v, o->time_divisor, tr)
                        : csv_pose(path, lineno, v, o->time_divisor, tr);
    }
    if (!rc && !header)
        rc = pb_error(NULL, PB_ERR_BAD_FILE, "%s: no rows; a track needs the header %s and at least two rows",
                      path, matrix ? "t,r00,r01,r02,tx,...,tz" : "t,tx,ty,tz,qw,qx,qy,qz");
    return rc;
}
