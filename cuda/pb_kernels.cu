/* The CUDA translation unit of the kernels: the very source the OpenCL backend
 * embeds (cl/pb_blur.cl, which includes the shim, cl/pb_shim.h), then one
 * launch function for every kernel, generated from src/kernel_table.h. */
#include <cuda_runtime.h>

#include "../cl/pb_blur.cl"
#include "../src/devices/kernel_table.h"
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

/* The backend's layout of a volume into layers, CUDA's half of image_layout
 * (src/backend.h): reads coalesced along x, writes each voxel's layer texel. */
static __global__ void pb_cuda_layout_kernel(const float *in, int nx, int ny, int nz, int m,
                                             cudaSurfaceObject_t surface)
{
    int ix = PB_GID_X, iy = PB_GID_Y, iz = PB_GID_Z;
    if (ix >= nx || iy >= ny || iz >= nz)
        return;
    /* pb_layer_across's axes, selected rather than indexed (no local memory). */
    int a = m == 0 ? iy : ix, b = m == 2 ? iy : iz, layer = m == 0 ? ix : (m == 1 ? iy : iz);
    surf2DLayeredwrite(in[ix + nx * (iy + ny * iz)], surface, a * (int)sizeof(float), b, layer);
}

extern "C" cudaError_t pb_cuda_layout(const float *in, const size_t dims[3], int m, cudaSurfaceObject_t surface,
                                      cudaStream_t stream)
{
    dim3 block(32, 4, 2);
    dim3 grid((unsigned)((dims[0] + 31) / 32), (unsigned)((dims[1] + 3) / 4), (unsigned)((dims[2] + 1) / 2));
    pb_cuda_layout_kernel<<<grid, block, 0, stream>>>(in, (int)dims[0], (int)dims[1], (int)dims[2], m, surface);
    return cudaGetLastError();
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
