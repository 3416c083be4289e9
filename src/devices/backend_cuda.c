/* The CUDA backend: the kernels of cl/pb_blur.cl, compiled by nvcc
 * (cuda/pb_kernels.cu) or at run time by NVRTC (cuda_rtc.c), run through the
 * CUDA runtime. This file translates src/devices/backend.h's primitives (buffers,
 * images, launches by kernel id, event timing) into runtime calls, plain C,
 * launching the context's kernel handles (cu_kernels); the device side is
 * cuda_device.c. Every call is checked and its error text reaches the
 * caller. */
#include <stdlib.h>
#include <string.h>

#include "cuda_impl.h"

/* An image: a CUDA array and its texture objects, which carry the filter: a
 * linear one for HARDWARE fetches and layers, a point one for EXACT and REF;
 * layers also have a surface, which cuda_image_layout writes through. */
typedef struct cu_image {
    cudaArray_t array;
    cudaTextureObject_t linear, point;
    cudaSurfaceObject_t surface;
    size_t extent[3];
} cu_image;

static void cuda_native(const pb_device *dev, pb_native *out)
{
    const cu_impl *cu = dev->impl;
    out->queue = cu->queue;
    out->device_index = cu->device;
}

/* ---- buffers ----------------------------------------------------------- */

/* Before memory is freed, every kernel that may read it: those of the last
 * call, which on a caller's stream returns unfinished (stop; at once when it
 * is done, or was never recorded), and those queued since, inside a call
 * (cudaFree is documented as only "may" synchronise). */
static void wait_last_call(pb_device *dev)
{
    cu_impl *cu = dev->impl;
    cudaEventSynchronize(cu->stop);
    cudaStreamSynchronize(cu->queue);
}

static pb_status cuda_buffer_create(pb_device *dev, size_t bytes, void **buffer)
{
    pb_status st = pb_cu_use_device(dev);
    cudaError_t e = st == PB_OK ? cudaMalloc(buffer, bytes) : cudaSuccess;
    if (e != cudaSuccess)
        return pb_cu_fail(dev, PB_ERR_DEVICE, "cudaMalloc", e);
    return st;
}

static void cuda_buffer_release(pb_device *dev, void *buffer)
{
    pb_cu_use_device(dev);
    wait_last_call(dev);
    cudaFree(buffer);
    (void)cudaGetLastError();
}

/* Copies through the stream, then waits: from pageable memory the runtime
 * stages the data anyway. */
static pb_status copy_sync(pb_device *dev, void *dst, const void *src, size_t bytes, enum cudaMemcpyKind kind,
                           const char *what)
{
    cu_impl *cu = dev->impl;
    pb_status st = pb_cu_use_device(dev);
    if (st != PB_OK)
        return st;
    cudaError_t e = cudaMemcpyAsync(dst, src, bytes, kind, cu->queue);
    if (e == cudaSuccess)
        e = cudaStreamSynchronize(cu->queue);
    return e == cudaSuccess ? PB_OK : pb_cu_fail(dev, PB_ERR_DEVICE, what, e);
}

static pb_status cuda_buffer_write(pb_device *dev, void *buffer, const void *host, size_t bytes)
{
    return copy_sync(dev, buffer, host, bytes, cudaMemcpyHostToDevice, "cudaMemcpyAsync (upload)");
}

static pb_status cuda_buffer_read(pb_device *dev, const void *buffer, void *host, size_t bytes)
{
    return copy_sync(dev, host, buffer, bytes, cudaMemcpyDeviceToHost, "cudaMemcpyAsync (download)");
}

static pb_status cuda_buffer_zero(pb_device *dev, void *buffer, size_t bytes)
{
    cu_impl *cu = dev->impl;
    pb_status st = pb_cu_use_device(dev);
    if (st != PB_OK)
        return st;
    cudaError_t e = cudaMemsetAsync(buffer, 0, bytes, cu->queue);
    return e == cudaSuccess ? PB_OK : pb_cu_fail(dev, PB_ERR_DEVICE, "cudaMemsetAsync", e);
}

/* Device (or managed) memory of the context's GPU. The runtime API cannot
 * tell an allocation's size: the caller's binding checks it. */
static pb_status cuda_buffer_check(pb_device *dev, const void *buffer, size_t bytes, const char *what, int written)
{
    (void)bytes;
    (void)written;
    cu_impl *cu = dev->impl;
    struct cudaPointerAttributes a;
    cudaError_t e = cudaPointerGetAttributes(&a, buffer);
    (void)cudaGetLastError();
    if (e != cudaSuccess || (a.type != cudaMemoryTypeDevice && a.type != cudaMemoryTypeManaged))
        return pb_error(pb_owner(dev), PB_ERR_INVALID_ARGUMENT, "the %s is not CUDA device memory; pass a device pointer "
                        "(cudaMalloc, a CuPy or PyTorch CUDA array's data pointer)", what);
    if (a.type == cudaMemoryTypeDevice && a.device != cu->device)
        return pb_error(pb_owner(dev), PB_ERR_INVALID_ARGUMENT, "the %s is on CUDA device %d, the context on device %d; "
                        "copy it there or make the context on device %d", what, a.device, cu->device, a.device);
    return PB_OK;
}

/* ---- images ------------------------------------------------------------ */

/* One texture object on an array: border addressing (zero outside),
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

static void cuda_image_release(pb_device *dev, void *image)
{
    cu_image *img = image;
    pb_cu_use_device(dev);
    wait_last_call(dev);
    if (img->linear)
        cudaDestroyTextureObject(img->linear);
    if (img->point)
        cudaDestroyTextureObject(img->point);
    if (img->surface)
        cudaDestroySurfaceObject(img->surface);
    if (img->array)
        cudaFreeArray(img->array);
    (void)cudaGetLastError();
    free(img);
}

/* Layers are read only through the linear filter (AB HARDWARE). */
static pb_status cuda_image_create(pb_device *dev, int layered, const size_t extent[3], void **image)
{
    pb_status st = pb_cu_use_device(dev);
    if (st != PB_OK)
        return st;
    cu_image *img = calloc(1, sizeof *img);
    if (!img)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for an image");
    memcpy(img->extent, extent, sizeof img->extent);
    struct cudaChannelFormatDesc fmt = cudaCreateChannelDesc(32, 0, 0, 0, cudaChannelFormatKindFloat);
    struct cudaExtent ext = {extent[0], extent[1], extent[2]}; /* in elements, for arrays */
    unsigned flags = layered ? cudaArrayLayered | cudaArraySurfaceLoadStore : 0;
    cudaError_t e = cudaMalloc3DArray(&img->array, &fmt, ext, flags);
    if (e != cudaSuccess) {
        img->array = NULL;
        cuda_image_release(dev, img);
        return pb_cu_fail(dev, PB_ERR_DEVICE, layered ? "cudaMalloc3DArray (layers)" : "cudaMalloc3DArray", e);
    }
    if ((e = make_texture(img->array, cudaFilterModeLinear, &img->linear)) != cudaSuccess ||
        (!layered && (e = make_texture(img->array, cudaFilterModePoint, &img->point)) != cudaSuccess)) {
        cuda_image_release(dev, img);
        return pb_cu_fail(dev, PB_ERR_DEVICE, "cudaCreateTextureObject", e);
    }
    if (layered) {
        struct cudaResourceDesc res;
        memset(&res, 0, sizeof res);
        res.resType = cudaResourceTypeArray;
        res.res.array.array = img->array;
        if ((e = cudaCreateSurfaceObject(&img->surface, &res)) != cudaSuccess) {
            cuda_image_release(dev, img);
            return pb_cu_fail(dev, PB_ERR_DEVICE, "cudaCreateSurfaceObject", e);
        }
    }
    *image = img;
    return PB_OK;
}

static pb_status cuda_image_copy(pb_device *dev, void *image, const void *buffer)
{
    cu_impl *cu = dev->impl;
    cu_image *img = image;
    struct cudaMemcpy3DParms cp;
    memset(&cp, 0, sizeof cp);
    cp.srcPtr.ptr = (void *)buffer;
    cp.srcPtr.pitch = img->extent[0] * sizeof(float);
    cp.srcPtr.xsize = img->extent[0];
    cp.srcPtr.ysize = img->extent[1];
    cp.dstArray = img->array;
    cp.extent = (struct cudaExtent){img->extent[0], img->extent[1], img->extent[2]};
    cp.kind = cudaMemcpyDeviceToDevice;
    pb_status st = pb_cu_use_device(dev);
    if (st != PB_OK)
        return st;
    cudaError_t e = cudaMemcpy3DAsync(&cp, cu->queue);
    return e == cudaSuccess ? PB_OK : pb_cu_fail(dev, PB_ERR_DEVICE, "cudaMemcpy3DAsync (buffer to array)", e);
}

/* The runtime's copy into a layered array is several times slower than into a
 * 3-D one; a kernel writing through the surface lays a volume out in one pass
 * (cuda/pb_kernels.cu). */
static pb_status cuda_image_layout(pb_device *dev, void *image, const void *buffer, const size_t dims[3], int m)
{
    cu_impl *cu = dev->impl;
    cu_image *img = image;
    pb_status st = pb_cu_use_device(dev);
    if (st != PB_OK)
        return st;
    int d[3] = {(int)dims[0], (int)dims[1], (int)dims[2]};
    const float *in = buffer;
    void *args[] = {&in, &d[0], &d[1], &d[2], &m, &img->surface};
    dim3 block = {32, 4, 2}; /* a warp along x: coalesced reads */
    dim3 grid = {(unsigned)((dims[0] + 31) / 32), (unsigned)((dims[1] + 3) / 4), (unsigned)((dims[2] + 1) / 2)};
    cudaError_t e = cudaLaunchKernel(cu->kernels.layout, grid, block, args, 0, cu->queue);
    return e == cudaSuccess ? PB_OK : pb_cu_fail(dev, PB_ERR_LAUNCH, "the layout kernel's launch", e);
}

/* ---- launches and timing ----------------------------------------------- */

static pb_status cuda_launch(pb_device *dev, const pb_launch *l)
{
    cu_impl *cu = dev->impl;
    const pb_kernel_info *info = &pb_kernel_table[l->kernel];
    pb_status st = pb_cu_use_device(dev);
    if (st != PB_OK)
        return st;
    unsigned n[3];
    for (int d = 0; d < 3; d++)
        n[d] = (unsigned)((l->extent[d] + info->group[d] - 1) / info->group[d]);
    dim3 block = {info->group[0], info->group[1], info->group[2]}, grid = {n[0], n[1], n[2]};
    /* Every kernel is (input, plan, parameters, output); the input a texture
     * object or a buffer, as its row of cl/pb_kernel_table.h says. */
    const cu_image *img = l->input;
    cudaTextureObject_t texture = 0;
    const void *buffer = l->input, *plan = l->plan;
    if (info->reads != PB_READS_BUFFER)
        texture = info->reads == PB_READS_NEAREST ? img->point : img->linear;
    pb_kparams prm = l->prm;
    float *out = l->out;
    void *args[] = {info->reads == PB_READS_BUFFER ? (void *)&buffer : (void *)&texture, &plan, &prm, &out};
    cudaError_t e = cudaLaunchKernel(cu->kernels.kernel[l->kernel], grid, block, args, 0, cu->queue);
    return e == cudaSuccess ? PB_OK : pb_cu_fail(dev, PB_ERR_LAUNCH, "the kernel launch", e);
}

static pb_status record(pb_device *dev, cudaEvent_t ev)
{
    cu_impl *cu = dev->impl;
    cudaError_t e = cudaEventRecord(ev, cu->queue);
    return e == cudaSuccess ? PB_OK : pb_cu_fail(dev, PB_ERR_LAUNCH, "cudaEventRecord", e);
}

static pb_status cuda_timer_begin(pb_device *dev)
{
    cu_impl *cu = dev->impl;
    cu->marked = cu->pending = 0;
    pb_status st = pb_cu_use_device(dev);
    return st == PB_OK ? record(dev, cu->start) : st;
}

static pb_status cuda_timer_mark(pb_device *dev)
{
    cu_impl *cu = dev->impl;
    cu->marked = 1;
    return record(dev, cu->mark);
}

/* Waits for the work timed and gives its times; a kernel that faulted
 * reports here. */
static pb_status timer_result(pb_device *dev, double *total_ms, double *before_mark_ms)
{
    cu_impl *cu = dev->impl;
    cudaError_t e = cudaEventSynchronize(cu->stop);
    if (e != cudaSuccess)
        return pb_cu_fail(dev, PB_ERR_LAUNCH, "cudaEventSynchronize (the kernel failed)", e);
    float ms = 0.0f, before = 0.0f;
    if ((e = cudaEventElapsedTime(&ms, cu->start, cu->stop)) != cudaSuccess ||
        (cu->marked && (e = cudaEventElapsedTime(&before, cu->start, cu->mark)) != cudaSuccess))
        return pb_cu_fail(dev, PB_ERR_LAUNCH, "cudaEventElapsedTime", e);
    *total_ms = (double)ms;
    *before_mark_ms = (double)before;
    return PB_OK;
}

/* On a caller's stream the call returns once queued (a progress report still
 * waits for each slab); the times wait for pb_context_last_kernel_ms. */
static pb_status cuda_timer_end(pb_device *dev, double *total_ms, double *before_mark_ms)
{
    cu_impl *cu = dev->impl;
    *total_ms = *before_mark_ms = 0.0;
    pb_status st = record(dev, cu->stop);
    if (st != PB_OK)
        return st;
    if (cu->caller && !dev->progress) {
        cu->pending = 1;
        return PB_OK;
    }
    return timer_result(dev, total_ms, before_mark_ms);
}

static int cuda_timer_wait(const pb_device *dev, pb_status *status, double *total_ms, double *before_mark_ms)
{
    const cu_impl *cu = dev->impl;
    if (!cu->pending)
        return 0;
    /* The context is the caller's to change (the last error's text). */
    *status = timer_result((pb_device *)dev, total_ms, before_mark_ms);
    return 1;
}

/* The new queue waits for the end of the context's last call (stop), so
 * that calls stay in order; the old queue, which the caller may have
 * destroyed since, is not touched. */
static pb_status cuda_set_stream(pb_device *dev, void *stream)
{
    cu_impl *cu = dev->impl;
    cudaStream_t next = stream ? (cudaStream_t)stream : cu->stream;
    pb_status st = pb_cu_use_device(dev);
    if (st != PB_OK)
        return st;
    cudaError_t e = next == cu->queue ? cudaSuccess : cudaStreamWaitEvent(next, cu->stop, 0);
    if (e != cudaSuccess)
        return pb_cu_fail(dev, PB_ERR_INVALID_ARGUMENT,
                          "pb_context_set_stream (pass a live stream of the context's device)", e);
    cu->queue = next;
    cu->caller = stream != NULL;
    return PB_OK;
}

const pb_backend_ops pb_backend_cuda_ops = {
    .id = PB_BACKEND_CUDA,
    .addresses = 1,
    .device_count = pb_cuda_device_count,
    .device_info = pb_cuda_device_info,
    .context_init = pb_cuda_context_init,
    .context_release = pb_cuda_context_release,
    .native = cuda_native,
    .buffer_create = cuda_buffer_create,
    .buffer_release = cuda_buffer_release,
    .buffer_write = cuda_buffer_write,
    .buffer_read = cuda_buffer_read,
    .buffer_zero = cuda_buffer_zero,
    .buffer_check = cuda_buffer_check,
    .image_create = cuda_image_create,
    .image_release = cuda_image_release,
    .image_copy = cuda_image_copy,
    .image_layout = cuda_image_layout,
    .launch = cuda_launch,
    .frame_prepare = pb_launch_prepare,
    .frame_apply = pb_launch_frame,
    .frames_forward = pb_launch_frames,
    .frames_apply = pb_launch_frames_apply,
    .timer_begin = cuda_timer_begin,
    .timer_mark = cuda_timer_mark,
    .timer_end = cuda_timer_end,
    .set_stream = cuda_set_stream,
    .timer_wait = cuda_timer_wait,
};
