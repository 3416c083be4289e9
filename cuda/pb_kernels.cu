/* The CUDA translation unit of the kernels: the very source the OpenCL backend
 * embeds (cl/pb_blur.cl, which includes the shim, cl/pb_shim.h), then one
 * launch function for every kernel, generated from src/kernel_table.h. */
#include <cuda_runtime.h>

#include "../cl/pb_blur.cl"
#include "../src/kernel_table.h"
#include "pb_cuda_launch.h"

/* What a kernel reads, by its first parameter's type: a texture object, or a
 * buffer. */
template <typename In> static In input_of(const pb_cuda_launch_args *a);
template <> cudaTextureObject_t input_of<cudaTextureObject_t>(const pb_cuda_launch_args *a)
{
    return a->texture;
}
template <> const float *input_of<const float *>(const pb_cuda_launch_args *a)
{
    return a->buffer;
}

/* Every kernel has the shape (input, plan, parameters, output); the plan's
 * type (key poses or REF steps) comes from the kernel itself. */
template <typename In, typename Plan>
static cudaError_t launch(void (*kernel)(In, const Plan *, pb_kparams, float *), const pb_cuda_launch_args *a)
{
    dim3 block(a->block[0], a->block[1], a->block[2]), grid(a->grid[0], a->grid[1], a->grid[2]);
    kernel<<<grid, block, 0, a->stream>>>(input_of<In>(a), static_cast<const Plan *>(a->plan), a->prm, a->out);
    return cudaGetLastError();
}

extern "C" cudaError_t pb_cuda_launch(int kernel, const pb_cuda_launch_args *args)
{
    switch (kernel) {
#define PB_CASE_(id, name, ...)                                                                                  \
    case PB_KERNEL_##id: return launch(name, args);
        PB_KERNELS(PB_CASE_)
#undef PB_CASE_
    }
    return cudaErrorInvalidValue;
}

extern "C" cudaError_t pb_cuda_check_kernels(void)
{
    const void *kernels[PB_KERNEL_COUNT] = {
#define PB_ENTRY_(id, name, ...) (const void *)name,
        PB_KERNELS(PB_ENTRY_)
#undef PB_ENTRY_
    };
    for (const void *k : kernels) {
        cudaFuncAttributes attr;
        cudaError_t e = cudaFuncGetAttributes(&attr, k);
        if (e != cudaSuccess)
            return e;
    }
    return cudaSuccess;
}
