/* The one place that formats the program's messages. */
#include <stdarg.h>
#include <stdio.h>

#include "cli.h"
#include "petblur.h"

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

pbc_number pbc_number_of(double v)
{
    pbc_number n;
    pb_number_text(v, n.text);
    return n;
}
