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

/* Adds a warning of kind flag (PB_WARN_*), one line of text, to w (which may
 * be NULL: nobody asked). */
void pb_warn(pb_warnings *w, unsigned flag, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Puts a prefix before the calling thread's last-error text (a message of a
 * call made on the way, in context) and returns status. */
pb_status pb_error_prefix(pb_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* How many failures the calling thread has written: a call whose parts may
 * fail without a text of their own compares it with its value on entry to
 * tell its own failure's text from an earlier call's, while a successful call
 * leaves the text as it was. */
unsigned long pb_error_serial(void);

/* Appends text (a build log, say) to the last-error text of ctx. */
void pb_error_append(struct pb_context *ctx, const char *text);

/* The calling thread's last-error text (pb_last_error(NULL)). */
const char *pb_thread_error(void);

/* A context's copy of its last-error text, PB_ERROR_TEXT_MAX bytes: the API
 * layer, which owns contexts, registers this before it makes the first one. */
typedef char *(*pb_context_text_fn)(struct pb_context *ctx);
void pb_error_context_text(pb_context_text_fn text_of);

#define PB_ERROR_TEXT_MAX 65536

#endif
