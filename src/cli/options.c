/* The table-driven option parser and the value parsers. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "options.h"
#include "petblur.h"

void pbc_print_help(const pbc_command *cmd)
{
    printf("usage: petblur %s %s\n\n%s\n", cmd->name, cmd->synopsis, cmd->summary);
    if (cmd->option_count)
        puts("\noptions:");
    for (int i = 0; i < cmd->option_count; i++) {
        const pbc_option *o = &cmd->options[i];
        if (!o->help)
            continue; /* read by the command, not typed (petblur motion's --motion) */
        char head[96];
        snprintf(head, sizeof head, "%s%s%s%s%s", o->alias ? o->alias : "", o->alias ? ", " : "", o->name,
                 o->metavar ? " " : "", o->metavar ? o->metavar : "");
        printf("  %-28s %s\n", head, o->help);
    }
    printf("  %-28s %s\n", "-h, --help", "this text");
    if (cmd->epilog)
        printf("\n%s\n", cmd->epilog);
}

static int find_option(const pbc_command *cmd, const char *arg, size_t len)
{
    for (int i = 0; i < cmd->option_count; i++) {
        const pbc_option *o = &cmd->options[i];
        if ((strlen(o->name) == len && !strncmp(o->name, arg, len)) ||
            (o->alias && strlen(o->alias) == len && !strncmp(o->alias, arg, len)))
            return i;
    }
    return -1;
}

static int take_option(const pbc_command *cmd, int argc, char **argv, int *i, pbc_args *args)
{
    const char *arg = argv[*i], *eq = strchr(arg, '=');
    size_t len = eq && arg[1] == '-' ? (size_t)(eq - arg) : strlen(arg);
    int k = find_option(cmd, arg, len);
    if (k < 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s: unknown option '%.*s'; see petblur %s --help", cmd->name, (int)len, arg,
                        cmd->name);
    const pbc_option *o = &cmd->options[k];
    if (args->value[k])
        return pbc_fail(PBC_EXIT_USAGE, "%s: %s is given twice; give it once", cmd->name, o->name);
    if (!o->metavar) {
        if (eq && arg[1] == '-')
            return pbc_fail(PBC_EXIT_USAGE, "%s: %s takes no value", cmd->name, o->name);
        args->value[k] = "";
    } else if (eq && arg[1] == '-') {
        args->value[k] = eq + 1;
    } else if (*i + 1 < argc) {
        args->value[k] = argv[++*i];
    } else {
        return pbc_fail(PBC_EXIT_USAGE, "%s: %s needs a value (%s)", cmd->name, o->name, o->metavar);
    }
    return 0;
}

int pbc_parse_args(const pbc_command *cmd, int argc, char **argv, pbc_args *args)
{
    memset(args, 0, sizeof *args);
    int only_positional = 0;
    for (int i = 0; i < argc; i++) {
        const char *arg = argv[i];
        if (!only_positional && (!strcmp(arg, "--help") || !strcmp(arg, "-h"))) {
            pbc_print_help(cmd);
            return -1;
        }
        if (!only_positional && !strcmp(arg, "--")) {
            only_positional = 1;
        } else if (!only_positional && arg[0] == '-' && arg[1] != '\0') {
            int rc = take_option(cmd, argc, argv, &i, args);
            if (rc)
                return rc;
        } else if (args->positional_count < cmd->max_positional) {
            args->positional[args->positional_count++] = arg;
        } else {
            return pbc_fail(PBC_EXIT_USAGE, "%s: unexpected argument '%s'; usage: petblur %s %s", cmd->name, arg,
                            cmd->name, cmd->synopsis);
        }
    }
    if (args->positional_count < cmd->min_positional)
        return pbc_fail(PBC_EXIT_USAGE, "%s: missing arguments; usage: petblur %s %s", cmd->name, cmd->name,
                        cmd->synopsis);
    return 0;
}

const char *pbc_arg(const pbc_command *cmd, const pbc_args *args, const char *name)
{
    int k = find_option(cmd, name, strlen(name));
    return k < 0 ? NULL : args->value[k];
}

/* Splits "a,b,c" into exactly n finite numbers, plain decimal: strtod alone
 * would take hex floats (0x7fffffff), "inf" and "nan" too. An underflow to
 * (almost) zero is that number. */
static int numbers(const char *text, int n, double *v)
{
    const char *s = text;
    if (strspn(text, "0123456789+-.eE, ") != strlen(text))
        return -1;
    for (int i = 0; i < n; i++) {
        char *end;
        errno = 0;
        v[i] = strtod(s, &end);
        if (end == s || (errno == ERANGE && fabs(v[i]) > 1.0) || !isfinite(v[i]))
            return -1;
        s = end;
        if (i + 1 < n && *s++ != ',')
            return -1;
    }
    return *s == '\0' ? 0 : -1;
}

int pbc_parse_dims(const char *option, const char *text, size_t dims[3])
{
    /* digits alone: a count written 1e2 or 64.0 is a slip for a size in mm as often as a count */
    double v[3];
    int ok = strspn(text, "0123456789,") == strlen(text) && numbers(text, 3, v) == 0;
    for (int i = 0; ok && i < 3; i++) {
        ok = v[i] >= 1 && v[i] <= 65536;
        dims[i] = ok ? (size_t)v[i] : 0;
    }
    if (!ok)
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: give three whole numbers of voxels from 1 to 65536, e.g. "
                        "128,128,64", option, text);
    return 0;
}

int pbc_parse_vec3(const char *option, const char *text, int positive, double v[3])
{
    int ok = numbers(text, 3, v) == 0;
    for (int i = 0; ok && positive && i < 3; i++)
        ok = v[i] > 0;
    if (!ok)
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: give three %snumbers separated by commas, e.g. %s", option, text,
                        positive ? "positive " : "", positive ? "2,2,2.8" : "12,10,-11");
    return 0;
}

int pbc_parse_interval(const char *option, const char *text, double v[2])
{
    if (numbers(text, 2, v) != 0 || !(v[0] < v[1]))
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: give a start and a later end separated by a comma, e.g. 0,30",
                        option, text);
    return 0;
}

int pbc_parse_bounds(const char *option, const char *text, double **v, size_t *count)
{
    size_t n = 1;
    for (const char *c = text; *c; c++)
        n += *c == ',';
    *v = malloc(n * sizeof **v);
    if (!*v)
        return pbc_fail(PBC_EXIT_RUNTIME, "%s: out of memory for %zu numbers", option, n);
    *count = n;
    int ok = n >= 2 && numbers(text, (int)n, *v) == 0;
    for (size_t i = 0; ok && i + 1 < n; i++)
        ok = (*v)[i + 1] > (*v)[i];
    if (ok)
        return 0;
    free(*v);
    *v = NULL;
    if (!strcmp(option, "--gates"))
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: give the gates' edges in the signal's units, at least two, "
                        "increasing, separated by commas, e.g. 0,0.25,0.5,0.75,1 for four gates", option, text);
    return pbc_fail(PBC_EXIT_USAGE, "%s %s: give the frames' boundaries in seconds, at least two, increasing, "
                    "separated by commas, e.g. 0,30,60,120 for three frames", option, text);
}

int pbc_parse_number(const char *option, const char *text, double *v)
{
    if (numbers(text, 1, v) != 0)
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: give a finite number", option, text);
    return 0;
}

int pbc_plain_number(const char *text, double *v)
{
    return numbers(text, 1, v);
}

int pbc_parse_count(const char *option, const char *text, unsigned long lo, unsigned long hi, unsigned long *v)
{
    char *end;
    errno = 0;
    unsigned long x = strtoul(text, &end, 10);
    if (end == text || *end || errno == ERANGE || text[0] == '-' || x < lo || x > hi)
        return pbc_fail(PBC_EXIT_USAGE, "%s %s: give a whole number from %lu to %lu", option, text, lo, hi);
    *v = x;
    return 0;
}

int pbc_parse_choice(const char *option, const char *text, const char *const *names, int count, int *index)
{
    for (int i = 0; i < count; i++)
        if (!strcmp(text, names[i])) {
            *index = i;
            return 0;
        }
    char list[256] = "";
    for (int i = 0; i < count; i++)
        snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? ", " : "", names[i]);
    return pbc_fail(PBC_EXIT_USAGE, "%s %s: choose one of %s", option, text, list);
}

int pbc_refused_name(const char *option)
{
    const char *msg = pb_last_error(NULL), *rest = strchr(msg, ' '); /* "method 'x': choose ..." */
    return pbc_fail(PBC_EXIT_USAGE, "%s%s", option, rest ? rest : msg);
}
