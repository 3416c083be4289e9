/* The one place that formats the program's messages. */
#include <stdarg.h>
#include <stdio.h>

#include "cli.h"

int pbc_show_progress;

int pbc_fail(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("petblur: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return code;
}
