/* Command-line options: each command declares a table, from which both the
 * parser and its --help text come, so the two cannot disagree. */
#ifndef PBC_OPTIONS_H
#define PBC_OPTIONS_H

#include <stddef.h>

typedef struct pbc_option {
    const char *name;    /* "--dims" */
    const char *alias;   /* "-o", or NULL */
    const char *metavar; /* "NX,NY,NZ"; NULL for a flag */
    const char *help;    /* NULL: read by the command, left out of --help */
} pbc_option;

enum { PBC_MAX_OPTIONS = 48, PBC_MAX_POSITIONAL = 4 };

/* The --device row, the same in every command that opens a device. */
#define PBC_OPTION_DEVICE {"--device", NULL, "DEV", "auto (default), host, opencl[:N] or cuda[:N]"}

typedef struct pbc_command {
    const char *name;     /* "blur" */
    const char *synopsis; /* "-i IN -o OUT [options]" */
    const char *summary;  /* one paragraph: what it does */
    const pbc_option *options;
    int option_count;
    int min_positional, max_positional;
    const char *epilog;   /* examples, or NULL */
} pbc_command;

typedef struct pbc_args {
    const char *value[PBC_MAX_OPTIONS]; /* per option: its value, "" for a flag, NULL when absent */
    const char *positional[PBC_MAX_POSITIONAL];
    int positional_count;
} pbc_args;

/* Parses argv (after the command's name). Returns 0, -1 when --help was
 * printed (the caller exits 0), or an exit status after the message. Accepts
 * "--name VALUE" and "--name=VALUE"; an option given twice is an error. */
int pbc_parse_args(const pbc_command *cmd, int argc, char **argv, pbc_args *args);

void pbc_print_help(const pbc_command *cmd);

/* The value of the option called name, or NULL; name must be in the table. */
const char *pbc_arg(const pbc_command *cmd, const pbc_args *args, const char *name);

/* Value parsers: each prints "petblur: OPTION VALUE: what is expected" and
 * returns PBC_EXIT_USAGE on a bad value, 0 otherwise. */
int pbc_parse_dims(const char *option, const char *text, size_t dims[3]);
/* Three finite numbers "X,Y,Z"; positive when positive != 0. */
int pbc_parse_vec3(const char *option, const char *text, int positive, double v[3]);
/* Two finite numbers "A,B" with A < B. */
int pbc_parse_interval(const char *option, const char *text, double v[2]);
int pbc_parse_number(const char *option, const char *text, double *v);
/* The same without a message, for numbers inside a file: 0, or -1 when text is
 * not one finite plain decimal number. */
int pbc_plain_number(const char *text, double *v);
/* "T0,T1,...": at least two increasing finite numbers, malloc'ed into *v. */
int pbc_parse_bounds(const char *option, const char *text, double **v, size_t *count);
int pbc_parse_count(const char *option, const char *text, unsigned long lo, unsigned long hi, unsigned long *v);
/* One of names[0..count-1]; *index gets which. */
int pbc_parse_choice(const char *option, const char *text, const char *const *names, int count, int *index);
/* A name the library's parser refused (pb_method_parse and kin): its message,
 * which lists the choices, under the option's name; exit status for usage. */
int pbc_refused_name(const char *option);

#endif
