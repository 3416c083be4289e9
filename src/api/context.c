/* The public API above the backend boundary: argument checks, backend choice,
 * and dispatch through the ops table. */
#include <ctype.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "backend.h"

static const pb_backend_ops *backend_ops(pb_backend backend)
{
    switch (backend) {
    case PB_BACKEND_HOST: return &pb_backend_host_ops;
#ifdef PB_HAVE_OPENCL
    case PB_BACKEND_OPENCL: return &pb_backend_opencl_ops;
#endif
#ifdef PB_HAVE_CUDA
    case PB_BACKEND_CUDA: return &pb_backend_cuda_ops;
#endif
    default: return NULL;
    }
}

const char *pb_backend_name(pb_backend backend)
{
    switch (backend) {
    case PB_BACKEND_AUTO: return "auto";
    case PB_BACKEND_HOST: return "host";
    case PB_BACKEND_OPENCL: return "opencl";
    case PB_BACKEND_CUDA: return "cuda";
    }
    return "unknown";
}

int pb_backend_compiled(pb_backend backend)
{
    return backend_ops(backend) != NULL;
}

pb_status pb_device_parse(const char *spec, pb_backend *backend, int *index)
{
    if (!spec || !backend || !index)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "spec, backend and index must not be NULL");
    for (int b = PB_BACKEND_AUTO; b <= PB_BACKEND_CUDA; b++) {
        const char *name = pb_backend_name((pb_backend)b);
        size_t n = strlen(name);
        if (strncmp(spec, name, n) != 0)
            continue;
        *backend = (pb_backend)b;
        *index = 0;
        if (spec[n] == '\0')
            return PB_OK;
        /* Only device backends have several devices to number. */
        if (spec[n] == ':' && (b == PB_BACKEND_OPENCL || b == PB_BACKEND_CUDA) && isdigit((unsigned char)spec[n + 1])) {
            char *end;
            long v = strtol(spec + n + 1, &end, 10);
            if (*end == '\0' && v < 1000) {
                *index = (int)v;
                return PB_OK;
            }
        }
    }
    return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "device '%s' is not auto, host, opencl[:N] or cuda[:N]", spec);
}

static pb_status require_ops(pb_backend backend, const pb_backend_ops **ops)
{
    *ops = backend_ops(backend);
    if (*ops)
        return PB_OK;
    if (backend == PB_BACKEND_OPENCL || backend == PB_BACKEND_CUDA)
        return pb_error(NULL, PB_ERR_BACKEND_UNAVAILABLE,
                        "the %s backend is not compiled into this build of petblur; rebuild with -D%s=enabled "
                        "(and its SDK installed) or choose another backend",
                        pb_backend_name(backend), pb_backend_name(backend));
    return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "unknown backend %d; use host, opencl, cuda or auto",
                    (int)backend);
}

pb_status pb_device_count(pb_backend backend, int *count)
{
    const pb_backend_ops *ops;
    if (!count)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "count must not be NULL");
    *count = 0;
    pb_status st = require_ops(backend, &ops);
    return st == PB_OK ? ops->device_count(count) : st;
}

pb_status pb_device_get_info(pb_backend backend, int index, pb_device_info *info)
{
    const pb_backend_ops *ops;
    if (!info)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "info must not be NULL");
    pb_status st = require_ops(backend, &ops);
    if (st != PB_OK)
        return st;
    int n = 0;
    st = ops->device_count(&n);
    if (st != PB_OK)
        return st;
    if (index < 0 || index >= n)
        return pb_error(NULL, PB_ERR_NO_DEVICE, "%s device %d does not exist (%d found); pick 0 to %d",
                        pb_backend_name(backend), index, n, n - 1);
    return ops->device_info(index, info);
}

/* CUDA if a GPU is there, else an OpenCL GPU, else the first OpenCL device. */
static pb_status choose_auto(pb_backend *backend, int *index)
{
    int n = 0;
    if (backend_ops(PB_BACKEND_CUDA) && pb_device_count(PB_BACKEND_CUDA, &n) == PB_OK && n > 0) {
        *backend = PB_BACKEND_CUDA;
        *index = 0;
        return PB_OK;
    }
    if (backend_ops(PB_BACKEND_OPENCL) && pb_device_count(PB_BACKEND_OPENCL, &n) == PB_OK && n > 0) {
        *backend = PB_BACKEND_OPENCL;
        *index = 0;
        for (int i = 0; i < n; i++) {
            pb_device_info info;
            if (pb_device_get_info(PB_BACKEND_OPENCL, i, &info) == PB_OK && info.is_gpu) {
                *index = i;
                break;
            }
        }
        return PB_OK;
    }
    return pb_error(NULL, PB_ERR_NO_DEVICE,
                    "no CUDA or OpenCL device found; install an OpenCL driver (on Debian: apt-get install "
                    "pocl-opencl-icd) or choose the host backend");
}

pb_status pb_context_create(const pb_context_options *options, pb_context **out)
{
    if (!out)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "the context pointer must not be NULL");
    *out = NULL;
    pb_context_options opt = {PB_BACKEND_AUTO, 0, NULL};
    if (options)
        opt = *options;
    pb_status st = PB_OK;
    if (opt.backend == PB_BACKEND_AUTO)
        st = choose_auto(&opt.backend, &opt.device_index);
    const pb_backend_ops *ops = NULL;
    if (st == PB_OK)
        st = require_ops(opt.backend, &ops);
    if (st != PB_OK)
        return st;
    if (opt.device_index < 0)
        return pb_error(NULL, PB_ERR_NO_DEVICE, "device index %d is negative; count devices from 0",
                        opt.device_index);

    pb_context *ctx = calloc(1, sizeof *ctx);
    if (!ctx)
        return pb_error(NULL, PB_ERR_OUT_OF_MEMORY, "out of host memory for a context");
    ctx->ops = ops;
    st = ops->context_init(ctx, opt.device_index, opt.build_options);
    if (st != PB_OK) {
        /* The backend wrote its message on ctx; hand it to the thread. */
        pb_error(NULL, st, "%s", ctx->last_error);
        ops->context_release(ctx);
        free(ctx);
        return st;
    }
    *out = ctx;
    return PB_OK;
}

static void context_release(pb_context *ctx)
{
    if (ctx->scratch)
        ctx->ops->buffer_release(ctx, ctx->scratch);
    ctx->ops->context_release(ctx);
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
    if (ctx->ops->native)
        ctx->ops->native(ctx, native);
    return PB_OK;
}

pb_backend pb_context_backend(const pb_context *ctx)
{
    return ctx ? ctx->ops->id : PB_BACKEND_AUTO;
}

pb_status pb_context_device_info(const pb_context *ctx, pb_device_info *info)
{
    if (!ctx || !info)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "ctx and info must not be NULL");
    *info = ctx->device;
    return PB_OK;
}

/* The last call's times; for a call queued on a caller's stream, once it is
 * done. */
static pb_status last_times(const pb_context *ctx, double *kernel_ms, double *input_ms)
{
    pb_status st = PB_OK;
    if (!ctx->ops->timer_wait || !ctx->ops->timer_wait(ctx, &st, kernel_ms, input_ms)) {
        *kernel_ms = ctx->last_kernel_ms;
        *input_ms = ctx->last_input_ms;
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
    if (ctx->ops->set_stream)
        return ctx->ops->set_stream(ctx, stream);
    if (stream)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT,
                        "pb_context_set_stream takes a CUDA stream, and this context runs on the %s backend, which "
                        "queues on its own queue (pb_context_native); pass NULL or use a CUDA context",
                        pb_backend_name(ctx->ops->id));
    return PB_OK;
}

pb_status pb_context_set_progress(pb_context *ctx, pb_progress_fn fn, void *user)
{
    if (!ctx)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "ctx must not be NULL");
    ctx->progress = fn;
    ctx->progress_user = user;
    return PB_OK;
}

/* ---- volumes ----------------------------------------------------------- */

pb_status pb_geometry_check(pb_context *ctx, const pb_geometry *g, size_t *count)
{
    for (int i = 0; i < 3; i++) {
        if (g->dims[i] == 0)
            return pb_error(ctx, PB_ERR_ZERO_DIMS, "volume dimension %c is 0 (dims %zu x %zu x %zu); every dimension needs at least one voxel",
                            "xyz"[i], g->dims[0], g->dims[1], g->dims[2]);
        if (!isfinite(g->voxel_size[i]) || !(g->voxel_size[i] > 0.0))
            return pb_error(ctx, PB_ERR_BAD_VOXEL_SIZE, "voxel size %c is %g mm; give a positive, finite size in mm",
                            "xyz"[i], g->voxel_size[i]);
    }
    /* Kernels index voxels with 32-bit ints and bytes with size_t. */
    if (g->dims[0] > INT32_MAX / g->dims[1] || g->dims[0] * g->dims[1] > INT32_MAX / g->dims[2])
        return pb_error(ctx, PB_ERR_VOLUME_TOO_LARGE,
                        "volume %zu x %zu x %zu has more than 2^31 - 1 voxels; split it into slabs",
                        g->dims[0], g->dims[1], g->dims[2]);
    *count = g->dims[0] * g->dims[1] * g->dims[2];
    return PB_OK;
}

pb_status pb_device_check_volume(pb_context *ctx, const pb_device_info *info, const pb_geometry *g)
{
    if (!info->image_support)
        return pb_error(ctx, PB_ERR_NO_IMAGE_SUPPORT,
                        "device '%s' cannot hold 3-D float images with linear filtering, which every method "
                        "samples; choose another device or the host backend",
                        info->name);
    for (int i = 0; i < 3; i++) {
        if (info->image3d_max[i] && g->dims[i] > info->image3d_max[i])
            return pb_error(ctx, PB_ERR_VOLUME_TOO_LARGE,
                            "volume %zu x %zu x %zu exceeds the largest 3-D image of device '%s' (%zu x %zu x %zu); "
                            "crop or resample the volume, or use a device with larger images",
                            g->dims[0], g->dims[1], g->dims[2], info->name, info->image3d_max[0],
                            info->image3d_max[1], info->image3d_max[2]);
    }
    uint64_t bytes = (uint64_t)g->dims[0] * g->dims[1] * g->dims[2] * sizeof(float);
    if (info->max_alloc_bytes && bytes > info->max_alloc_bytes)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY,
                        "volume %zu x %zu x %zu needs %.1f MiB in one allocation, more than device '%s' allows "
                        "(%.1f MiB); use a smaller volume or a device with more memory",
                        g->dims[0], g->dims[1], g->dims[2], bytes / 1048576.0, info->name,
                        info->max_alloc_bytes / 1048576.0);
    return PB_OK;
}

pb_status pb_volume_create(pb_context *ctx, const pb_geometry *g, pb_volume **out)
{
    if (!ctx || !g || !out)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ctx, geometry and volume must not be NULL");
    *out = NULL;
    size_t count = 0;
    pb_status st = pb_geometry_check(ctx, g, &count);
    if (st == PB_OK)
        st = pb_device_check_volume(ctx, &ctx->device, g);
    if (st != PB_OK)
        return st;
    pb_volume *vol = calloc(1, sizeof *vol);
    if (!vol)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for a volume");
    vol->ctx = ctx;
    vol->geometry = *g;
    vol->count = count;
    st = ctx->ops->buffer_create(ctx, count * sizeof(float), &vol->buffer);
    if (st != PB_OK) {
        free(vol);
        return st;
    }
    pb_images_stale(&vol->images);
    vol->next = ctx->volumes;
    if (ctx->volumes)
        ctx->volumes->prev = vol;
    ctx->volumes = vol;
    pb_context_hold(ctx);
    *out = vol;
    return PB_OK;
}

void pb_volume_destroy(pb_volume *vol)
{
    if (!vol)
        return;
    pb_context *ctx = vol->ctx;
    if (vol->prev)
        vol->prev->next = vol->next;
    else
        ctx->volumes = vol->next;
    if (vol->next)
        vol->next->prev = vol->prev;
    pb_images_release(ctx, &vol->images);
    ctx->ops->buffer_release(ctx, vol->buffer);
    free(vol);
    pb_context_release_hold(ctx);
}

pb_status pb_volume_get_geometry(const pb_volume *vol, pb_geometry *g)
{
    if (!vol || !g)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "volume and geometry must not be NULL");
    *g = vol->geometry;
    return PB_OK;
}

pb_status pb_volume_upload(pb_volume *vol, const float *host)
{
    if (!vol || !host)
        return pb_error(vol ? vol->ctx : NULL, PB_ERR_INVALID_ARGUMENT, "volume and host data must not be NULL");
    /* One NaN would spread through every blur that reads it; refuse it here,
     * where the voxel can still be named. */
    const size_t *n = vol->geometry.dims;
    for (size_t i = 0; i < vol->count; i++)
        if (!isfinite(host[i]))
            return pb_error(vol->ctx, PB_ERR_NOT_FINITE,
                            "activity at voxel (%zu, %zu, %zu) is %g; replace NaN and infinite values (for "
                            "example by 0) before uploading",
                            i % n[0], i / n[0] % n[1], i / (n[0] * n[1]), (double)host[i]);
    pb_status st = vol->ctx->ops->buffer_write(vol->ctx, vol->buffer, host, vol->count * sizeof(float));
    pb_images_stale(&vol->images);
    return st;
}

pb_status pb_volume_download(const pb_volume *vol, float *host)
{
    if (!vol || !host)
        return pb_error(vol ? vol->ctx : NULL, PB_ERR_INVALID_ARGUMENT, "volume and host data must not be NULL");
    return vol->ctx->ops->buffer_read(vol->ctx, vol->buffer, host, vol->count * sizeof(float));
}

void pb_volume_memory_written(pb_context *ctx, const void *memory)
{
    for (pb_volume *v = ctx->volumes; v; v = v->next)
        if (v->buffer == memory)
            pb_images_stale(&v->images);
}

pb_status pb_volume_memory(const pb_volume *vol, void **memory)
{
    if (!vol || !memory)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "volume and memory must not be NULL");
    *memory = vol->buffer;
    return PB_OK;
}

/* ---- blurring ---------------------------------------------------------- */

static pb_status check_options(pb_context *ctx, const pb_blur_options *o)
{
    if ((unsigned)o->method > PB_METHOD_REF)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "unknown method %d; use AB, RM, CL or REF", (int)o->method);
    if ((unsigned)o->filter > PB_FILTER_EXACT)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "unknown filter %d; use HARDWARE or EXACT", (int)o->filter);
    /* Bounds keep per-voxel loops and step lists within what a kernel can run. */
    if (o->steps > 100000)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "steps %u is above 100000; use fewer", o->steps);
    if (o->ref_points > 100000)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ref_points %u is above 100000; use fewer", o->ref_points);
    if (o->ref_time_steps > 100000)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "ref_time_steps %u is above 100000; use fewer",
                        o->ref_time_steps);
    if ((unsigned)o->path > PB_PATH_TRACKED)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "unknown path model %d; use PB_PATH_DEFAULT, PB_PATH_BOUNDED "
                        "or PB_PATH_TRACKED", (int)o->path);
    if (o->path == PB_PATH_BOUNDED && !(o->max_path_error > 0.0 && o->max_path_error <= 1000.0))
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "max_path_error %g: give a bound in voxels above 0 and at most "
                        "1000 (e.g. 0.25), or the paper's polyline (one segment per tracked interval)",
                        o->max_path_error);
    if (o->path != PB_PATH_BOUNDED && o->max_path_error != 0.0)
        return pb_error(ctx, PB_ERR_INVALID_ARGUMENT, "max_path_error %g is set, but the path model is %s; set the "
                        "model to PB_PATH_BOUNDED for a bound", o->max_path_error,
                        o->path == PB_PATH_TRACKED ? "the paper's polyline" : "the default bound");
    return PB_OK;
}

pb_status pb_path_segments(const pb_geometry *geometry, const pb_motion *motion, const pb_blur_options *options,
                           size_t *segments)
{
    size_t count;
    if (!geometry || !motion || !segments)
        return pb_error(NULL, PB_ERR_INVALID_ARGUMENT, "geometry, motion and segments must not be NULL");
    pb_blur_options opt = {PB_METHOD_AB, PB_FILTER_HARDWARE, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0};
    if (options)
        opt = *options;
    pb_status st = pb_geometry_check(NULL, geometry, &count);
    if (st == PB_OK)
        st = check_options(NULL, &opt);
    if (st != PB_OK)
        return st;
    /* AB's plan: CL and REF follow the path itself, but the question is what
     * a polyline of these options would need. */
    opt.method = PB_METHOD_AB;
    pb_path plan;
    if ((st = pb_path_create(NULL, geometry, motion, &opt, &plan)) != PB_OK)
        return st;
    *segments = plan.count - 1;
    pb_path_destroy(&plan);
    return PB_OK;
}

pb_status pb_options_check(const pb_blur_options *options)
{
    pb_blur_options opt;
    return pb_options_prepare(NULL, options, &opt);
}

pb_status pb_options_prepare(pb_context *ctx, const pb_blur_options *options, pb_blur_options *opt)
{
    *opt = (pb_blur_options){PB_METHOD_AB, PB_FILTER_HARDWARE, 0, 0, 0, 0, PB_PATH_DEFAULT, 0.0};
    if (options)
        *opt = *options;
    pb_status st = check_options(ctx, opt);
    if (st == PB_OK && opt->ref_points == 0)
        opt->ref_points = 200;
    return st;
}

double pb_error_percent(const float *reference, const float *x, size_t n)
{
    double num = 0.0, den = 0.0;
    if (!reference || !x)
        return (double)NAN;
    for (size_t i = 0; i < n; i++) {
        double d = (double)x[i] - (double)reference[i];
        num += d * d;
        den += (double)reference[i] * (double)reference[i];
    }
    return den > 0.0 ? 100.0 * num / den : (double)NAN;
}
