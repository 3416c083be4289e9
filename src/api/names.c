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
                                     {"sweep", PB_AB_SAMPLING_SWEEP, "two where the path sweeps sideways"}};

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

const char *pb_method_name(pb_method method)
{
    return name_of(methods, COUNT(methods), (int)method);
}

pb_status pb_method_parse(const char *name, pb_method *method)
{
    int v = 0;
    pb_status st = method ? parse("method", methods, COUNT(methods), name, &v)
                          : pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the method pointer must not be NULL");
    if (st == PB_OK)
        *method = (pb_method)v;
    return st;
}

const char *pb_filter_name(pb_filter filter)
{
    return name_of(filters, COUNT(filters), (int)filter);
}

pb_status pb_filter_parse(const char *name, pb_filter *filter)
{
    int v = 0;
    pb_status st = filter ? parse("filter", filters, COUNT(filters), name, &v)
                          : pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the filter pointer must not be NULL");
    if (st == PB_OK)
        *filter = (pb_filter)v;
    return st;
}

const char *pb_ab_sampling_name(pb_ab_sampling sampling)
{
    return name_of(samplings, COUNT(samplings), (int)sampling);
}

pb_status pb_ab_sampling_parse(const char *name, pb_ab_sampling *sampling)
{
    int v = 0;
    pb_status st = sampling ? parse("ab_sampling", samplings, COUNT(samplings), name, &v)
                            : pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the sampling pointer must not be NULL");
    if (st == PB_OK)
        *sampling = (pb_ab_sampling)v;
    return st;
}
