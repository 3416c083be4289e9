/* The command line's shared conventions: exit statuses and messages. The
 * library never prints; the program does, always as "petblur: what is wrong;
 * how to fix it" on stderr. */
#ifndef PBC_CLI_H
#define PBC_CLI_H

#include <stddef.h>

enum {
    PBC_EXIT_OK = 0,
    PBC_EXIT_USAGE = 2,  /* bad usage or bad input: the user can fix it */
    PBC_EXIT_RUNTIME = 3 /* device or runtime failure: out of memory, no device, I/O errors */
};

#if defined(__GNUC__)
#define PBC_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define PBC_PRINTF(f, a)
#endif

/* Prints "petblur: <message>\n" on stderr and returns code, so that callers can
 * write `return pbc_fail(PBC_EXIT_USAGE, "...")`. */
int pbc_fail(int code, const char *fmt, ...) PBC_PRINTF(2, 3);

/* pb_number_text as a value, for messages and files: PBC_NUM(v) is the text,
 * alive until the end of the full expression that holds it. */
typedef struct pbc_number { char text[32]; } pbc_number;
pbc_number pbc_number_of(double v);
#define PBC_NUM(v) (pbc_number_of(v).text)

/* 1 when stderr is a terminal and not --quiet: progress lines are shown then. */
extern int pbc_show_progress;

#endif
