/* The options' names as the program and the bindings spell them, one table
 * each, so that a front end parses and prints them through the library and
 * never spells them itself. */
#include <stdio.h>
#include <string.h>

#include "error.h"

typedef struct name_row {
    const char *name;
    int value;
    const char *what; /* said in the list of choices */
} name_row;

static const name_row methods[] = {{"ab", PB_METHOD_AB, "the paper's antialiased Bresenham"},
                                   {"rm", PB_METHOD_RM, "ray marching"},
                                   {"cl", PB_METHOD_CL, "the classical blur"},
                                   {"ref", PB_METHOD_REF, "the multi-point reference"}};
static const name_row filters[] = {{"hardware", PB_FILTER_HARDWARE, "one filtered fetch per sample"},
                                   {"exact", PB_FILTER_EXACT, "nearest reads weighted in float"}};
static const name_row samplings[] = {{"default", PB_AB_SAMPLING_DEFAULT, "slice"},
                                     {"slice", PB_AB_SAMPLING_SLICE, "one point a slice, the paper's AB"},
                                     {"sweep", PB_AB_SAMPLING_SWEEP, "two where the path sweeps sideways"},
                                     {"chord", PB_AB_SAMPLING_CHORD, "every segment read exactly, never walked"}};

#define COUNT(a) (sizeof(a) / sizeof((a)[0]))

static const char *name_of(const name_row *rows, size_t n, int value)
{
    for (size_t i = 0; i < n; i++)
        if (rows[i].value == value)
            return rows[i].name;
    return NULL;
}

static pb_status parse(const char *kind, const name_row *rows, size_t n, const char *name, int *value)
{
    for (size_t i = 0; name && i < n; i++)
        if (!strcmp(name, rows[i].name)) {
            *value = rows[i].value;
            return PB_OK;
        }
    char list[512] = "";
    for (size_t i = 0; i < n; i++) {
        size_t used = strlen(list);
        snprintf(list + used, sizeof list - used, "%s%s (%s)", i == 0 ? "" : i + 1 < n ? ", " : " or ", rows[i].name,
                 rows[i].what);
    }
    return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "%s '%.200s': choose %s", kind, name ? name : "(none)", list);
}

/* pb_KIND_name and pb_KIND_parse of one table. */
#define NAMED(kind, type, rows)                                                                               \
    const char *pb_##kind##_name(type value)                                                                  \
    {                                                                                                         \
        return name_of(rows, COUNT(rows), (int)value);                                                        \
    }                                                                                                         \
    pb_status pb_##kind##_parse(const char *name, type *value)                                                \
    {                                                                                                         \
        int v = 0;                                                                                            \
        if (!value)                                                                                           \
            return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the " #kind " pointer must not be NULL");         \
        pb_status st = parse(#kind, rows, COUNT(rows), name, &v);                                             \
        if (st == PB_OK)                                                                                      \
            *value = (type)v;                                                                                 \
        return st;                                                                                            \
    }

NAMED(method, pb_method, methods)
NAMED(filter, pb_filter, filters)
NAMED(ab_sampling, pb_ab_sampling, samplings)
