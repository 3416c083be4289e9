/* NDI Polaris logs, in the two layouts STIR reads (src/experimental/motion/
 * Polaris_MT_File.cxx):
 *  - .mt: a first line "DD/MM/YYYY hh:mm:ss - v1 v2 tool", then records
 *    "time rand tool q0 qx qy qz tx ty tz rms" (time in seconds since midnight)
 *    and "time rand tool : ---- Missing ----";
 *  - NDI Toolviewer CSV: "Collection Data ..." first, a date line, then the
 *    header "Frame,Q0,Qx,Qy,Qz,x,y,z,Error,OOV" and records on a 60 Hz frame
 *    clock, "frame, MISSING" where the tool was not seen; time is counted from
 *    the first complete record, as STIR does.
 * Each record is the tool's pose in the tracker's frame, p_tracker = R(q)
 * p_tool + t in mm (NDI's manual), with a quaternion that need not be unit. */
#include <math.h>
#include <string.h>

#include "error.h"
#include "track.h"

#define TOOLVIEWER_HZ 60.0

static int missing_line(const char *s)
{
    return strstr(s, "---- Missing ----") || strstr(s, "MISSING");
}

static pb_status add_record(const char *path, size_t lineno, double t, const double q[4], const double tr[3],
                            size_t *missing, pb_track *track)
{
    pb_pose p;
    for (int i = 0; i < 3; i++)
        if (!isfinite(tr[i]) || !isfinite(q[i]) || !isfinite(q[3]))
            return pb_error(NULL, PB_ERR_NOT_FINITE, "%s:%zu: a record holds NaN or infinity; drop or repair it",
                            path, lineno);
    memcpy(p.translation, tr, sizeof p.translation);
    pb_status st = pb_track_unit_quaternion(path, lineno, q, 0, p.rotation);
    if (st == PB_OK)
        st = pb_track_append(path, lineno, t, &p, *missing, track);
    *missing = 0;
    return st;
}

static pb_status read_mt(const char *path, FILE *f, pb_track *track)
{
    char line[4096], tool;
    size_t missing = 0;
    unsigned rand;
    for (size_t lineno = 2;; lineno++) {
        int got = pb_track_line(path, f, lineno, line, sizeof line);
        if (got != 1)
            return (pb_status)got;
        double t, q[4], tr[3], rms;
        int end = 0;
        if (!line[strspn(line, " \t")])
            continue;
        if (missing_line(line)) {
            missing++;
            continue;
        }
        if (sscanf(line, "%lf %u %c %lf %lf %lf %lf %lf %lf %lf %lf %n", &t, &rand, &tool, &q[0], &q[1], &q[2],
                   &q[3], &tr[0], &tr[1], &tr[2], &rms, &end) != 11 || line[end] || !isfinite(t))
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: not a Polaris record 'time rand tool q0 qx qy qz tx ty tz "
                            "rms' nor '---- Missing ----'; fix or drop that line", path, lineno);
        pb_status st = add_record(path, lineno, t, q, tr, &missing, track);
        if (st != PB_OK)
            return st;
    }
}

static pb_status read_toolviewer(const char *path, FILE *f, pb_track *track)
{
    char line[4096];
    size_t missing = 0;
    long long first = -1;
    int header = 0;
    for (size_t lineno = 2;; lineno++) {
        int got = pb_track_line(path, f, lineno, line, sizeof line);
        if (got != 1)
            return (pb_status)got;
        long long frame;
        double q[4], tr[3], err;
        unsigned oov;
        int end = 0;
        if (!header) { /* the date line and a blank line come before the header */
            header = strstr(line, "Frame") && strstr(line, "Q0");
            continue;
        }
        if (!line[strspn(line, " \t")])
            continue;
        if (missing_line(line)) {
            missing++;
            continue;
        }
        if (sscanf(line, " %lld , %lf , %lf , %lf , %lf , %lf , %lf , %lf , %lf , %u %n", &frame, &q[0], &q[1], &q[2],
                   &q[3], &tr[0], &tr[1], &tr[2], &err, &oov, &end) != 10 || line[end])
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu: not a Toolviewer record 'Frame,Q0,Qx,Qy,Qz,x,y,z,Error,"
                            "OOV' nor 'frame, MISSING'; fix or drop that line", path, lineno);
        first = first < 0 ? frame : first;
        double t = ((double)frame - (double)first) / TOOLVIEWER_HZ;
        pb_status st = add_record(path, lineno, t, q, tr, &missing, track);
        if (st != PB_OK)
            return st;
    }
}

int pb_polaris_layout(const char *first_line)
{
    int d, mo, y, h, mi, s, n = 0;
    if (!strncmp(first_line, "Collection Data", 15))
        return 2;
    return sscanf(first_line, "%d/%d/%d %d:%d:%d -%n", &d, &mo, &y, &h, &mi, &s, &n) == 6 && n > 0;
}

pb_status pb_track_read_polaris(const char *path, FILE *f, pb_track *track)
{
    char line[4096];
    int got = pb_track_line(path, f, 1, line, sizeof line);
    if (got != 1)
        return got ? (pb_status)got : pb_error(NULL, PB_ERR_BAD_FILE, "%s: the file is empty", path);
    int layout = pb_polaris_layout(line);
    if (layout == 2)
        return read_toolviewer(path, f, track);
    if (layout == 1)
        return read_mt(path, f, track);
    return pb_error(NULL, PB_ERR_BAD_FILE, "%s:1: not a Polaris log: an .mt file starts 'DD/MM/YYYY hh:mm:ss - v1 v2 "
                    "tool', a Toolviewer CSV 'Collection Data'; check --motion-format", path);
}
