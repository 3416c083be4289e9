/* Pose tracks: the format told by name or by content, the readers
 * dispatched, tracks made from arrays, and the public accessors. */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "motion.h"
#include "track.h"

/* The format from the first line: Polaris's two layouts by their first words,
 * a header by its column names, and yrt-pet's header-less rows by their 13 or
 * 14 numbers. */
static pb_status detect(const char *path, FILE *f, pb_track_format *format)
{
    char line[4096];
    int rc = pb_track_line(path, f, 1, line, sizeof line);
    rewind(f);
    if (rc == 0)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s: the file is empty; a track needs a header such as "
                        "t,tx,ty,tz,qw,qx,qy,qz and at least two rows", path);
    if (rc != 1)
        return (pb_status)rc;
    char *s = line;
    if (!strncmp(s, "\xEF\xBB\xBF", 3))
        s += 3;
    if (pb_polaris_layout(s)) {
        *format = PB_TRACK_POLARIS;
        return PB_OK;
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
        *format = PB_TRACK_MATRIX_CSV;
        return PB_OK;
    }
    if (!isdigit((unsigned char)lower[0]) && lower[0] != '-' && lower[0] != '+' && lower[0] != '.') {
        *format = PB_TRACK_CSV; /* a header; the csv reader says what it lacks */
        return PB_OK;
    }
    return pb_error(NULL, PB_ERR_BAD_FILE, "%s:1: '%.60s' is no header, nor the 13 or 14 numbers of a matrix row; "
                    "give a header (t,tx,ty,tz,qw,qx,qy,qz or t,r00,r01,r02,tx,...,tz) or --motion-format", path, s);
}

/* The options as the readers take them (time_divisor 0 is 1), or a refusal. */
static pb_status check_options(const pb_track_read_options *in, pb_track_read_options *out)
{
    *out = in ? *in : (pb_track_read_options){PB_TRACK_AUTO, 1.0, 0};
    if ((int)out->format < PB_TRACK_AUTO || (int)out->format > PB_TRACK_POLARIS) /* a binding passes any int */
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "unknown track format %d; use PB_TRACK_AUTO, PB_TRACK_CSV, "
                        "PB_TRACK_MATRIX_CSV or PB_TRACK_POLARIS", (int)out->format);
    if (!isfinite(out->time_divisor) || out->time_divisor < 0.0)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "time_divisor %g: give the file's time units per second (1 "
                        "for seconds, 1000 for milliseconds; 0 means 1)", out->time_divisor);
    if (out->time_divisor == 0.0)
        out->time_divisor = 1.0;
    return PB_OK;
}

/* The format's reader on an open file, with the checks of options against the
 * format and of the count. */
static pb_status read_open(const char *path, FILE *f, const pb_track_read_options *o, pb_track *track)
{
    pb_track_format format = o->format;
    pb_status st = format == PB_TRACK_AUTO ? detect(path, f, &format) : PB_OK;
    track->format = format;
    if (st != PB_OK)
        return st;
    if (format == PB_TRACK_POLARIS && (o->xyzw || o->time_divisor != 1.0))
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "%s: a Polaris log gives seconds and q0 first; --time-unit "
                        "and --quaternion-order are for csv and matrix-csv tracks", path);
    if (format == PB_TRACK_MATRIX_CSV && o->xyzw)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "%s: a matrix-csv track holds no quaternions; drop "
                        "--quaternion-order", path);
    st = format == PB_TRACK_POLARIS ? pb_track_read_polaris(path, f, track) : pb_track_read_csv(path, f, o, track);
    if (st == PB_OK && track->count < 2)
        st = pb_error(NULL, track->count ? PB_ERR_TRACK_GAP : PB_ERR_BAD_FILE, "%s: %zu pose%s; a track needs at "
                      "least two (the frame's start and end)", path, track->count, track->count == 1 ? "" : "s");
    return st;
}

pb_status pb_track_read(const char *path, const pb_track_read_options *options, pb_track **track)
{
    if (track)
        *track = NULL;
    if (!path || !track)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "path and track must not be NULL");
    pb_track_read_options o;
    pb_status st = check_options(options, &o);
    if (st != PB_OK)
        return st;
    pb_track *t = calloc(1, sizeof *t);
    if (!t)
        return pb_error(NULL, PB_ERR_OUT_OF_MEMORY, "out of memory reading the pose track %s", path);
    t->source = strdup(path);
    FILE *f = t->source ? fopen(path, "r") : NULL;
    if (!t->source)
        st = pb_error(NULL, PB_ERR_OUT_OF_MEMORY, "out of memory reading the pose track %s", path);
    else if (!f)
        st = pb_error(NULL, PB_ERR_BAD_FILE, "%s: cannot open the pose track (%s); check the path", path,
                      strerror(errno));
    else {
        st = read_open(path, f, &o, t);
        fclose(f);
    }
    if (st != PB_OK)
        pb_track_free(t);
    else
        *track = t;
    return st;
}

void pb_track_free(pb_track *track)
{
    if (!track)
        return;
    free(track->times);
    free(track->poses);
    free(track->lines);
    free(track->missing);
    free(track->source);
    free(track);
}

pb_status pb_track_create(const char *source, pb_track_format format, const double *times, const pb_pose *poses,
                          const size_t *lines, const size_t *missing, size_t count, pb_track **track)
{
    if (track)
        *track = NULL;
    if (!times || !poses || !track)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "times, poses and track must not be NULL");
    if ((int)format < PB_TRACK_CSV || (int)format > PB_TRACK_POLARIS)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "track format %d: a track made from arrays is PB_TRACK_CSV "
                        "(poses about a centre), PB_TRACK_MATRIX_CSV or PB_TRACK_POLARIS (maps about the origin)",
                        (int)format);
    if (!source)
        source = "the track";
    if (count < 2)
        return pb_error(NULL, count ? PB_ERR_TRACK_GAP : PB_ERR_INVALID_ARGUMENT, "%s: %zu pose%s; a track needs at "
                        "least two (the frame's start and end)", source, count, count == 1 ? "" : "s");
    pb_track *t = calloc(1, sizeof *t);
    if (!t || !(t->source = strdup(source))) {
        free(t);
        return pb_error(NULL, PB_ERR_OUT_OF_MEMORY, "out of memory for the track %s", source);
    }
    t->format = format;
    pb_status st = PB_OK;
    for (size_t i = 0; i < count && st == PB_OK; i++) {
        size_t line = lines ? lines[i] : i + 1;
        pb_pose p = poses[i];
        if (!isfinite(times[i]))
            st = pb_error(NULL, PB_ERR_NOT_FINITE, "%s: sample %zu's time is %g; give finite seconds", source, i,
                          times[i]);
        else if (!pb_all_finite(p.translation, 3) || !pb_all_finite(p.rotation, 4))
            st = pb_error(NULL, PB_ERR_NOT_FINITE, "%s: sample %zu holds NaN or infinity; give finite mm and unit "
                          "quaternions", source, i);
        else if ((st = pb_track_unit_quaternion(source, line, poses[i].rotation, 1, p.rotation)) == PB_OK)
            st = pb_track_append(source, line, times[i], &p, missing ? missing[i] : 0, t);
    }
    if (st != PB_OK)
        pb_track_free(t);
    else
        *track = t;
    return st;
}

const char *pb_track_source(const pb_track *track)
{
    return track ? track->source : NULL;
}

size_t pb_track_count(const pb_track *track)
{
    return track ? track->count : 0;
}

pb_track_format pb_track_get_format(const pb_track *track)
{
    return track ? track->format : PB_TRACK_AUTO;
}

const double *pb_track_times(const pb_track *track)
{
    return track ? track->times : NULL;
}

const pb_pose *pb_track_poses(const pb_track *track)
{
    return track ? track->poses : NULL;
}

const size_t *pb_track_lines(const pb_track *track)
{
    return track ? track->lines : NULL;
}

const size_t *pb_track_missing(const pb_track *track)
{
    return track ? track->missing : NULL;
}

const char *pb_track_format_name(pb_track_format format)
{
    switch (format) {
    case PB_TRACK_AUTO: return "auto";
    case PB_TRACK_CSV: return "csv";
    case PB_TRACK_MATRIX_CSV: return "matrix-csv";
    case PB_TRACK_POLARIS: return "polaris";
    }
    return "unknown";
}

pb_status pb_track_format_parse(const char *name, pb_track_format *format)
{
    if (!format)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the format pointer must not be NULL");
    for (int i = PB_TRACK_AUTO; name && i <= PB_TRACK_POLARIS; i++)
        if (!strcmp(name, pb_track_format_name((pb_track_format)i))) {
            *format = (pb_track_format)i;
            return PB_OK;
        }
    return pb_error(NULL, PB_ERR_INVALID_ARGUMENT,
                    "format '%.200s': choose auto (from the file's content), csv (t,tx,ty,tz,qw,qx,qy,qz), matrix-csv "
                    "(t and a 3x4 matrix row by row, as yrt-pet writes) or polaris (NDI .mt or Toolviewer CSV)",
                    name ? name : "(none)");
}
