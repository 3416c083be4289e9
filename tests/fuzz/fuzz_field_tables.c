/* libFuzzer harness: the command line's tables of non-rigid motion on the
 * bytes given, the first byte choosing which: a --fields table ('time,path'
 * or 'value,path' rows) or a --signal trace ('time,value' rows), then, on a
 * trace read, its amplitude gates between edges that the next bytes place in
 * the trace's range. A table read must keep what the blur relies on (two
 * rows or more, times finite and increasing, every path set); a refusal must
 * be a usage error; gates must be intervals inside the span, increasing, each
 * where the signal lies in its gate, and count what they write. */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "fields.h"
#include "fuzz_files.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

enum { GATES_MOST = 4 };

/* The signal linear between its samples at time x (inside its span). */
static double signal_at(const pbc_fields *f, double x)
{
    size_t i = 0;
    while (i + 2 < f->signal_count && f->signal_times[i + 1] <= x)
        i++;
    double a = (x - f->signal_times[i]) / (f->signal_times[i + 1] - f->signal_times[i]);
    return f->signal[i] + a * (f->signal[i + 1] - f->signal[i]);
}

static void check_gates(const pbc_fields *f, const uint8_t *p, size_t n)
{
    const double *t = f->signal_times, *s = f->signal;
    double lo = s[0], hi = s[0];
    for (size_t i = 1; i < f->signal_count; i++) {
        lo = fmin(lo, s[i]);
        hi = fmax(hi, s[i]);
    }
    if (!(hi > lo) || !isfinite(hi - lo))
        return;
    size_t gates = 1 + (n ? p[0] % GATES_MOST : 0);
    double edges[GATES_MOST + 1];
    for (size_t g = 0; g <= gates; g++) /* increasing, from below the range to above it */
        edges[g] = lo + (hi - lo) * ((double)g / (double)gates + (g + 1 < n ? ((double)p[g + 1] - 128.0) / 2048.0 : 0));
    for (size_t g = 0; g < gates; g++)
        if (!(edges[g + 1] > edges[g]))
            return;
    const double t0 = t[0], t1 = t[f->signal_count - 1];
    size_t counts[GATES_MOST], again[GATES_MOST];
    size_t total = pbc_amplitude_gates(t, s, f->signal_count, edges, gates, t0, t1, NULL, counts);
    double *iv = malloc((2 * total + 1) * sizeof *iv);
    if (!iv)
        abort();
    if (pbc_amplitude_gates(t, s, f->signal_count, edges, gates, t0, t1, iv, again) != total)
        abort();
    const double tol = 1e-9 * (t1 - t0), vtol = 1e-6 * (hi - lo);
    size_t k = 0;
    for (size_t g = 0; g < gates; g++) {
        if (again[g] != counts[g])
            abort();
        for (size_t i = 0; i < counts[g]; i++, k++) {
            const double a = iv[2 * k], b = iv[2 * k + 1];
            if (!(a >= t0 && b <= t1 && b >= a) || (i > 0 && !(a >= iv[2 * k - 1])))
                abort();
            /* where the signal lies in gate g: its middle (the top gate is closed), on an interval longer
             * than the rounding of its ends (times a few ulps apart round the crossing a whole ulp) */
            const double m = signal_at(f, 0.5 * (a + b));
            if (b - a > tol + 64.0 * DBL_EPSILON * fmax(fabs(a), fabs(b)) &&
                !(m >= edges[g] - vtol && m <= edges[g + 1] + vtol))
                abort();
        }
    }
    free(iv);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static char dir[256];
    if (!dir[0] && pbc_fuzz_dir(dir, sizeof dir))
        abort();
    if (size < 2)
        return 0;
    const int trace = data[0] & 1;
    const size_t split = data[1] < size ? data[1] : size; /* the file, then the gates' bytes */
    char path[300];
    snprintf(path, sizeof path, "%s/%s", dir, trace ? "signal.csv" : "fields.csv");
    pbc_fuzz_write(path, data + 2, split > 2 ? split - 2 : 0);
    pbc_fields f;
    memset(&f, 0, sizeof f);
    f.table = path;
    if (trace) {
        int rc = pbc_signal_read(path, &f);
        if (rc == 0) {
            if (f.signal_count < 2)
                abort();
            for (size_t i = 0; i < f.signal_count; i++)
                if (!isfinite(f.signal_times[i]) || !isfinite(f.signal[i]) ||
                    (i > 0 && !(f.signal_times[i] > f.signal_times[i - 1])))
                    abort();
            check_gates(&f, data + split, size - split);
        } else if (rc != PBC_EXIT_USAGE && rc != PBC_EXIT_RUNTIME)
            abort(); /* a refusal is a usage error (its message on stderr) */
    } else {
        int rc = pbc_field_table_read(path, &f);
        if (rc == 0) {
            if (f.rows < 2)
                abort();
            for (size_t i = 0; i < f.rows; i++)
                if (!isfinite(f.times[i]) || (i > 0 && !(f.times[i] > f.times[i - 1])) || !f.paths[i] ||
                    !f.paths[i][0])
                    abort();
        } else if (rc != PBC_EXIT_USAGE && rc != PBC_EXIT_RUNTIME)
            abort();
    }
    f.table = NULL;
    pbc_fields_free(&f);
    pbc_fuzz_clean(dir);
    return 0;
}
