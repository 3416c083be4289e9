/* The public track readers (pb_track_read): files of every format written
 * here from fresh random poses (unit quaternions, Polaris's scaled as NDI's
 * manual allows), with comments, blank lines and missing samples between
 * them, must read back as written, to the precision they were printed with,
 * each pose with its line and its missing samples; broken files must be
 * refused with their own status and a message naming the file and line, and
 * NULL arguments cleanly. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "testlib.h"

#define MAX_POSES 64
/* The error of a number printed with d decimals, with room for double's own
 * rounding of numbers below 1e5 (half an ulp: 7e-12). A time printed in ms
 * with d decimals is off by that in seconds with d + 3. */
#define PRINTED(d) (0.5 * pow(10.0, -(d)) + 1e-11)

typedef struct expected {
    size_t n;
    double times[MAX_POSES];
    pb_pose poses[MAX_POSES];
    size_t lines[MAX_POSES], missing[MAX_POSES];
} expected;

typedef struct tolerance {
    double time, translation, rotation;
} tolerance;

static char dir[64];
static char path[128];

static void random_quaternion(double q[4])
{
    double n2;
    do {
        for (int i = 0; i < 4; i++)
            q[i] = pb_rand_range(-1.0, 1.0);
        n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    } while (n2 < 0.01 || n2 > 1.0);
    for (int i = 0; i < 4; i++)
        q[i] /= sqrt(n2);
}

/* n fresh poses at increasing times from t0, steps of 0.01 to 1 s. */
static void random_track(expected *e, size_t n, double t0)
{
    memset(e, 0, sizeof *e);
    e->n = n;
    for (size_t i = 0; i < n; i++) {
        e->times[i] = (i ? e->times[i - 1] : t0) + pb_rand_range(0.01, 1.0);
        for (int k = 0; k < 3; k++)
            e->poses[i].translation[k] = pb_rand_range(-50.0, 50.0);
        random_quaternion(e->poses[i].rotation);
    }
}

static FILE *open_file(const char *name)
{
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    if (!f) {
        perror(path);
        exit(1);
    }
    return f;
}

/* Now and then a comment or a blank line, which readers skip; returns the
 * lines written. */
static size_t noise(FILE *f, int comments)
{
    double u = pb_rand_uniform();
    if (u < 0.1)
        fputs(comments ? "# a logger's comment\n" : "\n", f);
    return u < 0.1;
}

/* Rotations compare up to sign when sign_free (a matrix gives w >= 0). */
static double rotation_error(const double a[4], const double b[4], int sign_free)
{
    double plus = 0.0, minus = 0.0;
    for (int k = 0; k < 4; k++) {
        plus = fmax(plus, fabs(a[k] - b[k]));
        minus = fmax(minus, fabs(a[k] + b[k]));
    }
    return sign_free ? fmin(plus, minus) : plus;
}

static void compare(const char *what, const pb_track *t, pb_track_format format, const expected *e,
                    const tolerance *tol, int sign_free)
{
    if (!pb_check(t && pb_track_count(t) == e->n, "%s: %zu poses read, %zu written", what, pb_track_count(t), e->n))
        return;
    pb_check(pb_track_get_format(t) == format, "%s: format %s, want %s", what,
             pb_track_format_name(pb_track_get_format(t)), pb_track_format_name(format));
    const double *times = pb_track_times(t);
    const pb_pose *poses = pb_track_poses(t);
    const size_t *lines = pb_track_lines(t), *missing = pb_track_missing(t);
    double dt = 0.0, dtr = 0.0, dq = 0.0;
    size_t bad_lines = 0;
    for (size_t i = 0; i < e->n; i++) {
        dt = fmax(dt, fabs(times[i] - e->times[i]));
        for (int k = 0; k < 3; k++)
            dtr = fmax(dtr, fabs(poses[i].translation[k] - e->poses[i].translation[k]));
        dq = fmax(dq, rotation_error(poses[i].rotation, e->poses[i].rotation, sign_free));
        bad_lines += lines[i] != e->lines[i] || missing[i] != e->missing[i];
    }
    pb_check(dt <= tol->time, "%s: times off by %.3g (tolerance %.3g)", what, dt, tol->time);
    pb_check(dtr <= tol->translation, "%s: translations off by %.3g (tolerance %.3g)", what, dtr, tol->translation);
    pb_check(dq <= tol->rotation, "%s: quaternions off by %.3g (tolerance %.3g)", what, dq, tol->rotation);
    pb_check(bad_lines == 0, "%s: %zu poses with the wrong line or missing count", what, bad_lines);
}

/* Reads path, checks the track against e, and frees it. */
static void read_back(const char *what, const pb_track_read_options *o, pb_track_format format, const expected *e,
                      const tolerance *tol, int sign_free)
{
    pb_track *t = NULL;
    pb_status st = pb_track_read(path, o, &t);
    if (pb_check(st == PB_OK, "%s: %s: %s", what, pb_status_string(st), pb_last_error(NULL)))
        compare(what, t, format, e, tol, sign_free);
    pb_track_free(t);
}

/* ---- the formats ------------------------------------------------------------ */

/* petblur's csv: columns by name in a shuffled order, an extra one; or the
 * quaternion numbered q0..q3 in x,y,z,w order, times in ms. */
static void test_csv(int numbered)
{
    static const char *named[9] = {"t", "tx", "ty", "tz", "qw", "qx", "qy", "qz", "extra"};
    static const char *numbers[9] = {"time", "tx", "ty", "tz", "q3", "q0", "q1", "q2", "extra"};
    const char **names = numbered ? numbers : named;
    int order[9] = {0, 1, 2, 3, 4, 5, 6, 7, 8};
    for (int i = 8; i > 0; i--) {
        int j = (int)(pb_rand_uniform() * (i + 1)), s = order[i];
        order[i] = order[j];
        order[j] = s;
    }
    expected e;
    random_track(&e, 2 + (size_t)(pb_rand_uniform() * 40), pb_rand_range(-100.0, 100.0));
    FILE *f = open_file(numbered ? "numbered.csv" : "named.csv");
    for (int c = 0; c < 9; c++)
        fprintf(f, "%s%s", c ? "," : "", names[order[c]]);
    fputc('\n', f);
    size_t line = 1;
    for (size_t i = 0; i < e.n; i++) {
        line += noise(f, 1);
        const pb_pose *p = &e.poses[i];
        double v[9] = {numbered ? 1000.0 * e.times[i] : e.times[i], p->translation[0], p->translation[1],
                       p->translation[2], p->rotation[0], p->rotation[1], p->rotation[2], p->rotation[3], 42.0};
        for (int c = 0; c < 9; c++)
            fprintf(f, "%s%.*f", c ? "," : "", order[c] == 0 ? (numbered ? 6 : 9) : order[c] < 4 ? 6 : 9,
                    v[order[c]]);
        fputs(pb_rand_uniform() < 0.5 ? "\n" : "\r\n", f);
        e.lines[i] = ++line;
    }
    fclose(f);
    tolerance tol = {PRINTED(9), PRINTED(6), PRINTED(9)};
    if (numbered) {
        pb_track_read_options o = {PB_TRACK_CSV, 1000.0, 1};
        read_back("csv, numbered x,y,z,w, ms", &o, PB_TRACK_CSV, &e, &tol, 0);
    } else {
        pb_track_read_options zero;
        memset(&zero, 0, sizeof zero);
        read_back("csv, named, NULL options", NULL, PB_TRACK_CSV, &e, &tol, 0);
        read_back("csv, named, zero options", &zero, PB_TRACK_CSV, &e, &tol, 0);
    }
}

/* yrt-pet's matrices: with a header, or without one as yrt-pet writes them
 * (blanks between fields, ms, an error column). */
static void test_matrix(int yrt)
{
    expected e;
    random_track(&e, 2 + (size_t)(pb_rand_uniform() * 40), pb_rand_range(0.0, 100.0));
    FILE *f = open_file(yrt ? "yrt.txt" : "matrix.csv");
    size_t line = 0;
    if (!yrt) {
        fputs("t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz\n", f);
        line++;
    }
    for (size_t i = 0; i < e.n; i++) {
        double m[16];
        pb_pose_to_matrix(&e.poses[i], m);
        fprintf(f, yrt ? "%.6f" : "%.9f", yrt ? 1000.0 * e.times[i] : e.times[i]);
        for (int k = 0; k < 12; k++)
            fprintf(f, yrt ? " %.*f" : ",%.*f", k % 4 == 3 ? 6 : 12, m[k]);
        fputs(yrt ? " 0.25\n" : "\n", f);
        e.lines[i] = ++line;
    }
    fclose(f);
    /* Entries off by d = 5e-13 move the quaternion by a few d; 1e-10 is room. */
    tolerance tol = {PRINTED(9), PRINTED(6), 1e-10};
    pb_track_read_options o = {PB_TRACK_AUTO, yrt ? 1000.0 : 0.0, 0};
    read_back(yrt ? "matrix-csv, yrt-pet's" : "matrix-csv, header", &o, PB_TRACK_MATRIX_CSV, &e, &tol, 1);
}

/* NDI's quaternions need not be unit: a factor of 0.5 to 2, now and then
 * times 1e200 or 1e-170, whose squares overflow and underflow a double. */
static double ndi_scale(void)
{
    double u = pb_rand_uniform(), s = pb_rand_range(0.5, 2.0);
    return u < 0.1 ? 1e200 * s : u < 0.2 ? 1e-170 * s : s;
}

/* A Polaris .mt log: seconds since midnight, quaternions scaled (ndi_scale),
 * runs of missing samples. */
static void test_polaris_mt(void)
{
    expected e;
    random_track(&e, 2 + (size_t)(pb_rand_uniform() * 40), 40000.0);
    FILE *f = open_file("log.mt");
    fputs("23/5/2003 18:18:32 - 11 1 966_IRSL_II\n", f);
    size_t line = 1;
    for (size_t i = 0; i < e.n; i++) {
        for (; pb_rand_uniform() < 0.3; e.missing[i]++, line++)
            fprintf(f, "%.6f %zu A : ---- Missing ----\n", e.times[i] - 0.001 * (double)(e.missing[i] + 1), i);
        line += noise(f, 0);
        const pb_pose *p = &e.poses[i];
        double s = ndi_scale();
        fprintf(f, "%.6f %zu A %.9e %.9e %.9e %.9e %.6f %.6f %.6f 0.18\n", e.times[i], i, s * p->rotation[0],
                s * p->rotation[1], s * p->rotation[2], s * p->rotation[3], p->translation[0], p->translation[1],
                p->translation[2]);
        e.lines[i] = ++line;
    }
    fclose(f);
    /* Each part off by 5e-10 of it (%.9e), so its share of the norm too:
     * normalised, off by 4 x 5e-10 at most. */
    tolerance tol = {PRINTED(6), PRINTED(6), 8.0 * PRINTED(9)};
    read_back("polaris .mt", NULL, PB_TRACK_POLARIS, &e, &tol, 0);
}

/* NDI Toolviewer's CSV: a 60 Hz frame clock counted from the first record,
 * missing frames before it too; frame numbers positive, negative, or both. */
static void test_polaris_toolviewer(void)
{
    expected e;
    random_track(&e, 2 + (size_t)(pb_rand_uniform() * 40), 0.0);
    FILE *f = open_file("toolviewer.csv");
    fputs("Collection Data : Port 0B  ( ICL          S/N: 3608C803 Type: 01000000 Rev: 000 )\n"
          "[June 25, 2010  04:00PM]\n\n"
          "Frame,         Q0,         Qx,         Qy,         Qz,          x,          y,          z,"
          "      Error,        OOV\n", f);
    size_t line = 4;
    long long frame = (long long)pb_rand_range(-402115.0, 402115.0), first = 0;
    if (pb_rand_uniform() < 0.3) /* counting up through 0 */
        frame = -(long long)(pb_rand_uniform() * 30);
    for (size_t i = 0; i < e.n; i++) {
        for (; pb_rand_uniform() < 0.3; e.missing[i]++, line++)
            fprintf(f, "   %lld,    MISSING\n", frame++);
        first = i ? first : frame;
        e.times[i] = (double)(frame - first) / 60.0;
        const pb_pose *p = &e.poses[i];
        double s = ndi_scale();
        fprintf(f, "%lld, %.9e, %.9e, %.9e, %.9e, %.6f, %.6f, %.6f, 0.1834, 0\n", frame, s * p->rotation[0],
                s * p->rotation[1], s * p->rotation[2], s * p->rotation[3], p->translation[0], p->translation[1],
                p->translation[2]);
        e.lines[i] = ++line;
        frame += 1 + (long long)(pb_rand_uniform() * 4);
    }
    fclose(f);
    tolerance tol = {1e-12, PRINTED(6), 8.0 * PRINTED(9)};
    read_back("polaris toolviewer", NULL, PB_TRACK_POLARIS, &e, &tol, 0);
}

/* ---- refusals ----------------------------------------------------------------- */

/* Writes a file of n good rows (times 0, 1, ...) with a random row but the
 * first replaced by text, reads it and checks the status and that the message
 * names file and line. */
static void expect_bad_row(const char *what, const char *header, const char *text, pb_status want,
                           const char *needle)
{
    size_t n = 3 + (size_t)(pb_rand_uniform() * 10), bad = 1 + (size_t)(pb_rand_uniform() * (double)(n - 1));
    FILE *f = open_file("bad.csv");
    fprintf(f, "%s\n", header);
    for (size_t i = 0; i < n; i++)
        if (i == bad)
            fprintf(f, "%s\n", text);
        else if (!strncmp(header, "t,r00", 5))
            fprintf(f, "%zu,1,0,0,%zu,0,1,0,0,0,0,1,0\n", i, i);
        else
            fprintf(f, "%zu,%zu,0,0,1,0,0,0\n", i, i);
    fclose(f);
    char where[160];
    snprintf(where, sizeof where, "%s:%zu: ", path, bad + 2);
    pb_track *t = (pb_track *)&where; /* must come back NULL */
    pb_status st = pb_track_read(path, NULL, &t);
    const char *msg = pb_last_error(NULL);
    pb_check(st == want, "%s: got %s, want %s: %s", what, pb_status_string(st), pb_status_string(want), msg);
    pb_check(t == NULL, "%s: a track left after a refusal", what);
    pb_check(!strncmp(msg, where, strlen(where)) && strstr(msg, needle), "%s: \"%s\" should start \"%s\" and say "
             "\"%s\"", what, msg, where, needle);
}

/* A whole file and its refusal: status, and what the message starts with. */
static void expect_bad_file(const char *what, const char *text, size_t size, const pb_track_read_options *o,
                            pb_status want, const char *start)
{
    FILE *f = open_file("whole.csv");
    fwrite(text, 1, size, f);
    fclose(f);
    char prefix[192];
    snprintf(prefix, sizeof prefix, "%s%s", path, start);
    pb_track *t = NULL;
    pb_status st = pb_track_read(path, o, &t);
    const char *msg = pb_last_error(NULL);
    pb_check(st == want && t == NULL, "%s: got %s, want %s: %s", what, pb_status_string(st), pb_status_string(want),
             msg);
    pb_check(!strncmp(msg, prefix, strlen(prefix)), "%s: \"%s\" should start \"%s\"", what, msg, prefix);
}

/* A file of the literal's bytes, NUL bytes included. */
#define BAD_FILE(what, literal, o, want, start) expect_bad_file(what, literal, sizeof literal - 1, o, want, start)

/* Numbers and layouts: hex, inf and nan in every format, a header that names
 * a column twice, the Polaris layouts' fields; each with its line. */
static void test_layout_refusals(void)
{
    static const char mt[] = "23/5/2003 18:18:32 - 11 1 tool\n", tv[] = "Collection Data\n[June 25, 2010  04:00PM]"
                             "\n\nFrame,Q0,Qx,Qy,Qz,x,y,z,Error,OOV\n";
    static const struct {
        const char *what, *text;
        pb_status status;
        const char *start;
    } cases[] = {
        {"mt hex", "1 2 A 0x1p0 0 0 0 1 2 3 0.1\n", PB_ERR_BAD_FILE, ":2: q0 is '0x1p0', not a number"},
        {"mt hex time", "0x10 2 A 1 0 0 0 1 2 3 0.1\n", PB_ERR_BAD_FILE, ":2: time is '0x10', not a number"},
        {"mt inf", "1 2 A 1 0 0 0 1 inf 3 0.1\n", PB_ERR_BAD_FILE, ":2: ty is 'inf', not a number"},
        {"mt nan rms", "\n1 2 A 1 0 0 0 1 2 3 NaN\n", PB_ERR_BAD_FILE, ":3: rms is 'NaN', not a number"},
        {"mt overflow", "1 2 A 1 0 0 0 1 2 -1e400 0.1\n", PB_ERR_NOT_FINITE, ":2: tz is '-1e400', beyond"},
        {"mt tool", "1 2 AB 1 0 0 0 1 2 3 0.1\n", PB_ERR_BAD_FILE, ":2: the tool is 'AB', not one character"},
        {"mt rand", "1 -2 A 1 0 0 0 1 2 3 0.1\n", PB_ERR_BAD_FILE, ":2: rand is '-2', not a whole number"},
        {"mt missing hex", "0x1 2 A : ---- Missing ----\n", PB_ERR_BAD_FILE, ":2: time is '0x1'"},
        {"mt zero", "1 2 A 0 0 0 0 1 2 3 0.1\n", PB_ERR_BAD_QUATERNION, ":2: the quaternion is zero"},
        {"mt 12 fields", "1 2 A 1 0 0 0 1 2 3 0.1 9\n", PB_ERR_BAD_FILE, ":2: more than 11 fields"},
        {"tv hex", "5, 0x1p0, 0, 0, 0, 1, 2, 3, 0.1, 0\n", PB_ERR_BAD_FILE, ":5: Q0 is '0x1p0', not a number"},
        {"tv inf", "5, 1, 0, 0, 0, 1, 2, INF, 0.1, 0\n", PB_ERR_BAD_FILE, ":5: z is 'INF', not a number"},
        {"tv frame", "5.5, 1, 0, 0, 0, 1, 2, 3, 0.1, 0\n", PB_ERR_BAD_FILE, ":5: Frame is '5.5', not a whole"},
        {"tv frame 16 digits", "1000000000000000, MISSING\n", PB_ERR_BAD_FILE, ":5: Frame is '1000000000000000', "
         "beyond 999999999999999"},
        {"tv oov", "5, 1, 0, 0, 0, 1, 2, 3, 0.1, -1\n", PB_ERR_BAD_FILE, ":5: OOV is '-1', not a whole number"},
        {"tv 9 fields", "5, 1, 0, 0, 0, 1, 2, 3, 0.1\n", PB_ERR_BAD_FILE, ":5: 9 fields, not a Toolviewer"},
        {"tv zero", "-4, 1, 0, 0, 0, 1, 2, 3, 0.1, 0\n-3, 0, 0, 0, 0, 1, 2, 3, 0.1, 0\n", PB_ERR_BAD_QUATERNION,
         ":6: the quaternion is zero"},
        {"tv order", "-4, 1, 0, 0, 0, 1, 2, 3, 0.1, 0\n-5, 1, 0, 0, 0, 1, 2, 3, 0.1, 0\n", PB_ERR_TRACK_ORDER,
         ":6: time -0.0166"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char text[512];
        snprintf(text, sizeof text, "%s%s", !strncmp(cases[i].what, "mt", 2) ? mt : tv, cases[i].text);
        expect_bad_file(cases[i].what, text, strlen(text), NULL, cases[i].status, cases[i].start);
    }
    static const struct {
        const char *what, *header, *start;
        pb_status status;
    } headers[] = {
        {"t twice", "t,tx,ty,tz,qw,qx,qy,qz,t", ":1: the header names the time twice, 't' (column 1) and 't' "
         "(column 9)", PB_ERR_BAD_FILE},
        {"time and t", "time,tx,ty,tz,qw,qx,qy,qz,T", ":1: the header names the time twice, 'time' (column 1) and "
         "'t' (column 9)", PB_ERR_BAD_FILE},
        {"timestamp and time", "tx,ty,tz,timestamp,qw,qx,qy,qz,Time", ":1: the header names the time twice",
         PB_ERR_BAD_FILE},
        {"tx twice", "t,tx,ty,tz,qw,qx,qy,qz, TX ", ":1: the header names tx twice", PB_ERR_BAD_FILE},
        {"qz twice", "t,tx,ty,tz,qw,qx,qy,qz,qz", ":1: the header names qz twice", PB_ERR_BAD_FILE},
        {"q1 twice", "t,tx,ty,tz,q0,q1,q2,q3,q1", ":1: the header names q1 twice", PB_ERR_BAD_FILE},
        {"named and numbered", "t,tx,ty,tz,qw,qx,qy,qz,q0", ":1: the header gives the quaternion both named",
         PB_ERR_BAD_FILE},
        {"both numberings", "t,tx,ty,tz,q0,q1,q2,q3,q4", ":1: the header numbers the quaternion both",
         PB_ERR_BAD_FILE},
        {"matrix r11 twice", "t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz,r11", ":1: the header names r11 twice",
         PB_ERR_BAD_FILE},
        {"header after comments", "# logger 2.1\n\nt,tx,ty,tz,qw,qx,qy", ":3: the header has no column 'qz'",
         PB_ERR_BAD_FILE},
    };
    for (size_t i = 0; i < sizeof headers / sizeof headers[0]; i++) {
        char text[512];
        snprintf(text, sizeof text, "%s\n0,0,0,0,1,0,0,0,0\n1,0,0,0,1,0,0,0,0\n", headers[i].header);
        expect_bad_file(headers[i].what, text, strlen(text), NULL, headers[i].status, headers[i].start);
    }
    BAD_FILE("tv header", "Collection Data\n[June 25, 2010  04:00PM]\n\nframe, q0, qx, qy, qz, tx, ty, tz, error, "
             "oov\n", NULL, PB_ERR_BAD_FILE, ":4: a Toolviewer header other than");
}

static void test_refusals(void)
{
    const char *csv = "t,tx,ty,tz,qw,qx,qy,qz", *matrix = "t,r00,r01,r02,tx,r10,r11,r12,ty,r20,r21,r22,tz";
    expect_bad_row("not a number", csv, "7,1,0,0,1,0,0,abc", PB_ERR_BAD_FILE, "field qz is 'abc', not a number");
    expect_bad_row("hex", csv, "7,0x10,0,0,1,0,0,0", PB_ERR_BAD_FILE, "not a number");
    expect_bad_row("overflow", csv, "7,1e999,0,0,1,0,0,0", PB_ERR_NOT_FINITE, "field tx is '1e999', beyond");
    expect_bad_row("inf", csv, "7,1,0,0,1,0,0,-inf", PB_ERR_BAD_FILE, "field qz is '-inf', not a number");
    expect_bad_row("nan", csv, "nan,1,0,0,1,0,0,0", PB_ERR_BAD_FILE, "field t is 'nan', not a number");
    expect_bad_row("hex float", csv, "7,1,0x1p-2,0,1,0,0,0", PB_ERR_BAD_FILE, "field ty is '0x1p-2', not a number");
    expect_bad_row("decimal comma", csv, "7,1,0,0,\"1,0\",0,0,0", PB_ERR_BAD_FILE, "9 fields");
    expect_bad_row("blank inside", csv, "7,1 5,0,0,1,0,0,0", PB_ERR_BAD_FILE, "field tx is '1 5', not a number");
    expect_bad_row("empty", csv, "7,1,,0,1,0,0,0", PB_ERR_BAD_FILE, "field ty is empty");
    /* csv quaternions must be unit: one scaled by 1e200 or 1e-170 names its
     * norm, which neither overflows nor underflows to zero. */
    expect_bad_row("norm 1e200", csv, "7,1,0,0,0,1e200,0,0", PB_ERR_BAD_QUATERNION, "norm is 1e+200, not 1");
    expect_bad_row("norm 1e-170", csv, "7,1,0,0,0,0,-1e-170,0", PB_ERR_BAD_QUATERNION, "norm is 1e-170, not 1");
    expect_bad_row("fields", csv, "7,1,0,0,1,0,0", PB_ERR_BAD_FILE, "7 fields where the header has 8");
    expect_bad_row("norm", csv, "7,1,0,0,1.1,0,0,0", PB_ERR_BAD_QUATERNION, "norm is 1.1");
    expect_bad_row("zero quaternion", csv, "7,1,0,0,0,0,0,0", PB_ERR_BAD_QUATERNION, "the quaternion is zero");
    expect_bad_row("order", csv, "-1,1,0,0,1,0,0,0", PB_ERR_TRACK_ORDER, "must increase strictly");
    expect_bad_row("scaled matrix", matrix, "7,2,0,0,0,0,2,0,0,0,0,2,0", PB_ERR_NOT_RIGID, "fix that row");
    pb_track_read_options polaris_ms = {PB_TRACK_POLARIS, 1000.0, 0}, matrix_xyzw = {PB_TRACK_MATRIX_CSV, 1.0, 1};
    BAD_FILE("empty", "", NULL, PB_ERR_BAD_FILE, ": the file is empty");
    BAD_FILE("one pose", "t,tx,ty,tz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n", NULL, PB_ERR_TRACK_GAP, ": 1 pose;");
    BAD_FILE("no column", "t,tx,ty,tz,qw,qx,qy\n", NULL, PB_ERR_BAD_FILE, ":1: the header has no column 'qz'");
    BAD_FILE("no header", "1,2,3\n", NULL, PB_ERR_BAD_FILE, ":1: '1,2,3' is no header");
    BAD_FILE("NUL", "t,tx\0,ty\n", NULL, PB_ERR_BAD_FILE, ":1: holds a NUL byte");
    BAD_FILE("mt record", "23/5/2003 18:18:32 - 11 1 tool\n1 2 A 1 0 0\n", NULL, PB_ERR_BAD_FILE,
                    ":2: 6 fields, not a Polaris record");
    test_layout_refusals();
    BAD_FILE("polaris in ms", "23/5/2003 18:18:32 - 11 1 tool\n", &polaris_ms, PB_ERR_INVALID_ARGUMENT,
                    ": a Polaris log gives seconds");
    BAD_FILE("matrix xyzw", "t,r00\n", &matrix_xyzw, PB_ERR_INVALID_ARGUMENT, ": a matrix-csv track holds");
    snprintf(path, sizeof path, "%s/none.csv", dir);
    pb_track *t = NULL;
    pb_check(pb_track_read(path, NULL, &t) == PB_ERR_BAD_FILE && !t && strstr(pb_last_error(NULL), "cannot open"),
             "a missing file: %s", pb_last_error(NULL));
    pb_check(!strcmp(pb_status_string(PB_ERR_BAD_FILE), "unreadable or malformed file"), "PB_ERR_BAD_FILE's string");
}

/* What a binding can pass: NULL everywhere, formats and divisors out of range. */
static void test_arguments(void)
{
    pb_track *t = (pb_track *)dir;
    pb_check(pb_track_read(NULL, NULL, &t) == PB_ERR_INVALID_ARGUMENT && t == NULL, "NULL path refused");
    pb_check(pb_track_read(path, NULL, NULL) == PB_ERR_INVALID_ARGUMENT, "NULL track refused");
    pb_track_read_options bad[] = {{(pb_track_format)4, 1.0, 0}, {(pb_track_format)-1, 1.0, 0},
                                   {PB_TRACK_CSV, -1.0, 0}, {PB_TRACK_CSV, (double)NAN, 0},
                                   {PB_TRACK_CSV, (double)INFINITY, 0}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        t = (pb_track *)dir;
        pb_status st = pb_track_read(path, &bad[i], &t);
        pb_check(st == PB_ERR_INVALID_ARGUMENT && t == NULL && *pb_last_error(NULL), "bad options %zu: %s: %s", i,
                 pb_status_string(st), pb_last_error(NULL));
    }
    pb_track_free(NULL);
    pb_check(pb_track_count(NULL) == 0 && pb_track_get_format(NULL) == PB_TRACK_AUTO && !pb_track_times(NULL) &&
             !pb_track_poses(NULL) && !pb_track_lines(NULL) && !pb_track_missing(NULL), "a NULL track holds nothing");
    pb_check(!strcmp(pb_track_format_name(PB_TRACK_AUTO), "auto") && !strcmp(pb_track_format_name(PB_TRACK_CSV),
             "csv") && !strcmp(pb_track_format_name(PB_TRACK_MATRIX_CSV), "matrix-csv") &&
             !strcmp(pb_track_format_name(PB_TRACK_POLARIS), "polaris") &&
             !strcmp(pb_track_format_name((pb_track_format)9), "unknown"), "format names");
}

int main(void)
{
    pb_test_seed();
    const char *tmp = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/pb_track_XXXXXX", tmp && strlen(tmp) < 40 ? tmp : "/tmp");
    if (!mkdtemp(dir)) {
        perror(dir);
        return 1;
    }
    for (int round = 0; round < 20; round++) {
        test_csv(0);
        test_csv(1);
        test_matrix(0);
        test_matrix(1);
        test_polaris_mt();
        test_polaris_toolviewer();
    }
    test_refusals();
    test_arguments();
    static const char *files[] = {"named.csv", "numbered.csv", "matrix.csv", "yrt.txt", "log.mt", "toolviewer.csv",
                                  "bad.csv", "whole.csv"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, files[i]);
        remove(path);
    }
    rmdir(dir);
    return pb_test_finish();
}
