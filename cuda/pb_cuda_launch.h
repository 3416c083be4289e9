/* The C-callable edge of cuda/pb_kernels.cu: the CUDA backend
 * (src/backend_cuda.c, plain C) launches every kernel through this one
 * function and never sees CUDA C++. */
#ifndef PB_CUDA_LAUNCH_H
#define PB_CUDA_LAUNCH_H

#include <cuda_runtime_api.h>

#include "../cl/pb_kernel_types.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One launch: its blocks, what the kernel reads (a texture object for the
 * kernels that read an image or layers, a buffer for the others: its row of
 * src/kernel_table.h says which), its plan in device memory (key poses, or
 * REF's steps; unused by pb_permute), its parameters and output. */
typedef struct pb_cuda_launch_args {
    unsigned block[3], grid[3];
    cudaTextureObject_t texture;
    const float *buffer;
    const void *plan;
    pb_kparams prm;
    float *out;
    cudaStream_t stream;
} pb_cuda_launch_args;

/* Queues kernel `kernel` (a pb_kernel_id); returns the launch's error
 * (cudaSuccess when it was queued). */
cudaError_t pb_cuda_launch(int kernel, const pb_cuda_launch_args *args);

/* Writes the volume `in` of dims (x fastest) into the layered array behind
 * `surface`, laid out along axis m (pb_layer_across), in one pass: the
 * runtime's copy into a layered array is several times slower than a copy
 * into a 3-D one (docs/performance.md, "Device memory in and out"). */
cudaError_t pb_cuda_layout(const float *in, const size_t dims[3], int m, cudaSurfaceObject_t surface,
                           cudaStream_t stream);

/* cudaSuccess when the current device can run every kernel (the fat binary
 * holds code for it); otherwise the error a launch would give. */
cudaError_t pb_cuda_check_kernels(void);

#ifdef __cplusplus
}
#endif

#endif
