/* Pose tracks: the format told by name or by content, and what every format's
 * reader shares. */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "track.h"

static const char *const format_names[] = {"csv", "matrix-csv", "polaris"};

const char *pbc_track_format_name(pbc_track_format format)
{
    return format >= 0 && format <= PBC_TRACK_POLARIS ? format_names[format] : "auto";
}

int pbc_track_format_parse(const char *text, pbc_track_format *format)
{
    for (int i = 0; i <= PBC_TRACK_POLARIS; i++)
        if (!strcmp(text, format_names[i])) {
            *format = (pbc_track_format)i;
            return 0;
        }
    return pbc_fail(PBC_EXIT_USAGE, "--motion-format %s: choose csv (t,tx,ty,tz,qw,qx,qy,qz), matrix-csv (t and a "
                    "3x4 matrix row by row, as yrt-pet writes) or polaris (NDI .mt or Toolviewer CSV)", text);
}

int pbc_track_line(const char *path, FILE *f, size_t lineno, char *buf, size_t size)
{
    size_t n = 0;
    int c = EOF;
    while ((c = getc(f)) != EOF && c != '\n') {
        if (c == '\0')
            return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: holds a NUL byte; a pose track is text", path, lineno);
        if (n + 1 >= size)
            return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: line longer than %zu characters; is this a pose track?", path,
                            lineno, size - 1);
        buf[n++] = (char)c;
    }
    if (ferror(f))
        return pbc_fail(PBC_EXIT_USAGE, "%s: read error (%s)", path, strerror(errno));
    while (n > 0 && buf[n - 1] == '\r')
        n--;
    buf[n] = '\0';
    return c == EOF && n == 0 ? 0 : 1;
}

int pbc_track_number(const char *text, double *v)
{
    /* Plain decimal only: strtod would also take hex floats, "inf" and "nan". */
    if (!*text || strspn(text, "0123456789+-.eE") != strlen(text))
        return 1;
    char *end;
    errno = 0;
    *v = strtod(text, &end);
    if (*end || end == text)
        return 1;
    return errno == ERANGE && fabs(*v) > 1.0 ? 2 : 0; /* an underflow to (almost) 0 is that number */
}

int pbc_track_unit_quaternion(const char *path, size_t line, const double q[4], int strict, double out[4])
{
    double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(norm > 0.0))
        return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: the quaternion is zero, which is no rotation at all; the identity "
                        "is 1,0,0,0", path, line);
    /* The library normalises small rounding; anything more is a broken log. */
    if (strict && fabs(norm - 1.0) > 1e-3)
        return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: the quaternion's norm is %.6g, not 1; write unit quaternions "
                        "(w,x,y,z divided by their norm)", path, line, norm);
    for (int i = 0; i < 4; i++)
        out[i] = strict ? q[i] : q[i] / norm;
    return 0;
}

int pbc_track_append(const char *path, size_t line, double t, const pb_pose *pose, size_t missing, pbc_track *tr)
{
    if (tr->count > 0 && !(t > tr->times[tr->count - 1]))
        return pbc_fail(PBC_EXIT_USAGE, "%s:%zu: time %.9g s does not come after the previous row's %.9g s (line "
                        "%zu); a track's times must increase strictly (sort the log, drop repeated rows)", path, line,
                        t, tr->times[tr->count - 1], tr->lines[tr->count - 1]);
    if (tr->count == tr->capacity) {
        size_t n = tr->capacity ? 2 * tr->capacity : 64;
        double *times = realloc(tr->times, n * sizeof *times);
        if (times)
            tr->times = times;
        pb_pose *poses = times ? realloc(tr->poses, n * sizeof *poses) : NULL;
        if (poses)
            tr->poses = poses;
        size_t *lines = poses ? realloc(tr->lines, n * sizeof *lines) : NULL;
        if (lines)
            tr->lines = lines;
        size_t *miss = lines ? realloc(tr->missing, n * sizeof *miss) : NULL;
        if (!miss)
            return pbc_fail(PBC_EXIT_RUNTIME, "out of memory reading the pose track %s", path);
        tr->missing = miss;
        tr->capacity = n;
    }
    tr->times[tr->count] = t;
    tr->poses[tr->count] = *pose;
    tr->lines[tr->count] = line;
    tr->missing[tr->count++] = missing;
    return 0;
}

/* The format from the first line: Polaris's two layouts by their first words,
 * a header by its column names, and yrt-pet's header-less rows by their 13 or
 * 14 numbers. */
static int detect(const char *path, FILE *f, pbc_track_format *format)
{
    char line[4096];
    int rc = pbc_track_line(path, f, 1, line, sizeof line);
    rewind(f);
    if (rc == 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s: the file is empty; a track needs a header such as "
                        "t,tx,ty,tz,qw,qx,qy,qz and at least two rows", path);
    if (rc != 1)
        return rc;
    char *s = line;
    if (!strncmp(s, "\xEF\xBB\xBF", 3))
        s += 3;
    if (pbc_polaris_layout(s)) {
        *format = PBC_TRACK_POLARIS;
        return 0;
    }
    char lower[4096];
    size_t i = 0, fields = 0;
    for (; s[i] && i + 1 < sizeof lower; i++) {
        lower[i] = (char)tolower((unsigned char)s[i]);
        /* yrt-pet separates by any run of commas and blanks */
        fields += !strchr(", \t", s[i]) && (i == 0 || strchr(", \t", s[i - 1]));
    }
    lower[i] = '\0';
    if (strstr(lower, "r00") || (isdigit((unsigned char)lower[0]) && (fields == 13 || fields == 14))) {
        *format = PBC_TRACK_MATRIX_CSV;
        return 0;
    }
    if (!isdigit((unsigned char)lower[0]) && lower[0] != '-' && lower[0] != '+' && lower[0] != '.') {
        *format = PBC_TRACK_CSV; /* a header; the csv reader says what it lacks */
        return 0;
    }
    return pbc_fail(PBC_EXIT_USAGE, "%s:1: '%.60s' is no header, nor the 13 or 14 numbers of a matrix row; give "
                    "a header (t,tx,ty,tz,qw,qx,qy,qz or t,r00,r01,r02,tx,...,tz) or --motion-format", path, s);
}

int pbc_track_read(const char *path, const pbc_track_read_options *options, pbc_track *track)
{
    memset(track, 0, sizeof *track);
    FILE *f = fopen(path, "r");
    if (!f)
        return pbc_fail(PBC_EXIT_USAGE, "%s: cannot open the pose track (%s); check the path", path,
                        strerror(errno));
    pbc_track_format format = options->format;
    int rc = format == PBC_TRACK_AUTO ? detect(path, f, &format) : 0;
    track->format = format;
    if (!rc && format == PBC_TRACK_POLARIS && (options->xyzw || options->time_divisor != 1.0))
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: a Polaris log gives seconds and q0 first; --time-unit and "
                      "--quaternion-order are for csv and matrix-csv tracks", path);
    if (!rc && format == PBC_TRACK_MATRIX_CSV && options->xyzw)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: a matrix-csv track holds no quaternions; drop --quaternion-order", path);
    if (!rc)
        rc = format == PBC_TRACK_POLARIS ? pbc_track_read_polaris(path, f, track)
                                         : pbc_track_read_csv(path, f, options, track);
    fclose(f);
    if (!rc && track->count < 2)
        rc = pbc_fail(PBC_EXIT_USAGE, "%s: %zu pose%s; a track needs at least two (the frame's start and end)", path,
                      track->count, track->count == 1 ? "" : "s");
    if (rc)
        pbc_track_free(track);
    return rc;
}

void pbc_track_free(pbc_track *track)
{
    free(track->times);
    free(track->poses);
    free(track->lines);
    free(track->missing);
    memset(track, 0, sizeof *track);
}
