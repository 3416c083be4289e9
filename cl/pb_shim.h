/* The shim: the one place that knows the kernels are compiled by two
 * compilers, as OpenCL C (the library embeds cl/pb_blur.cl) and as CUDA
 * (cuda/pb_kernels.cu includes the very same file). Each name below is spelled
 * once per compiler, side by side; kernel bodies use nothing else, so both
 * compilers see the same arithmetic.
 *
 * Coordinates, on every backend: unnormalized texel coordinates, texel i's
 * centre at i + 0.5, border addressing (zero outside the volume), x fastest.
 *
 *   PB_KERNEL          an entry point with an unmangled name
 *   PB_KERNEL_FULL     the same, kept to five groups' registers on CUDA
 *   PB_FN              a helper, inlined
 *   PB_GLOBAL(_RO)     device memory (read-only)
 *   PB_GID_X/Y/Z       the work item's (thread's) global id
 *   PB_LID_X/Y/Z, PB_LSIZE_X/Y/Z  its id in its group, the group's size
 *   PB_LOCAL           memory a work group shares;  PB_BARRIER  the group's barrier on it
 *   pb_image           a 3-D float volume the texture unit filters
 *   pb_layers          the same volume as 2-D layers along one axis
 *   PB_FETCH_LINEAR    a trilinear fetch;  PB_FETCH_NEAREST  a nearest one
 *   PB_FETCH_LAYER     a bilinear fetch inside one layer
 *   PB_ATOMIC_ADD      the adjoint's float atomic add
 *   PB_DIV             a division off the precise path
 *   PB_RCP             an approximate reciprocal (of a number far from 0 and inf)
 *   PB_SINCOS, PB_RSQRT  CL's step: one range reduction, one reciprocal root */
#ifndef PB_SHIM_H
#define PB_SHIM_H

#if defined(__OPENCL_VERSION__) /* ---- OpenCL C ---------------------------- */

#define PB_KERNEL __kernel
#define PB_KERNEL_FULL __kernel
#define PB_FN static inline
#define PB_GLOBAL __global
#define PB_GLOBAL_RO __global const
#define PB_GID_X ((int)get_global_id(0))
#define PB_GID_Y ((int)get_global_id(1))
#define PB_GID_Z ((int)get_global_id(2))
#define PB_LID_X ((int)get_local_id(0))
#define PB_LID_Y ((int)get_local_id(1))
#define PB_LID_Z ((int)get_local_id(2))
#define PB_LSIZE_X ((int)get_local_size(0))
#define PB_LSIZE_Y ((int)get_local_size(1))
#define PB_LSIZE_Z ((int)get_local_size(2))
#define PB_LOCAL __local
#define PB_BARRIER() barrier(CLK_LOCAL_MEM_FENCE)
/* Macros, not typedefs: PoCL 3.1 reads garbage through a typedef that carries
 * the access qualifier (every fetch returned 123). */
#define pb_image __read_only image3d_t
#define pb_layers __read_only image2d_array_t

__constant sampler_t pb_sampler_linear = CLK_NORMALIZED_COORDS_FALSE | CLK_ADDRESS_CLAMP | CLK_FILTER_LINEAR;
__constant sampler_t pb_sampler_nearest = CLK_NORMALIZED_COORDS_FALSE | CLK_ADDRESS_CLAMP | CLK_FILTER_NEAREST;

/* The border colour of a single-channel image is (0, 0, 0, 1): .x is zero
 * outside. A layer index must be in range: an array clamps it. */
#define PB_FETCH_LINEAR(img, px, py, pz) read_imagef((img), pb_sampler_linear, (float4)((px), (py), (pz), 0.0f)).x
#define PB_FETCH_NEAREST(img, px, py, pz) read_imagef((img), pb_sampler_nearest, (float4)((px), (py), (pz), 0.0f)).x
#define PB_FETCH_LAYER(img, pa, pb, layer)                                                                       \
    read_imagef((img), pb_sampler_linear, (float4)((pa), (pb), (float)(layer), 0.0f)).x

/* OpenCL 1.2 has no float atomic add. On NVIDIA's platform (the backend
 * defines PB_OPENCL_NVIDIA) PTX's red.global.add.f32, what CUDA's atomicAdd
 * compiles to; elsewhere a compare-and-swap loop on the float's bits, which on
 * CPUs (PoCL) seldom retries. */
#if defined(PB_OPENCL_NVIDIA)
static inline void pb_atomic_add(volatile __global float *p, float v)
{
    asm volatile("red.global.add.f32 [%0], %1;" : : "l"(p), "f"(v) : "memory");
}
#else
static inline void pb_atomic_add(volatile __global float *p, float v)
{
    volatile __global unsigned int *u = (volatile __global unsigned int *)p;
    unsigned int old = *u, seen;
    while ((seen = atomic_cmpxchg(u, old, as_uint(as_float(old) + v))) != old)
        old = seen;
}
#endif
#define PB_ATOMIC_ADD(p, v) pb_atomic_add((p), (v))
/* The walk's per-segment divisions: under the error bound a path has many
 * short segments, and precise divisions cost AB-E measurably. The forward
 * and the adjoint divide through the same helpers, so they agree. */
#define PB_DIV(a, b) native_divide((a), (b))
#define PB_RCP(x) native_recip(x)
/* Four floats from p, 16-byte aligned (a float4). */
#define PB_LOAD4(p) vload4(0, (p))
#define PB_SINCOS(x, c) sincos((x), (c))
#define PB_RSQRT(x) rsqrt(x)

#elif defined(__CUDACC__) /* ---- CUDA ------------------------------------- */

#define PB_KERNEL extern "C" __global__
/* AB's forward with its registers capped for five groups of 256 a
 * multiprocessor: it is bound by issuing instructions, and at 51 registers
 * only four fit (ncu; docs/performance.md "What bounds the set-up"). Every
 * group in cl/pb_kernel_table.h is 256 work items. */
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ < 800
/* Turing holds 1024 threads a multiprocessor: five groups never fit there. */
#define PB_KERNEL_FULL extern "C" __global__
#else
#define PB_KERNEL_FULL extern "C" __global__ __launch_bounds__(256, 5)
#endif
#define PB_FN static __device__ __forceinline__
#define PB_GLOBAL
#define PB_GLOBAL_RO const
#define PB_GID_X ((int)(blockIdx.x * blockDim.x + threadIdx.x))
#define PB_GID_Y ((int)(blockIdx.y * blockDim.y + threadIdx.y))
#define PB_GID_Z ((int)(blockIdx.z * blockDim.z + threadIdx.z))
#define PB_LID_X ((int)threadIdx.x)
#define PB_LID_Y ((int)threadIdx.y)
#define PB_LID_Z ((int)threadIdx.z)
#define PB_LSIZE_X ((int)blockDim.x)
#define PB_LSIZE_Y ((int)blockDim.y)
#define PB_LSIZE_Z ((int)blockDim.z)
#define PB_LOCAL __shared__
#define PB_BARRIER() __syncthreads()
/* A texture object carries its filter mode, where OpenCL passes a sampler per
 * read: the backend binds a linear and a point texture object to the volume's
 * array and passes the one the kernel's row of cl/pb_kernel_table.h names. */
typedef cudaTextureObject_t pb_image;
typedef cudaTextureObject_t pb_layers;

#define PB_FETCH_LINEAR(img, px, py, pz) tex3D<float>((img), (px), (py), (pz))
#define PB_FETCH_NEAREST(img, px, py, pz) tex3D<float>((img), (px), (py), (pz))
#define PB_FETCH_LAYER(img, pa, pb, layer) tex2DLayered<float>((img), (pa), (pb), (layer))

/* With its result unused nvcc emits RED.ADD.F32. */
#define PB_ATOMIC_ADD(p, v) atomicAdd((p), (v))
#define PB_DIV(a, b) __fdividef((a), (b))
#define PB_LOAD4(p) (*(const float4 *)(p))
/* One MUFU.RCP: __fdividef(1, x) adds a guard for huge x that the chord's
 * kinks (cl/pb_chord.cl), which take it of lengths from 1e-6 to a grid's, never need. */
PB_FN float pb_rcp(float x)
{
    float r;
    asm("rcp.approx.ftz.f32 %0, %1;" : "=f"(r) : "f"(x));
    return r;
}
#define PB_RCP(x) pb_rcp(x)
/* Left to 1.0f / sqrtf, nvcc emits a correctly rounded root and division
 * (NVIDIA's OpenCL compiler does not), which made CUDA's CL steps slower. */
PB_FN float pb_sincos(float x, float *c)
{
    float s;
    sincosf(x, &s, c);
    return s;
}
#define PB_SINCOS(x, c) pb_sincos((x), (c))
#define PB_RSQRT(x) rsqrtf(x)
/* Float maths: for float arguments C++ overloads pick the float versions
 * (floorf, fabsf, fmaxf), as OpenCL C does. */

#else
#error "cl/pb_shim.h is for the OpenCL C compiler or nvcc"
#endif

#endif
