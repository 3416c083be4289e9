/* Frame times from a BIDS-PET sidecar: FrameTimesStart and FrameDuration,
 * arrays of seconds relative to TimeZero (BIDS specification, PET's
 * "Time" metadata). Only these two keys are read, so a small scanner of JSON
 * arrays of numbers does; a key that is not such an array is refused. */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "petblur.h"

/* Sidecars are a few kB; anything this big is not one. */
#define MAX_SIDECAR_BYTES (4 << 20)

static char *load(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        pbc_fail(PBC_EXIT_USAGE, "--frames-from %s: cannot open it (%s); check the path", path, strerror(errno));
        return NULL;
    }
    char *text = malloc(MAX_SIDECAR_BYTES + 1);
    size_t n = text ? fread(text, 1, MAX_SIDECAR_BYTES + 1, f) : 0;
    int err = ferror(f);
    fclose(f);
    if (!text || err || n > MAX_SIDECAR_BYTES || memchr(text, '\0', n)) {
        pbc_fail(text ? PBC_EXIT_USAGE : PBC_EXIT_RUNTIME, "--frames-from %s: %s", path,
                 !text ? "out of memory" : err ? "read error" : "not a JSON sidecar (binary, or over 4 MiB)");
        free(text);
        return NULL;
    }
    text[n] = '\0';
    return text;
}

/* The array of numbers after "key": in text; *count numbers malloc'ed. */
static int number_array(const char *path, const char *text, const char *key, double **out, size_t *count)
{
    char quoted[64];
    snprintf(quoted, sizeof quoted, "\"%s\"", key);
    const char *s = strstr(text, quoted);
    *out = NULL;
    *count = 0;
    if (!s)
        return pbc_fail(PBC_EXIT_USAGE, "--frames-from %s: no \"%s\"; a BIDS-PET sidecar gives FrameTimesStart and "
                        "FrameDuration (arrays of seconds)", path, key);
    s += strlen(quoted);
    while (isspace((unsigned char)*s))
        s++;
    if (*s++ != ':')
        return pbc_fail(PBC_EXIT_USAGE, "--frames-from %s: \"%s\" is not followed by ':'; is it JSON?", path, key);
    while (isspace((unsigned char)*s))
        s++;
    if (*s++ != '[')
        return pbc_fail(PBC_EXIT_USAGE, "--frames-from %s: \"%s\" is not an array; give it as [t0, t1, ...] in "
                        "seconds", path, key);
    size_t cap = 0;
    for (;;) {
        while (isspace((unsigned char)*s))
            s++;
        if (*s == ']' && *count == 0)
            break;
        char *end;
        double v = strtod(s, &end);
        if (end == s || !isfinite(v) || (s[0] == '0' && (s[1] == 'x' || s[1] == 'X'))) {
            free(*out);
            *out = NULL;
            return pbc_fail(PBC_EXIT_USAGE, "--frames-from %s: \"%s\" holds '%.20s', not a number; give seconds",
                            path, key, s);
        }
        if (*count == cap) {
            cap = cap ? 2 * cap : 64;
            double *grown = realloc(*out, cap * sizeof *grown);
            if (!grown) {
                free(*out);
                *out = NULL;
                return pbc_fail(PBC_EXIT_RUNTIME, "out of memory reading %s", path);
            }
            *out = grown;
        }
        (*out)[(*count)++] = v;
        for (s = end; isspace((unsigned char)*s); s++)
            ;
        if (*s == ']')
            break;
        if (*s++ != ',') {
            free(*out);
            *out = NULL;
            return pbc_fail(PBC_EXIT_USAGE, "--frames-from %s: \"%s\" is not an array of numbers", path, key);
        }
    }
    return 0;
}

int pbc_bids_frames(const char *path, double **bounds, size_t *count)
{
    char *text = load(path);
    if (!text)
        return PBC_EXIT_USAGE;
    double *start = NULL, *length = NULL;
    size_t ns = 0, nd = 0;
    int rc = number_array(path, text, "FrameTimesStart", &start, &ns);
    if (!rc)
        rc = number_array(path, text, "FrameDuration", &length, &nd);
    free(text);
    if (!rc && (ns == 0 || ns != nd))
        rc = pbc_fail(PBC_EXIT_USAGE, "--frames-from %s: %zu frame starts and %zu durations; BIDS gives one of each "
                      "per frame", path, ns, nd);
    *bounds = rc ? NULL : malloc((ns + 1) * sizeof **bounds);
    if (!rc && !*bounds)
        rc = pbc_fail(PBC_EXIT_RUNTIME, "out of memory reading %s", path);
    /* The frames' rules are the library's, as Python's are. */
    if (!rc && pb_frames_from_starts(start, length, ns, *bounds) != PB_OK)
        rc = pbc_fail(PBC_EXIT_USAGE, "--frames-from %s: %s", path, pb_last_error(NULL));
    if (!rc)
        *count = ns + 1;
    else {
        free(*bounds);
        *bounds = NULL;
    }
    free(start);
    free(length);
    return rc;
}
