/* The CUDA backend: the kernels of cl/pb_blur.cl compiled by nvcc
 * (cuda/pb_kernels.cu), run through the CUDA runtime. The only library file that
 * includes a CUDA header; plain C, so it reaches the kernels through
 * cuda/pb_cuda_launch.h. Every runtime call is checked and its error text
 * reaches the caller. */
#include <cuda_runtime_api.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../cuda/pb_cuda_launch.h"
#include "backend.h"
#include "kernel_args.h"

typedef struct cu_impl {
    int device;
    cudaStream_t stream; /* every copy and launch of the context, in order */
    cudaEvent_t start, stop;
    void *plan;          /* key poses or REF steps of the current launch */
    size_t plan_bytes;
    void *scratch;       /* a volume laid out for its layers (pb_permute), kept: the adjoint's */
    size_t scratch_bytes; /* gather lays out every tomograph it reads, and a cudaMalloc there would count */
    size_t layer_limits[3]; /* layered 2-D textures: width, height, layers */
} cu_impl;

typedef struct cu_volume {
    float *buffer;               /* what the kernels write and the host reads */
    cudaArray_t array;           /* what the kernels sample; made on first use as an input */
    cudaTextureObject_t linear;  /* HARDWARE fetches */
    cudaTextureObject_t point;   /* EXACT and REF reads */
    int array_stale;
    cudaArray_t layers[3];             /* layered along each axis, for pb_shift_ab_layers, made on first use */
    cudaTextureObject_t layers_tex[3]; /* their linear filters */
    int layers_stale[3];
} cu_volume;

/* The buffer changed: the array and layers made from it are out of date. */
static void mark_written(cu_volume *v)
{
    v->array_stale = 1;
    for (int m = 0; m < 3; m++)
        v->layers_stale[m] = 1;
}

/* Maps a failed CUDA call to a status; allocation failures are memory errors.
 * Clears the runtime's last error, so that one failure is reported once. */
static pb_status cu_fail(pb_context *ctx, pb_status kind, const char *call, cudaError_t e)
{
    (void)cudaGetLastError();
    const char *hint = "";
    if (e == cudaErrorMemoryAllocation) {
        kind = PB_ERR_OUT_OF_MEMORY;
        hint = "; free device memory or use a smaller volume";
    } else if (e == cudaErrorNoKernelImageForDevice || e == cudaErrorUnsupportedPtxVersion) {
        kind = PB_ERR_BUILD;
        hint = "; petblur's CUDA kernels were not built for this GPU: rebuild with -Dgpu_archs=<its compute "
               "capability, e.g. 90> or use --device opencl";
    } else if (e == cudaErrorInsufficientDriver) {
        hint = "; the NVIDIA driver is older than this CUDA toolkit: update the driver or use --device opencl";
    }
    return pb_error(ctx, kind, "%s() failed: %s (%s, %d)%s", call, cudaGetErrorString(e), cudaGetErrorName(e),
                    (int)e, hint);
}

/* No GPU, or no driver to reach one (CI machines): zero devices, not an error. */
static int means_no_device(cudaError_t e)
{
    return e == cudaErrorNoDevice || e == cudaErrorInsufficientDriver;
}

static pb_status cuda_device_count(int *count)
{
    *count = 0;
    cudaError_t e = cudaGetDeviceCount(count);
    if (means_no_device(e)) {
        (void)cudaGetLastError();
        *count = 0;
        return PB_OK;
    }
    return e == cudaSuccess ? PB_OK : cu_fail(NULL, PB_ERR_DEVICE, "cudaGetDeviceCount", e);
}

static pb_status fill_info(pb_context *ctx, int index, pb_device_info *info)
{
    struct cudaDeviceProp p;
    cudaError_t e = cudaGetDeviceProperties(&p, index);
    if (e != cudaSuccess)
        return cu_fail(ctx, PB_ERR_DEVICE, "cudaGetDeviceProperties", e);
    int runtime = 0, driver = 0;
    cudaRuntimeGetVersion(&runtime);
    cudaDriverGetVersion(&driver);
    memset(info, 0, sizeof *info);
    snprintf(info->name, sizeof info->name, "%s", p.name);
    snprintf(info->platform, sizeof info->platform, "CUDA %d.%d (driver API %d.%d), sm_%d%d", runtime / 1000,
             runtime % 1000 / 10, driver / 1000, driver % 1000 / 10, p.major, p.minor);
    info->is_gpu = 1;
    info->image_support = 1; /* every CUDA GPU filters float textures linearly */
    for (int d = 0; d < 3; d++)
        info->image3d_max[d] = (size_t)p.maxTexture3D[d];
    info->max_alloc_bytes = p.totalGlobalMem;
    info->global_mem_bytes = p.totalGlobalMem;
    info->compute_units = (unsigned)p.multiProcessorCount;
    return PB_OK;
}

static pb_status cuda_device_info(int index, pb_device_info *info)
{
    return fill_info(NULL, index, info);
}

/* The runtime's current device is per thread; a context may be used from any
 * thread, so every entry point selects its device first. */
static pb_status use_device(pb_context *ctx)
{
    cu_impl *cu = ctx->impl;
    cudaError_t e = cudaSetDevice(cu->device);
    return e == cudaSuccess ? PB_OK : cu_fail(ctx, PB_ERR_DEVICE, "cudaSetDevice", e);
}

static pb_status cuda_context_init(pb_context *ctx, int index, const char *build_options)
{
    (void)build_options; /* the kernels were compiled with the library */
    int n = 0;
    cudaError_t e = cudaGetDeviceCount(&n);
    if (e != cudaSuccess && !means_no_device(e))
        return cu_fail(ctx, PB_ERR_DEVICE, "cudaGetDeviceCount", e);
    if (e != cudaSuccess || n == 0) {
        (void)cudaGetLastError();
        return pb_error(ctx, PB_ERR_NO_DEVICE,
                        "no CUDA device found (%s); check the NVIDIA driver with nvidia-smi, or use --device opencl "
                        "or --device host",
                        e != cudaSuccess ? cudaGetErrorString(e) : "the driver lists none");
    }
    if (index >= n)
        return pb_error(ctx, PB_ERR_NO_DEVICE, "CUDA device %d does not exist (%d found); pick 0 to %d", index, n,
                        n - 1);
    cu_impl *cu = calloc(1, sizeof *cu);
    if (!cu)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for a CUDA context");
    ctx->impl = cu;
    cu->device = index;
    pb_status st = use_device(ctx);
    if (st == PB_OK)
        st = fill_info(ctx, index, &ctx->device);
    if (st != PB_OK)
        return st;
    if ((e = cudaStreamCreateWithFlags(&cu->stream, cudaStreamNonBlocking)) != cudaSuccess)
        return cu_fail(ctx, PB_ERR_DEVICE, "cudaStreamCreateWithFlags", e);
    int lim[3] = {0, 0, 0};
    if (cudaDeviceGetAttribute(&lim[0], cudaDevAttrMaxTexture2DLayeredWidth, index) != cudaSuccess ||
        cudaDeviceGetAttribute(&lim[1], cudaDevAttrMaxTexture2DLayeredHeight, index) != cudaSuccess ||
        cudaDeviceGetAttribute(&lim[2], cudaDevAttrMaxTexture2DLayeredLayers, index) != cudaSuccess)
        lim[0] = lim[1] = lim[2] = 0; /* unknown: no layers */
    (void)cudaGetLastError();
    for (int d = 0; d < 3; d++)
        cu->layer_limits[d] = (size_t)lim[d];
    if ((e = cudaEventCreate(&cu->start)) != cudaSuccess || (e = cudaEventCreate(&cu->stop)) != cudaSuccess)
        return cu_fail(ctx, PB_ERR_DEVICE, "cudaEventCreate", e);
    /* A GPU the fat binary has no code for fails here, not at the first blur. */
    if ((e = pb_cuda_check_kernels()) != cudaSuccess)
        return cu_fail(ctx, PB_ERR_BUILD, "cudaFuncGetAttributes", e);
    return PB_OK;
}

static void cuda_context_release(pb_context *ctx)
{
    cu_impl *cu = ctx->impl;
    if (!cu)
        return;
    cudaSetDevice(cu->device);
    if (cu->plan)
        cudaFree(cu->plan);
    if (cu->scratch)
        cudaFree(cu->scratch);
    if (cu->start)
        cudaEventDestroy(cu->start);
    if (cu->stop)
        cudaEventDestroy(cu->stop);
    if (cu->stream)
        cudaStreamDestroy(cu->stream);
    (void)cudaGetLastError();
    free(cu);
    ctx->impl = NULL;
}

static pb_status cuda_volume_init(pb_volume *vol)
{
    pb_status st = use_device(vol->ctx);
    if (st != PB_OK)
        return st;
    cu_volume *v = calloc(1, sizeof *v);
    if (!v)
        return pb_error(vol->ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for a volume");
    cudaError_t e = cudaMalloc((void **)&v->buffer, vol->count * sizeof(float));
    if (e != cudaSuccess) {
        free(v);
        return cu_fail(vol->ctx, PB_ERR_DEVICE, "cudaMalloc", e);
    }
    mark_written(v);
    vol->impl = v;
    return PB_OK;
}

static void release_array(cu_volume *v)
{
    if (v->linear)
        cudaDestroyTextureObject(v->linear);
    if (v->point)
        cudaDestroyTextureObject(v->point);
    if (v->array)
        cudaFreeArray(v->array);
    v->linear = v->point = 0;
    v->array = NULL;
    for (int m = 0; m < 3; m++) {
        if (v->layers_tex[m])
            cudaDestroyTextureObject(v->layers_tex[m]);
        if (v->layers[m])
            cudaFreeArray(v->layers[m]);
        v->layers_tex[m] = 0;
        v->layers[m] = NULL;
    }
}

static void cuda_volume_release(pb_volume *vol)
{
    cu_volume *v = vol->impl;
    use_device(vol->ctx);
    release_array(v);
    cudaFree(v->buffer);
    (void)cudaGetLastError();
    free(v);
}

static pb_status cuda_volume_upload(pb_volume *vol, const float *host)
{
    cu_impl *cu = vol->ctx->impl;
    cu_volume *v = vol->impl;
    pb_status st = use_device(vol->ctx);
    if (st != PB_OK)
        return st;
    cudaError_t e = cudaMemcpyAsync(v->buffer, host, vol->count * sizeof(float), cudaMemcpyHostToDevice, cu->stream);
    if (e == cudaSuccess)
        e = cudaStreamSynchronize(cu->stream);
    if (e != cudaSuccess)
        return cu_fail(vol->ctx, PB_ERR_DEVICE, "cudaMemcpyAsync (upload)", e);
    mark_written(v);
    return PB_OK;
}

static pb_status cuda_volume_download(const pb_volume *vol, float *host)
{
    cu_impl *cu = vol->ctx->impl;
    const cu_volume *v = vol->impl;
    pb_status st = use_device(vol->ctx);
    if (st != PB_OK)
        return st;
    cudaError_t e = cudaMemcpyAsync(host, v->buffer, vol->count * sizeof(float), cudaMemcpyDeviceToHost, cu->stream);
    if (e == cudaSuccess)
        e = cudaStreamSynchronize(cu->stream);
    if (e != cudaSuccess)
        return cu_fail(vol->ctx, PB_ERR_DEVICE, "cudaMemcpyAsync (download)", e);
    return PB_OK;
}

/* One texture object on the volume's array: border addressing (zero outside),
 * unnormalized coordinates (texel i's centre at i + 0.5), float reads. */
static cudaError_t make_texture(cudaArray_t array, enum cudaTextureFilterMode filter, cudaTextureObject_t *tex)
{
    struct cudaResourceDesc res;
    struct cudaTextureDesc td;
    memset(&res, 0, sizeof res);
    memset(&td, 0, sizeof td); /* border colour (0, 0, 0, 0) */
    res.resType = cudaResourceTypeArray;
    res.res.array.array = array;
    for (int d = 0; d < 3; d++)
        td.addressMode[d] = cudaAddressModeBorder;
    td.filterMode = filter;
    td.readMode = cudaReadModeElementType;
    td.normalizedCoords = 0;
    return cudaCreateTextureObject(tex, &res, &td, NULL);
}

/* Brings the volume's array up to date with its buffer (a device-side copy). */
static pb_status refresh_array(pb_context *ctx, const pb_volume *vol)
{
    cu_impl *cu = ctx->impl;
    cu_volume *v = vol->impl;
    const size_t *n = vol->geometry.dims;
    struct cudaExtent extent = {n[0], n[1], n[2]}; /* in elements, for arrays */
    cudaError_t e;
    if (!v->array) {
        struct cudaChannelFormatDesc fmt = cudaCreateChannelDesc(32, 0, 0, 0, cudaChannelFormatKindFloat);
        if ((e = cudaMalloc3DArray(&v->array, &fmt, extent, 0)) != cudaSuccess) {
            v->array = NULL;
            return cu_fail(ctx, PB_ERR_DEVICE, "cudaMalloc3DArray", e);
        }
        if ((e = make_texture(v->array, cudaFilterModeLinear, &v->linear)) != cudaSuccess ||
            (e = make_texture(v->array, cudaFilterModePoint, &v->point)) != cudaSuccess) {
            release_array(v);
            return cu_fail(ctx, PB_ERR_DEVICE, "cudaCreateTextureObject", e);
        }
        v->array_stale = 1;
    }
    if (v->array_stale) {
        struct cudaMemcpy3DParms cp;
        memset(&cp, 0, sizeof cp);
        cp.srcPtr.ptr = v->buffer;
        cp.srcPtr.pitch = n[0] * sizeof(float);
        cp.srcPtr.xsize = n[0];
        cp.srcPtr.ysize = n[1];
        cp.dstArray = v->array;
        cp.extent = extent;
        cp.kind = cudaMemcpyDeviceToDevice;
        if ((e = cudaMemcpy3DAsync(&cp, cu->stream)) != cudaSuccess)
            return cu_fail(ctx, PB_ERR_DEVICE, "cudaMemcpy3DAsync (buffer to array)", e);
        v->array_stale = 0;
    }
    return PB_OK;
}

/* kernel's blocks over a grid of dims (pb_kernel_group, pb_kernel_extent). */
static pb_cuda_shape shape_of(int kernel, const size_t *dims)
{
    pb_cuda_shape s;
    size_t extent[3];
    pb_kernel_group(kernel, s.block);
    pb_kernel_extent(kernel, dims, extent);
    for (int d = 0; d < 3; d++)
        s.grid[d] = (unsigned)((extent[d] + s.block[d] - 1) / s.block[d]);
    return s;
}

/* A device buffer of the context that holds at least bytes (*have of them
 * now); it grows as needed and lives as long as the context. */
static pb_status reserve(pb_context *ctx, void **buf, size_t *have, size_t bytes, const char *call)
{
    if (bytes <= *have)
        return PB_OK;
    if (*buf)
        cudaFree(*buf);
    *buf = NULL;
    *have = 0;
    cudaError_t e = cudaMalloc(buf, bytes);
    if (e != cudaSuccess) {
        *buf = NULL;
        return cu_fail(ctx, PB_ERR_DEVICE, call, e);
    }
    *have = bytes;
    return PB_OK;
}

/* Lays vol out in a layered texture along axis m (pb_permute into the
 * context's scratch buffer, then a copy; along z the buffer already is in
 * that order), once per axis and change of the buffer. The forward's object
 * is laid out once and blurred many times; the adjoint's gather lays out every
 * tomograph, and the calls it makes here are on the stream its events time. */
static pb_status refresh_layers(pb_context *ctx, const pb_volume *vol, int m)
{
    cu_impl *cu = ctx->impl;
    cu_volume *v = vol->impl;
    const size_t *n = vol->geometry.dims;
    size_t w = n[pb_layer_across(m, 0)], h = n[pb_layer_across(m, 1)];
    struct cudaExtent extent = {w, h, n[m]};
    cudaError_t e;
    if (!v->layers[m]) {
        struct cudaChannelFormatDesc fmt = cudaCreateChannelDesc(32, 0, 0, 0, cudaChannelFormatKindFloat);
        if ((e = cudaMalloc3DArray(&v->layers[m], &fmt, extent, cudaArrayLayered)) != cudaSuccess) {
            v->layers[m] = NULL;
            return cu_fail(ctx, PB_ERR_DEVICE, "cudaMalloc3DArray (layers)", e);
        }
        if ((e = make_texture(v->layers[m], cudaFilterModeLinear, &v->layers_tex[m])) != cudaSuccess) {
            cudaFreeArray(v->layers[m]);
            v->layers[m] = NULL;
            v->layers_tex[m] = 0;
            return cu_fail(ctx, PB_ERR_DEVICE, "cudaCreateTextureObject (layers)", e);
        }
        v->layers_stale[m] = 1;
    }
    if (!v->layers_stale[m])
        return PB_OK;
    float *source = v->buffer;
    if (m != 2) {
        pb_status st = reserve(ctx, &cu->scratch, &cu->scratch_bytes, vol->count * sizeof(float),
                               "cudaMalloc (layers)");
        if (st != PB_OK)
            return st;
        source = cu->scratch;
        pb_kparams prm;
        pb_kparams_permute(n, m, &prm);
        pb_cuda_shape shape = shape_of(PB_KERNEL_PERMUTE, n);
        e = pb_cuda_launch_adjoint(PB_KERNEL_PERMUTE, &shape, v->buffer, NULL, &prm, source, cu->stream);
    } else {
        e = cudaSuccess;
    }
    if (e == cudaSuccess) {
        struct cudaMemcpy3DParms cp;
        memset(&cp, 0, sizeof cp);
        cp.srcPtr.ptr = source;
        cp.srcPtr.pitch = w * sizeof(float);
        cp.srcPtr.xsize = w;
        cp.srcPtr.ysize = h;
        cp.dstArray = v->layers[m];
        cp.extent = extent;
        cp.kind = cudaMemcpyDeviceToDevice;
        e = cudaMemcpy3DAsync(&cp, cu->stream);
    }
    if (e != cudaSuccess)
        return cu_fail(ctx, PB_ERR_DEVICE, "laying the volume out in layers", e);
    v->layers_stale[m] = 0;
    return PB_OK;
}

/* Brings up to date what forward kernel `kernel` reads of vol: its array, or
 * its layers along the plan's axis. */
static pb_status refresh_input(pb_context *ctx, const pb_volume *vol, int kernel, const pb_path *plan)
{
    return pb_kernel_layered(kernel) ? refresh_layers(ctx, vol, pb_path_layer_axis(plan))
                                               : refresh_array(ctx, vol);
}

/* The context's plan buffer holds at least bytes; it grows as needed. */
static pb_status reserve_plan(pb_context *ctx, size_t bytes)
{
    cu_impl *cu = ctx->impl;
    return reserve(ctx, &cu->plan, &cu->plan_bytes, bytes, "cudaMalloc (plan)");
}

/* The plans' key poses (or REF steps) in the kernels' float layout, one after
 * the other in the context's plan buffer; offsets[i] (may be NULL for one
 * plan) receives where plan i starts. One copy for all: a copy from pageable
 * memory may wait for the stream, which must not happen between launches. */
static pb_status upload_plans(pb_context *ctx, size_t count, const pb_path *plans, const pb_blur_options *opt,
                              size_t *offsets)
{
    cu_impl *cu = ctx->impl;
    size_t total = 0, bytes = 0;
    void **parts = calloc(count, sizeof *parts);
    size_t *sizes = calloc(count, sizeof *sizes);
    pb_status st = parts && sizes ? PB_OK : PB_ERR_OUT_OF_MEMORY;
    for (size_t i = 0; i < count && st == PB_OK; i++) {
        if (!(parts[i] = pb_kernel_plan_pack(&plans[i], opt->method, &bytes)))
            st = PB_ERR_OUT_OF_MEMORY;
        sizes[i] = bytes;
        total += (bytes + 255) / 256 * 256; /* each plan aligned for the kernels' reads */
    }
    char *all = st == PB_OK ? calloc(1, total) : NULL;
    if (st == PB_OK && !all)
        st = PB_ERR_OUT_OF_MEMORY;
    if (st != PB_OK)
        pb_error(ctx, st, "out of host memory for the %s",
                 opt->method == PB_METHOD_REF ? "reference's steps" : "key poses");
    size_t at = 0;
    for (size_t i = 0; i < count && st == PB_OK; i++) {
        memcpy(all + at, parts[i], sizes[i]);
        if (offsets)
            offsets[i] = at;
        at += (sizes[i] + 255) / 256 * 256;
    }
    for (size_t i = 0; parts && i < count; i++)
        free(parts[i]);
    free(parts);
    free(sizes);
    if (st == PB_OK)
        st = reserve_plan(ctx, total);
    if (st == PB_OK) {
        /* From pageable memory the call returns once the data is staged, so the
         * host copy may go right away. */
        cudaError_t e = cudaMemcpyAsync(cu->plan, all, total, cudaMemcpyHostToDevice, cu->stream);
        if (e != cudaSuccess)
            st = cu_fail(ctx, PB_ERR_DEVICE, "cudaMemcpyAsync (plan)", e);
    }
    free(all);
    return st;
}

static pb_status upload_plan(pb_context *ctx, const pb_path *plan, const pb_blur_options *opt)
{
    return upload_plans(ctx, 1, plan, opt, NULL);
}

/* Which texture object a launch reads through: see cuda/pb_shim_cuda.h. */
static cudaTextureObject_t texture_of(const cu_volume *v, const pb_blur_options *opt)
{
    return opt->method == PB_METHOD_REF || opt->filter == PB_FILTER_EXACT ? v->point : v->linear;
}

/* Queues one frame's kernel: the plan at offset in the plan buffer. */
static cudaError_t launch_blur(pb_context *ctx, const pb_volume *object, const pb_path *plan, size_t offset,
                               const pb_blur_options *opt, pb_volume *tomograph)
{
    cu_impl *cu = ctx->impl;
    pb_kparams prm;
    pb_kparams_from_plan(plan, opt, &prm);
    const cu_volume *in = object->impl;
    cu_volume *out = tomograph->impl;
    mark_written(out);
    int kernel = pb_forward_kernel(plan, opt, cu->layer_limits);
    cudaTextureObject_t tex = pb_kernel_layered(kernel) ? in->layers_tex[prm.layer_axis] : texture_of(in, opt);
    pb_cuda_shape shape = shape_of(kernel, plan->geometry.dims);
    return pb_cuda_launch(kernel, &shape, tex, (const char *)cu->plan + offset, &prm, out->buffer, cu->stream);
}

/* Waits for the work between the context's start and stop events and sets
 * the kernel time from them. A kernel that faulted reports here. */
static pb_status finish_timed(pb_context *ctx)
{
    cu_impl *cu = ctx->impl;
    cudaError_t e = cudaEventRecord(cu->stop, cu->stream);
    if (e != cudaSuccess)
        return cu_fail(ctx, PB_ERR_LAUNCH, "cudaEventRecord", e);
    if ((e = cudaEventSynchronize(cu->stop)) != cudaSuccess)
        return cu_fail(ctx, PB_ERR_LAUNCH, "cudaEventSynchronize (the kernel failed)", e);
    float ms = 0.0f;
    if ((e = cudaEventElapsedTime(&ms, cu->start, cu->stop)) != cudaSuccess)
        return cu_fail(ctx, PB_ERR_LAUNCH, "cudaEventElapsedTime", e);
    ctx->last_kernel_ms = (double)ms;
    return PB_OK;
}

static pb_status cuda_blur(pb_context *ctx, const pb_volume *object, const pb_path *plan,
                           const pb_blur_options *opt, pb_volume *tomograph)
{
    cu_impl *cu = ctx->impl;
    pb_status st = use_device(ctx);
    if (st == PB_OK)
        st = refresh_input(ctx, object, pb_forward_kernel(plan, opt, cu->layer_limits), plan);
    if (st == PB_OK)
        st = upload_plan(ctx, plan, opt);
    if (st != PB_OK)
        return st;
    cudaError_t e = cudaEventRecord(cu->start, cu->stream);
    if (e != cudaSuccess)
        return cu_fail(ctx, PB_ERR_LAUNCH, "cudaEventRecord", e);
    if ((e = launch_blur(ctx, object, plan, 0, opt, tomograph)) != cudaSuccess)
        return cu_fail(ctx, PB_ERR_LAUNCH, "the kernel launch", e);
    return finish_timed(ctx);
}

/* The frames back to back on the stream: every input's array refreshed and
 * every plan copied first, then the launches, then one wait. The kernel time
 * spans the first launch to the end of the last. */
static pb_status cuda_blur_batch(pb_context *ctx, size_t frames, const pb_volume *const *objects,
                                 const pb_path *plans, const pb_blur_options *opt, pb_volume *const *tomographs)
{
    cu_impl *cu = ctx->impl;
    size_t *offsets = calloc(frames, sizeof *offsets);
    if (!offsets)
        return pb_error(ctx, PB_ERR_OUT_OF_MEMORY, "out of host memory for %zu frames", frames);
    pb_status st = use_device(ctx);
    for (size_t i = 0; i < frames && st == PB_OK; i++)
        st = refresh_input(ctx, objects[i], pb_forward_kernel(&plans[i], opt, cu->layer_limits), &plans[i]);
    if (st == PB_OK)
        st = upload_plans(ctx, frames, plans, opt, offsets);
    cudaError_t e = cudaSuccess;
    if (st == PB_OK && (e = cudaEventRecord(cu->start, cu->stream)) != cudaSuccess)
        st = cu_fail(ctx, PB_ERR_LAUNCH, "cudaEventRecord", e);
    for (size_t i = 0; i < frames && st == PB_OK; i++)
        if ((e = launch_blur(ctx, objects[i], &plans[i], offsets[i], opt, tomographs[i])) != cudaSuccess)
            st = cu_fail(ctx, PB_ERR_LAUNCH, "the kernel launch", e);
    free(offsets);
    return st == PB_OK ? finish_timed(ctx) : st;
}

/* Under a motion of translations only the adjoint is the shift-invariant
 * kernel mirrored (cl/pb_shift.cl): a gather that reads the tomograph through
 * its array, or its layers where the forward reads layers, and writes (or
 * adds into) every object voxel once. Otherwise the scatter adds into zeros.
 * The array's copy or the layers' (pb_permute and a copy), or the zeroing,
 * counts with the kernel's time. */
static pb_status cuda_adjoint(pb_context *ctx, const pb_volume *tomograph, const pb_path *plan,
                              const pb_blur_options *opt, pb_volume *object, int accumulate)
{
    cu_impl *cu = ctx->impl;
    int gather = pb_path_shift_invariant(plan, opt);
    pb_status st = use_device(ctx);
    if (st == PB_OK)
        st = upload_plan(ctx, plan, opt);
    if (st != PB_OK)
        return st;
    pb_kparams prm;
    pb_kparams_from_plan(plan, opt, &prm);
    prm.mirror = gather;
    prm.accumulate = accumulate;
    /* The scatter's transpose of what the texture unit computed (cl/pb_adjoint.cl). */
    if (!gather && opt->filter == PB_FILTER_HARDWARE)
        prm.weight_steps = PB_NVIDIA_WEIGHT_STEPS;
    const cu_volume *in = tomograph->impl;
    cu_volume *out = object->impl;
    mark_written(out);
    cudaError_t e = cudaEventRecord(cu->start, cu->stream);
    if (e != cudaSuccess)
        return cu_fail(ctx, PB_ERR_LAUNCH, "cudaEventRecord", e);
    int kernel = gather ? pb_forward_kernel(plan, opt, cu->layer_limits) : pb_adjoint_index((int)opt->method);
    pb_cuda_shape shape = shape_of(kernel, plan->geometry.dims);
    if (gather) {
        if ((st = refresh_input(ctx, tomograph, kernel, plan)) != PB_OK)
            return st;
        cudaTextureObject_t tex = pb_kernel_layered(kernel) ? in->layers_tex[prm.layer_axis] : texture_of(in, opt);
        e = pb_cuda_launch(kernel, &shape, tex, cu->plan, &prm, out->buffer, cu->stream);
    } else {
        if (!accumulate &&
            (e = cudaMemsetAsync(out->buffer, 0, object->count * sizeof(float), cu->stream)) != cudaSuccess)
            return cu_fail(ctx, PB_ERR_DEVICE, "cudaMemsetAsync", e);
        e = pb_cuda_launch_adjoint(kernel, &shape, in->buffer, cu->plan, &prm, out->buffer, cu->stream);
    }
    if (e != cudaSuccess)
        return cu_fail(ctx, PB_ERR_LAUNCH, "the adjoint kernel launch", e);
    return finish_timed(ctx);
}

const pb_backend_ops pb_backend_cuda_ops = {
    PB_BACKEND_CUDA,      cuda_device_count,  cuda_device_info,    cuda_context_init,
    cuda_context_release, cuda_volume_init,   cuda_volume_release, cuda_volume_upload,
    cuda_volume_download, cuda_blur,          cuda_adjoint,        cuda_blur_batch,
};
