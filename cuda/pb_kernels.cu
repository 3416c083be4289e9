/* The CUDA translation unit of the kernels, compiled ahead of time by nvcc: the
 * very source the OpenCL backend embeds (cl/pb_blur.cl, which includes the
 * shim, cl/pb_shim.h) and the layout kernel. The backend (plain C) launches
 * them through cudaLaunchKernel by handle, as it launches NVRTC's
 * (src/devices/cuda_rtc.c), and never sees CUDA C++. */
#include <cuda_runtime.h>

#include "../cl/pb_blur.cl"
#include "../cl/pb_kernel_table.h"
#include "pb_cuda_launch.h"
#include "pb_layout.cuh"

extern "C" void pb_cuda_builtin_kernels(const void **kernels, const void **layout)
{
    int k = 0;
#define PB_ENTRY_(id, name, ...) kernels[k++] = (const void *)name;
    PB_KERNELS(PB_ENTRY_)
#undef PB_ENTRY_
    *layout = (const void *)pb_cuda_layout_kernel;
}
