/* Status strings and last-error texts. */
#ifndef PB_ERROR_H
#define PB_ERROR_H

#include "petblur.h"

struct pb_context;

/* Sets the last-error text of ctx (of the calling thread when ctx is NULL) and
 * returns status, so that callers can write `return pb_error(...)`. */
pb_status pb_error(struct pb_context *ctx, pb_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Appends text (a build log, say) to the last-error text of ctx. */
void pb_error_append(struct pb_context *ctx, const char *text);

#define PB_ERROR_TEXT_MAX 65536

#endif
