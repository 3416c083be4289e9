/* Frames from a BIDS-PET sidecar, the JSON file beside a PET image:
 * FrameTimesStart and FrameDuration, top-level arrays of seconds relative to
 * TimeZero (BIDS specification, PET "Time" metadata). Parsed by jansson, so
 * that the file is read as any JSON reader reads it: strict JSON (no hex, NaN
 * or comments), UTF-8, keys inside nested objects ignored, and of duplicate
 * keys the last one taken, as Python's json, nibabel and pybids take it.
 * Strings may hold \u0000, as Python's do (JSON_ALLOW_NUL). */
#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"

/* Sidecars are a few kB; anything this big is not one. */
#define MAX_SIDECAR_BYTES (4 << 20)

/* The array of numbers at key: checked, its length in *n. */
static pb_status number_array(const char *path, json_t *root, const char *key, json_t **array, size_t *n)
{
    *array = json_object_get(root, key);
    if (!*array)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s: no top-level \"%s\"; a BIDS-PET sidecar gives FrameTimesStart "
                        "and FrameDuration (arrays of seconds)", path, key);
    if (!json_is_array(*array))
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s: \"%s\" is not an array; give it as [t0, t1, ...] in seconds", path,
                        key);
    *n = json_array_size(*array);
    for (size_t i = 0; i < *n; i++) {
        json_t *v = json_array_get(*array, i);
        if (!json_is_number(v))
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s: \"%s\" item %zu is not a number; give seconds", path, key, i);
        if (!isfinite(json_number_value(v)))
            return pb_error(NULL, PB_ERR_NOT_FINITE, "%s: \"%s\" item %zu is not finite; give seconds", path, key, i);
    }
    return PB_OK;
}

pb_status pb_frames_read_sidecar(const char *path, double *bounds, size_t capacity, size_t *frames)
{
    if (!path || !frames || (capacity && !bounds))
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "path and frames must not be NULL, nor bounds with a capacity");
    *frames = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s: cannot open it (%s); check the path", path, strerror(errno));
    /* A sidecar is small: read whole, into a buffer that grows as the file
     * turns out longer (a few kB, not the limit, for the usual one), and a
     * file over the limit refused before it is parsed. */
    const size_t limit = (size_t)MAX_SIDECAR_BYTES + 1;
    size_t cap = 1 << 14, len = 0;
    char *text = NULL;
    int unread = 0;
    for (;;) {
        char *grown = realloc(text, cap);
        if (!grown) {
            free(text);
            fclose(f);
            return pb_error(NULL, PB_ERR_OUT_OF_MEMORY, "out of memory reading %s", path);
        }
        text = grown;
        len += fread(text + len, 1, cap - len, f);
        unread = ferror(f);
        if (len < cap || unread || cap == limit)
            break;
        cap = cap < limit / 2 ? 2 * cap : limit;
    }
    fclose(f);
    if (unread || len > MAX_SIDECAR_BYTES) {
        free(text);
        return unread ? pb_error(NULL, PB_ERR_BAD_FILE, "%s: cannot read it; check the file", path)
                      : pb_error(NULL, PB_ERR_BAD_FILE, "%s: over %d bytes, not a JSON sidecar (those are a few kB)",
                                 path, MAX_SIDECAR_BYTES);
    }
    /* JSON allows no raw control character anywhere (RFC 8259: in a string
     * only escaped, outside one only tab, line feed and carriage return as
     * white space); jansson passes some by, which Python's json refuses. */
    for (size_t i = 0, line = 1, column = 1; i < len; i++, column++) {
        unsigned char c = (unsigned char)text[i];
        if (c == '\n') {
            line++;
            column = 0;
        } else if (c < 0x20 && c != '\t' && c != '\r') {
            free(text);
            return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%zu:%zu: a raw control character (byte 0x%02X), which JSON "
                            "allows nowhere (in a string write it escaped, \\u%04X); not JSON", path, line, column,
                            (unsigned)c, (unsigned)c);
        }
    }
    json_error_t err;
    json_t *root = json_loadb(text, len, JSON_DECODE_INT_AS_REAL | JSON_ALLOW_NUL, &err);
    free(text);
    if (!root)
        return pb_error(NULL, PB_ERR_BAD_FILE, "%s:%d:%d: not JSON: %s; a BIDS sidecar is a JSON object", path,
                        err.line, err.column, err.text);
    pb_status st = PB_OK;
    json_t *starts = NULL, *durations = NULL;
    size_t ns = 0, nd = 0;
    if (!json_is_object(root))
        st = pb_error(NULL, PB_ERR_BAD_FILE, "%s: the JSON is not an object; a BIDS sidecar is {\"key\": value, ...}",
                      path);
    if (st == PB_OK)
        st = number_array(path, root, "FrameTimesStart", &starts, &ns);
    if (st == PB_OK)
        st = number_array(path, root, "FrameDuration", &durations, &nd);
    if (st == PB_OK && (ns == 0 || ns != nd))
        st = pb_error(NULL, PB_ERR_BAD_FRAME, "%s: %zu frame starts and %zu durations; BIDS gives one of each per "
                      "frame", path, ns, nd);
    double *s = NULL, *d = NULL, *b = NULL;
    if (st == PB_OK) {
        s = malloc(ns * sizeof *s);
        d = malloc(ns * sizeof *d);
        b = malloc((ns + 1) * sizeof *b);
        if (!s || !d || !b)
            st = pb_error(NULL, PB_ERR_OUT_OF_MEMORY, "out of memory reading %s", path);
    }
    for (size_t i = 0; st == PB_OK && i < ns; i++) {
        s[i] = json_number_value(json_array_get(starts, i));
        d[i] = json_number_value(json_array_get(durations, i));
    }
    /* The frames' rules are pb_frames_from_starts'. */
    if (st == PB_OK && (st = pb_frames_from_starts(s, d, ns, b)) != PB_OK)
        pb_error_prefix(st, "%s: ", path);
    if (st == PB_OK) {
        *frames = ns;
        if (capacity >= ns + 1)
            memcpy(bounds, b, (ns + 1) * sizeof *b);
        else if (capacity)
            st = pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "%s holds %zu frames: bounds needs room for %zu, not %zu",
                          path, ns, ns + 1, capacity);
    }
    free(s);
    free(d);
    free(b);
    json_decref(root);
    return st;
}
