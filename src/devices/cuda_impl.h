/* What the CUDA backend's two files share: the context's runtime objects
 * (cuda_device.c opens them, backend_cuda.c runs on them). With
 * cuda/pb_kernels.cu, the only files that include a CUDA header. */
#ifndef PB_CUDA_IMPL_H
#define PB_CUDA_IMPL_H

#include <cuda_runtime_api.h>

#include "backend.h"

/* The kernels a context launches, as the handles cudaLaunchKernel takes:
 * nvcc's, built into the library (cuda/pb_kernels.cu), or NVRTC's, compiled
 * at run time for the device and cached on disk (cuda_rtc.c; library is then
 * theirs). PETBLUR_CUDA_KERNELS picks: 'builtin', 'nvrtc', or unset (nvcc's
 * where they hold code for the device, else NVRTC's). */
typedef struct cu_kernels {
    const void *kernel[PB_KERNEL_COUNT];
    const void *layout;
    cudaLibrary_t library;
} cu_kernels;

typedef struct cu_impl {
    int device;
    cu_kernels kernels;
    /* Every copy and launch of the context, in order. A blocking stream: it
     * waits for work queued before on the legacy default stream, where CuPy
     * and PyTorch queue by default, so their arrays are ready. */
    cudaStream_t stream;
    /* Where work is queued: stream, or the caller's (pb_context_set_stream),
     * where timer_end only records (pending) and calls return unfinished.
     * stop, recorded at the end of every call's work, is also what a new
     * queue waits for, and what releases wait for. */
    cudaStream_t queue;
    int caller, pending;
    cudaEvent_t start, mark, stop;
    int marked;
} cu_impl;

/* Maps a failed CUDA call to a status and message (allocation failures are
 * memory errors) and clears the runtime's last error, so that one failure is
 * reported once. */
pb_status pb_cu_fail(pb_device *dev, pb_status kind, const char *call, cudaError_t e);
/* The runtime's current device is per thread; a context may be used from any
 * thread, so every entry point that allocates or launches selects its device
 * first. */
pb_status pb_cu_use_device(pb_device *dev);

/* cuda_rtc.c: 1 where NVRTC can be opened, else 0 and why (a message with the
 * fix). pb_cuda_rtc_load compiles (or reads from the cache) and loads the
 * kernels for device. */
int pb_cuda_rtc_available(char *why, size_t n);
pb_status pb_cuda_rtc_load(pb_device *dev, int device, cu_kernels *k);

/* cuda_device.c: the device ops of pb_backend_cuda_ops. */
pb_status pb_cuda_device_count(int *count);
pb_status pb_cuda_device_info(int index, pb_device_info *info);
pb_status pb_cuda_context_init(pb_device *dev, int index, const char *build_options);
void pb_cuda_context_release(pb_device *dev);

#endif
