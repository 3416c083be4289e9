/* What every track reader shares: lines, blanks, quaternions and the samples
 * appended in time order (track.h); numbers are numbers.c's. The readers call
 * these; nothing here calls a reader. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "track.h"

int pb_track_line(const char *path, FILE *f, size_t lineno, char *buf, size_t size)
{
    size_t n = 0;
    int c = EOF;
    while ((c = getc(f)) != EOF && c != '\n') {
        if (c == '\0')
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: holds a NUL byte; give a text file", path, lineno);
        if (n + 1 >= size)
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: line longer than %zu characters; is this the right file?",
                            path, lineno, size - 1);
        buf[n++] = (char)c;
    }
    if (ferror(f))
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s: read error (%s)", path, strerror(errno));
    while (n > 0 && buf[n - 1] == '\r')
        n--;
    buf[n] = '\0';
    return c == EOF && n == 0 ? 0 : 1;
}

int pb_track_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\v' || c == '\f' || c == '\r';
}

char *pb_track_trim(char *s)
{
    while (pb_track_blank(*s))
        s++;
    char *e = s + strlen(s);
    while (e > s && pb_track_blank(e[-1]))
        *--e = '\0';
    return s;
}

void pb_track_lower(char *s)
{
    for (; *s; s++)
        if (*s >= 'A' && *s <= 'Z')
            *s = (char)(*s - 'A' + 'a');
}

pb_status pb_track_unit_quaternion(const char *path, size_t line, const double q[4], int strict, double out[4])
{
    double largest = fmax(fmax(fabs(q[0]), fabs(q[1])), fmax(fabs(q[2]), fabs(q[3])));
    if (!(largest > 0.0))
        return pb_error(NULL, PB_ERR_BAD_QUATERNION, "%s:%zu: the quaternion is zero, which is no rotation at all; "
                        "the identity is 1,0,0,0", path, line);
    double s[4], sum = 0.0;
    for (int i = 0; i < 4; i++) {
        s[i] = q[i] / largest;
        sum += s[i] * s[i];
    }
    double norm = sqrt(sum); /* of s, in [1, 2]; q's is largest * norm */
    /* The library normalises small rounding; anything more is a broken log. */
    if (strict && fabs(largest * norm - 1.0) > 1e-3)
        return pb_error(NULL, PB_ERR_BAD_QUATERNION, "%s:%zu: the quaternion's norm is %.6g, not 1; write unit "
                        "quaternions (w,x,y,z divided by their norm)", path, line, largest * norm);
    for (int i = 0; i < 4; i++)
        out[i] = strict ? q[i] : s[i] / norm;
    return PB_OK;
}

static pb_status grow(const char *path, pb_track *tr)
{
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
        return pb_error(NULL, PB_ERR_OUT_OF_MEMORY, "out of memory reading the pose track %s", path);
    tr->missing = miss;
    tr->capacity = n;
    return PB_OK;
}

pb_status pb_track_append(const char *path, size_t line, double t, const pb_pose *pose, size_t missing,
                          pb_track *tr)
{
    if (tr->count > 0 && !(t > tr->times[tr->count - 1]))
        return pb_error(NULL, PB_ERR_TRACK_ORDER, "%s:%zu: time %.9g s does not come after the previous row's %.9g s "
                        "(line %zu); a track's times must increase strictly (sort the log, drop repeated rows)", path,
                        line, t, tr->times[tr->count - 1], tr->lines[tr->count - 1]);
    pb_status st = tr->count == tr->capacity ? grow(path, tr) : PB_OK;
    if (st != PB_OK)
        return st;
    tr->times[tr->count] = t;
    tr->poses[tr->count] = *pose;
    tr->lines[tr->count] = line;
    tr->missing[tr->count++] = missing;
    return PB_OK;
}
