/* The CUDA translation unit of the kernels: the CUDA side of the shim, then the
 * very source the OpenCL backend embeds (cl/pb_blur.cl). Nothing of the kernels
 * is copied here. */
#include <cuda_runtime.h>

#include "pb_shim_cuda.h"
#include "../cl/pb_blur.cl"
#include "pb_cuda_launch.h"

extern "C" cudaError_t pb_cuda_launch(int kernel, const pb_cuda_shape *shape, cudaTextureObject_t volume,
                                      const void *plan, const pb_kparams *prm, float *out, cudaStream_t stream)
{
    dim3 block(shape->block[0], shape->block[1], shape->block[2]), grid(shape->grid[0], shape->grid[1], shape->grid[2]);
    const pb_kpose *poses = static_cast<const pb_kpose *>(plan);
    switch (kernel) { /* PB_KERNEL_NAMES order */
    case 0: pb_blur_ab<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 1: pb_blur_ab_exact<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 2: pb_blur_rm<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 3: pb_blur_rm_exact<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 4: pb_blur_cl<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 5: pb_blur_cl_exact<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 6: pb_blur_ref<<<grid, block, 0, stream>>>(volume, static_cast<const pb_kstep *>(plan), *prm, out); break;
    case 11: pb_shift_ab<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 12: pb_shift_ab_exact<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 13: pb_shift_rm<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 14: pb_shift_rm_exact<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 15: pb_shift_cl<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case 16: pb_shift_cl_exact<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case PB_KERNEL_SHIFT_AB_LAYERS: pb_shift_ab_layers<<<grid, block, 0, stream>>>(volume, poses, *prm, out); break;
    case PB_KERNEL_SHIFT_AB_LAYERS_X:
        pb_shift_ab_layers_x<<<grid, block, 0, stream>>>(volume, poses, *prm, out);
        break;
    default: return cudaErrorInvalidValue;
    }
    return cudaGetLastError();
}

extern "C" cudaError_t pb_cuda_launch_adjoint(int kernel, const pb_cuda_shape *shape, const float *in,
                                              const void *plan, const pb_kparams *prm, float *out, cudaStream_t stream)
{
    dim3 block(shape->block[0], shape->block[1], shape->block[2]), grid(shape->grid[0], shape->grid[1], shape->grid[2]);
    const pb_kpose *poses = static_cast<const pb_kpose *>(plan);
    switch (kernel) { /* PB_KERNEL_NAMES order */
    case 7: pb_adjoint_ab<<<grid, block, 0, stream>>>(in, poses, *prm, out); break;
    case 8: pb_adjoint_rm<<<grid, block, 0, stream>>>(in, poses, *prm, out); break;
    case 9: pb_adjoint_cl<<<grid, block, 0, stream>>>(in, poses, *prm, out); break;
    case 10: pb_adjoint_ref<<<grid, block, 0, stream>>>(in, static_cast<const pb_kstep *>(plan), *prm, out); break;
    case PB_KERNEL_PERMUTE: pb_permute<<<grid, block, 0, stream>>>(in, poses, *prm, out); break;
    default: return cudaErrorInvalidValue;
    }
    return cudaGetLastError();
}

extern "C" cudaError_t pb_cuda_check_kernels(void)
{
    const void *kernels[PB_KERNEL_COUNT] = {
        (const void *)pb_blur_ab, (const void *)pb_blur_ab_exact, (const void *)pb_blur_rm,
        (const void *)pb_blur_rm_exact, (const void *)pb_blur_cl, (const void *)pb_blur_cl_exact,
        (const void *)pb_blur_ref, (const void *)pb_adjoint_ab, (const void *)pb_adjoint_rm,
        (const void *)pb_adjoint_cl, (const void *)pb_adjoint_ref, (const void *)pb_shift_ab,
        (const void *)pb_shift_ab_exact, (const void *)pb_shift_rm, (const void *)pb_shift_rm_exact,
        (const void *)pb_shift_cl, (const void *)pb_shift_cl_exact, (const void *)pb_shift_ab_layers,
        (const void *)pb_permute, (const void *)pb_shift_ab_layers_x};
    for (const void *k : kernels) {
        cudaFuncAttributes attr;
        cudaError_t e = cudaFuncGetAttributes(&attr, k);
        if (e != cudaSuccess)
            return e;
    }
    return cudaSuccess;
}
