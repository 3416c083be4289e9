/* The public motion layer (include/petblur.h): calibration files, the
 * tracker conventions, a frame's part of a track, the mean pose of a frame,
 * and the checks that refuse or warn, on fresh random poses each run. Every
 * expected value is computed here another way: a pose's matrix composed by
 * hand, a mean by quadrature, a reordered quaternion by its definition. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "testlib.h"

static char dir[64];

static const char *file_with(const char *name, const char *text)
{
    static char path[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    fputs(text, f);
    fclose(f);
    return path;
}

static void random_pose(pb_pose *p, double deg, double mm)
{
    double axis[3] = {pb_rand_range(-1, 1), pb_rand_range(-1, 1), pb_rand_range(-1, 1)};
    *p = pb_test_pose(pb_rand_range(-mm, mm), pb_rand_range(-mm, mm), pb_rand_range(-mm, mm), axis,
                      pb_rand_range(-deg, deg));
}

static double pose_distance(const pb_pose *a, const pb_pose *b)
{
    double d = 0.0, dot = 0.0;
    for (int i = 0; i < 3; i++)
        d = fmax(d, fabs(a->translation[i] - b->translation[i]));
    for (int i = 0; i < 4; i++)
        dot += a->rotation[i] * b->rotation[i];
    return fmax(d, 1.0 - fabs(dot));
}

/* ---- calibration files --------------------------------------------------- */

/* A calibration's text, built value by value in a random layout: blanks, one
 * comma or semicolon, line breaks on either side of it, comments and blank
 * lines. Each value's first byte is kept, so a refusal's line is known. */
typedef struct {
    char text[4096];
    size_t used, at[16];
} cal_text;

static void cal_put(cal_text *c, const char *s)
{
    c->used += (size_t)snprintf(c->text + c->used, sizeof c->text - c->used, "%s", s);
}

static size_t cal_line(const cal_text *c, size_t offset)
{
    size_t line = 1;
    for (size_t i = 0; i < offset; i++)
        line += c->text[i] == '\n';
    return line;
}

static void cal_layout(cal_text *c, char values[][48], size_t n)
{
    static const char *const seps[] = {" ", "\t", ", ", ",", "; ", " ,\t", "  ;"};
    static const char *const breaks[] = {"\n", " # row\n", "\n\n", "\r\n", "\n# a comment line\n", "\n  \t\n"};
    c->used = 0;
    if (pb_rand_uniform() < 0.3)
        cal_put(c, pb_rand_uniform() < 0.5 ? "# tracker to scanner, mm\n" : "\n");
    for (size_t i = 0; i < n; i++) {
        if (i > 0) {
            const char *sep = seps[(size_t)(pb_rand_uniform() * 7)];
            int broken = i % 4 == 0 ? pb_rand_uniform() < 0.8 : pb_rand_uniform() < 0.1;
            const char *br = broken ? breaks[(size_t)(pb_rand_uniform() * 6)] : "";
            int after = pb_rand_uniform() < 0.5; /* the separator at the next line's start */
            cal_put(c, after ? br : sep);
            cal_put(c, after ? sep : br);
        }
        c->at[i] = c->used;
        cal_put(c, values[i]);
    }
    cal_put(c, pb_rand_uniform() < 0.8 ? "\n" : "");
}

/* One calibration's text read: the status, and for a refusal the line and
 * words its message must hold. */
static void expect_calibration(const char *what, const cal_text *c, pb_status want, size_t line, const char *words,
                               const double want_m[16])
{
    file_with("cal.txt", c->text);
    char path[128], start[160];
    snprintf(path, sizeof path, "%s/cal.txt", dir);
    snprintf(start, sizeof start, line ? "%s:%zu: " : "%s: ", path, line);
    double m[16];
    pb_status st = pb_calibration_read(path, m);
    const char *msg = pb_last_error(NULL);
    if (want == PB_OK) {
        pb_check(st == PB_OK && !memcmp(m, want_m, sizeof m), "%s: %s: %s\n%s", what, pb_status_string(st), msg,
                 c->text);
        return;
    }
    pb_check(st == want && !strncmp(msg, start, strlen(start)) && strstr(msg, words), "%s: status %d, '%s'; want "
             "%d, '%s...%s'\n%s", what, (int)st, msg, (int)want, start, words, c->text);
}

static void test_calibration_class(void)
{
    static const char *const not_numbers[] = {"0x1p3", "0X10", "inf", "-Infinity", "nan", "NaN", "1e", "1.2.3",
                                              "--1", "1e5e5", "1_0", "1'000", "0b1", "\xd9\xa1", "e5", "."};
    for (int round = 0; round < 40; round++) {
        pb_pose pose;
        random_pose(&pose, 180.0, 500.0);
        double m[16];
        pb_pose_to_matrix(&pose, m);
        size_t n = pb_rand_uniform() < 0.5 ? 12 : 16;
        char values[16][48];
        for (size_t i = 0; i < 16; i++)
            snprintf(values[i], sizeof values[i], "%.17g", m[i]);
        cal_text c;
        cal_layout(&c, values, n);
        expect_calibration("a fresh calibration", &c, PB_OK, 0, NULL, m);
        /* A 3x4 with its 4th row after ", " is the 4x4. */
        if (n == 12) {
            snprintf(values[11], sizeof values[11], "%.17g, 0 0 0 1", m[11]);
            cal_layout(&c, values, 12);
            expect_calibration("a 4th row after ', '", &c, PB_OK, 0, NULL, m);
            snprintf(values[11], sizeof values[11], "%.17g", m[11]);
        }
        /* A 17th value, on the 16th's line or the next. */
        size_t k = (size_t)(pb_rand_uniform() * 3);
        snprintf(values[15], sizeof values[15], "%.17g%s", m[15], k == 0 ? " 7" : k == 1 ? ", 0 0 0 1" : "\n\n7");
        cal_layout(&c, values, 16);
        expect_calibration("a 17th value", &c, PB_ERR_BAD_FILE, cal_line(&c, c.at[15]) + 2 * (k == 2),
                           "is a 17th value", NULL);
        snprintf(values[15], sizeof values[15], "%.17g", m[15]);
        /* 13 to 15 values: no matrix. */
        size_t count = 13 + (size_t)(pb_rand_uniform() * 3);
        cal_layout(&c, values, count);
        char words[32];
        snprintf(words, sizeof words, "%zu numbers", count);
        expect_calibration("13 to 15 values", &c, PB_ERR_BAD_FILE, 0, words, NULL);
        /* One value no number of the grammar. */
        size_t at = (size_t)(pb_rand_uniform() * (double)n);
        const char *bad = not_numbers[(size_t)(pb_rand_uniform() * 16)];
        snprintf(values[at], sizeof values[at], "%s", bad);
        cal_layout(&c, values, n);
        snprintf(words, sizeof words, "value %zu is '", at + 1);
        expect_calibration("not a number", &c, PB_ERR_BAD_FILE, cal_line(&c, c.at[at]), words, NULL);
        snprintf(values[at], sizeof values[at], "%s", pb_rand_uniform() < 0.5 ? "1e999" : "-1E+400");
        cal_layout(&c, values, n);
        expect_calibration("beyond a double", &c, PB_ERR_NOT_FINITE, cal_line(&c, c.at[at]), "beyond", NULL);
        /* An empty value: two separators, or one before the first value. */
        snprintf(values[at], sizeof values[at], "%.17g%s", m[at], pb_rand_uniform() < 0.5 ? ",," : " ; ,");
        cal_layout(&c, values, n);
        expect_calibration("an empty value", &c, PB_ERR_BAD_FILE, cal_line(&c, c.at[at]), "with no value before it",
                           NULL);
        snprintf(values[at], sizeof values[at], "%.17g", m[at]);
        snprintf(values[0], sizeof values[0], ", %.17g", m[0]);
        cal_layout(&c, values, n);
        expect_calibration("a separator first", &c, PB_ERR_BAD_FILE, cal_line(&c, c.at[0]), "with no value before",
                           NULL);
        snprintf(values[0], sizeof values[0], "%.17g", m[0]);
        snprintf(values[n - 1], sizeof values[n - 1], "%.17g;", m[n - 1]);
        cal_layout(&c, values, n);
        expect_calibration("a separator last", &c, PB_ERR_BAD_FILE, cal_line(&c, c.at[n - 1]), "after the last value",
                           NULL);
        snprintf(values[n - 1], sizeof values[n - 1], "%.17g", m[n - 1]);
    }
    /* Underflow is that number: 1e-400 is 0, as every decimal reader takes it;
     * -0 is -0, bit for bit. */
    cal_text c = {.used = 0};
    cal_put(&c, "1 0 0 0\n0 1 0 0\n0 0 1 0\n1e-400 -0 0.0e-999 1\n");
    expect_calibration("an underflow", &c, PB_OK, 0, NULL, (double[16]){1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -0.0, 0, 1});
}

static void test_calibration(void)
{
    double m[16];
    const char *p = file_with("cal34.txt", "# tracker to scanner\n0, -1, 0, 10.5  # row 1\n1 0 0 -2;\n0 0 1 3\n");
    pb_check(pb_calibration_read(p, m) == PB_OK && m[1] == -1.0 && m[3] == 10.5 && m[7] == -2.0 && m[15] == 1.0 &&
                 m[12] == 0.0,
             "a 3x4 calibration with comments and separators: %s", pb_last_error(NULL));
    struct {
        const char *text, *words;
        pb_status status;
    } bad[] = {
        {"1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n7\n", "cal.txt:5: '7' is a 17th value", PB_ERR_BAD_FILE},
        {"1 0 0 0x1p3\n0 1 0 0\n0 0 1 0\n", "cal.txt:1: value 4 is '0x1p3', not a number", PB_ERR_BAD_FILE},
        {"1 0 0 0\n0 1 0 0\n0 0 1\n", "11 numbers", PB_ERR_BAD_FILE},
        {"2 0 0 0\n0 1 0 0\n0 0 1 0\n", "not a rotation", PB_ERR_NOT_RIGID},
        {"1 0 0 1e999\n0 1 0 0\n0 0 1 0\n", "cal.txt:1: value 4 is '1e999', beyond", PB_ERR_NOT_FINITE},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        pb_status st = pb_calibration_read(file_with("cal.txt", bad[i].text), m);
        pb_check(st == bad[i].status && strstr(pb_last_error(NULL), bad[i].words), "calibration %zu: status %d, "
                 "'%s'", i, (int)st, pb_last_error(NULL));
    }
    test_calibration_class();
}

/* A pose about centre c as a 4x4 about the origin: composed here by applying
 * it to the basis, independently of the library's matrix helpers. */
static void pose_matrix(const pb_pose *p, const double c[3], double m[16])
{
    double o[3], e[3];
    pb_pose_apply(p, c, (double[3]){0, 0, 0}, o);
    memset(m, 0, 16 * sizeof *m);
    for (int k = 0; k < 3; k++) {
        double v[3] = {k == 0, k == 1, k == 2};
        pb_pose_apply(p, c, v, e);
        for (int r = 0; r < 3; r++)
            m[4 * r + k] = e[r] - o[r];
    }
    for (int r = 0; r < 3; r++)
        m[4 * r + 3] = o[r];
    m[15] = 1.0;
}

static void apply_matrix(const double m[16], const double v[3], double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = m[4 * r] * v[0] + m[4 * r + 1] * v[1] + m[4 * r + 2] * v[2] + m[4 * r + 3];
}

/* M(t) = C P(t) P(ref)^-1 C^-1 on points: C^-1 x, then P(ref)^-1 found by
 * solving, then P(t), then C, against the library's pose applied to x. */
static void test_conventions(void)
{
    enum { N = 5 };
    double times[N];
    pb_pose poses[N], world[N], cal_pose;
    for (int i = 0; i < N; i++) {
        times[i] = 2.0 * i;
        random_pose(&poses[i], 40.0, 30.0);
    }
    random_pose(&cal_pose, 170.0, 500.0);
    pb_track *track;
    pb_check(pb_track_create("m.csv", PB_TRACK_MATRIX_CSV, times, poses, NULL, NULL, N, &track) == PB_OK,
             "pb_track_create: %s", pb_last_error(NULL));
    pb_track_conventions cv;
    memset(&cv, 0, sizeof cv);
    cv.has_reference_time = 1;
    cv.reference_time = times[2];
    cv.has_calibration = 1;
    pb_pose_to_matrix(&cal_pose, cv.calibration);
    pb_motion wm;
    pb_warnings w = {0, ""};
    pb_check(pb_track_world(track, &cv, NULL, NULL, world, &wm, &w) == PB_OK && wm.has_center &&
                 wm.center[0] == 0.0,
             "pb_track_world: %s", pb_last_error(NULL));
    double zero[3] = {0, 0, 0}, c[16], cinv_x[3], pr[16], p[16], worst = 0.0;
    pose_matrix(&cal_pose, zero, c);
    pose_matrix(&poses[2], zero, pr);
    for (int i = 0; i < N; i++) {
        pose_matrix(&poses[i], zero, p);
        for (int k = 0; k < 4; k++) {
            double x[3] = {pb_rand_range(-200, 200), pb_rand_range(-200, 200), pb_rand_range(-200, 200)}, y[3],
                   z[3], want[3], got[3];
            /* C^-1 x: solve C y = x through the rotation's transpose. */
            for (int r = 0; r < 3; r++)
                cinv_x[r] = 0.0;
            for (int r = 0; r < 3; r++)
                for (int q = 0; q < 3; q++)
                    cinv_x[r] += c[4 * q + r] * (x[q] - c[4 * q + 3]);
            for (int r = 0; r < 3; r++) { /* P(ref)^-1 the same way */
                y[r] = 0.0;
                for (int q = 0; q < 3; q++)
                    y[r] += pr[4 * q + r] * (cinv_x[q] - pr[4 * q + 3]);
            }
            apply_matrix(p, y, z);
            apply_matrix(c, z, want);
            pb_pose_apply(&world[i], wm.center, x, got);
            for (int r = 0; r < 3; r++)
                worst = fmax(worst, fabs(want[r] - got[r]));
        }
    }
    pb_check(worst < 1e-8, "C P(t) P(ref)^-1 C^-1 of random points: off by %.3g mm", worst);
    pb_pose rest = {{0, 0, 0}, {1, 0, 0, 0}};
    pb_check(pose_distance(&world[2], &rest) < 1e-10, "the pose at the reference time is rest: off by %.3g",
             pose_distance(&world[2], &rest));
    /* Inverted twice is the track itself. */
    pb_track_conventions inv;
    memset(&inv, 0, sizeof inv);
    inv.inverse = 1;
    pb_pose once[N], twice[N];
    pb_track *t2;
    pb_track_world(track, &inv, NULL, NULL, once, &wm, NULL);
    pb_check(pb_track_create("inv", PB_TRACK_MATRIX_CSV, times, once, NULL, NULL, N, &t2) == PB_OK, "a track of "
             "the inverses");
    pb_track_world(t2, &inv, NULL, NULL, twice, &wm, NULL);
    double d = 0.0;
    for (int i = 0; i < N; i++)
        d = fmax(d, pose_distance(&twice[i], &poses[i]));
    pb_check(d < 1e-10, "inverse of the inverse: off by %.3g", d);
    /* Refusals. */
    cv.reference_time = 99.0;
    pb_check(pb_track_world(track, &cv, NULL, NULL, world, &wm, NULL) == PB_ERR_TRACK_GAP &&
                 strstr(pb_last_error(NULL), "--reference-time 99"),
             "a reference time outside the track: %s", pb_last_error(NULL));
    cv.reference_time = 0.0;
    cv.has_center = 1;
    pb_check(pb_track_world(track, &cv, NULL, NULL, world, &wm, NULL) == PB_ERR_INVALID_ARGUMENT &&
                 strstr(pb_last_error(NULL), "drop --center"),
             "a centre for matrices about the origin: %s", pb_last_error(NULL));
    cv.has_center = 0;
    cv.calibration[0] = 2.0;
    pb_check(pb_track_world(track, &cv, NULL, NULL, world, &wm, NULL) == PB_ERR_NOT_RIGID, "a calibration that "
             "scales: %s", pb_last_error(NULL));
    pb_track_free(track);
    pb_track_free(t2);
}

/* The frame's mean pose against quadrature of the interpolated track. */
static void test_mean_pose(void)
{
    enum { N = 6, Q = 20000 };
    double times[N];
    pb_pose poses[N];
    for (int i = 0; i < N; i++) {
        times[i] = i + pb_rand_range(0.0, 0.5);
        random_pose(&poses[i], 20.0, 10.0);
    }
    pb_motion m = {times, poses, N, pb_rand_range(times[0], times[1]), pb_rand_range(times[4], times[5]), 0,
                   {0, 0, 0}};
    pb_pose mean;
    pb_check(pb_motion_mean_pose(&m, &mean) == PB_OK, "pb_motion_mean_pose: %s", pb_last_error(NULL));
    double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 0}, ref[4];
    for (int k = 0; k < Q; k++) { /* midpoint rule */
        pb_pose p;
        pb_motion_pose_at(&m, m.frame_start + (k + 0.5) / Q * (m.frame_end - m.frame_start), &p);
        if (k == 0)
            memcpy(ref, p.rotation, sizeof ref);
        double s = p.rotation[0] * ref[0] + p.rotation[1] * ref[1] + p.rotation[2] * ref[2] + p.rotation[3] * ref[3];
        for (int i = 0; i < 3; i++)
            t[i] += p.translation[i] / Q;
        for (int i = 0; i < 4; i++)
            q[i] += (s < 0 ? -1.0 : 1.0) * p.rotation[i] / Q;
    }
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int i = 0; i < 4; i++)
        q[i] /= n;
    pb_pose want = {{t[0], t[1], t[2]}, {q[0], q[1], q[2], q[3]}};
    double d = pose_distance(&mean, &want);
    pb_check(d < 1e-7, "mean pose against quadrature: off by %.3g", d);
}

static void test_frames(void)
{
    double times[5] = {0, 1, 2, 3, 4};
    pb_pose poses[5];
    for (int i = 0; i < 5; i++)
        poses[i] = (pb_pose){{0, 0, 0}, {1, 0, 0, 0}};
    pb_motion track = {times, poses, 5, 0, 4, 0, {0, 0, 0}}, part;
    struct {
        double t0, t1;
        size_t first, count;
    } cases[] = {{1.0, 2.0, 1, 2}, {0.5, 2.5, 0, 4}, {1.0, 1.5, 1, 2}, {3.5, 4.0, 3, 2}, {0.0, 4.0, 0, 5}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        pb_motion_frame(&track, cases[i].t0, cases[i].t1, &part);
        pb_check(part.times == times + cases[i].first && part.count == cases[i].count &&
                     part.frame_start == cases[i].t0 && part.frame_end == cases[i].t1,
                 "frame %g..%g: samples %td..+%zu", cases[i].t0, cases[i].t1, part.times - times, part.count);
    }
    double starts[3] = {0, 60, 120}, durations[3] = {60, 60, 180}, bounds[4];
    pb_check(pb_frames_from_starts(starts, durations, 3, bounds) == PB_OK && bounds[3] == 300.0, "BIDS frames");
    durations[1] = 50;
    pb_check(pb_frames_from_starts(starts, durations, 3, bounds) == PB_ERR_BAD_FRAME &&
                 strstr(pb_last_error(NULL), "frame 1 ends at 110 s but frame 2 starts at 120 s"),
             "a gap between BIDS frames: %s", pb_last_error(NULL));
    /* 1.8 s after 5.6e74 s is 5.6e74 s in doubles: an empty frame. */
    double far_start[2] = {5.6e74, 5.6e74}, far_duration[2] = {1.8, 1.8};
    pb_check(pb_frames_from_starts(far_start, far_duration, 1, bounds) == PB_ERR_BAD_FRAME &&
                 strstr(pb_last_error(NULL), "below double precision"),
             "a frame lost to rounding: %s", pb_last_error(NULL));
    pb_check(pb_frames_from_starts(far_start, far_duration, 2, bounds) == PB_ERR_BAD_FRAME,
             "two frames at one double: %s", pb_last_error(NULL));
    /* Bounds on their own: seconds pass quietly, milliseconds are warned of, NaN refused. */
    double seconds[4] = {0, 60, 120, 300}, ms[4] = {0, 60000, 120000, 300000};
    pb_warnings w = {0, ""};
    pb_check(pb_frames_check(seconds, 3, &w) == PB_OK && w.flags == 0, "frames in seconds: %s", w.text);
    pb_check(pb_frames_check(ms, 3, &w) == PB_OK && w.flags == PB_WARN_TIME_UNIT &&
                 strstr(w.text, "frame 2 (120000 to 300000 s) lasts 50 h: are the times in milliseconds?"),
             "frames in milliseconds: %s", w.text);
    ms[2] = (double)NAN;
    pb_check(pb_frames_check(ms, 3, NULL) == PB_ERR_NOT_FINITE, "a NaN bound: %s", pb_last_error(NULL));
}

/* A track written x,y,z,w and read as w,x,y,z: every pose near 180 degrees
 * from rest; the warning names the order that fits. A glitch, a grid out of
 * view for a whole frame, and at some poses. */
static void test_checks(void)
{
    enum { N = 40 };
    double times[N];
    pb_pose read[N], grid[N];
    for (int i = 0; i < N; i++) {
        pb_pose p;
        times[i] = 0.1 * i;
        random_pose(&p, 8.0, 3.0);
        if (p.rotation[0] < 0)
            for (int k = 0; k < 4; k++)
                p.rotation[k] = -p.rotation[k];
        read[i] = p; /* the file's x,y,z,w taken as w,x,y,z */
        read[i].rotation[0] = p.rotation[1];
        read[i].rotation[1] = p.rotation[2];
        read[i].rotation[2] = p.rotation[3];
        read[i].rotation[3] = p.rotation[0];
    }
    pb_geometry g = {{32, 32, 20}, {2, 2, 3}};
    pb_track *t;
    pb_motion m;
    pb_warnings w = {0, ""};
    pb_track_create("slip.csv", PB_TRACK_CSV, times, read, NULL, NULL, N, &t);
    pb_check(pb_track_place(t, NULL, &g, NULL, grid, &m, &w) == PB_OK && (w.flags & PB_WARN_FAR_FROM_REST) &&
                 strstr(w.text, "read as x,y,z,w (--quaternion-order xyzw) instead, every pose stays within"),
             "a whole track in the wrong order: flags %u, '%s'", w.flags, w.text);
    pb_track_free(t);
    for (int i = 0; i < N; i++) { /* now in the right order: no warning */
        double q[4] = {read[i].rotation[3], read[i].rotation[0], read[i].rotation[1], read[i].rotation[2]};
        memcpy(read[i].rotation, q, sizeof q);
    }
    pb_track_create("ok.csv", PB_TRACK_CSV, times, read, NULL, NULL, N, &t);
    w = (pb_warnings){0, ""};
    double bounds[3] = {0.0, 1.5, 3.9};
    pb_check(pb_track_place(t, NULL, &g, NULL, grid, &m, &w) == PB_OK &&
                 pb_track_check_frames(t, &m, &g, bounds, 2, &w) == PB_OK && w.flags == 0,
             "a sane track: flags %u, '%s'", w.flags, w.text);
    pb_track_free(t);
    /* A one-sample glitch of 120 degrees. */
    double axis[3] = {0, 1, 0};
    pb_pose keep = read[17];
    read[17] = pb_test_pose(0, 0, 0, axis, 120.0);
    pb_track_create("glitch.csv", PB_TRACK_CSV, times, read, NULL, NULL, N, &t);
    w = (pb_warnings){0, ""};
    pb_check(pb_track_place(t, NULL, &g, NULL, grid, &m, &w) == PB_OK && (w.flags & PB_WARN_TURN_STEP) &&
                 strstr(w.text, "slip") == NULL && strstr(w.text, "glitch.csv:18: the pose turns"),
             "a glitch: flags %u, '%s'", w.flags, w.text);
    pb_track_free(t);
    read[17] = keep;
    /* Out of view: the whole frame, then most poses. */
    for (int i = 0; i < N; i++)
        read[i].translation[0] += 1000.0;
    pb_track_create("away.csv", PB_TRACK_CSV, times, read, NULL, NULL, N, &t);
    pb_track_place(t, NULL, &g, NULL, grid, &m, NULL);
    pb_check(pb_track_check_frames(t, &m, &g, bounds, 2, NULL) == PB_ERR_OUT_OF_VIEW &&
                 strstr(pb_last_error(NULL), "out of the field of view for the whole frame 0 to 1.5 s"),
             "out of view: %s", pb_last_error(NULL));
    pb_track_free(t);
    for (int i = 0; i < N; i++)
        read[i].translation[0] = i == 0 ? 0.0 : 1000.0;
    pb_track_create("most.csv", PB_TRACK_CSV, times, read, NULL, NULL, N, &t);
    pb_track_place(t, NULL, &g, NULL, grid, &m, NULL);
    w = (pb_warnings){0, ""};
    pb_check(pb_track_check_frames(t, &m, &g, bounds, 1, &w) == PB_OK && (w.flags & PB_WARN_OUT_OF_VIEW),
             "mostly out of view: flags %u '%s' %s", w.flags, w.text, pb_last_error(NULL));
    bounds[1] = 9.0;
    pb_check(pb_track_check_frames(t, &m, &g, bounds, 1, NULL) == PB_ERR_TRACK_GAP &&
                 strstr(pb_last_error(NULL), "lies outside the track most.csv"),
             "a frame beyond the track: %s", pb_last_error(NULL));
    pb_track_free(t);
}

int main(void)
{
    pb_test_seed();
    snprintf(dir, sizeof dir, "/tmp/pb_motion_layer_XXXXXX");
    if (!mkdtemp(dir))
        return 1;
    test_calibration();
    test_conventions();
    test_mean_pose();
    test_frames();
    test_checks();
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd) != 0)
        pb_check(0, "removing %s", dir);
    return pb_test_finish();
}
