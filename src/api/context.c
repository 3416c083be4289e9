/* Contexts: one device opened on one backend, what it reports, its timing,
 * stream and progress report, and the holders that keep it alive. */
#include <stdlib.h>

#include "objects.h"

static char *context_error_text(pb_context *ctx)
{
    return ctx->last_error;
}

const char *pb_last_error(const pb_context *ctx)
{
    return ctx ? ctx->last_error : pb_thread_error();
}

pb_status pb_context_create(const pb_context_options *options, pb_context **out)
{
    pb_error_context_text(context_error_text); /* before any failure can name this context */
    if (!out)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the context pointer must not be NULL");
    *out = NULL;
    pb_context_options opt = {PB_BACKEND_AUTO, 0, NULL};
    if (options)
        opt = *options;
    const pb_backend_ops *ops = NULL;
    pb_status st = pb_backend_select(&opt, &ops);
    if (st != PB_OK)
        return st;

    pb_context *ctx = calloc(1, sizeof *ctx);
    if (!ctx)
        return pb_error(NULL, PB_ERR_OUT_OF_MEMORY, "out of host memory for a context");
    ctx->dev.ops = ops;
    ctx->dev.owner = ctx;
    st = ops->context_init(&ctx->dev, opt.device_index, opt.build_options);
    if (st != PB_OK) {
        ops->context_release(&ctx->dev);
        free(ctx);
        return st;
    }
    *out = ctx;
    return PB_OK;
}

static void context_release(pb_context *ctx)
{
    if (ctx->dev.scratch)
        ctx->dev.ops->buffer_release(&ctx->dev, ctx->dev.scratch);
    ctx->dev.ops->context_release(&ctx->dev);
    free(ctx);
}

void pb_context_destroy(pb_context *ctx)
{
    if (!ctx || ctx->destroyed)
        return;
    ctx->destroyed = 1;
    if (ctx->holders == 0)
        context_release(ctx);
}

void pb_context_hold(pb_context *ctx)
{
    ctx->holders++;
}

/* The contexts this thread is inside (a progress report may call into a
 * second one), and how deeply. */
enum { MAX_NESTED = 8 };
static _Thread_local pb_context *inside[MAX_NESTED];
static _Thread_local unsigned depth[MAX_NESTED];
static _Thread_local int entered;

pb_status pb_context_enter(pb_context *ctx)
{
    for (int i = 0; i < entered; i++)
        if (inside[i] == ctx) {
            depth[i]++;
            return PB_OK;
        }
    if (entered == MAX_NESTED)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "calls nest in more than %d contexts; call petblur from a "
                        "progress report less deeply", MAX_NESTED);
    if (atomic_exchange(&ctx->busy, 1))
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the context (%s) is in use by another thread; a context, its "
                        "volumes and its plans take one thread at a time: take turns with a lock, or give each "
                        "thread its own context", ctx->dev.info.name);
    inside[entered] = ctx;
    depth[entered++] = 1;
    return PB_OK;
}

void pb_context_leave(pb_context *ctx)
{
    for (int i = entered - 1; i >= 0; i--)
        if (inside[i] == ctx) {
            if (--depth[i] == 0) {
                inside[i] = inside[entered - 1];
                depth[i] = depth[entered - 1];
                entered--;
                atomic_store(&ctx->busy, 0);
            }
            return;
        }
}

void pb_context_release_hold(pb_context *ctx)
{
    if (--ctx->holders == 0 && ctx->destroyed)
        context_release(ctx);
}

pb_status pb_context_native(const pb_context *ctx, pb_native *native)
{
    if (!ctx || !native)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "ctx and native must not be NULL");
    *native = (pb_native){NULL, NULL, NULL, 0};
    if (ctx->dev.ops->native)
        ctx->dev.ops->native(&ctx->dev, native);
    return PB_OK;
}

pb_backend pb_context_backend(const pb_context *ctx)
{
    return ctx ? ctx->dev.ops->id : PB_BACKEND_AUTO;
}

pb_status pb_context_device_info(const pb_context *ctx, pb_device_info *info)
{
    if (!ctx || !info)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "ctx and info must not be NULL");
    *info = ctx->dev.info;
    return PB_OK;
}

const char *pb_context_notes(const pb_context *ctx)
{
    return ctx ? ctx->dev.notes : "";
}

/* The last call's times; for a call queued on a caller's stream, once it is
 * done. */
static pb_status last_times(const pb_context *ctx, double *kernel_ms, double *input_ms)
{
    pb_status st = PB_OK;
    if (!ctx->dev.ops->timer_wait || !ctx->dev.ops->timer_wait(&ctx->dev, &st, kernel_ms, input_ms)) {
        *kernel_ms = ctx->dev.last_kernel_ms;
        *input_ms = ctx->dev.last_input_ms;
    }
    return st;
}

pb_status pb_context_last_kernel_ms(const pb_context *ctx, double *ms)
{
    if (!ctx || !ms)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "ctx and ms must not be NULL");
    double input;
    return last_times(ctx, ms, &input);
}

pb_status pb_context_last_input_ms(const pb_context *ctx, double *ms)
{
    if (!ctx || !ms)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "ctx and ms must not be NULL");
    double kernel;
    return last_times(ctx, &kernel, ms);
}

pb_status pb_context_set_stream(pb_context *ctx, void *stream)
{
    if (!ctx)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "ctx must not be NULL");
    if (ctx->dev.ops->set_stream)
        return ctx->dev.ops->set_stream(&ctx->dev, stream);
    if (stream)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT,
                        "pb_context_set_stream takes a CUDA stream, and this context runs on the %s backend, which "
                        "queues on its own queue (pb_context_native); pass NULL or use a CUDA context",
                        pb_backend_name(ctx->dev.ops->id));
    return PB_OK;
}

pb_status pb_context_set_progress(pb_context *ctx, pb_progress_fn fn, void *user)
{
    if (!ctx)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "ctx must not be NULL");
    ctx->dev.progress = fn;
    ctx->dev.progress_user = user;
    return PB_OK;
}
