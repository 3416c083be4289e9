/* --signal and --gates: a surrogate's trace (a respiratory belt, a
 * data-driven breathing signal) that drives a table of fields given at its
 * values, and amplitude gates computed from it (gates.c), of fields or of a
 * track alike. The trace is small
 * text ("time,value" and a row per sample), its size bounded before it is
 * read. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"
#include "fields.h"

#define MAX_LINE 256

static int take_sample(pbc_fields *f, char *s, size_t line, size_t *capacity)
{
    const char *path = f->signal_path;
    char *comma = strchr(s, ',');
    double t, v;
    if (!comma)
        return pbc_fail(PBC_EXIT_USAGE, "--signal %s line %zu: '%s' is not 'time,value'; give the time in seconds, "
                        "a comma and the surrogate's value", path, line, s);
    *comma = '\0';
    char *ts = pbc_field_trim(s), *vs = pbc_field_trim(comma + 1);
    if (pbc_plain_number(ts, &t))
        return pbc_fail(PBC_EXIT_USAGE, "--signal %s line %zu: time '%s' is not a finite number; give seconds as a "
                        "plain decimal", path, line, ts);
    if (pbc_plain_number(vs, &v))
        return pbc_fail(PBC_EXIT_USAGE, "--signal %s line %zu: value '%s' is not a finite number; fill or cut the "
                        "trace's gaps before petblur reads it", path, line, vs);
    if (f->signal_count && !(t > f->signal_times[f->signal_count - 1]))
        return pbc_fail(PBC_EXIT_USAGE, "--signal %s line %zu: time %s s is not after the row before it (%s s); give "
                        "the samples in increasing time, each once", path, line, PBC_NUM(t),
                        PBC_NUM(f->signal_times[f->signal_count - 1]));
    if (f->signal_count == PBC_MAX_SIGNAL)
        return pbc_fail(PBC_EXIT_USAGE, "--signal %s: more than %d samples; resample the trace (25 Hz is plenty)",
                        path, PBC_MAX_SIGNAL);
    if (f->signal_count == *capacity) {
        size_t cap = *capacity ? 2 * *capacity : 1024;
        double *a = realloc(f->signal_times, cap * sizeof *a);
        if (a)
            f->signal_times = a;
        double *b = a ? realloc(f->signal, cap * sizeof *b) : NULL;
        if (b)
            f->signal = b;
        if (!a || !b)
            return pbc_fail(PBC_EXIT_RUNTIME, "--signal %s: out of memory for %zu samples", path, cap);
        *capacity = cap;
    }
    f->signal_times[f->signal_count] = t;
    f->signal[f->signal_count++] = v;
    return 0;
}

static int read_samples(FILE *in, pbc_fields *f)
{
    char buf[MAX_LINE + 2], *s;
    size_t line = 0, capacity = 0;
    int header = 0, rc = 0;
    while (!rc && !(rc = pbc_field_next_row(in, buf, sizeof buf, &line, &s, "--signal", f->signal_path, "time,value")) &&
           s) {
        if (!header) {
            char *comma = strchr(s, ',');
            if (!comma || (*comma = '\0', !pbc_field_same_words(pbc_field_trim(s), "time")) || !pbc_field_same_words(pbc_field_trim(comma + 1), "value"))
                return pbc_fail(PBC_EXIT_USAGE, "--signal %s line %zu: the first line must be the header 'time,value'; "
                                "add it, then one row per sample: its time in seconds and the surrogate's value",
                                f->signal_path, line);
            header = 1;
            continue;
        }
        rc = take_sample(f, s, line, &capacity);
    }
    if (!rc && ferror(in))
        rc = pbc_fail(PBC_EXIT_USAGE, "--signal %s: reading failed (%s)", f->signal_path, strerror(errno));
    if (!rc && f->signal_count < 2)
        rc = pbc_fail(PBC_EXIT_USAGE, "--signal %s: %zu sample%s; give at least two", f->signal_path, f->signal_count,
                      f->signal_count == 1 ? "" : "s");
    return rc;
}

int pbc_signal_read(const char *path, pbc_fields *f)
{
    struct stat st;
    f->signal_path = path;
    FILE *in = fopen(path, "r");
    if (!in)
        return pbc_fail(PBC_EXIT_USAGE, "--signal %s: cannot read it (%s); check the path", path, strerror(errno));
    int rc = 0;
    if (fstat(fileno(in), &st) != 0 || !S_ISREG(st.st_mode))
        rc = pbc_fail(PBC_EXIT_USAGE, "--signal %s: not a regular file; give the surrogate's trace (a .csv)", path);
    else if (st.st_size > (off_t)PBC_MAX_SIGNAL * 64)
        rc = pbc_fail(PBC_EXIT_USAGE, "--signal %s: %lld bytes, more than a trace of %d samples holds; give the "
                      "trace ('time,value' rows), resampled if need be", path, (long long)st.st_size, PBC_MAX_SIGNAL);
    if (!rc)
        rc = read_samples(in, f);
    fclose(in);
    return rc;
}

static int compute_gates(const char *text, pbc_fields *f)
{
    size_t ne;
    int rc = pbc_parse_bounds("--gates", text, &f->edges, &ne);
    if (rc)
        return rc;
    f->gates = ne - 1;
    const double *t = f->signal_times, *s = f->signal;
    size_t n = f->signal_count;
    if (!(f->counts = calloc(f->gates, sizeof *f->counts)))
        return pbc_fail(PBC_EXIT_RUNTIME, "--gates: out of memory");
    size_t total = pbc_amplitude_gates(t, s, n, f->edges, f->gates, f->frame[0], f->frame[1], NULL, f->counts);
    double lo = (double)INFINITY, hi = -(double)INFINITY;
    for (size_t i = 0; i < n; i++)
        if (t[i] >= f->frame[0] && t[i] <= f->frame[1]) {
            lo = fmin(lo, s[i]);
            hi = fmax(hi, s[i]);
        }
    for (size_t g = 0; g < f->gates; g++)
        if (!f->counts[g])
            return pbc_fail(PBC_EXIT_USAGE, "--gates: gate %zu, [%s, %s%c, is never visited by the signal from %s to "
                            "%s s (its samples there span %s to %s); give edges inside the signal's range, or a longer "
                            "--frame", g, PBC_NUM(f->edges[g]), PBC_NUM(f->edges[g + 1]), g + 1 == f->gates ? ']' : ')',
                            PBC_NUM(f->frame[0]), PBC_NUM(f->frame[1]), PBC_NUM(lo), PBC_NUM(hi));
    if (!(f->intervals = malloc(2 * total * sizeof *f->intervals)))
        return pbc_fail(PBC_EXIT_RUNTIME, "--gates: out of memory for %zu intervals", total);
    pbc_amplitude_gates(t, s, n, f->edges, f->gates, f->frame[0], f->frame[1], f->intervals, f->counts);
    return 0;
}

/* Reads the trace; the span the gates bin is the --frame (inside the
 * trace), else the whole trace. */
static int signal_span(const char *signal, pbc_fields *f)
{
    int rc = pbc_signal_read(signal, f);
    if (rc)
        return rc;
    double first = f->signal_times[0], last = f->signal_times[f->signal_count - 1];
    if (!f->has_frame) {
        f->frame[0] = first;
        f->frame[1] = last;
    } else if (f->frame[0] < first || f->frame[1] > last)
        return pbc_fail(PBC_EXIT_USAGE, "--frame %s,%s: the signal %s covers %s to %s s; give a frame inside it",
                        PBC_NUM(f->frame[0]), PBC_NUM(f->frame[1]), signal, PBC_NUM(first), PBC_NUM(last));
    return 0;
}

/* A track's gates: --signal only bins its time (the track moves by itself),
 * so --gates must come with it; the span is --frame, else the whole signal. */
static int track_gates(const pbc_command *cmd, const pbc_args *args, const char *signal, const char *gates,
                       pbc_fields *f)
{
    if (!gates)
        return pbc_fail(PBC_EXIT_USAGE, "--signal without --fields gates a track: give --gates E0,E1,... too (the "
                        "amplitude bins), or --fields TABLE.csv, a table 'value,path' of fields the signal drives");
    const char *frame = pbc_arg(cmd, args, "--frame");
    int rc = frame ? pbc_parse_interval("--frame", frame, f->frame) : 0;
    f->has_frame = frame != NULL;
    if (rc || (rc = signal_span(signal, f)))
        return rc;
    return compute_gates(gates, f);
}

int pbc_fields_signal(const pbc_command *cmd, const pbc_args *args, pbc_fields *f)
{
    const char *signal = pbc_arg(cmd, args, "--signal"), *gates = pbc_arg(cmd, args, "--gates");
    if (gates && !signal)
        return pbc_fail(PBC_EXIT_USAGE, "--gates bins a surrogate's amplitude: give --signal TRACE.csv, the "
                        "surrogate's 'time,value' samples, too");
    if (!f->table)
        return signal ? track_gates(cmd, args, signal, gates, f) : 0;
    if (signal && !f->by_value)
        return pbc_fail(PBC_EXIT_USAGE, "--signal %s: --fields %s gives fields at times ('time,path'); with a "
                        "signal, give them at the signal's values: a table whose header is 'value,path'", signal,
                        f->table);
    if (f->by_value && !signal)
        return pbc_fail(PBC_EXIT_USAGE, "--fields %s gives fields at a surrogate's values ('value,path'): give "
                        "--signal TRACE.csv too, the surrogate's 'time,value' samples", f->table);
    if (!signal)
        return 0;
    int rc = signal_span(signal, f);
    return rc ? rc : gates ? compute_gates(gates, f) : 0;
}
