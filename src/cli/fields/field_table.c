/* --fields: the options, and the table of fields and their times. The table
 * is small text ("time,path" and a row per field), read whole before any
 * file it names, with its size and rows bounded so that a wrong file costs
 * nothing. */
#include <ctype.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"
#include "fields.h"

/* A row is a time and a path: PATH_MAX and a number fit. */
#define MAX_LINE (PATH_MAX + 128)

/* Options that shape a pose track, which a field motion has none of. */
static const char *const track_options[] = {"--motion", "--translate", "--rotate"};
static const char *const track_only[] = {"--axis", "--center", "--coords", "--motion-format", "--time-unit",
                                         "--quaternion-order", "--calibration", "--reference-time",
                                         "--motion-inverse"};

static int convention_arg(const pbc_command *cmd, const pbc_args *args, pbc_fields *f)
{
    static const char *const names[] = {"nifti", "niftyreg", "itk"};
    const char *v = pbc_arg(cmd, args, "--field-convention");
    f->convention = PBC_FIELDS_AUTO;
    if (v && !f->table)
        return pbc_fail(PBC_EXIT_USAGE, "--field-convention applies to --fields; give --fields TABLE.csv too");
    int idx;
    if (v && pbc_parse_choice("--field-convention", v, names, 3, &idx))
        return PBC_EXIT_USAGE;
    if (v)
        f->convention = idx;
    return 0;
}

int pbc_fields_from_args(const pbc_command *cmd, const pbc_args *args, pbc_fields *f)
{
    memset(f, 0, sizeof *f);
    f->table = pbc_arg(cmd, args, "--fields");
    int rc = convention_arg(cmd, args, f);
    if (rc || !f->table)
        return rc;
    for (size_t i = 0; i < sizeof track_options / sizeof track_options[0]; i++)
        if (pbc_arg(cmd, args, track_options[i]))
            return pbc_fail(PBC_EXIT_USAGE, "--fields and %s: give one motion, either the fields (non-rigid) or a "
                            "track (--motion, --translate/--rotate)", track_options[i]);
    for (size_t i = 0; i < sizeof track_only / sizeof track_only[0]; i++)
        if (pbc_arg(cmd, args, track_only[i]))
            return pbc_fail(PBC_EXIT_USAGE, "%s applies to a pose track, not to --fields: a field's vectors are world "
                            "mm and its paths are walked exactly between its samples; leave %s out", track_only[i],
                            track_only[i]);
    const char *frame = pbc_arg(cmd, args, "--frame");
    if (frame && (rc = pbc_parse_interval("--frame", frame, f->frame)))
        return rc;
    f->has_frame = frame != NULL;
    if ((rc = pbc_field_table_read(f->table, f))) {
        pbc_fields_free(f);
        return rc;
    }
    if (f->by_value && !pbc_arg(cmd, args, "--signal")) {
        if (strcmp(cmd->name, "blur"))
            rc = pbc_fail(PBC_EXIT_USAGE, "--fields %s gives fields at a surrogate's values ('value,path'); petblur "
                          "%s reads fields at times ('time,path'): blur such a table with petblur blur --signal "
                          "TRACE.csv", f->table, cmd->name);
        else
            rc = pbc_fail(PBC_EXIT_USAGE, "--fields %s gives fields at a surrogate's values ('value,path'): give "
                          "--signal TRACE.csv too, the surrogate's 'time,value' samples", f->table);
        pbc_fields_free(f);
        return rc;
    }
    if (!f->has_frame && !f->by_value) {
        f->frame[0] = f->times[0];
        f->frame[1] = f->times[f->rows - 1];
    }
    return 0;
}

char *pbc_field_trim(char *s)
{
    while (*s == ' ' || *s == '\t')
        s++;
    size_t n = strlen(s);
    while (n && (s[n - 1] == ' ' || s[n - 1] == '\t' || s[n - 1] == '\r' || s[n - 1] == '\n'))
        s[--n] = '\0';
    return s;
}

int pbc_field_same_words(const char *a, const char *b)
{
    for (; *a && *b; a++, b++)
        if (tolower((unsigned char)*a) != tolower((unsigned char)*b))
            return 0;
    return *a == *b;
}

/* The path of a row: relative ones are the table's folder's. */
static char *resolve(const char *table, const char *path)
{
    const char *slash = strrchr(table, '/');
    int dir = path[0] == '/' || !slash ? 0 : (int)(slash - table) + 1;
    size_t n = (size_t)dir + strlen(path) + 1;
    char *out = n <= PATH_MAX ? malloc(n) : NULL;
    if (out)
        snprintf(out, n, "%.*s%s", dir, table, path);
    return out;
}

static int grow(pbc_fields *f, size_t *capacity)
{
    if (f->rows < *capacity)
        return 0;
    size_t cap = *capacity ? 2 * *capacity : 16;
    double *t = realloc(f->times, cap * sizeof *t);
    if (t)
        f->times = t;
    char **p = t ? realloc(f->paths, cap * sizeof *p) : NULL;
    if (p)
        f->paths = p;
    if (!t || !p)
        return pbc_fail(PBC_EXIT_RUNTIME, "--fields %s: out of memory for %zu rows", f->table, cap);
    *capacity = cap;
    return 0;
}

/* One row "T,PATH" (line number `line`), appended. */
static int take_row(pbc_fields *f, char *text, size_t line, size_t *capacity)
{
    char *comma = strchr(text, ',');
    if (!comma)
        return pbc_fail(PBC_EXIT_USAGE, "--fields %s line %zu: '%s' is not 'time,path'; give the field's time in "
                        "seconds, a comma and its file", f->table, line, text);
    *comma = '\0';
    char *time = pbc_field_trim(text), *path = pbc_field_trim(comma + 1);
    size_t n = strlen(path);
    if (n >= 2 && path[0] == '"' && path[n - 1] == '"') { /* a quoted path, as spreadsheets write one */
        path[n - 1] = '\0';
        path++;
    }
    double t;
    if (pbc_plain_number(time, &t))
        return pbc_fail(PBC_EXIT_USAGE, "--fields %s line %zu: time '%s' is not a number; give seconds as a plain "
                        "decimal", f->table, line, time);
    if (!path[0])
        return pbc_fail(PBC_EXIT_USAGE, "--fields %s line %zu: no file after the time; give the field's NIfTI "
                        "file", f->table, line);
    if (f->rows == PBC_MAX_FIELDS)
        return pbc_fail(PBC_EXIT_USAGE, "--fields %s: more than %d fields; petblur reads at most %d: give a table "
                        "of the frames' fields only", f->table, PBC_MAX_FIELDS, PBC_MAX_FIELDS);
    if (f->rows && !(t > f->times[f->rows - 1]) && f->by_value)
        return pbc_fail(PBC_EXIT_USAGE, "--fields %s line %zu: value %s is not above the row before it (%s); sort the "
                        "rows by the surrogate's value", f->table, line, PBC_NUM(t), PBC_NUM(f->times[f->rows - 1]));
    if (f->rows && !(t > f->times[f->rows - 1]))
        return pbc_fail(PBC_EXIT_USAGE, "--fields %s line %zu: time %s s is not after the row before it (%s s); "
                        "sort the rows by time (a still warp is the same file at two times)", f->table, line,
                        PBC_NUM(t), PBC_NUM(f->times[f->rows - 1]));
    int rc = grow(f, capacity);
    if (rc)
        return rc;
    f->times[f->rows] = t;
    if (!(f->paths[f->rows] = resolve(f->table, path)))
        return pbc_fail(PBC_EXIT_USAGE, "--fields %s line %zu: the path %s is too long (or memory ran out)", f->table,
                        line, path);
    f->rows++;
    return 0;
}

int pbc_field_next_row(FILE *in, char *buf, size_t size, size_t *line, char **row, const char *option,
                       const char *path, const char *form)
{
    *row = NULL;
    while (fgets(buf, (int)size, in)) {
        ++*line;
        size_t n = strlen(buf);
        if (n == size - 1 && buf[n - 1] != '\n')
            return pbc_fail(PBC_EXIT_USAGE, "%s %s line %zu: longer than %zu characters; a row is '%s'", option, path,
                            *line, size - 2, form);
        char *s = buf;
        if (*line == 1 && !strncmp(s, "\xEF\xBB\xBF", 3)) /* a byte-order mark, as some editors write */
            s += 3;
        s = pbc_field_trim(s);
        if (*s) {
            *row = s;
            return 0;
        }
    }
    return 0;
}

static int read_lines(FILE *in, pbc_fields *f)
{
    char buf[MAX_LINE + 2], *s;
    size_t line = 0, capacity = 0;
    int header = 0, rc = 0;
    while (!rc && !(rc = pbc_field_next_row(in, buf, sizeof buf, &line, &s, "--fields", f->table, "time,path")) && s) {
        if (!header) {
            char *comma = strchr(s, ',');
            if (comma)
                *comma = '\0';
            f->by_value = comma && pbc_field_same_words(pbc_field_trim(s), "value");
            if (!comma || !(f->by_value || pbc_field_same_words(pbc_field_trim(s), "time")) || !pbc_field_same_words(pbc_field_trim(comma + 1), "path"))
                return pbc_fail(PBC_EXIT_USAGE, "--fields %s line %zu: the first line must be the header 'time,path' "
                                "(or 'value,path', fields at a surrogate's values with --signal); add it, then one row "
                                "per field: its time in seconds and its NIfTI file", f->table, line);
            header = 1;
            continue;
        }
        rc = take_row(f, s, line, &capacity);
    }
    if (!rc && ferror(in))
        rc = pbc_fail(PBC_EXIT_USAGE, "--fields %s: reading failed (%s)", f->table, strerror(errno));
    if (!rc && f->rows < 2)
        rc = pbc_fail(PBC_EXIT_USAGE, "--fields %s: %zu field%s; give at least two, at or before the frame's start "
                      "and at or after its end (a still warp: the same file at both times)", f->table, f->rows,
                      f->rows == 1 ? "" : "s");
    return rc;
}

int pbc_field_table_read(const char *table, pbc_fields *f)
{
    struct stat st;
    FILE *in = fopen(table, "r");
    if (!in)
        return pbc_fail(PBC_EXIT_USAGE, "--fields %s: cannot read it (%s); check the path", table, strerror(errno));
    /* Rows at most, of a path and a number each: a bigger file is not a table of fields. */
    int rc = 0;
    if (fstat(fileno(in), &st) != 0 || !S_ISREG(st.st_mode))
        rc = pbc_fail(PBC_EXIT_USAGE, "--fields %s: not a regular file; give the table of fields (a .csv)", table);
    else if (st.st_size > (off_t)PBC_MAX_FIELDS * 512)
        rc = pbc_fail(PBC_EXIT_USAGE, "--fields %s: %lld bytes, more than a table of %d fields holds; give the table "
                      "of fields ('time,path' rows), not a field itself", table, (long long)st.st_size,
                      PBC_MAX_FIELDS);
    if (!rc)
        rc = read_lines(in, f);
    fclose(in);
    return rc;
}

void pbc_fields_files(const pbc_fields *f, pbc_files *files)
{
    if (!f->table)
        return;
    pbc_files_read(files, "--fields", f->table);
    pbc_files_read(files, "--signal", f->signal_path);
    for (size_t i = 0; i < f->rows; i++)
        pbc_files_read(files, "--fields", f->paths[i]);
}

void pbc_fields_free(pbc_fields *f)
{
    for (size_t i = 0; i < f->rows; i++)
        free(f->paths[i]);
    free(f->paths);
    free(f->times);
    free(f->vectors);
    free(f->signal_times);
    free(f->signal);
    free(f->edges);
    free(f->intervals);
    free(f->counts);
    f->signal_times = f->signal = f->edges = f->intervals = NULL;
    f->counts = NULL;
    f->signal_count = f->gates = 0;
    f->paths = NULL;
    f->times = NULL;
    f->vectors = NULL;
    f->rows = 0;
}
