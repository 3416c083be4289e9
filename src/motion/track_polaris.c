/* NDI Polaris logs, in the two layouts STIR reads (its experimental/motion/
 * Polaris_MT_File.cxx):
 *  - .mt: a first line "DD/MM/YYYY hh:mm:ss - v1 v2 tool", then records
 *    "time rand tool q0 qx qy qz tx ty tz rms" (time in seconds since midnight)
 *    and "time rand tool : ---- Missing ----";
 *  - NDI Toolviewer CSV: "Collection Data ..." first, a date line, then the
 *    header "Frame,Q0,Qx,Qy,Qz,x,y,z,Error,OOV" and records on a 60 Hz frame
 *    clock, "frame, MISSING" where the tool was not seen; time is counted from
 *    the first complete record, as STIR does.
 * Each record is the tool's pose in the tracker's frame, p_tracker = R(q)
 * p_tool + t in mm (NDI's manual), with a quaternion that need not be unit.
 * Lines are read field by field, numbers by numbers.h's grammar, so anything
 * else is refused with its line (docs/motion.md, "Layouts"), where STIR's
 * sscanf would take hex floats, inf and nan. */
#include <stdio.h>
#include <string.h>

#include "error.h"
#include "numbers.h"
#include "track.h"

#define TOOLVIEWER_HZ 60.0
/* Frame numbers of at most 15 digits: their differences stay exact in a
 * double (below 2^53), and 10^15 frames at 60 Hz are 500,000 years. */
#define MAX_FRAME 999999999999999LL
/* rand and OOV, unsigned int as NDI and STIR write them. */
#define MAX_UNSIGNED 4294967295LL

enum { MT_FIELDS = 11, TOOLVIEWER_FIELDS = 10 };

static const char *const mt_names[MT_FIELDS] = {"time", "rand", "tool", "q0", "qx", "qy", "qz", "tx", "ty", "tz",
                                                "rms"};
static const char *const toolviewer_names[TOOLVIEWER_FIELDS] = {"Frame", "Q0", "Qx", "Qy", "Qz", "x", "y", "z",
                                                                "Error", "OOV"};

/* Splits line at runs of blanks (.mt) or at each comma (Toolviewer), each
 * field trimmed. Returns the number of fields; a line of more than max gets
 * max + 1, the last field holding the rest of the line. A blank line has no
 * fields in .mt, one empty field in CSV. */
static int split(char *line, char **fields, int max, int commas)
{
    char *s = pb_track_trim(line);
    if (!commas && !*s)
        return 0;
    for (int n = 0;; n++) {
        if (n == max) {
            fields[n] = s;
            return max + 1;
        }
        size_t len = 0;
        while (s[len] && (commas ? s[len] != ',' : !pb_track_blank(s[len])))
            len++;
        int more = s[len] != '\0';
        s[len] = '\0';
        fields[n] = pb_track_trim(s);
        if (!more)
            return n + 1;
        s += len + 1;
        while (!commas && pb_track_blank(*s))
            s++;
    }
}

/* A record's pose, normalised (NDI's quaternions need not be unit), after the
 * missing samples before it. */
static pb_status add_record(const char *path, size_t lineno, double t, const double q[4], const double tr[3],
                            size_t *missing, pb_track *track)
{
    pb_pose p;
    memcpy(p.translation, tr, sizeof p.translation);
    pb_status st = pb_track_unit_quaternion(path, lineno, q, 0, p.rotation);
    if (st == PB_OK)
        st = pb_track_append(path, lineno, t, &p, *missing, track);
    *missing = 0;
    return st;
}

/* .mt fields 0-2, time rand tool, which missing samples carry too. */
static pb_status mt_stamp(const char *path, size_t lineno, char **f, double *t)
{
    long long rand;
    pb_status st = pb_number_read(path, lineno, "time", f[0], t);
    if (st == PB_OK)
        st = pb_whole_read(path, lineno, "rand", f[1], 0, MAX_UNSIGNED, &rand);
    if (st == PB_OK && strlen(f[2]) != 1)
        st = pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: the tool is '%.40s', not one character (such as A); fix "
                      "that line", path, lineno, f[2]);
    return st;
}

/* "time rand tool : ---- Missing ----", as STIR reads it: what follows the
 * tool, blanks aside, is ":----Missing----". */
static int mt_missing(char **f, int n)
{
    static const char word[] = ":----Missing----";
    size_t k = 0;
    for (int i = 3; i < n; i++)
        for (const char *c = f[i]; *c; c++)
            if (!pb_track_blank(*c) && (k == sizeof word - 1 || *c != word[k++]))
                return 0;
    return k == sizeof word - 1;
}

static pb_status read_mt(const char *path, FILE *f, pb_track *track)
{
    char line[4096], *fields[MT_FIELDS + 1];
    size_t missing = 0;
    for (size_t lineno = 2;; lineno++) {
        int got = pb_track_line(path, f, lineno, line, sizeof line);
        if (got != 1)
            return (pb_status)got;
        int n = split(line, fields, MT_FIELDS, 0);
        if (n == 0)
            continue;
        double t, v[8];
        if (mt_missing(fields, n)) {
            pb_status st = mt_stamp(path, lineno, fields, &t);
            if (st != PB_OK)
                return st;
            missing++;
            continue;
        }
        if (n != MT_FIELDS)
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: %s%d fields, not a Polaris record 'time rand tool q0 qx "
                            "qy qz tx ty tz rms' (11) nor 'time rand tool : ---- Missing ----'; fix or drop that "
                            "line", path, lineno, n > MT_FIELDS ? "more than " : "", n > MT_FIELDS ? MT_FIELDS : n);
        pb_status st = mt_stamp(path, lineno, fields, &t);
        for (int i = 0; i < 8 && st == PB_OK; i++)
            st = pb_number_read(path, lineno, mt_names[3 + i], fields[3 + i], &v[i]);
        if (st == PB_OK)
            st = add_record(path, lineno, t, v, v + 4, &missing, track);
        if (st != PB_OK)
            return st;
    }
}

/* The header line, "Frame,Q0,Qx,Qy,Qz,x,y,z,Error,OOV" in any case: the
 * columns are read by position, so any other header is refused. */
static pb_status toolviewer_header(const char *path, size_t lineno, char **f, int n)
{
    int same = n == TOOLVIEWER_FIELDS;
    for (int i = 0; same && i < n; i++) {
        pb_track_lower(f[i]);
        char want[8];
        snprintf(want, sizeof want, "%s", toolviewer_names[i]);
        pb_track_lower(want);
        same = !strcmp(f[i], want);
    }
    return same ? PB_OK : pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: a Toolviewer header other than 'Frame,Q0,Qx,Qy,"
                                   "Qz,x,y,z,Error,OOV'; petblur reads those columns in that order only", path,
                                   lineno);
}

static pb_status read_toolviewer(const char *path, FILE *f, pb_track *track)
{
    char line[4096], *fields[TOOLVIEWER_FIELDS + 1];
    size_t missing = 0;
    long long first = 0;
    int header = 0, records = 0;
    for (size_t lineno = 2;; lineno++) {
        int got = pb_track_line(path, f, lineno, line, sizeof line);
        if (got != 1)
            return (pb_status)got;
        int n = split(line, fields, TOOLVIEWER_FIELDS, 1);
        pb_status st = PB_OK;
        if (!header) { /* the date line and a blank line come before the header */
            char word[8];
            snprintf(word, sizeof word, "%s", fields[0]);
            pb_track_lower(word);
            header = !strcmp(word, "frame");
            if (header && (st = toolviewer_header(path, lineno, fields, n)) != PB_OK)
                return st;
            continue;
        }
        if (n == 1 && !*fields[0])
            continue;
        long long frame;
        if (n == 2 && !strcmp(fields[1], "MISSING")) {
            if ((st = pb_whole_read(path, lineno, "Frame", fields[0], 1, MAX_FRAME, &frame)) != PB_OK)
                return st;
            missing++;
            continue;
        }
        if (n != TOOLVIEWER_FIELDS)
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: %s%d fields, not a Toolviewer record 'Frame,Q0,Qx,Qy,Qz,"
                            "x,y,z,Error,OOV' (10) nor 'frame, MISSING'; fix or drop that line", path, lineno,
                            n > TOOLVIEWER_FIELDS ? "more than " : "", n > TOOLVIEWER_FIELDS ? TOOLVIEWER_FIELDS : n);
        double v[8];
        long long oov;
        st = pb_whole_read(path, lineno, "Frame", fields[0], 1, MAX_FRAME, &frame);
        for (int i = 0; i < 8 && st == PB_OK; i++)
            st = pb_number_read(path, lineno, toolviewer_names[1 + i], fields[1 + i], &v[i]);
        if (st == PB_OK)
            st = pb_whole_read(path, lineno, "OOV", fields[9], 0, MAX_UNSIGNED, &oov);
        if (st != PB_OK)
            return st;
        if (!records++) /* time counts from the first complete record, as STIR counts it */
            first = frame;
        st = add_record(path, lineno, (double)(frame - first) / TOOLVIEWER_HZ, v, v + 4, &missing, track);
        if (st != PB_OK)
            return st;
    }
}

/* "D/M/Y h:m:s -" with digits for each letter: the first line of a .mt. */
static int mt_first_line(const char *s)
{
    static const char pattern[] = "0/0/0 0:0:0 -"; /* 0: digits; ' ': blanks */
    for (const char *p = pattern; *p; p++) {
        size_t n = 0;
        if (*p == '0')
            while (s[n] >= '0' && s[n] <= '9')
                n++;
        else if (*p == ' ')
            while (pb_track_blank(s[n]))
                n++;
        else
            n = *s == *p;
        if (n == 0)
            return 0;
        s += n;
    }
    return 1;
}

int pb_polaris_layout(const char *first_line)
{
    if (!strncmp(first_line, "Collection Data", 15))
        return 2;
    return mt_first_line(first_line);
}

pb_status pb_track_read_polaris(const char *path, FILE *f, pb_track *track)
{
    char line[4096];
    int got = pb_track_line(path, f, 1, line, sizeof line);
    if (got != 1)
        return got ? (pb_status)got : pb_error(NULL, PB_ERR_BAD_FILE, "%s: the file is empty", path);
    const char *s = strncmp(line, "\xEF\xBB\xBF", 3) ? line : line + 3; /* as detection skips it */
    int layout = pb_polaris_layout(s);
    if (layout == 2)
        return read_toolviewer(path, f, track);
    if (layout == 1)
        return read_mt(path, f, track);
    return pb_error(NULL, PB_ERR_BAD_FILE, "%s:1: not a Polaris log: an .mt file starts 'DD/MM/YYYY hh:mm:ss - v1 v2 "
                    "tool', a Toolviewer CSV 'Collection Data'; check --motion-format", path);
}
