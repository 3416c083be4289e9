/* The CUDA backend's device side: listing GPUs, opening one (its stream,
 * events and layered-texture limits), checking that the fat binary has code
 * for it, and naming the runtime's errors. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pb_cuda_launch.h"
#include "cuda_impl.h"

/* Maps a failed CUDA call to a status; allocation failures are memory errors.
 * Clears the runtime's last error, so that one failure is reported once. */
pb_status pb_cu_fail(pb_device *dev, pb_status kind, const char *call, cudaError_t e)
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
    return pb_error(pb_owner(dev), kind, "%s() failed: %s (%s, %d)%s", call, cudaGetErrorString(e), cudaGetErrorName(e),
                    (int)e, hint);
}

/* No GPU, or no driver to reach one (CI machines): zero devices, not an error. */
static int means_no_device(cudaError_t e)
{
    return e == cudaErrorNoDevice || e == cudaErrorInsufficientDriver;
}

pb_status pb_cuda_device_count(int *count)
{
    *count = 0;
    cudaError_t e = cudaGetDeviceCount(count);
    if (means_no_device(e)) {
        (void)cudaGetLastError();
        *count = 0;
        return PB_OK;
    }
    return e == cudaSuccess ? PB_OK : pb_cu_fail(NULL, PB_ERR_DEVICE, "cudaGetDeviceCount", e);
}

static pb_status fill_info(pb_device *dev, int index, pb_device_info *info)
{
    struct cudaDeviceProp p;
    cudaError_t e = cudaGetDeviceProperties(&p, index);
    if (e != cudaSuccess)
        return pb_cu_fail(dev, PB_ERR_DEVICE, "cudaGetDeviceProperties", e);
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

pb_status pb_cuda_device_info(int index, pb_device_info *info)
{
    return fill_info(NULL, index, info);
}

pb_status pb_cu_use_device(pb_device *dev)
{
    cu_impl *cu = dev->impl;
    cudaError_t e = cudaSetDevice(cu->device);
    return e == cudaSuccess ? PB_OK : pb_cu_fail(dev, PB_ERR_DEVICE, "cudaSetDevice", e);
}

/* cudaSuccess when the device can run every kernel of k; otherwise the error
 * a launch would give (a fat binary without code for it). */
static cudaError_t check_kernels(const cu_kernels *k)
{
    struct cudaFuncAttributes attr;
    for (int i = 0; i < PB_KERNEL_COUNT; i++) {
        cudaError_t e = cudaFuncGetAttributes(&attr, k->kernel[i]);
        if (e != cudaSuccess)
            return e;
    }
    return cudaFuncGetAttributes(&attr, k->layout);
}

/* The context's kernels (cuda_impl.h's cu_kernels says which): checked here,
 * so that a GPU no kernel can serve fails at the context, not at a blur. */
static pb_status choose_kernels(pb_device *dev, cu_impl *cu)
{
    const char *want = getenv("PETBLUR_CUDA_KERNELS");
    int builtin = !want || !*want || strcmp(want, "builtin") == 0, nvrtc = !want || !*want || !strcmp(want, "nvrtc");
    if (!builtin && !nvrtc)
        return pb_error(pb_owner(dev), PB_ERR_INVALID_ARGUMENT,
                        "PETBLUR_CUDA_KERNELS is '%s': set 'builtin' (nvcc's, in the library), 'nvrtc' (compiled at "
                        "run time) or leave it unset (nvcc's where they serve this GPU, else NVRTC's)",
                        want);
    cudaError_t e = cudaSuccess;
    if (builtin) {
        pb_cuda_builtin_kernels(cu->kernels.kernel, &cu->kernels.layout);
        if ((e = check_kernels(&cu->kernels)) == cudaSuccess)
            return PB_OK;
        (void)cudaGetLastError();
        if (!nvrtc)
            return pb_cu_fail(dev, PB_ERR_BUILD, "cudaFuncGetAttributes (nvcc's kernels for this GPU)", e);
    }
    pb_status st = pb_cuda_rtc_load(dev, cu->device, &cu->kernels);
    if (st != PB_OK) {
        if (builtin) /* neither serves: say both */
            pb_error_append(pb_owner(dev), e == cudaSuccess ? "" : "; nvcc's kernels hold no code for this GPU either");
        return st;
    }
    e = check_kernels(&cu->kernels);
    return e == cudaSuccess ? PB_OK : pb_cu_fail(dev, PB_ERR_BUILD, "cudaFuncGetAttributes (NVRTC's kernels)", e);
}

pb_status pb_cuda_context_init(pb_device *dev, int index, const char *build_options)
{
    (void)build_options; /* the kernels were compiled with the library */
    int n = 0;
    cudaError_t e = cudaGetDeviceCount(&n);
    if (e != cudaSuccess && !means_no_device(e))
        return pb_cu_fail(dev, PB_ERR_DEVICE, "cudaGetDeviceCount", e);
    if (e != cudaSuccess || n == 0) {
        (void)cudaGetLastError();
        return pb_error(pb_owner(dev), PB_ERR_NO_DEVICE,
                        "no CUDA device found (%s); check the NVIDIA driver with nvidia-smi, or use --device opencl "
                        "or --device host",
                        e != cudaSuccess ? cudaGetErrorString(e) : "the driver lists none");
    }
    if (index >= n)
        return pb_error(pb_owner(dev), PB_ERR_NO_DEVICE, "CUDA device %d does not exist (%d found); pick 0 to %d", index, n,
                        n - 1);
    cu_impl *cu = calloc(1, sizeof *cu);
    if (!cu)
        return pb_error(pb_owner(dev), PB_ERR_OUT_OF_MEMORY, "out of host memory for a CUDA context");
    dev->impl = cu;
    cu->device = index;
    pb_status st = pb_cu_use_device(dev);
    if (st == PB_OK)
        st = fill_info(dev, index, &dev->info);
    if (st != PB_OK)
        return st;
    if ((e = cudaStreamCreateWithFlags(&cu->stream, cudaStreamDefault)) != cudaSuccess)
        return pb_cu_fail(dev, PB_ERR_DEVICE, "cudaStreamCreateWithFlags", e);
    int lim[3] = {0, 0, 0};
    if (cudaDeviceGetAttribute(&lim[0], cudaDevAttrMaxTexture2DLayeredWidth, index) != cudaSuccess ||
        cudaDeviceGetAttribute(&lim[1], cudaDevAttrMaxTexture2DLayeredHeight, index) != cudaSuccess ||
        cudaDeviceGetAttribute(&lim[2], cudaDevAttrMaxTexture2DLayeredLayers, index) != cudaSuccess)
        lim[0] = lim[1] = lim[2] = 0; /* unknown: no layers */
    (void)cudaGetLastError();
    for (int d = 0; d < 3; d++)
        dev->layer_limits[d] = (size_t)lim[d];
    dev->texture_weight_steps = PB_NVIDIA_WEIGHT_STEPS;
    cu->queue = cu->stream;
    if ((e = cudaEventCreate(&cu->start)) != cudaSuccess || (e = cudaEventCreate(&cu->mark)) != cudaSuccess ||
        (e = cudaEventCreate(&cu->stop)) != cudaSuccess)
        return pb_cu_fail(dev, PB_ERR_DEVICE, "cudaEventCreate", e);
    return choose_kernels(dev, cu);
}

void pb_cuda_context_release(pb_device *dev)
{
    cu_impl *cu = dev->impl;
    if (!cu)
        return;
    cudaSetDevice(cu->device);
    if (cu->stop) /* the last call on a caller's stream may still run */
        cudaEventSynchronize(cu->stop);
    if (cu->start)
        cudaEventDestroy(cu->start);
    if (cu->mark)
        cudaEventDestroy(cu->mark);
    if (cu->stop)
        cudaEventDestroy(cu->stop);
    if (cu->stream)
        cudaStreamDestroy(cu->stream);
    if (cu->kernels.library)
        cudaLibraryUnload(cu->kernels.library);
    (void)cudaGetLastError();
    free(cu);
    dev->impl = NULL;
}

