/* The C-callable edge of cuda/pb_kernels.cu: the backend (src/backend_cuda.c,
 * plain C) launches the kernels through this one function and never sees CUDA
 * C++. */
#ifndef PB_CUDA_LAUNCH_H
#define PB_CUDA_LAUNCH_H

#include <cuda_runtime_api.h>

#include "../cl/pb_kernel_types.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A launch's blocks: threads per block and blocks per grid, x, y, z (the
 * backend's, from pb_kernel_group and pb_kernel_extent). */
typedef struct pb_cuda_shape {
    unsigned block[3], grid[3];
} pb_cuda_shape;

/* Launches kernel `kernel` (pb_kernel_index or pb_shift_index) in `shape` on
 * `stream`. `plan` holds prm->segments + 1 pb_kpose, or
 * prm->ref_steps pb_kstep for REF, in device memory. Returns the launch's error
 * (cudaSuccess when it was queued). */
cudaError_t pb_cuda_launch(int kernel, const pb_cuda_shape *shape, cudaTextureObject_t volume, const void *plan,
                           const pb_kparams *prm, float *out, cudaStream_t stream);

/* Launches adjoint kernel `kernel` (pb_adjoint_index): reads the tomograph
 * buffer `in`, adds into `out`, which must hold zeros (or what to add to).
 * Also PB_KERNEL_PERMUTE, which reads a buffer and writes one (plan unused). */
cudaError_t pb_cuda_launch_adjoint(int kernel, const pb_cuda_shape *shape, const float *in, const void *plan,
                                   const pb_kparams *prm, float *out, cudaStream_t stream);

/* cudaSuccess when the current device can run every kernel (the fat binary
 * holds code for it); otherwise the error a launch would give. */
cudaError_t pb_cuda_check_kernels(void);

#ifdef __cplusplus
}
#endif

#endif
