/* The C-callable edge of cuda/pb_kernels.cu, the kernels nvcc compiled ahead
 * of time: their host handles, which cudaLaunchKernel takes as it takes the
 * handles of the kernels NVRTC compiles at run time. */
#ifndef PB_CUDA_LAUNCH_H
#define PB_CUDA_LAUNCH_H

#ifdef __cplusplus
extern "C" {
#endif

/* kernels[PB_KERNEL_COUNT] in cl/pb_kernel_table.h's order, and the
 * layout kernel (cuda/pb_layout.cuh). */
void pb_cuda_builtin_kernels(const void **kernels, const void **layout);

#ifdef __cplusplus
}
#endif

#endif
