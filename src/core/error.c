#include "error.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include <stdatomic.h>

/* Every failure writes the calling thread's text, so that pb_last_error(NULL)
 * always tells the last failure of this thread, with or without a context;
 * a failure on a context also leaves the text on it. */
static _Thread_local char thread_error[PB_ERROR_TEXT_MAX];
/* Formatted here first: a message may quote the text it replaces. */
static _Thread_local char scratch[PB_ERROR_TEXT_MAX];
static _Thread_local unsigned long thread_serial;
/* Where a context keeps its copy: the context is the API layer's object, so it
 * says (pb_error_context_text) and this layer never sees inside one. */
static _Atomic(pb_context_text_fn) context_text;

void pb_error_context_text(pb_context_text_fn text_of)
{
    atomic_store(&context_text, text_of);
}

static char *text_of(struct pb_context *ctx)
{
    pb_context_text_fn f = ctx ? atomic_load(&context_text) : NULL;
    return f ? f(ctx) : NULL;
}

pb_status pb_error(struct pb_context *ctx, pb_status status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(scratch, PB_ERROR_TEXT_MAX, fmt, ap);
    va_end(ap);
    size_t n = strlen(scratch) + 1;
    memcpy(thread_error, scratch, n);
    thread_serial++;
    char *copy = text_of(ctx);
    if (copy)
        memcpy(copy, scratch, n);
    return status;
}

pb_status pb_error_prefix(pb_status status, const char *fmt, ...)
{
    char prefix[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(prefix, sizeof prefix, fmt, ap); /* fmt's arguments may quote the text */
    va_end(ap);
    size_t n = strlen(prefix), used = strlen(thread_error);
    if (n + used >= PB_ERROR_TEXT_MAX)
        used = PB_ERROR_TEXT_MAX - n - 1;
    memmove(thread_error + n, thread_error, used);
    memcpy(thread_error, prefix, n);
    thread_error[n + used] = '\0';
    return status;
}

unsigned long pb_error_serial(void)
{
    return thread_serial;
}

void pb_error_append(struct pb_context *ctx, const char *text)
{
    size_t used = strlen(thread_error);
    snprintf(thread_error + used, PB_ERROR_TEXT_MAX - used, "%s", text);
    char *copy = text_of(ctx);
    if (copy)
        memcpy(copy, thread_error, strlen(thread_error) + 1);
}

void pb_warn(pb_warnings *w, unsigned flag, const char *fmt, ...)
{
    if (!w)
        return;
    w->flags |= flag;
    size_t used = strlen(w->text);
    if (used + 1 >= sizeof w->text)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(w->text + used, sizeof w->text - used - 1, fmt, ap);
    va_end(ap);
    used = strlen(w->text);
    w->text[used] = '\n';
    w->text[used + 1] = '\0';
}

const char *pb_thread_error(void)
{
    return thread_error;
}

const char *pb_status_string(pb_status status)
{
    switch (status) {
    case PB_OK: return "success";
    case PB_ERR_INVALID_ARGUMENT: return "invalid argument";
    case PB_ERR_ZERO_DIMS: return "zero volume dimension";
    case PB_ERR_BAD_VOXEL_SIZE: return "bad voxel size";
    case PB_ERR_NOT_FINITE: return "NaN or infinite number";
    case PB_ERR_BAD_QUATERNION: return "zero or non-unit quaternion";
    case PB_ERR_BAD_FRAME: return "frame end not after its start";
    case PB_ERR_TRACK_ORDER: return "track times not strictly increasing";
    case PB_ERR_TRACK_GAP: return "track does not cover the frame";
    case PB_ERR_SIZE_MISMATCH: return "volumes differ in size or context";
    case PB_ERR_AFFINE_SHEAR: return "voxel-to-world affine with a shear";
    case PB_ERR_NOT_RIGID: return "pose matrix not rigid";
    case PB_ERR_OUT_OF_VIEW: return "grid out of the field of view for a whole frame";
    case PB_ERR_BACKEND_UNAVAILABLE: return "backend not compiled in";
    case PB_ERR_NO_DEVICE: return "no device";
    case PB_ERR_NO_IMAGE_SUPPORT: return "no 3-D float image support";
    case PB_ERR_VOLUME_TOO_LARGE: return "volume beyond the device's image limits";
    case PB_ERR_DEVICE: return "device runtime failure";
    case PB_ERR_BUILD: return "kernel build failed";
    case PB_ERR_LAUNCH: return "kernel launch failed";
    case PB_ERR_OUT_OF_MEMORY: return "out of memory";
    case PB_ERR_BAD_FILE: return "unreadable or malformed file";
    }
    return "unknown status";
}
