/* Pose tracks from CSV motion logs. Every check names the file and line, so a
 * bad row in a log of thousands is found at once. */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "track_csv.h"

enum { FIELDS = 8 };
static const char *const field_names[FIELDS] = {"t", "tx", "ty", "tz", "qw", "qx", "qy", "qz"};

static char *trim(char *s)
{
    while (isspace((unsigned char)*s))
        s++;
    char *e = s + strlen(s);
    while (e > s && isspace((unsigned char)e[-1]))
        *--e = '\0';
    return s;
}

/* Splits line at commas into at most max fields; returns how many. */
static int split(char *line, char **fields, int max)
{
    int n = 0;
    for (char *s = line;; n++) {
        char *comma = strchr(s, ',');
        if (n < max)
            fields[n] = trim(s);
        if (!comma)
            return n + 1;
        *comma = '\0';
        s = comma + 1;
    }
}

static int check_header(const char *path, char *line)
{
    char *f[FIELDS + 1];
    int n = split(line, f, FIELDS + 1);
    int ok = n == FIELDS;
    for (int i = 0; ok && i < FIELDS; i++)
        ok = !strcmp(f[i], field_names[i]);
    if (!ok)
        return pbc_fail(PBC_EXIT_USAGE, "%s:1: the first line must be the header t,tx,ty,tz,qw,qx,qy,qz (seconds, "
                        "mm, unit quaternion w first); add or correct it", path);
    return 0;
}

static int parse_row(const char *path, size_t lineno, char *line, double v[FIELDS])
{
    char *f[FIELDS + 1];
    int n = split(line, f, FIELDS + 1);
    if (n != FIELDS)
        return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: %d fields where the header has 8 (t,tx,ty,tz,qw,qx,qy,qz); fix "
                        "that row", path, lineno, n);
    for (int i = 0; i < FIELDS; i++) {
        char *end;
        if (!*f[i])
            return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: field %s is empty; every row needs all 8 numbers", path,
                            lineno, field_names[i]);
        errno = 0;
        v[i] = strtod(f[i], &end);
        if (*end || errno == ERANGE)
            return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: field %s is '%s', not a number; fix that row", path, lineno,
                            field_names[i], f[i]);
        if (!isfinite(v[i]))
            return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: field %s is '%s'; times, translations and quaternions must "
                            "be finite numbers (drop or repair that row)", path, lineno, field_names[i], f[i]);
    }
    return 0;
}

static int check_pose(const char *path, size_t lineno, const double v[FIELDS], const pbc_track *tr)
{
    double norm = sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
    if (norm == 0.0)
        return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: the quaternion is zero, which is no rotation at all; the identity "
                        "is 1,0,0,0", path, lineno);
    /* The library normalises small rounding; anything more is a broken log. */
    if (fabs(norm - 1.0) > 1e-3)
        return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: the quaternion's norm is %.6g, not 1; write unit quaternions "
                        "(w,x,y,z divided by their norm)", path, lineno, norm);
    if (tr->count > 0 && !(v[0] > tr->times[tr->count - 1]))
        return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: time %.9g s does not come after the previous row's %.9g s; a "
                        "track's times must increase strictly (sort the log, drop repeated rows)", path, lineno,
                        v[0], tr->times[tr->count - 1]);
    return 0;
}

static int append(pbc_track *tr, size_t *cap, const double v[FIELDS])
{
    if (tr->count == *cap) {
        size_t n = *cap ? 2 * *cap : 64;
        double *t = realloc(tr->times, n * sizeof *t);
        if (t)
            tr->times = t;
        pb_pose *p = t ? realloc(tr->poses, n * sizeof *p) : NULL;
        if (!p)
            return pbc_fail(PBC_EXIT_RUNTIME, "out of memory reading the pose track");
        tr->poses = p;
        *cap = n;
    }
    tr->times[tr->count] = v[0];
    pb_pose *p = &tr->poses[tr->count++];
    memcpy(p->translation, v + 1, 3 * sizeof(double));
    memcpy(p->rotation, v + 4, 4 * sizeof(double));
    return 0;
}

static int read_rows(const char *path, FILE *f, pbc_track *tr)
{
    char line[4096];
    size_t lineno = 0, cap = 0;
    int rc = 0;
    while (!rc && fgets(line, sizeof line, f)) {
        lineno++;
        if (!strchr(line, '\n') && !feof(f))
            return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: line longer than %zu characters; is this a pose track?", path,
                            lineno, sizeof line - 1);
        char *s = trim(line);
        if (lineno == 1) {
            /* Spreadsheets often start a CSV with a UTF-8 byte-order mark. */
            if (!strncmp(s, "\xEF\xBB\xBF", 3))
                s += 3;
            rc = check_header(path, s);
            continue;
        }
        if (!*s || *s == '#') /* blank lines and comments, as loggers write them */
            continue;
        double v[FIELDS];
        if (!(rc = parse_row(path, lineno, s, v)) && !(rc = check_pose(path, lineno, v, tr)))
            rc = append(tr, &cap, v);
    }
    if (!rc && ferror(f))
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: read error (%s)", path, strerror(errno));
    if (!rc && lineno == 0)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: the file is empty; a track needs the header t,tx,ty,tz,qw,qx,qy,qz and "
                      "at least two rows", path);
    else if (!rc && tr->count < 2)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: %zu pose%s; a track needs at least two (the frame's start and end)", path,
                      tr->count, tr->count == 1 ? "" : "s");
    return rc;
}

int pbc_track_read(const char *path, pbc_track *track)
{
    memset(track, 0, sizeof *track);
    FILE *f = fopen(path, "r");
    if (!f)
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot open the pose track (%s); check the path", path,
                        strerror(errno));
    int rc = read_rows(path, f, track);
    fclose(f);
    if (rc)
        pbc_track_free(track);
    return rc;
}

void pbc_track_free(pbc_track *track)
{
    free(track->times);
    free(track->poses);
    memset(track, 0, sizeof *track);
}
